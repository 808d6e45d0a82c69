//! `pbd calibrate`: the robot calibrates its eyes in the empty workcell of a scene, and the
//! calibration is written to a file for `pbd execute --calibration FILE`.

use std::io::Write;
use std::path::PathBuf;

use clap::Args;
use pbd::calibrate::{CalibrateOptions, calibrate};

use crate::output::emit;
use crate::progress::Bars;

/// Arguments of `pbd calibrate`.
#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// Scene whose workcell is calibrated (its objects taken away): a built-in name (pick-place,
    /// sorting, sorting-new, sorting-demo) or a TOML file.
    #[arg(long, default_value = "sorting-new")]
    scene: String,
    /// The calibration file to write.
    #[arg(short, long, default_value = "workcell.cal")]
    output: PathBuf,
    /// Seed of the cameras' noise; default: the workcell's own, which gives the calibration
    /// `pbd execute` computes without --calibration.
    #[arg(long)]
    seed: Option<u64>,
    /// The robot: the simulated Dexter (its workcell emptied of objects), or a robot over ROS 2
    /// whose table was cleared (its topics from --config; --scene then names only its workcell).
    #[arg(long, value_enum, default_value_t = crate::execute::Hardware::Sim)]
    hardware: crate::execute::Hardware,
    /// With --hardware ros2: the topic mapping (TOML; default: Dexter's built-in assets/ros2/dexter.toml).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs `pbd calibrate`.
pub fn main(a: CalibrateArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    // Nothing is written before the end (and then atomically): Ctrl-C simply ends the process.
    crate::progress::exit_on_interrupt()?;
    let options = CalibrateOptions {
        scene: a.scene,
        output: a.output,
        seed: a.seed,
    };
    if a.config.is_some() && a.hardware != crate::execute::Hardware::Ros2 {
        anyhow::bail!("--config maps a robot's ROS 2 topics: pass --hardware ros2 too");
    }
    let report = match a.hardware {
        crate::execute::Hardware::Sim => calibrate(&options, &Bars::new(a.json, false)?)?,
        crate::execute::Hardware::Ros2 => {
            anyhow::ensure!(a.seed.is_none(), "--seed: a robot over ROS 2 has its own noise");
            pbd::ros2::calibrate(&options, a.config.as_deref(), &Bars::new(a.json, false)?)?
        }
    };
    emit(a.json, &report, out)
}

//! `pbd execute`: the robot does a demonstrated task in a new scene (§4.3.2), from its own senses.

use std::io::Write;
use std::path::PathBuf;

use clap::Args;
use pbd::execute::{ExecuteOptions, execute};

use crate::output::emit;
use crate::progress::Bars;

/// Arguments of `pbd execute`.
#[derive(Debug, Args)]
pub struct ExecuteArgs {
    /// Scene to act in: a built-in name (pick-place, sorting, sorting-new) or a TOML file.
    #[arg(long, default_value = "sorting-new")]
    scene: String,
    /// A learned procedural model (from `pbd learn`): decides relevance and place per object.
    #[arg(long, conflicts_with = "demo")]
    model: Option<PathBuf>,
    /// An inference (from `pbd infer`): its MAP schema, with the place its first instance used.
    #[arg(long)]
    demo: Option<PathBuf>,
    /// Only this object (scene label); default: every object in the scene.
    #[arg(long)]
    object: Option<String>,
    /// Override the place (with --demo).
    #[arg(long, requires = "demo")]
    place: Option<String>,
    /// Schema library (TOML; default: the built-in library).
    #[arg(long)]
    library: Option<PathBuf>,
    /// Seed of every random choice; default: the scene's seed.
    #[arg(long)]
    seed: Option<u64>,
    /// Record the execution to this MCAP file.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// The robot's calibration of the empty workcell, from `pbd calibrate` (default: calibrate
    /// the workcell now, which gives the same calibration as `pbd calibrate` with its default seed).
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// The robot: the simulated Dexter in-process, or a robot over ROS 2 (its topics from --config;
    /// --scene then names only its workcell, and --calibration is required).
    #[arg(long, value_enum, default_value_t = Hardware::Sim)]
    hardware: Hardware,
    /// With --hardware ros2: the topic mapping (TOML; default: Dexter's built-in assets/ros2/dexter.toml).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    live: crate::output::LiveArgs,
}

/// Which robot a command drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Hardware {
    /// The simulated Dexter, in this process.
    Sim,
    /// A robot over ROS 2 (a real one, or `pbd sim serve --ros2` in another process).
    Ros2,
}

/// Runs `pbd execute`.
pub fn main(a: ExecuteArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    if a.config.is_some() && a.hardware != Hardware::Ros2 {
        anyhow::bail!("--config maps a robot's ROS 2 topics: pass --hardware ros2 too");
    }
    let options = ExecuteOptions {
        scene: a.scene,
        model: a.model,
        demo: a.demo,
        object: a.object,
        place: a.place,
        library: a.library,
        seed: a.seed,
        output: a.output,
        calibration: a.calibration,
        live: pbd::LiveOptions::bind(a.live.bind()),
    };
    if a.hardware == Hardware::Ros2 {
        anyhow::ensure!(
            !options.live.is_on(),
            "--live: a run over ROS 2 is not logged by pbd yet"
        );
        let options = pbd::ros2::Ros2ExecuteOptions {
            execute: options,
            config: a.config,
        };
        let report = pbd::ros2::execute(&options, &Bars::new(a.json, true)?)?;
        return emit(a.json, &report, out);
    }
    let report = execute(&options, &Bars::new(a.json, true)?)?;
    emit(a.json, &report, out)
}

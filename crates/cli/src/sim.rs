//! `pbd sim pick-place`: one pick-and-place with the robot's own skills, judged by the world;
//! `pbd sim serve` (the simulated robot over ROS 2); `pbd sim catalog` (a generated object catalog).

use std::io::Write;
use std::path::PathBuf;

use clap::{Args, Subcommand};
use pbd::sim::{ArmChoice, PickPlaceOptions, pick_place};

use crate::output::emit;
use crate::progress::Bars;

/// `pbd sim …` subcommands.
#[derive(Debug, Subcommand)]
pub enum SimCommand {
    /// One pick-and-place: pick OBJECT and put it in PLACE, with either arm.
    PickPlace(PickPlaceArgs),
    /// Serve the simulated Dexter as a ROS 2 robot (joint states, fingertip wrenches, camera images
    /// on the topics of a mapping file; motor-unit references from its command topic) until Ctrl-C;
    /// then print where every object ended.
    Serve(ServeArgs),
    /// Generate an object catalog from a seed (colour families after the basic colour terms, shapes
    /// and sizes the hand can grasp, caps, lids and labels; colour and size classes as a teacher
    /// would label them): catalogs to tune on and others to report on.
    Catalog(CatalogArgs),
}

/// Arguments of `pbd sim catalog`.
#[derive(Debug, Args)]
pub struct CatalogArgs {
    /// Seed of every random choice: the same seed gives the same catalog.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Objects per colour family (ten families).
    #[arg(long, default_value_t = 8)]
    per_family: usize,
    /// The catalog file to write (TOML).
    #[arg(short, long)]
    output: PathBuf,
    /// Print the result as JSON.
    #[arg(long)]
    json: bool,
}

/// Arguments of `pbd sim serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// Serve over ROS 2 (DDS; the only transport so far, and required).
    #[arg(long)]
    ros2: bool,
    /// Scene: a built-in name (pick-place, sorting, sorting-new) or a TOML file.
    #[arg(long, default_value = "sorting-new")]
    scene: String,
    /// Seed of the world's random choices; default: the scene's seed.
    #[arg(long)]
    seed: Option<u64>,
    /// The topic mapping (TOML; default: Dexter's built-in assets/ros2/dexter.toml).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Advance the world only when a command arrives (a deterministic co-simulation), not in real time.
    #[arg(long)]
    lockstep: bool,
    /// Control period (s): a real-time tick, and the lock step of an array command.
    #[arg(long, default_value_t = 0.002)]
    period: f64,
    /// Stop after this many seconds without a command, once one has arrived.
    #[arg(long)]
    idle_exit: Option<f64>,
    /// Serve the workcell without its objects (to run `pbd calibrate --hardware ros2` against).
    #[arg(long)]
    empty: bool,
    /// A scripted teacher at the robot's side demonstrates this task on the mapping's [[teleop]]
    /// topics (to run `pbd record --hardware ros2` against).
    #[arg(long, value_enum, value_name = "TASK", conflicts_with = "empty")]
    teach: Option<pbd::record::Script>,
    /// Publish the fingertip wrenches in their sensors' own frames (as real force/torque sensors
    /// do) instead of world-aligned.
    #[arg(long)]
    sensor_frames: bool,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

/// Arguments of `pbd sim pick-place`.
#[derive(Debug, Args)]
pub struct PickPlaceArgs {
    /// Scene: a built-in name (pick-place, sorting, sorting-new) or a TOML file.
    #[arg(long, default_value = "pick-place")]
    scene: String,
    /// Object to pick (presentation name as in the scene; default: the scene's first object).
    #[arg(long)]
    object: Option<String>,
    /// Place to put it (default: the scene's first place).
    #[arg(long)]
    place: Option<String>,
    /// Arm to use.
    #[arg(long, value_enum, default_value_t = ArmChoice::Auto)]
    arm: ArmChoice,
    /// Seed of every random choice (encoder noise, placement jitter); default: the scene's seed.
    #[arg(long)]
    seed: Option<u64>,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
    /// Record the run to this MCAP file (open it in Foxglove).
    #[arg(long)]
    mcap: Option<PathBuf>,
    /// Logging rate of the MCAP file (Hz of simulated time).
    #[arg(long, default_value_t = 30.0)]
    log_hz: f64,
}

/// Runs a `pbd sim` subcommand.
pub fn main(cmd: SimCommand, out: &mut dyn Write) -> anyhow::Result<()> {
    let a = match cmd {
        SimCommand::PickPlace(a) => a,
        SimCommand::Serve(a) => return serve(a, out),
        SimCommand::Catalog(a) => {
            let report = pbd::sim::generate_catalog(&pbd::sim::CatalogOptions {
                seed: a.seed,
                per_family: a.per_family,
                output: a.output,
            })?;
            return emit(a.json, &report, out);
        }
    };
    if !(a.log_hz.is_finite() && a.log_hz > 0.0) {
        anyhow::bail!("--log-hz must be a positive number (got {})", a.log_hz);
    }
    let options = PickPlaceOptions {
        scene: a.scene,
        object: a.object,
        place: a.place,
        arm: a.arm,
        seed: a.seed,
        mcap: a.mcap,
        log_hz: a.log_hz,
    };
    let run = pick_place(&options, &Bars::new(a.json, true)?)?;
    emit(a.json, &run, out)
}

fn serve(a: ServeArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    if !a.ros2 {
        anyhow::bail!("pbd sim serve: pass --ros2 (the only transport so far)");
    }
    if !(a.period.is_finite() && a.period > 0.0) {
        anyhow::bail!("--period must be a positive number of seconds (got {})", a.period);
    }
    if let Some(t) = a.idle_exit
        && !(t.is_finite() && t > 0.0)
    {
        anyhow::bail!("--idle-exit must be a positive number of seconds (got {t})");
    }
    let options = pbd::ros2::ServeOptions {
        scene: a.scene,
        seed: a.seed,
        config: a.config,
        lockstep: a.lockstep,
        period: a.period,
        idle_exit: a.idle_exit,
        empty: a.empty,
        teach: a.teach,
        sensor_frames: a.sensor_frames,
    };
    // The first Ctrl-C / SIGTERM ends serving at the next tick, and the report is printed.
    let report = pbd::ros2::serve_sim(&options, &Bars::new(a.json, true)?)?;
    emit(a.json, &report, out)
}

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
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    live: crate::output::LiveArgs,
}

/// Runs `pbd execute`.
pub fn main(a: ExecuteArgs, out: &mut dyn Write) -> anyhow::Result<()> {
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
    let report = execute(&options, &Bars::new(a.json, true)?)?;
    emit(a.json, &report, out)
}

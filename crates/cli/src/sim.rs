//! `pbd sim pick-place`: one pick-and-place with the robot's own skills, judged by the world.

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
    let SimCommand::PickPlace(a) = cmd;
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

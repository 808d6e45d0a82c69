//! `pbd grasp`: visual grasp prototypes (Sweeney 2011, ch. 6) — record demonstrated grasps, learn
//! prototypes, generate pre-grasps for new objects, and evaluate against the naive baseline in the sim.

use std::io::Write;

use clap::Subcommand;

/// `pbd grasp …` subcommands.
#[derive(Debug, Subcommand)]
pub enum GraspCommand {}

/// Runs a `pbd grasp` subcommand.
pub fn main(cmd: GraspCommand, _out: &mut dyn Write) -> anyhow::Result<()> {
    match cmd {}
}

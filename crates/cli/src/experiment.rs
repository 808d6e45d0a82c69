//! `pbd experiment`: the seed's procedural-learning experiments (Sweeney 2011, §5.1–5.2) on features
//! rendered from an object catalog.

use std::io::Write;

use clap::Subcommand;

/// `pbd experiment …` subcommands.
#[derive(Debug, Subcommand)]
pub enum ExperimentCommand {}

/// Runs a `pbd experiment` subcommand.
pub fn main(cmd: ExperimentCommand, _out: &mut dyn Write) -> anyhow::Result<()> {
    match cmd {}
}

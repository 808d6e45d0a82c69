//! `pbd demo`: the whole story on the built-in scenes — record, infer, learn, execute — with no files
//! or flags needed. Every file goes to `--out` (default `pbd-demo/`).

use std::io::Write;
use std::path::PathBuf;

use clap::Args;
use pbd::demo::{DemoOptions, demo};

use crate::progress::Bars;

/// Arguments of `pbd demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Directory for the files.
    #[arg(long, default_value = "pbd-demo")]
    out: PathBuf,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print the final execution report as JSON.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    live: crate::output::LiveArgs,
}

/// Runs `pbd demo`.
pub fn main(a: DemoArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let report = demo(
        &DemoOptions {
            out: a.out,
            seed: a.seed,
            live: pbd::LiveOptions::bind(a.live.bind()),
        },
        &Bars::new(a.json, true)?,
    )?;
    if a.json {
        let text = serde_json::to_string_pretty(&report.execute)?;
        writeln!(out, "{text}")?;
    } else {
        writeln!(out, "{report}")?;
    }
    Ok(())
}

//! `pbd infer`: which schema of the library explains a recorded demonstration (§4.2).

use std::io::Write;
use std::path::PathBuf;

use clap::Args;
use pbd::infer::{InferOptions, infer};

use crate::progress::Bars;

/// Arguments of `pbd infer`.
#[derive(Debug, Args)]
pub struct InferArgs {
    /// The demonstration (MCAP from `pbd record`).
    demo: PathBuf,
    /// Output JSON (default: next to the demo, `NAME.infer.json`; the companion MCAP is `NAME.infer.mcap`).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Schema library (TOML; default: the built-in library).
    #[arg(long)]
    library: Option<PathBuf>,
    /// Print the result (the inference file) as JSON instead of a summary.
    #[arg(long)]
    json: bool,
}

/// Runs `pbd infer`.
pub fn main(a: InferArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let options = InferOptions {
        demo: a.demo,
        output: a.output,
        library: a.library,
    };
    let run = infer(&options, &Bars::new(a.json, false)?)?;
    if a.json {
        let text = serde_json::to_string_pretty(&run.file)?;
        writeln!(out, "{text}")?;
    } else {
        write!(out, "{run}")?;
    }
    Ok(())
}

//! `pbd doctor`: check an MCAP file, and repair one that was cut short, malformed or inconsistent.

use std::io::Write;
use std::path::PathBuf;

use clap::Args;

use crate::output::emit;

/// Arguments of `pbd doctor`.
#[derive(Debug, Args)]
pub struct DoctorArgs {
    /// The MCAP file.
    file: PathBuf,
    /// Write a repaired, complete copy here (everything readable, with a fresh summary section).
    #[arg(long)]
    repair: Option<PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs `pbd doctor`.
pub fn main(a: DoctorArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let report = pbd::doctor::doctor(&a.file, a.repair.as_deref())?;
    emit(a.json, &report, out)?;
    if report.needs_repair() {
        anyhow::bail!(
            "{} is {}; `pbd doctor {} --repair NEW.mcap` writes a complete copy of everything readable",
            report.file,
            report.what_is_wrong(),
            report.file
        );
    }
    Ok(())
}

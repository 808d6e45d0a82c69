//! `pbd doctor`: report on an MCAP file — complete or cut short, channels and message counts,
//! inconsistencies — and repair one that was cut short by rewriting what it holds into a new,
//! complete file.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use serde::Serialize;

use crate::mcap_log::{FileStatus, read_summary, repair};

/// Arguments of `pbd doctor`.
#[derive(Debug, Args)]
pub struct DoctorArgs {
    /// The MCAP file.
    pub file: PathBuf,
    /// Write a repaired, complete copy here (everything readable, with a fresh summary section).
    #[arg(long)]
    pub repair: Option<PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Serialize)]
struct Report {
    file: String,
    bytes: u64,
    complete: bool,
    problem: Option<String>,
    messages: u64,
    duration_secs: f64,
    channels: Vec<(String, String, u64)>,
    attachments: Vec<String>,
    metadata: Vec<String>,
    issues: Vec<String>,
    repaired: Option<(String, u64)>,
}

/// Runs `pbd doctor`.
pub fn main(args: DoctorArgs, out: &mut dyn Write) -> Result<()> {
    let s = read_summary(&args.file)?;
    let (complete, problem) = match &s.status {
        FileStatus::Complete => (true, None),
        FileStatus::Recovered { reason, .. } => (false, Some(reason.clone())),
    };
    let repaired = match &args.repair {
        Some(path) => Some((path.display().to_string(), repair(&args.file, path)?)),
        None => None,
    };
    let report = Report {
        file: args.file.display().to_string(),
        bytes: s.file_bytes,
        complete,
        problem,
        messages: s.message_count,
        duration_secs: s.duration_secs(),
        channels: s
            .channels
            .iter()
            .map(|c| (c.topic.clone(), c.schema_name.clone(), c.message_count))
            .collect(),
        attachments: s.attachments.clone(),
        metadata: s.metadata.clone(),
        issues: s.issues.clone(),
        repaired,
    };
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&report)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "{}: {} ({:.1} MB, {} messages over {:.1} s)",
        report.file,
        if report.complete { "complete" } else { "CUT SHORT" },
        report.bytes as f64 / 1e6,
        report.messages,
        report.duration_secs
    )?;
    if let Some(p) = &report.problem {
        writeln!(out, "  problem     {p}; everything before it is readable")?;
    }
    for (topic, schema, n) in &report.channels {
        writeln!(out, "  {topic:<28} {schema:<28} {n:>8}")?;
    }
    if !report.attachments.is_empty() {
        writeln!(out, "  attachments {}", report.attachments.join(", "))?;
    }
    if !report.metadata.is_empty() {
        writeln!(out, "  metadata    {}", report.metadata.join(", "))?;
    }
    for i in &report.issues {
        writeln!(out, "  issue       {i}")?;
    }
    if let Some((path, n)) = &report.repaired {
        writeln!(out, "  repaired    {path} ({n} messages, complete)")?;
    }
    Ok(())
}

//! `pbd doctor`: report on an MCAP file — complete, cut short, malformed (no header first, two
//! recordings concatenated) or inconsistent (chunk times that are not those of their messages),
//! channels and message counts — and repair one by rewriting what it holds into a new, complete file.

use std::fmt;
use std::path::Path;

use anyhow::Result;
use serde::Serialize;

use crate::mcap_log::{FileStatus, read_summary, repair};

/// What `doctor` found in an MCAP file (and what it repaired).
#[derive(Debug, Clone, Serialize)]
pub struct DoctorReport {
    /// The file.
    pub file: String,
    /// Its size (bytes).
    pub bytes: u64,
    /// One complete recording: it begins with a header, ends with a valid footer and summary with
    /// nothing after it, and its chunk headers, chunk indexes and statistics agree with its messages.
    pub complete: bool,
    /// `complete`, `cut short` (the writer did not finish), `malformed` (no header first, or bytes
    /// after the end: two recordings concatenated) or `inconsistent` (chunk times or counts that
    /// disagree with the messages; see `issues`).
    pub verdict: String,
    /// Why it is not complete, with the byte offset where that applies.
    pub problem: Option<String>,
    /// Messages readable.
    pub messages: u64,
    /// From the first to the last message (s).
    pub duration_secs: f64,
    /// (topic, schema, messages) per channel.
    pub channels: Vec<(String, String, u64)>,
    /// Attachment names.
    pub attachments: Vec<String>,
    /// Metadata record names.
    pub metadata: Vec<String>,
    /// Inconsistencies found.
    pub issues: Vec<String>,
    /// Damaged chunks skipped (everything else was read).
    pub skipped_chunks: Vec<String>,
    /// The repaired copy and its message count.
    pub repaired: Option<(String, u64)>,
}

/// Checks `file`; with `repair`, writes a complete copy of everything readable there.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn doctor(file: &Path, repair_to: Option<&Path>) -> crate::Result<DoctorReport> {
    doctor_impl(file, repair_to).map_err(crate::Error::from)
}

fn doctor_impl(file: &Path, repair_to: Option<&Path>) -> Result<DoctorReport> {
    if let Some(out) = repair_to {
        crate::files::refuse_inputs_as_outputs(&[file], &[out])?;
    }
    let s = read_summary(file)?;
    let (verdict, problem) = match &s.status {
        FileStatus::Complete if s.issues.is_empty() => ("complete", None),
        FileStatus::Complete => (
            "inconsistent",
            Some(match s.issues.len() {
                1 => s.issues[0].clone(),
                n => format!("{} ({n} disagreements in all, listed under issues)", s.issues[0]),
            }),
        ),
        FileStatus::Recovered { reason, .. } => ("cut short", Some(reason.clone())),
        FileStatus::Malformed { reason } => ("malformed", Some(reason.clone())),
    };
    let repaired = match repair_to {
        Some(path) => Some((path.display().to_string(), repair(file, path)?)),
        None => None,
    };
    Ok(DoctorReport {
        file: file.display().to_string(),
        bytes: s.file_bytes,
        complete: problem.is_none(),
        verdict: verdict.to_owned(),
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
        skipped_chunks: s.skipped_chunks.clone(),
        repaired,
    })
}

impl DoctorReport {
    /// The file needs a repair: not complete or with damaged chunks, and no repaired copy was written.
    pub fn needs_repair(&self) -> bool {
        (!self.complete || !self.skipped_chunks.is_empty()) && self.repaired.is_none()
    }

    /// What is wrong, for a message: the verdict and the problem (`damaged` for a full-length file
    /// with damaged chunks).
    pub fn what_is_wrong(&self) -> String {
        match (&self.problem, self.skipped_chunks.first()) {
            (Some(p), _) => format!("{}: {p}", self.verdict),
            (None, Some(c)) => format!("damaged: {c}"),
            (None, None) => self.verdict.clone(),
        }
    }
}

impl fmt::Display for DoctorReport {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let report = self;
        writeln!(
            out,
            "{}: {} ({:.1} MB, {} messages over {:.1} s)",
            report.file,
            match (report.complete, report.skipped_chunks.is_empty()) {
                (true, true) => "complete".to_string(),
                (true, false) => format!("full length, {} DAMAGED part(s) skipped", report.skipped_chunks.len()),
                (false, _) => report.verdict.to_uppercase(),
            },
            report.bytes as f64 / 1e6,
            report.messages,
            report.duration_secs
        )?;
        if let Some(p) = &report.problem {
            match report.verdict.as_str() {
                "cut short" => writeln!(out, "  problem     {p}; everything before it is readable")?,
                _ => writeln!(out, "  problem     {p}")?,
            }
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
        for c in &report.skipped_chunks {
            writeln!(out, "  damaged     {c}")?;
        }
        if let Some((path, n)) = &report.repaired {
            writeln!(out, "  repaired    {path} ({n} messages, complete)")?;
        }
        Ok(())
    }
}

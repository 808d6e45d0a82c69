//! `pbd robot info | fk`: a robot model's summary, and forward kinematics with the Jacobian.

use std::io::Write;
use std::path::PathBuf;

use anyhow::ensure;
use clap::{Args, Subcommand};
use pbd::robot::{FkOptions, fk, info};

use crate::output::emit;

/// `pbd robot …` subcommands.
#[derive(Debug, Subcommand)]
pub enum RobotCommand {
    /// Summarise a robot: links, joints, degrees of freedom with limits, mimic couplings and chains.
    Info(InfoArgs),
    /// Forward kinematics and Jacobian of the chain BASE -> TIP at joint values Q.
    Fk(FkArgs),
}

/// Arguments of `pbd robot info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// URDF file to describe [default: the built-in Dexter model]
    urdf: Option<PathBuf>,
    /// Print one JSON object (field names documented in the README) instead of tables.
    #[arg(long)]
    json: bool,
}

/// Arguments of `pbd robot fk`.
#[derive(Debug, Args)]
pub struct FkArgs {
    /// URDF file [default: the built-in Dexter model]
    urdf: Option<PathBuf>,
    /// Base link of the chain: the frame the pose and the Jacobian are expressed in.
    #[arg(long, value_name = "LINK")]
    base: String,
    /// Tip link of the chain.
    #[arg(long, value_name = "LINK")]
    tip: String,
    /// Joint values, comma-separated, one per chain variable in base-to-tip order (radians, metres for
    /// prismatic joints). `pbd robot info` lists them. Omitted: all zero.
    #[arg(long, value_name = "V1,...,VN", allow_hyphen_values = true)]
    q: Option<String>,
    /// Read the revolute and continuous entries of --q in degrees (prismatic ones stay in metres).
    #[arg(long)]
    degrees: bool,
    /// Print one JSON object with full-precision numbers instead of tables.
    #[arg(long)]
    json: bool,
}

/// Runs a `pbd robot` subcommand.
pub fn main(cmd: RobotCommand, out: &mut dyn Write) -> anyhow::Result<()> {
    match cmd {
        RobotCommand::Info(a) => emit(a.json, &info(a.urdf.as_deref())?, out),
        RobotCommand::Fk(a) => {
            let options = FkOptions {
                urdf: a.urdf,
                base: a.base,
                tip: a.tip,
                q: a.q.as_deref().map(parse_q).transpose()?,
                degrees: a.degrees,
            };
            let report = fk(&options)?;
            for w in &report.warnings {
                eprintln!("warning: {w}");
            }
            emit(a.json, &report, out)
        }
    }
}

/// Parses `--q`: comma-separated finite numbers; the error names the offending entry.
fn parse_q(text: &str) -> anyhow::Result<Vec<f64>> {
    ensure!(
        !text.trim().is_empty(),
        "--q is empty; give comma-separated joint values such as --q 0.1,-0.2,0.3 (or omit --q for all zeros)"
    );
    let entries: Vec<&str> = text.split(',').collect();
    let count = entries.len();
    entries
        .iter()
        .enumerate()
        .map(|(i, raw)| {
            let entry = raw.trim();
            let pos = i + 1;
            ensure!(!entry.is_empty(), "--q entry {pos} of {count} is empty (in '{text}')");
            let v: f64 = entry
                .parse()
                .map_err(|_| anyhow::anyhow!("--q entry {pos} of {count} ('{entry}') is not a number"))?;
            ensure!(
                v.is_finite(),
                "--q entry {pos} of {count} ('{entry}') is not a finite number"
            );
            Ok(v)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_q_accepts_spaces_signs_and_exponents() {
        assert_eq!(parse_q("0.5, -1,+2e-1 ,3").unwrap(), vec![0.5, -1.0, 0.2, 3.0]);
    }

    #[test]
    fn parse_q_names_the_bad_entry() {
        let e = parse_q("0.1,NaN,0.3").unwrap_err().to_string();
        assert!(
            e.contains("entry 2") && e.contains("NaN") && e.contains("finite"),
            "{e}"
        );
        let e = parse_q("0.1,,0.3").unwrap_err().to_string();
        assert!(e.contains("entry 2") && e.contains("empty"), "{e}");
        let e = parse_q("0.1,inf").unwrap_err().to_string();
        assert!(e.contains("entry 2") && e.contains("inf"), "{e}");
        let e = parse_q("0.1,abc").unwrap_err().to_string();
        assert!(e.contains("'abc'") && e.contains("not a number"), "{e}");
        assert!(parse_q("  ").unwrap_err().to_string().contains("empty"));
    }
}

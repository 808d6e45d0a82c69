//! Teleoperation streams: one glove sample per hand ([`HandCommand`]), a recorded stream read from
//! and written to CSV or JSON lines (the formats of the module docs) and checked line by line, and
//! its playback ([`Replay`]).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::SimError;
use crate::snapshot::Arm;
use dexter::control::FLEX_CLOSED;
pub use dexter::teleop::HandCommand;

/// Latest sample time (s) a teleop stream may hold: an hour (a recording stops at 600 s).
pub const MAX_STREAM_SECS: f64 = 3600.0;

/// Longest gap (s) between two samples of one hand: a glove streams at tens of hertz, and a gap of
/// 10⁹ s once ran a recording to its time cap on the last command.
pub const MAX_SAMPLE_GAP_SECS: f64 = 60.0;

/// A recorded teleoperation stream: samples per hand in time order.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TeleopStream {
    /// Samples in file order, both hands interleaved (time non-decreasing per hand).
    pub samples: Vec<HandCommand>,
}

fn bad(path: &Path, line: usize, message: impl Into<String>) -> SimError {
    SimError::Invalid {
        path: path.to_path_buf(),
        field: format!("line {line}"),
        message: message.into(),
    }
}

/// The CSV header a teleop file must start with.
pub const CSV_HEADER: &str = "t,hand,x,y,z,qx,qy,qz,qw,flexion";

impl TeleopStream {
    /// Reads a CSV (`.csv`) or JSON-lines (anything else) teleop file and validates it.
    pub fn load(path: impl AsRef<Path>) -> Result<TeleopStream, SimError> {
        let path = path.as_ref();
        let text = bayes::input::read_text(path).map_err(|e| SimError::Io {
            path: path.to_path_buf(),
            source: e,
        })?;
        TeleopStream::parse(&text, path)
    }

    /// Parses and validates a teleop stream held in memory; `path` names it in errors and picks the
    /// format as [`TeleopStream::load`] does (`.csv`: CSV, anything else: JSON lines).
    pub fn parse(text: &str, path: impl AsRef<Path>) -> Result<TeleopStream, SimError> {
        let path = path.as_ref();
        let csv = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv"));
        let (stream, lines) = if csv {
            Self::parse_csv(text, path)?
        } else {
            Self::parse_jsonl(text, path)?
        };
        stream.validate_lines(path, &lines)?;
        Ok(stream)
    }

    /// The samples and the file line (1-based) of each.
    fn parse_csv(text: &str, path: &Path) -> Result<(TeleopStream, Vec<usize>), SimError> {
        let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
        let Some((_, header)) = lines.next() else {
            return Err(bad(
                path,
                1,
                "empty file (expected the header `t,hand,x,y,z,qx,qy,qz,qw,flexion`)",
            ));
        };
        let header_line = text.lines().position(|l| !l.trim().is_empty()).unwrap_or(0) + 1;
        let header: String = header.chars().filter(|c| !c.is_whitespace()).collect();
        if header != CSV_HEADER {
            return Err(bad(
                path,
                header_line,
                format!("header `{header}` is not `{CSV_HEADER}`"),
            ));
        }
        let mut samples = Vec::new();
        let mut numbers = Vec::new();
        for (i, line) in lines {
            let n = i + 1;
            numbers.push(n);
            let cols: Vec<&str> = line.split(',').map(str::trim).collect();
            if cols.len() != 10 {
                return Err(bad(
                    path,
                    n,
                    format!("{} columns, expected 10 ({CSV_HEADER})", cols.len()),
                ));
            }
            let hand =
                Arm::parse(cols[1]).ok_or_else(|| bad(path, n, format!("hand `{}` is not left or right", cols[1])))?;
            let mut v = [0.0; 9];
            for (k, (j, name)) in [0usize, 2, 3, 4, 5, 6, 7, 8, 9]
                .into_iter()
                .zip(["t", "x", "y", "z", "qx", "qy", "qz", "qw", "flexion"])
                .enumerate()
            {
                v[k] = cols[j]
                    .parse::<f64>()
                    .map_err(|_| bad(path, n, format!("{name} = `{}` is not a number", cols[j])))?;
            }
            samples.push(HandCommand {
                t: v[0],
                hand,
                position: [v[1], v[2], v[3]],
                orientation: [v[4], v[5], v[6], v[7]],
                flexion: v[8],
            });
        }
        Ok((TeleopStream { samples }, numbers))
    }

    fn parse_jsonl(text: &str, path: &Path) -> Result<(TeleopStream, Vec<usize>), SimError> {
        let mut samples = Vec::new();
        let mut numbers = Vec::new();
        for (i, line) in text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            if let Err(dup) = bayes::input::check_json_keys(line) {
                return Err(bad(
                    path,
                    i + 1,
                    format!(
                        "duplicate key `{}` (second at column {}): a JSON object may give each key only once",
                        dup.path, dup.column
                    ),
                ));
            }
            let s: HandCommand =
                serde_json::from_str(line).map_err(|e| bad(path, i + 1, format!("not a teleop sample: {e}")))?;
            samples.push(s);
            numbers.push(i + 1);
        }
        Ok((TeleopStream { samples }, numbers))
    }

    /// Checks: at least one sample, finite numbers, unit quaternions (within 1e-3; renormalised),
    /// time non-decreasing per hand, flexion within [0, 2.4]. Errors name the sample (1-based).
    pub fn validate(&self, path: &Path) -> Result<(), SimError> {
        self.check(path, &|i| format!("sample {}", i + 1))
    }

    /// [`TeleopStream::validate`] naming the file line of each sample.
    fn validate_lines(&self, path: &Path, lines: &[usize]) -> Result<(), SimError> {
        self.check(path, &|i| format!("line {}", lines.get(i).copied().unwrap_or(i + 1)))
    }

    fn check(&self, path: &Path, at: &dyn Fn(usize) -> String) -> Result<(), SimError> {
        let bad = |_: &Path, n: String, message: String| SimError::Invalid {
            path: path.to_path_buf(),
            field: n,
            message,
        };
        if self.samples.is_empty() {
            return Err(bad(path, "samples".into(), "no samples".into()));
        }
        let mut last = [f64::NEG_INFINITY; 2];
        for (i, s) in self.samples.iter().enumerate() {
            let n = at(i);
            let nums = [s.t, s.flexion].into_iter().chain(s.position).chain(s.orientation);
            if nums.into_iter().any(|v| !v.is_finite()) {
                return Err(bad(path, n, "a value is not a finite number".into()));
            }
            let norm = s.orientation.iter().map(|v| v * v).sum::<f64>().sqrt();
            if (norm - 1.0).abs() > 1e-3 {
                return Err(bad(
                    path,
                    n.clone(),
                    format!("orientation is not a unit quaternion (norm {norm:.4})"),
                ));
            }
            if !(0.0..=FLEX_CLOSED + 1e-9).contains(&s.flexion) {
                return Err(bad(
                    path,
                    n.clone(),
                    format!("flexion {} outside [0, {FLEX_CLOSED}] rad", s.flexion),
                ));
            }
            if !(0.0..=MAX_STREAM_SECS).contains(&s.t) {
                return Err(bad(
                    path,
                    n.clone(),
                    format!("time {} s outside [0, {MAX_STREAM_SECS}] s", s.t),
                ));
            }
            let k = s.hand.index();
            if last[k].is_finite() && s.t - last[k] > MAX_SAMPLE_GAP_SECS {
                return Err(bad(
                    path,
                    n.clone(),
                    format!(
                        "a gap of {:.3} s after the previous {} hand sample (at {} s): at most {MAX_SAMPLE_GAP_SECS} s \
                         between a hand's samples",
                        s.t - last[k],
                        s.hand,
                        last[k]
                    ),
                ));
            }
            if s.t < last[k] {
                return Err(bad(
                    path,
                    n.clone(),
                    format!(
                        "time {} goes backwards for the {} hand (previous {})",
                        s.t, s.hand, last[k]
                    ),
                ));
            }
            last[k] = s.t;
        }
        Ok(())
    }

    /// Writes the stream as JSON lines.
    pub fn to_jsonl(&self) -> String {
        let mut out = String::new();
        for s in &self.samples {
            out.push_str(&serde_json::to_string(s).expect("serialisable"));
            out.push('\n');
        }
        out
    }

    /// Writes the stream as CSV.
    pub fn to_csv(&self) -> String {
        let mut out = String::from(CSV_HEADER);
        out.push('\n');
        for s in &self.samples {
            let [x, y, z] = s.position;
            let [qx, qy, qz, qw] = s.orientation;
            out.push_str(&format!(
                "{},{},{x},{y},{z},{qx},{qy},{qz},{qw},{}\n",
                s.t,
                s.hand.prefix(),
                s.flexion
            ));
        }
        out
    }

    /// Time of the last sample.
    pub fn duration(&self) -> f64 {
        self.samples.iter().map(|s| s.t).fold(0.0, f64::max)
    }
}

/// Plays a [`TeleopStream`] back: the latest sample at or before `t` per hand.
#[derive(Debug, Clone)]
pub struct Replay {
    stream: TeleopStream,
    next: usize,
    current: [Option<HandCommand>; 2],
}

impl Replay {
    /// A player at time 0.
    pub fn new(stream: TeleopStream) -> Replay {
        Replay {
            stream,
            next: 0,
            current: [None, None],
        }
    }

    /// Advances to `t` and returns the commands in force, per hand (left, right).
    pub fn at(&mut self, t: f64) -> [Option<HandCommand>; 2] {
        while self.next < self.stream.samples.len() && self.stream.samples[self.next].t <= t {
            let s = self.stream.samples[self.next];
            self.current[s.hand.index()] = Some(s);
            self.next += 1;
        }
        self.current
    }

    /// Whether every sample has been played.
    pub fn finished(&self) -> bool {
        self.next >= self.stream.samples.len()
    }

    /// Duration of the stream.
    pub fn duration(&self) -> f64 {
        self.stream.duration()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use control_basis::math::Iso3;

    fn write(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("pbd-teleop-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn csv_and_jsonl_round_trip() {
        let pose = Iso3::translation(0.4, 0.2, 0.9);
        let s = TeleopStream {
            samples: vec![
                HandCommand::new(0.0, Arm::Left, &pose, 0.3),
                HandCommand::new(0.033, Arm::Left, &pose, 0.5),
            ],
        };
        let a = TeleopStream::load(write("a.csv", &s.to_csv())).unwrap();
        let b = TeleopStream::load(write("a.jsonl", &s.to_jsonl())).unwrap();
        assert_eq!(a, s);
        assert_eq!(b, s);
    }

    #[test]
    fn bad_files_name_the_line() {
        for (name, text, needle) in [
            ("h.csv", "t,hand,x,y,z\n0,left,0,0,0\n", "header"),
            (
                "c.csv",
                "t,hand,x,y,z,qx,qy,qz,qw,flexion\n0,left,0,0,0,0,0,0,1\n",
                "9 columns",
            ),
            (
                "m.csv",
                "t,hand,x,y,z,qx,qy,qz,qw,flexion\n1,left,0,0,0,0,0,0,1,0\n0.5,left,0,0,0,0,0,0,1,0\n",
                "backwards",
            ),
            (
                "q.csv",
                "t,hand,x,y,z,qx,qy,qz,qw,flexion\n0,left,0,0,0,0,0,0,2,0\n",
                "unit quaternion",
            ),
            (
                "n.csv",
                "t,hand,x,y,z,qx,qy,qz,qw,flexion\n0,left,0,nan,0,0,0,0,1,0\n",
                "finite",
            ),
            (
                "a.csv",
                "t,hand,x,y,z,qx,qy,qz,qw,flexion\n0,middle,0,0,0,0,0,0,1,0\n",
                "middle",
            ),
            ("e.jsonl", "", "no samples"),
            ("j.jsonl", "{\"t\":0}\n", "line 1"),
        ] {
            let err = TeleopStream::load(write(name, text)).unwrap_err().to_string();
            assert!(err.contains(name) && err.contains(needle), "{name}: {err}");
        }
    }
}

//! What the end-to-end tests of the `pbd` binary share: running it and reading its output.
#![allow(dead_code)]

use std::path::PathBuf;
use std::process::{Command, Output};

/// The repository root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Runs the built `pbd` with `args`.
pub fn pbd(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pbd"))
        .args(args)
        .output()
        .expect("the pbd binary runs")
}

/// Standard output as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs `pbd args` and checks it was refused: exit code 1 (never a panic's 101 or an abort), and
/// stderr naming every needle.
pub fn refused(args: &[&str], needles: &[&str]) {
    let o = pbd(args);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
    assert!(!e.contains("panicked"), "{args:?}: {e}");
    for n in needles {
        assert!(e.contains(n), "{args:?}: expected {n:?} in: {e}");
    }
}

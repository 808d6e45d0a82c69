//! Printing a report: JSON for programs (`--json`), the library's text for people.

use std::fmt::Display;
use std::io::Write;

use serde::Serialize;

/// Prints `value` as pretty JSON when `json`, else as its `Display` text.
pub fn emit<T: Serialize + Display>(json: bool, value: &T, out: &mut dyn Write) -> anyhow::Result<()> {
    if json {
        // Serialise first: an I/O error (a closed pipe) then stays an io::Error main recognises.
        let text = serde_json::to_string_pretty(value)?;
        writeln!(out, "{text}")?;
    } else {
        let text = value.to_string();
        write!(out, "{text}")?;
        if !text.ends_with('\n') {
            writeln!(out)?;
        }
    }
    Ok(())
}

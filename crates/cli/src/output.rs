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

/// `--live` / `--bind`: serve the run to Foxglove over WebSocket while it is logged.
#[derive(Debug, Clone, clap::Args)]
pub struct LiveArgs {
    /// Serve the run live to Foxglove (WebSocket) while writing the log; no listener without it.
    #[arg(long)]
    live: bool,
    /// Address of the live view (HOST:PORT); 127.0.0.1 keeps it on this machine.
    #[arg(long, value_name = "HOST:PORT", default_value = pbd::live::DEFAULT_BIND, requires = "live")]
    bind: String,
}

impl LiveArgs {
    /// The address to serve on, if `--live`.
    pub fn bind(&self) -> Option<String> {
        self.live.then(|| self.bind.clone())
    }
}

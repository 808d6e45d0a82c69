//! Diagnostics. The library crates speak [`tracing`]: the schema executive opens an `action` span
//! per action (its outcome is an event inside it), the robot's executive (`dexter::exec`) reports
//! what its monitors saw after each action, its reach targets, handoff spots and ways at `debug`,
//! the tracker (`dexter::watch`) every stereo blob at `trace`, and a fault trial the world's truth
//! (`dexter_sim::truth`) at `trace`. Nothing is printed by the libraries themselves.
//!
//! This module gives a program a subscriber ([`init`]: standard error filtered by `RUST_LOG`, or
//! by a verbosity) and sends the events of a run into its MCAP file's `/log` topic
//! ([`McapLayer`] with a [`Capture`] per run), time-stamped with the simulated clock, so that they
//! appear in Foxglove's Log panel beside the images and the robot.
//!
//! An embedding program that installs its own subscriber adds [`McapLayer`] to it to keep the
//! `/log` topic; without any subscriber, a run that writes an MCAP file installs one for its own
//! thread that keeps `info` and above.

use std::cell::RefCell;
use std::fmt::Write as _;

use tracing::field::{Field, Visit};
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::layer::{Context, Layer, SubscriberExt as _};
use tracing_subscriber::registry::LookupSpan;
use tracing_subscriber::util::SubscriberInitExt as _;
use tracing_subscriber::{EnvFilter, Registry};

/// One diagnostic event, as kept for a run's `/log`.
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    /// Its level.
    pub level: Level,
    /// Where it came from (the module path, e.g. `dexter::exec`).
    pub target: String,
    /// The message, prefixed by the spans it happened in (`action{action=reach_object arm=left}: …`)
    /// and followed by its other fields.
    pub message: String,
    /// Source file, when known.
    pub file: Option<&'static str>,
    /// Source line, when known.
    pub line: Option<u32>,
}

thread_local! {
    /// The records of the run on this thread, while a [`Capture`] is alive.
    static CAPTURE: RefCell<Option<Vec<Record>>> = const { RefCell::new(None) };
}

/// Keeps the events this thread emits until dropped; [`Capture::drain`] takes them. Runs are
/// single-threaded (parallel experiments run one scene per thread), so each run sees its own.
#[derive(Debug)]
pub struct Capture {
    previous: Option<Vec<Record>>,
    _scoped: Option<ScopedDefault>,
}

/// The thread-local subscriber a capture installs when the program has none.
struct ScopedDefault(#[allow(dead_code)] tracing::subscriber::DefaultGuard);

impl std::fmt::Debug for ScopedDefault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ScopedDefault")
    }
}

impl Capture {
    /// Starts keeping this thread's events (nested captures stack: the inner one sees them).
    pub fn begin() -> Capture {
        let previous = CAPTURE.with(|c| c.borrow_mut().replace(Vec::new()));
        let scoped = (!tracing::dispatcher::has_been_set()).then(|| {
            let sub = Registry::default().with(McapLayer.with_filter(tracing_subscriber::filter::LevelFilter::INFO));
            ScopedDefault(tracing::subscriber::set_default(sub))
        });
        Capture {
            previous,
            _scoped: scoped,
        }
    }

    /// Takes the events kept since the last call (no allocation when there are none).
    pub fn drain(&self) -> Vec<Record> {
        CAPTURE.with(|c| c.borrow_mut().as_mut().map(std::mem::take).unwrap_or_default())
    }
}

impl Drop for Capture {
    fn drop(&mut self) {
        let previous = self.previous.take();
        CAPTURE.with(|c| *c.borrow_mut() = previous);
    }
}

/// A [`Layer`] that keeps events for the [`Capture`] alive on their thread (events on threads
/// without one are not kept). Spans' fields are formatted once, when the span is created.
#[derive(Debug, Clone, Copy, Default)]
pub struct McapLayer;

/// A span's fields, formatted.
struct SpanFields(String);

/// Collects an event's or a span's fields: `message` apart, the others as ` key=value`.
#[derive(Default)]
struct Fields {
    message: String,
    rest: String,
}

impl Visit for Fields {
    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "message" {
            self.message.push_str(value);
        } else if !value.is_empty() {
            let _ = write!(self.rest, " {}={value}", field.name());
        }
    }

    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        if field.name() == "message" {
            let _ = write!(self.message, "{value:?}");
        } else {
            let at = self.rest.len();
            let _ = write!(self.rest, " {}={value:?}", field.name());
            if self.rest.ends_with('=') {
                self.rest.truncate(at); // an empty value (`%""`): left out
            }
        }
    }
}

impl<S: Subscriber + for<'a> LookupSpan<'a>> Layer<S> for McapLayer {
    fn on_new_span(&self, attrs: &tracing::span::Attributes<'_>, id: &tracing::span::Id, ctx: Context<'_, S>) {
        if !capturing() {
            return;
        }
        let mut fields = Fields::default();
        attrs.record(&mut fields);
        if let Some(span) = ctx.span(id) {
            span.extensions_mut()
                .insert(SpanFields(fields.rest.trim_start().to_owned()));
        }
    }

    fn on_event(&self, event: &Event<'_>, ctx: Context<'_, S>) {
        if !capturing() {
            return;
        }
        let mut fields = Fields::default();
        event.record(&mut fields);
        let mut message = String::new();
        if let Some(scope) = ctx.event_scope(event) {
            for span in scope.from_root() {
                let ext = span.extensions();
                match ext.get::<SpanFields>() {
                    Some(f) if !f.0.is_empty() => {
                        let _ = write!(message, "{}{{{}}}: ", span.name(), f.0);
                    }
                    _ => {
                        let _ = write!(message, "{}: ", span.name());
                    }
                }
            }
        }
        message.push_str(&fields.message);
        message.push_str(&fields.rest);
        let meta = event.metadata();
        let record = Record {
            level: *meta.level(),
            target: meta.target().to_owned(),
            message,
            file: meta.file(),
            line: meta.line(),
        };
        CAPTURE.with(|c| {
            if let Some(v) = c.borrow_mut().as_mut() {
                v.push(record);
            }
        });
    }
}

fn capturing() -> bool {
    CAPTURE.with(|c| c.borrow().is_some())
}

/// The filter of standard error: `RUST_LOG` when set, else by `verbosity` — 0: warnings and errors,
/// 1: the actions and their outcomes (`info`), 2: what the executive saw and planned (`debug`),
/// 3 or more: every blob the tracker saw (`trace`).
pub fn stderr_filter(verbosity: u8) -> EnvFilter {
    match std::env::var("RUST_LOG") {
        Ok(v) if !v.trim().is_empty() => EnvFilter::new(v),
        _ => EnvFilter::new(match verbosity {
            0 => "warn",
            1 => "info",
            2 => "info,dexter=debug,schema=debug",
            _ => "info,dexter=trace,schema=trace,dexter_sim=trace",
        }),
    }
}

/// The filter of runs' `/log` topics: `RUST_LOG` when set, else the actions and their outcomes
/// (`info` and above), or as `verbosity` asks when it asks for more.
pub fn mcap_filter(verbosity: u8) -> EnvFilter {
    stderr_filter(verbosity.max(1))
}

/// Installs the program's subscriber: events to standard error (filtered by [`stderr_filter`]) and
/// to the `/log` topic of the run that is writing an MCAP file ([`McapLayer`], filtered by
/// [`mcap_filter`]). Fails when a subscriber is already installed.
pub fn init(verbosity: u8) -> Result<(), tracing_subscriber::util::TryInitError> {
    use std::io::IsTerminal as _;
    let stderr = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .without_time()
        .with_filter(stderr_filter(verbosity));
    Registry::default()
        .with(stderr)
        .with(McapLayer.with_filter(mcap_filter(verbosity)))
        .try_init()
}

/// The MCAP `/log` level of a `tracing` level.
pub(crate) fn log_level(level: Level) -> crate::mcap_log::LogLevel {
    use crate::mcap_log::LogLevel;
    match level {
        Level::ERROR => LogLevel::Error,
        Level::WARN => LogLevel::Warning,
        Level::INFO => LogLevel::Info,
        _ => LogLevel::Debug,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_capture_keeps_its_threads_events_with_their_spans_and_nothing_after_it_ends() {
        let capture = Capture::begin();
        {
            let span = tracing::info_span!("action", action = "reach_object", arm = "left");
            let _e = span.enter();
            tracing::info!(distance = 0.02, "converged");
        }
        tracing::debug!("below the scoped default's level");
        std::thread::spawn(|| tracing::warn!("another thread")).join().unwrap();
        let got = capture.drain();
        assert_eq!(got.len(), 1, "{got:?}");
        assert_eq!(got[0].level, Level::INFO);
        assert_eq!(
            got[0].message,
            "action{action=reach_object arm=left}: converged distance=0.02"
        );
        assert!(got[0].target.ends_with("logging::tests"), "{}", got[0].target);
        assert!(capture.drain().is_empty());
        drop(capture);
        tracing::warn!("after the capture");
        assert!(!capturing());
    }
}

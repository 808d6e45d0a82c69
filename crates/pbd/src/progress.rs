//! Progress and cancellation as a callback: the library reports what it is doing, a front end draws it.
//!
//! Every long pipeline of the facade takes a `&dyn Progress`. The CLI implements it with progress bars
//! and a Ctrl-C flag, the Python module with a callable, a test with [`Quiet`]. Calls may come from
//! worker threads, so an implementation is `Sync`.

/// Receives progress reports from a pipeline, and may ask it to stop.
///
/// All methods have do-nothing defaults: implement the ones you show.
pub trait Progress: Sync {
    /// A phase begins (`"record"`, `"trials"`, …) with `total` steps, or an unknown number.
    fn phase(&self, _name: &str, _total: Option<u64>) {}
    /// `n` more steps of the current phase are done.
    fn advance(&self, _n: u64) {}
    /// The current phase has reached step `position`.
    fn set_position(&self, _position: u64) {}
    /// What is happening now, in a few words.
    fn message(&self, _text: &str) {}
    /// Something the user should know that does not stop the run (a recovered file, a skipped
    /// instance).
    fn warn(&self, _text: &str) {}
    /// The current phase is over.
    fn finish(&self) {}
    /// `true` asks the pipeline to stop at its next safe point (Ctrl-C). Recordings then finish their
    /// file with what was captured; experiments stop between trials.
    fn should_stop(&self) -> bool {
        false
    }
}

/// Reports nothing and never stops.
#[derive(Debug, Clone, Copy, Default)]
pub struct Quiet;

impl Progress for Quiet {}

/// Collects warnings (and nothing else): for callers that want them as data.
#[derive(Debug, Default)]
pub struct Warnings(pub std::sync::Mutex<Vec<String>>);

impl Progress for Warnings {
    fn warn(&self, text: &str) {
        if let Ok(mut w) = self.0.lock() {
            w.push(text.to_string());
        }
    }
}

//! The library's progress callback drawn as indicatif bars on stderr (hidden for `--json` runs and
//! when stderr is not a terminal), and Ctrl-C / SIGTERM turned into a polite stop request.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use pbd::Progress;

/// The stop flag the signal handlers set (shared by every [`Bars`] of the process).
static STOP: std::sync::OnceLock<Arc<AtomicBool>> = std::sync::OnceLock::new();

/// Set when diagnostics go to stderr (`-v`, `RUST_LOG`): bars would tear their lines, so none is drawn.
pub static DIAGNOSTICS: AtomicBool = AtomicBool::new(false);

/// Whether Ctrl-C or SIGTERM asked the run to stop.
pub fn interrupted() -> bool {
    STOP.get().is_some_and(|s| s.load(Ordering::SeqCst))
}

/// For a command with no safe point to stop at (it writes its files only at the end): the first
/// Ctrl-C or SIGTERM ends the process at once with status 130 — also when the shell started it
/// with SIGINT ignored (a script's background job), where the default action would never come.
pub fn exit_on_interrupt() -> anyhow::Result<()> {
    let armed = Arc::new(AtomicBool::new(true));
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register_conditional_shutdown(sig, 130, Arc::clone(&armed))?;
    }
    Ok(())
}

/// Progress bars for one command.
#[derive(Debug)]
pub struct Bars {
    visible: bool,
    bar: Mutex<Option<ProgressBar>>,
    stop: Arc<AtomicBool>,
}

impl Bars {
    /// Bars, hidden when `quiet` or stderr is not a terminal. With `interruptible`, the first Ctrl-C or
    /// SIGTERM asks the run to stop at its next safe point (a recording finishes its file with what
    /// was captured) and a second one ends the process at once.
    pub fn new(quiet: bool, interruptible: bool) -> anyhow::Result<Self> {
        let stop = Arc::clone(STOP.get_or_init(|| Arc::new(AtomicBool::new(false))));
        if interruptible {
            for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
                // Order matters: the conditional shutdown sees the flag before this signal sets it.
                signal_hook::flag::register_conditional_shutdown(sig, 130, Arc::clone(&stop))?;
                signal_hook::flag::register(sig, Arc::clone(&stop))?;
            }
        }
        Ok(Bars {
            visible: !quiet && std::io::stderr().is_terminal() && !DIAGNOSTICS.load(Ordering::Relaxed),
            bar: Mutex::new(None),
            stop,
        })
    }

    fn with(&self, f: impl FnOnce(&ProgressBar)) {
        if let Ok(b) = self.bar.lock()
            && let Some(b) = b.as_ref()
        {
            f(b);
        }
    }
}

impl Progress for Bars {
    fn phase(&self, name: &str, total: Option<u64>) {
        let pb = if !self.visible {
            ProgressBar::with_draw_target(total, ProgressDrawTarget::hidden())
        } else if let Some(len) = total {
            let pb = ProgressBar::new(len);
            pb.set_style(
                ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} {msg} [{elapsed} < {eta}]")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            pb
        } else {
            let pb = ProgressBar::new_spinner();
            pb.set_style(
                ProgressStyle::with_template("{spinner} {prefix}: {msg} [{elapsed}]")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
            pb.enable_steady_tick(std::time::Duration::from_millis(120));
            pb
        };
        pb.set_prefix(name.to_string());
        if let Ok(mut b) = self.bar.lock()
            && let Some(old) = b.replace(pb)
        {
            old.finish_and_clear();
        }
    }

    fn advance(&self, n: u64) {
        self.with(|b| b.inc(n));
    }

    fn set_position(&self, position: u64) {
        self.with(|b| b.set_position(position));
    }

    fn message(&self, text: &str) {
        self.with(|b| b.set_message(text.to_string()));
    }

    fn warn(&self, text: &str) {
        let mut shown = false;
        self.with(|b| {
            b.suspend(|| eprintln!("warning: {text}"));
            shown = true;
        });
        if !shown {
            eprintln!("warning: {text}");
        }
    }

    fn finish(&self) {
        if let Ok(mut b) = self.bar.lock()
            && let Some(old) = b.take()
        {
            old.finish_and_clear();
        }
    }

    fn should_stop(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }
}

//! Running a long pipeline from Python: without the GIL, stoppable with Ctrl-C, reporting progress to
//! an optional Python callable.
//!
//! Python runs signal handlers only on the main thread, and only when that thread executes Python.
//! So the pipeline runs on a helper thread while the calling thread, the GIL released, waits for it
//! and every 50 ms briefly takes the GIL to run `PyErr_CheckSignals`. When a handler raises
//! (`KeyboardInterrupt` from Ctrl-C), the flag behind [`Progress::should_stop`] is set; the pipeline
//! stops at its next safe point (a recording finishes its file with what was captured; an experiment
//! stops between trials), and the exception is raised once it has returned. The same holds when the
//! progress callable raises.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::Duration;

use pbd::Progress;
use pyo3::prelude::*;

use crate::errors::{Kind, error, to_py};

/// The [`Progress`] given to the pipelines.
#[derive(Debug)]
pub struct PyProgress {
    callback: Option<Py<PyAny>>,
    stop: AtomicBool,
    failure: Mutex<Option<PyErr>>,
    warnings: Mutex<Vec<String>>,
}

impl PyProgress {
    fn new(callback: Option<Py<PyAny>>) -> Self {
        PyProgress {
            callback,
            stop: AtomicBool::new(false),
            failure: Mutex::new(None),
            warnings: Mutex::new(Vec::new()),
        }
    }

    fn fail(&self, e: PyErr) {
        if let Ok(mut f) = self.failure.lock()
            && f.is_none()
        {
            *f = Some(e);
        }
        self.stop.store(true, Ordering::SeqCst);
    }

    fn call(&self, event: &str, text: &str, value: Option<u64>) {
        if self.stop.load(Ordering::Relaxed) {
            return;
        }
        if let Some(cb) = &self.callback {
            Python::attach(|py| {
                if let Err(e) = cb.call1(py, (event, text, value)) {
                    self.fail(e);
                }
            });
        }
    }

    /// Warnings the pipeline reported.
    pub fn warnings(&self) -> Vec<String> {
        self.warnings.lock().map(|w| w.clone()).unwrap_or_default()
    }
}

impl Progress for PyProgress {
    fn phase(&self, name: &str, total: Option<u64>) {
        self.call("phase", name, total);
    }
    fn advance(&self, n: u64) {
        self.call("advance", "", Some(n));
    }
    fn set_position(&self, position: u64) {
        self.call("position", "", Some(position));
    }
    fn message(&self, text: &str) {
        self.call("message", text, None);
    }
    fn warn(&self, text: &str) {
        if let Ok(mut w) = self.warnings.lock() {
            w.push(text.to_string());
        }
        self.call("warn", text, None);
    }
    fn finish(&self) {
        self.call("finish", "", None);
    }
    fn should_stop(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }
}

/// Runs `f` on a helper thread with the GIL released, watching for Ctrl-C (see the module).
/// Returns the value and the warnings reported on the way.
pub fn run<T, F>(py: Python<'_>, callback: Option<Py<PyAny>>, f: F) -> PyResult<(T, Vec<String>)>
where
    T: Send,
    F: FnOnce(&dyn Progress) -> anyhow::Result<T> + Send,
{
    let progress = PyProgress::new(callback);
    let outcome = py.detach(|| {
        std::thread::scope(|s| {
            let (tx, rx) = mpsc::channel::<()>();
            let p = &progress;
            let handle = s.spawn(move || {
                let r = f(p);
                let _ = tx.send(());
                r
            });
            loop {
                match rx.recv_timeout(Duration::from_millis(50)) {
                    Ok(()) | Err(mpsc::RecvTimeoutError::Disconnected) => break,
                    Err(mpsc::RecvTimeoutError::Timeout) => {
                        if !progress.should_stop() {
                            Python::attach(|py| {
                                if let Err(e) = py.check_signals() {
                                    progress.fail(e);
                                }
                            });
                        }
                    }
                }
            }
            handle.join()
        })
    });
    if let Some(e) = progress.failure.lock().ok().and_then(|mut f| f.take()) {
        return Err(e);
    }
    let warnings = progress.warnings();
    match outcome {
        Ok(Ok(v)) => Ok((v, warnings)),
        Ok(Err(e)) => Err(to_py(e)),
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(error(
                Kind::Base,
                format!("internal error in pbd (please report it): {what}"),
            ))
        }
    }
}

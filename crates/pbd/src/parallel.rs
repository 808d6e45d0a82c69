//! One thread pool for all parallel work: rayon's.
//!
//! Trials, scenes and grasp attempts are independent pure functions of (config, index): [`map`] runs
//! them on rayon's global pool and returns the results in input order, so a run gives the same
//! output on one thread or many. The pool's size is rayon's default (one thread per core), the
//! `RAYON_NUM_THREADS` variable, or [`set_threads`] once at start-up.

use anyhow::{Result, bail};
use rayon::prelude::*;

use crate::progress::Progress;

/// Sizes the global pool (call once, before any parallel work; later calls are ignored with a
/// message). `0` keeps rayon's default.
pub fn set_threads(n: usize) -> Result<()> {
    if n == 0 {
        return Ok(());
    }
    crate::limits::check_at_most("threads", n, crate::limits::MAX_THREADS)?;
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build_global()
        .map_err(|e| anyhow::anyhow!("cannot size the thread pool to {n} threads: {e}"))
}

/// Threads of the pool.
pub fn threads() -> usize {
    rayon::current_num_threads()
}

/// Like [`map`], but a stop request is not an error: items not yet started when `progress` asks to
/// stop give `None`, finished ones keep their result (in input order), so a caller can write what
/// was done. Errors of `f` still end the run.
pub fn map_until_stopped<T: Sync, U: Send>(
    items: &[T],
    progress: &dyn Progress,
    f: impl Fn(&T) -> Result<U> + Sync,
) -> Result<Vec<Option<U>>> {
    items
        .par_iter()
        .map(|item| {
            if progress.should_stop() {
                return Ok(None);
            }
            let r = f(item).map(Some);
            progress.advance(1);
            r
        })
        .collect()
}

/// `f(item)` for every item on the pool; results in input order; the first error (in input order)
/// wins. Each finished item advances `progress` by one; when `progress` asks to stop, items not yet
/// started fail with "interrupted".
pub fn map<T: Sync, U: Send>(
    items: &[T],
    progress: &dyn Progress,
    f: impl Fn(&T) -> Result<U> + Sync,
) -> Result<Vec<U>> {
    items
        .par_iter()
        .map(|item| {
            if progress.should_stop() {
                bail!("interrupted");
            }
            let r = f(item);
            progress.advance(1);
            r
        })
        .collect()
}

//! The trial loop the experiments share: n = 1, 2, … examples per class, a number of trials each,
//! under one progress phase that counts the trials and may be stopped between them.

use crate::progress::Progress;

/// The trials of a run under one progress phase ("trials"): one or more sweeps over n = 1..=`max_n`
/// examples per class × `trials` trials.
pub(super) struct Trials<'a> {
    progress: &'a dyn Progress,
    max_n: usize,
    trials: usize,
    /// Stop between trials when the progress asks (Ctrl-C).
    interruptible: bool,
    planned: usize,
    done: usize,
}

impl<'a> Trials<'a> {
    /// Begins the phase for `sweeps` sweeps of `max_n × trials` trials; a stop request ends a sweep
    /// between trials.
    pub fn start(progress: &'a dyn Progress, sweeps: usize, max_n: usize, trials: usize) -> Self {
        let planned = sweeps * max_n * trials;
        progress.phase("trials", Some(planned as u64));
        Trials {
            progress,
            max_n,
            trials,
            interruptible: true,
            planned,
            done: 0,
        }
    }

    /// Runs every trial of its sweeps, whatever the progress asks (feature selection has always done
    /// so).
    pub fn uninterruptible(mut self) -> Self {
        self.interruptible = false;
        self
    }

    /// One sweep: `trial(n, t)` for n = 1..=max_n and t = 0..trials, a progress step each. Returns,
    /// per n, the n and its trials' results in trial order; when stopped, the n reached holds the
    /// trials run so far, and an n none of whose trials ran ends the sweep.
    pub fn sweep<T>(
        &mut self,
        mut trial: impl FnMut(usize, usize) -> anyhow::Result<T>,
    ) -> anyhow::Result<Vec<(usize, Vec<T>)>> {
        let mut by_n = Vec::new();
        for n in 1..=self.max_n {
            let mut results = Vec::new();
            for t in 0..self.trials {
                if self.interruptible && self.progress.should_stop() {
                    break;
                }
                self.done += 1;
                results.push(trial(n, t)?);
                self.progress.advance(1);
            }
            if results.is_empty() {
                break;
            }
            by_n.push((n, results));
        }
        Ok(by_n)
    }

    /// Ends the phase; when not every planned trial ran, says how many did (the summary's
    /// `partial`).
    pub fn finish(self) -> Option<String> {
        self.progress.finish();
        (self.done < self.planned).then(|| format!("interrupted after {} of {} trials", self.done, self.planned))
    }
}

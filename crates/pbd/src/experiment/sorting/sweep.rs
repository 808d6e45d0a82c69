//! The trial loop the experiments share: n = 1, 2, … examples per class, a number of trials each,
//! under one progress phase that counts the trials and may be stopped between them.

use crate::progress::Progress;

/// The trials of a run under one progress phase ("trials"): one or more sweeps over n = 1..=`max_n`
/// examples per class × `trials` trials.
pub(super) struct Trials<'a> {
    progress: &'a dyn Progress,
    max_n: usize,
    trials: usize,
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
            planned,
            done: 0,
        }
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
                if self.progress.should_stop() {
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicU64, Ordering};

    /// Asks to stop once `after` steps are done (a Ctrl-C after that many trials).
    struct StopAfter {
        after: u64,
        done: AtomicU64,
    }

    impl Progress for StopAfter {
        fn advance(&self, n: u64) {
            self.done.fetch_add(n, Ordering::SeqCst);
        }
        fn should_stop(&self) -> bool {
            self.done.load(Ordering::SeqCst) >= self.after
        }
    }

    #[test]
    fn a_stop_request_ends_the_sweeps_between_trials_and_the_run_is_marked_partial() {
        let progress = StopAfter {
            after: 5,
            done: AtomicU64::new(0),
        };
        // Two sweeps (two tasks) of n = 1..=3 × 2 trials: 12 planned.
        let mut trials = Trials::start(&progress, 2, 3, 2);
        let first = trials.sweep(|n, t| Ok((n, t))).unwrap();
        // Five trials ran: n = 1 and 2 whole, one trial of n = 3.
        assert_eq!(
            first,
            vec![(1, vec![(1, 0), (1, 1)]), (2, vec![(2, 0), (2, 1)]), (3, vec![(3, 0)])]
        );
        // The second sweep runs nothing: it is empty, and the caller stops there.
        assert!(trials.sweep(|n, t| Ok((n, t))).unwrap().is_empty());
        assert_eq!(trials.finish().as_deref(), Some("interrupted after 5 of 12 trials"));
    }

    #[test]
    fn without_a_stop_request_every_trial_runs() {
        let mut trials = Trials::start(&crate::progress::Quiet, 1, 2, 3);
        let all = trials.sweep(|n, t| Ok(n * 10 + t)).unwrap();
        assert_eq!(all, vec![(1, vec![10, 11, 12]), (2, vec![20, 21, 22])]);
        assert_eq!(trials.finish(), None);
    }
}

//! Upper bounds on every count a user sets, checked before any work or allocation: a typo such as
//! `trials = 1000000000` is an error naming the option, never a run without end or an abort.
//! Each bound is far above any useful value.

use anyhow::{Result, bail};

/// Trials per number of examples in the sorting experiments.
pub const MAX_TRIALS: usize = 100_000;
/// Most worker threads (`--threads`, `PBD_THREADS`): each holds a simulator; a million once hung
/// spawning them.
pub const MAX_THREADS: usize = 1_024;
/// Examples per class in the sorting experiments.
pub const MAX_EXAMPLES: usize = 100;
/// Rendered views per presentation.
pub const MAX_VIEWS: usize = 64;
/// Posterior-predictive samples drawn by `learn::explain`.
pub const MAX_SAMPLES: usize = 100_000;
/// Scenes of the execute experiment.
pub const MAX_SCENES: usize = 100_000;
/// Objects per scene of the execute experiment.
pub const MAX_OBJECTS: usize = 20;
/// Demonstrations per presentation, candidates per object and method, presentations in a split.
pub const MAX_PER_OBJECT: usize = 1_000;
/// Largest input file read whole (scenes, models, corpora, inference files): 256 MB.
pub const MAX_INPUT_BYTES: u64 = 256 << 20;

/// Fails when `value` of option `name` is 0 or above `max`.
pub fn check_count(name: &str, value: usize, max: usize) -> Result<()> {
    if value == 0 {
        bail!("{name} must be at least 1");
    }
    if value > max {
        bail!("{name} = {value} is above the limit of {max}");
    }
    Ok(())
}

/// Fails when `value` of option `name` is above `max` (0 allowed).
pub fn check_at_most(name: &str, value: usize, max: usize) -> Result<()> {
    if value > max {
        bail!("{name} = {value} is above the limit of {max}");
    }
    Ok(())
}

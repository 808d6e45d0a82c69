//! What a trial draws from: the class labels, the presentations of each class (the pools), the
//! fixed set-up of a run (classes, pools, negatives, background objects, the largest number of
//! examples) and the seeded stream and random view of each draw.

use anyhow::bail;
use rand::RngExt;
use rand::seq::SliceRandom;
use schema::procedural::{Features, Hyper};
use serde::Serialize;

use super::plan;
use crate::experiment::features::FeatureBank;
use crate::experiment::{Feature, SortingOptions};
use crate::rng::Generator;

/// Which catalog label a class name refers to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Label {
    /// `color_class`.
    Color,
    /// `size_class`.
    Size,
}

impl Label {
    pub(super) fn field(self) -> &'static str {
        match self {
            Label::Color => "color_class",
            Label::Size => "size_class",
        }
    }
}

/// Per presentation index, its class under a labelling, or None.
pub(super) fn labels(bank: &FeatureBank, label: Label) -> Vec<Option<&str>> {
    bank.presentations
        .iter()
        .map(|p| match label {
            Label::Color => p.color_class.as_deref(),
            Label::Size => p.size_class.as_deref(),
        })
        .collect()
}

/// Presentations per class; errors when the catalog lacks the labels or a class has fewer than
/// `min` presentations.
pub(super) fn class_pools(
    bank: &FeatureBank,
    label: Label,
    classes: &[String],
    min: usize,
) -> anyhow::Result<Vec<Vec<usize>>> {
    let l = labels(bank, label);
    if l.iter().all(Option::is_none) {
        bail!(
            "catalog {} has no `{}` labels: this experiment needs them on its objects",
            bank.catalog,
            label.field()
        );
    }
    let mut pools = Vec::new();
    for c in classes {
        let pool: Vec<usize> = (0..l.len()).filter(|&i| l[i] == Some(c.as_str())).collect();
        if pool.len() < min {
            let mut known: Vec<&str> = l.iter().flatten().copied().collect();
            known.sort_unstable();
            known.dedup();
            bail!(
                "catalog {}: class `{c}` ({}) has {} presentations, this experiment needs at least {min} (classes: {})",
                bank.catalog,
                label.field(),
                pool.len(),
                known.join(", ")
            );
        }
        pools.push(pool);
    }
    Ok(pools)
}

/// The random stream of trial `trial` with `n` examples per class; `salt` tells the experiments
/// (and the feature-selection tasks) apart.
pub(super) fn trial_rng(seed: u64, salt: u64, n: usize, trial: usize) -> Generator {
    crate::rng::stream(crate::rng::split(seed, salt), ((n as u64) << 32) | trial as u64)
}

/// Presentation `p` in one of its rendered views, drawn at random.
pub(super) fn view<'a>(bank: &'a FeatureBank, rng: &mut Generator, p: usize) -> &'a Features {
    let v = rng.random_range(0..bank.variants());
    &bank.features[p][v]
}

/// The first `take` presentations of `pool` in a random order, each in a random view: (presentation,
/// its features) — the pool is shuffled first, then the views are drawn in that order.
pub(super) fn draw(bank: &FeatureBank, pool: &[usize], take: usize, rng: &mut Generator) -> Vec<(usize, Features)> {
    let mut pool = pool.to_vec();
    pool.shuffle(rng);
    pool.iter()
        .take(take)
        .map(|&p| (p, view(bank, rng, p).clone()))
        .collect()
}

/// The fixed parts of a run: classes, pools, negatives.
pub(super) struct Setup<'a> {
    pub classes: Vec<String>,
    pub hyper: Hyper,
    pub pools: Vec<Vec<usize>>,
    /// Indices into the test bank (the held-out one when there is one).
    pub negatives: Vec<usize>,
    /// The training bank's presentations outside the task's classes (background scene objects).
    pub distractors: Vec<usize>,
    pub max_n: usize,
    /// The held-out bank and its class pools.
    pub test: Option<(&'a FeatureBank, Vec<Vec<usize>>)>,
}

pub(super) fn setup<'a>(
    args: &SortingOptions,
    bank: &FeatureBank,
    test: Option<&'a FeatureBank>,
) -> anyhow::Result<Setup<'a>> {
    let (classes, label, hyper) = plan(args)?;
    if !matches!(args.feature, Feature::Color | Feature::Size | Feature::Relevance) {
        bail!(
            "feature {:?}: trials one by one exist for color, size and relevance",
            format!("{:?}", args.feature).to_lowercase()
        );
    }
    let pools = class_pools(bank, label, &classes, if test.is_some() { 1 } else { 2 })?;
    let test = match test {
        Some(t) => Some((t, class_pools(t, label, &classes, 1)?)),
        None => None,
    };
    let negatives = if args.feature == Feature::Relevance {
        let l = labels(test.as_ref().map_or(bank, |t| t.0), label);
        let n: Vec<usize> = (0..l.len())
            .filter(|&i| !l[i].is_some_and(|c| classes.iter().any(|k| k == c)))
            .collect();
        if n.is_empty() {
            bail!("every presentation belongs to the task's classes: nothing to reject");
        }
        n
    } else {
        Vec::new()
    };
    let distractors = {
        let l = labels(bank, label);
        (0..l.len())
            .filter(|&i| !l[i].is_some_and(|c| classes.iter().any(|k| k == c)))
            .collect::<Vec<_>>()
    };
    // With a held-out catalog every training presentation may be an example; else one per class
    // stays out for testing.
    let held = usize::from(test.is_none());
    let max_n = pools.iter().map(Vec::len).min().unwrap_or(1) - held;
    let max_n = args.max_examples.min(max_n).max(1);
    Ok(Setup {
        classes,
        hyper,
        pools,
        negatives,
        distractors,
        max_n,
        test,
    })
}

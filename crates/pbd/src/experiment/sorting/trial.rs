//! One trial of the colour / size sorting or the relevance experiment: learn from n examples per
//! class, test on the rest, and the χ² test against a random sorter.

use std::collections::BTreeMap;

use bayes::chi2::chi2_contingency;
use bayes::roc::auc;
use schema::procedural::{Example, ProceduralModel};
use serde::Serialize;

use super::pools::{Setup, draw, setup, trial_rng, view};
use super::report::Summary;
use super::sweep::Trials;
use crate::experiment::features::FeatureBank;
use crate::experiment::{Feature, SortingOptions};
use crate::progress::Progress;
use crate::rng::Generator;

/// One sorting trial.
struct TrialResult {
    correct: usize,
    total: usize,
    p_value: Result<f64, String>,
    model: ProceduralModel,
    /// (score ln B10, is_task_object) for the relevance test set.
    scores: Vec<(f64, bool)>,
    /// The test bank's presentation of each score.
    scored: Vec<usize>,
}

/// One trial with `n` examples per class and `background` objects left alone in the demonstration
/// scenes (relevance), drawn from `rng`.
fn sorting_trial(
    bank: &FeatureBank,
    s: &Setup,
    n: usize,
    rng: &mut Generator,
    background: usize,
) -> anyhow::Result<TrialResult> {
    let names = &s.classes;
    // The scene's other objects (left alone by the teacher): drawn first, from the training bank.
    let scene = if background > 0 {
        draw(bank, &s.distractors, background, rng)
    } else {
        Vec::new()
    };
    let seen: Vec<&str> = scene
        .iter()
        .map(|(p, _)| bank.presentations[*p].object.as_str())
        .collect();
    let mut train = Vec::new();
    let mut test = Vec::new();
    for (k, pool) in s.pools.iter().enumerate() {
        // With a held-out catalog only the examples are drawn; else the rest are the test objects.
        let take = if s.test.is_some() { n } else { pool.len() };
        for (i, (p, f)) in draw(bank, pool, take, rng).into_iter().enumerate() {
            if i < n {
                train.push(Example {
                    features: f,
                    reference: names[k].clone(),
                });
            } else {
                test.push((k, p, f));
            }
        }
    }
    // A held-out catalog: every presentation of each class is a test object; the negatives are its.
    let bank = match &s.test {
        Some((test_bank, test_pools)) => {
            for (k, pool) in test_pools.iter().enumerate() {
                for &p in pool {
                    test.push((k, p, view(test_bank, rng, p).clone()));
                }
            }
            *test_bank
        }
        None => bank,
    };
    let mut model = ProceduralModel::learn(s.hyper.clone(), &train)?;
    for (_, f) in &scene {
        model.observe_background(f)?;
    }
    let order: Vec<&str> = model.place_names();
    let index: BTreeMap<&str, usize> = names.iter().enumerate().map(|(i, s)| (s.as_str(), i)).collect();
    let mut confusion = vec![vec![0.0; names.len()]; names.len()];
    let mut correct = 0;
    let mut scores = Vec::new();
    let mut scored = Vec::new();
    let predictor = model.predictor()?;
    for (k, p, f) in &test {
        let pred = model.predict_with(f, &predictor)?;
        let j = index.get(pred.map_place.as_str()).copied().unwrap_or(*k);
        confusion[*k][j] += 1.0;
        correct += usize::from(j == *k);
        scores.push((pred.relevance.bayes_factor.log_b10, true));
        scored.push(*p);
    }
    debug_assert_eq!(order.len(), names.len());
    for &p in &s.negatives {
        // An object seen in the demonstration scenes is not a new object (same catalog only).
        if s.test.is_none() && seen.contains(&bank.presentations[p].object.as_str()) {
            continue;
        }
        let f = view(bank, rng, p);
        scores.push((model.predict_with(f, &predictor)?.relevance.bayes_factor.log_b10, false));
        scored.push(p);
    }
    // χ² against a random sorter: is the predicted bin independent of the true class?
    let p_value = chi2_against_random(&confusion);
    Ok(TrialResult {
        correct,
        total: test.len(),
        p_value,
        model,
        scores,
        scored,
    })
}

/// Pearson's χ² test of independence of a confusion table (rows: true class, columns: predicted
/// place) — does the sorter do better than one that ignores the object? A place never predicted (an
/// all-zero column) carries no count and makes the expected table singular (scipy refuses such a
/// table), so it is left out; the test cannot be computed when fewer than two true classes or two
/// predicted places remain (e.g. every object put in one place). `Err` says why — never p = 1.
pub fn chi2_against_random(confusion: &[Vec<f64>]) -> Result<f64, String> {
    let rows: Vec<usize> = (0..confusion.len())
        .filter(|&i| confusion[i].iter().sum::<f64>() > 0.0)
        .collect();
    let cols = confusion.first().map_or(0, Vec::len);
    let cols: Vec<usize> = (0..cols)
        .filter(|&j| confusion.iter().map(|r| r[j]).sum::<f64>() > 0.0)
        .collect();
    if rows.len() < 2 {
        return Err("fewer than two classes among the tested objects".into());
    }
    if cols.len() < 2 {
        return Err("every tested object was put in one place".into());
    }
    let table: Vec<Vec<f64>> = rows
        .iter()
        .map(|&i| cols.iter().map(|&j| confusion[i][j]).collect())
        .collect();
    chi2_contingency(&table, false)
        .map(|t| t.p_value)
        .map_err(|e| format!("χ² test: {e}"))
}

/// One trial of the colour / size sorting or the relevance experiment, as a pure function of the
/// options, the rendered features, the number of examples per class and the trial index: the same
/// record the CSVs hold, identical to that trial of [`run`](super::run) /
/// [`run_on_bank`](super::run_on_bank) (each trial draws from its own seeded stream), so any
/// scheduler (Ray, a cluster, a notebook) can run trials one by one.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct TrialRecord {
    /// `color`, `size` or `relevance`.
    pub experiment: String,
    /// Examples per class the model learned from.
    pub examples_per_class: usize,
    /// Trial index.
    pub trial: usize,
    /// Test objects put in their class's place.
    pub correct: usize,
    /// Test objects.
    pub tested: usize,
    /// correct / tested.
    pub success_rate: f64,
    /// χ² p-value against a random sorter, when it can be computed.
    pub chi2_p_value: Option<f64>,
    /// Why the χ² test could not be computed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chi2_not_computed: Option<String>,
    /// MAP connectivity structure of the learned model (§5.3).
    pub map_structure: String,
    /// Its posterior probability.
    pub map_structure_probability: f64,
    /// Relevance: ROC AUC of ln B10 (task objects against all others).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auc: Option<f64>,
    /// Relevance: fraction of objects the decision ln B10 > threshold gets right.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accuracy_at_threshold: Option<f64>,
}

/// A trial's record, its (ln B10, is-a-task-object) scores and the test bank's presentation of each.
pub(super) type TrialScores = (TrialRecord, Vec<(f64, bool)>, Vec<usize>);

/// One trial, its (ln B10, is-a-task-object) scores (for the pooled ROC curve) and the test bank's
/// presentation of each score.
pub(super) fn run_trial(
    args: &SortingOptions,
    bank: &FeatureBank,
    s: &Setup,
    n: usize,
    t: usize,
) -> anyhow::Result<TrialScores> {
    let salt = if args.feature == Feature::Relevance { 2 } else { 1 };
    let mut rng = trial_rng(args.seed, salt, n, t);
    let background = if args.feature == Feature::Relevance {
        args.background
    } else {
        0
    };
    let r = sorting_trial(bank, s, n, &mut rng, background)?;
    let sp = r.model.structure_posterior()?;
    let (auc_value, accuracy) = if args.feature == Feature::Relevance {
        let th = s.hyper.relevance_log_threshold;
        let right = r.scores.iter().filter(|(x, pos)| (*x > th) == *pos).count();
        (Some(auc(&r.scores)), Some(right as f64 / r.scores.len().max(1) as f64))
    } else {
        (None, None)
    };
    let record = TrialRecord {
        experiment: format!("{:?}", args.feature).to_lowercase(),
        examples_per_class: n,
        trial: t,
        correct: r.correct,
        tested: r.total,
        success_rate: r.correct as f64 / r.total.max(1) as f64,
        chi2_p_value: r.p_value.as_ref().ok().copied(),
        chi2_not_computed: r.p_value.err(),
        map_structure: sp.map().name().to_string(),
        map_structure_probability: sp.map_probability(),
        auc: auc_value,
        accuracy_at_threshold: accuracy,
    };
    Ok((record, r.scores, r.scored))
}

/// The trials of a colour / size sorting or relevance run.
pub(super) struct Run<'a> {
    /// Its set-up.
    pub setup: Setup<'a>,
    /// Per n = 1, 2, … examples per class: n, and each trial's record and scores in trial order.
    pub by_n: Vec<(usize, Vec<TrialScores>)>,
}

/// Runs the trials of the colour / size sorting or relevance experiment `args` on `bank` (the test
/// objects from `test` when given) under the progress phase "trials"; when stopped, says so in
/// `summary.partial`.
pub(super) fn run_trials<'a>(
    args: &SortingOptions,
    progress: &dyn Progress,
    bank: &FeatureBank,
    test: Option<&'a FeatureBank>,
    summary: &mut Summary,
) -> anyhow::Result<Run<'a>> {
    let setup = setup(args, bank, test)?;
    let mut trials = Trials::start(progress, 1, setup.max_n, args.trials);
    let by_n = trials.sweep(|n, t| run_trial(args, bank, &setup, n, t))?;
    summary.partial = trials.finish();
    Ok(Run { setup, by_n })
}

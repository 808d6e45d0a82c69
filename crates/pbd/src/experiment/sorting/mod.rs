//! The sorting experiments of §5.1–5.3 on rendered catalog features.
//!
//! A *trial* with n examples per class draws, for every class, n presentations at random as the
//! demonstrations (each in a random rendered view), learns the procedural model, and tests on the
//! class's remaining presentations (again in a random view). Everything is seeded.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use anyhow::{Context, bail};
use bayes::chi2::chi2_contingency;
use bayes::roc::{auc, roc};
use dexter_sim::scene::Catalog;
use rand::RngExt;
use rand::seq::SliceRandom;
use schema::procedural::{Connectivity, Example, Features, Hyper, ProceduralModel, StructureChoice};
use serde::Serialize;

use super::features::{FeatureBank, render_bank};
use super::{Feature, SortingOptions};
use crate::figure::{Figure, FigureFile, LineChart, Series};
use crate::progress::Progress;
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
    fn field(self) -> &'static str {
        match self {
            Label::Color => "color_class",
            Label::Size => "size_class",
        }
    }
}

/// Per presentation index, its class under a labelling, or None.
fn labels(bank: &FeatureBank, label: Label) -> Vec<Option<&str>> {
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
fn class_pools(bank: &FeatureBank, label: Label, classes: &[String], min: usize) -> anyhow::Result<Vec<Vec<usize>>> {
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

fn trial_rng(seed: u64, salt: u64, n: usize, trial: usize) -> Generator {
    crate::rng::stream(crate::rng::split(seed, salt), ((n as u64) << 32) | trial as u64)
}

fn view<'a>(bank: &'a FeatureBank, rng: &mut Generator, p: usize) -> &'a Features {
    let v = rng.random_range(0..bank.variants());
    &bank.features[p][v]
}

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

#[allow(clippy::too_many_arguments)]
fn sorting_trial(
    bank: &FeatureBank,
    pools: &[Vec<usize>],
    names: &[String],
    hyper: &Hyper,
    n: usize,
    rng: &mut Generator,
    negatives: &[usize],
    held_out: Option<(&FeatureBank, &[Vec<usize>])>,
    background: (&[usize], usize),
) -> anyhow::Result<TrialResult> {
    let mut train = Vec::new();
    // The scene's other objects (left alone by the teacher): drawn first, from the training bank.
    let mut scene: Vec<usize> = Vec::new();
    if background.1 > 0 {
        scene = background.0.to_vec();
        scene.shuffle(rng);
        scene.truncate(background.1);
    }
    let scene_features: Vec<Features> = scene.iter().map(|&p| view(bank, rng, p).clone()).collect();
    let seen: Vec<&str> = scene.iter().map(|&p| bank.presentations[p].object.as_str()).collect();
    let mut test = Vec::new();
    for (k, pool) in pools.iter().enumerate() {
        let mut pool = pool.clone();
        pool.shuffle(rng);
        for (i, &p) in pool.iter().enumerate() {
            if held_out.is_some() && i >= n {
                break;
            }
            let f = view(bank, rng, p).clone();
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
    let bank = match held_out {
        Some((test_bank, test_pools)) => {
            for (k, pool) in test_pools.iter().enumerate() {
                for &p in pool {
                    test.push((k, p, view(test_bank, rng, p).clone()));
                }
            }
            test_bank
        }
        None => bank,
    };
    let mut model = ProceduralModel::learn(hyper.clone(), &train)?;
    for f in &scene_features {
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
    for &p in negatives {
        // An object seen in the demonstration scenes is not a new object (same catalog only).
        if held_out.is_none() && seen.contains(&bank.presentations[p].object.as_str()) {
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
/// record the CSVs hold, identical to that trial of [`run`] / [`run_on_bank`] (each trial draws from
/// its own seeded stream), so any scheduler (Ray, a cluster, a notebook) can run trials one by one.
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

/// The fixed parts of a run: classes, pools, negatives.
struct Setup<'a> {
    classes: Vec<String>,
    hyper: Hyper,
    pools: Vec<Vec<usize>>,
    /// Indices into the test bank (the held-out one when there is one).
    negatives: Vec<usize>,
    /// The training bank's presentations outside the task's classes (background scene objects).
    distractors: Vec<usize>,
    max_n: usize,
    /// The held-out bank and its class pools.
    test: Option<(&'a FeatureBank, Vec<Vec<usize>>)>,
}

fn setup<'a>(args: &SortingOptions, bank: &FeatureBank, test: Option<&'a FeatureBank>) -> anyhow::Result<Setup<'a>> {
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

/// A trial's record, its (ln B10, is-a-task-object) scores and the test bank's presentation of each.
type TrialScores = (TrialRecord, Vec<(f64, bool)>, Vec<usize>);

/// One trial, its (ln B10, is-a-task-object) scores (for the pooled ROC curve) and the test bank's
/// presentation of each score.
fn run_trial(args: &SortingOptions, bank: &FeatureBank, s: &Setup, n: usize, t: usize) -> anyhow::Result<TrialScores> {
    let salt = if args.feature == Feature::Relevance { 2 } else { 1 };
    let mut rng = trial_rng(args.seed, salt, n, t);
    let held_out = s.test.as_ref().map(|(b, p)| (*b, p.as_slice()));
    let r = sorting_trial(
        bank,
        &s.pools,
        &s.classes,
        &s.hyper,
        n,
        &mut rng,
        &s.negatives,
        held_out,
        (
            &s.distractors,
            if args.feature == Feature::Relevance {
                args.background
            } else {
                0
            },
        ),
    )?;
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

/// Trial `trial` with `examples` examples per class of the experiment `args` on `bank` (see
/// [`TrialRecord`]). `examples` must lie in 1..=the largest the classes allow.
pub fn trial(args: &SortingOptions, bank: &FeatureBank, examples: usize, trial: usize) -> anyhow::Result<TrialRecord> {
    trial_held_out(args, bank, None, examples, trial)
}

/// [`trial`] with the examples drawn from `train` and, when `test` is given (a held-out catalog's
/// features), every presentation of `test` of the task's classes as the test objects (and its other
/// presentations as the negatives of the relevance experiment).
pub fn trial_held_out(
    args: &SortingOptions,
    train: &FeatureBank,
    test: Option<&FeatureBank>,
    examples: usize,
    trial: usize,
) -> anyhow::Result<TrialRecord> {
    let s = setup(args, train, test)?;
    if examples == 0 || examples > s.max_n {
        bail!(
            "examples = {examples}: this experiment runs 1..={} examples per class (the smallest class's presentations{})",
            s.max_n,
            if test.is_none() { ", one kept for testing" } else { "" }
        );
    }
    Ok(run_trial(args, train, &s, examples, trial)?.0)
}

/// The held-out test features of a run: `test_features` read, or `test_catalog` rendered (its own
/// noise stream), or none (test objects are held out from the training catalog).
pub fn test_bank(args: &SortingOptions, progress: &dyn Progress) -> anyhow::Result<Option<FeatureBank>> {
    if let Some(path) = &args.test_features {
        return Ok(Some(super::features::load_bank(path)?));
    }
    let Some(path) = &args.test_catalog else {
        return Ok(None);
    };
    let catalog = Catalog::load(path)?;
    progress.phase(
        "rendering the test catalog",
        Some((catalog.presentation_names().len() * args.views) as u64),
    );
    let bank = render_bank(&catalog, args.views, crate::rng::split(args.seed, 0x7E57), || {
        progress.advance(1)
    })?;
    progress.finish();
    Ok(Some(bank))
}

fn mean_sd(xs: &[f64]) -> (f64, f64) {
    let n = xs.len().max(1) as f64;
    let m = xs.iter().sum::<f64>() / n;
    let v = if xs.len() > 1 {
        xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)
    } else {
        0.0
    };
    (m, v.sqrt())
}

fn median(xs: &[f64]) -> f64 {
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return f64::NAN;
    }
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

/// One row of the per-n summary.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// Examples per class.
    pub examples: usize,
    /// Mean over trials (success rate, AUC or selection accuracy).
    pub mean: f64,
    /// Sample standard deviation over trials.
    pub sd: f64,
    /// Median χ² p-value against a random sorter (sorting experiments).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub median_p: Option<f64>,
    /// Maximum χ² p-value.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_p: Option<f64>,
    /// Trials whose χ² test could be computed (the p-value columns summarise these).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub p_computed: Option<usize>,
    /// Sorting: the success rate pooled over the trials (correct / tested) with its 95 % Wilson
    /// interval.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pooled: Option<(f64, (f64, f64))>,
}

/// The JSON summary.
#[derive(Debug, Serialize)]
pub struct Summary {
    /// Which experiment.
    pub experiment: String,
    /// The catalog.
    pub catalog: String,
    /// Classes (or tasks).
    pub classes: Vec<String>,
    /// Structure choice.
    pub structure: String,
    /// Trials per n.
    pub trials: usize,
    /// Seed.
    pub seed: u64,
    /// What `mean` measures.
    pub measure: String,
    /// Per n (or per task and n for selection).
    pub rows: BTreeMap<String, Vec<Row>>,
    /// Extra findings (e.g. incremental = batch).
    pub notes: Vec<String>,
    /// Files written (and figures to draw, listed in `figures`).
    pub files: Vec<String>,
    /// Figures for the front end to draw, with their files.
    #[serde(skip)]
    pub figures: Vec<FigureFile>,
    /// Seconds for rendering and for the experiment.
    pub seconds: [f64; 2],
    /// `summary.md`.
    #[serde(skip)]
    pub markdown: String,
    /// Set when the run was interrupted: what was finished.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub partial: Option<String>,
}

/// The files `experiment sorting` writes in its output directory.
pub const OUTPUT_FILES: &[&str] = &[
    "summary.md",
    "success.csv",
    "success.svg",
    "p_values.svg",
    "relevance.csv",
    "relevance_objects.csv",
    "roc.csv",
    "roc.svg",
    "incremental_pmfs.csv",
    "incremental_pmfs.svg",
    "samples.svg",
    "size_density.svg",
    "selection.csv",
    "selection.svg",
];

/// `pbd experiment sorting`: renders the catalog's features, runs the trials, writes the CSVs and
/// `summary.md`; the figures are returned in [`Summary::figures`] for the caller to draw.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn run(args: &SortingOptions, progress: &dyn Progress) -> crate::Result<Summary> {
    run_impl(args, progress).map_err(crate::Error::from)
}

fn run_impl(args: &SortingOptions, progress: &dyn Progress) -> anyhow::Result<Summary> {
    if let Some(path) = &args.features {
        if args.dump_features.is_some() {
            bail!("features and dump_features: give one (features are read, not rendered)");
        }
        let bank = super::features::load_bank(path)?;
        return run_on_bank_impl(args, &bank, progress);
    }
    let mut io = crate::files::IoPlan::new();
    if let Some(c) = &args.catalog {
        io.read("--catalog", c);
    }
    io.write_in("-o", &args.output, OUTPUT_FILES);
    if let Some(p) = &args.dump_features {
        io.write("--dump-features", p);
    }
    io.check()?;
    let test = test_bank(args, progress)?;
    let catalog = match &args.catalog {
        Some(p) => Catalog::load(p)?,
        None => Catalog::builtin_household()?,
    };
    let (_, label, _) = plan(args)?;
    // Labels are checked before the (slow) rendering.
    check_labels(&catalog, args.feature, label)?;
    std::fs::create_dir_all(&args.output).with_context(|| format!("creating {}", args.output.display()))?;
    let t0 = Instant::now();
    let n_views = catalog.presentation_names().len() * args.views;
    progress.phase("rendering", Some(n_views as u64));
    let bank = render_bank(&catalog, args.views, args.seed, || progress.advance(1))?;
    progress.finish();
    let render_secs = t0.elapsed().as_secs_f64();
    if let Some(p) = &args.dump_features {
        crate::files::write_atomic(p, serde_json::to_string(&bank)?.as_bytes())?;
    }
    run_with(args, &bank, test.as_ref(), render_secs, progress)
}

/// The experiment on features already rendered (a bank from [`super::features::render_bank`], or a
/// `dump_features` file read with [`super::features::load_bank`]): the same trials, files and
/// summary as [`run`], without the rendering.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn run_on_bank(args: &SortingOptions, bank: &FeatureBank, progress: &dyn Progress) -> crate::Result<Summary> {
    run_on_bank_impl(args, bank, progress).map_err(crate::Error::from)
}

fn run_on_bank_impl(args: &SortingOptions, bank: &FeatureBank, progress: &dyn Progress) -> anyhow::Result<Summary> {
    plan(args)?;
    std::fs::create_dir_all(&args.output).with_context(|| format!("creating {}", args.output.display()))?;
    let test = test_bank(args, progress)?;
    run_with(args, bank, test.as_ref(), 0.0, progress)
}

/// The classes, the kind of label and the hyperparameters of a run, validated.
fn plan(args: &SortingOptions) -> anyhow::Result<(Vec<String>, Label, Hyper)> {
    crate::limits::check_count("trials", args.trials, crate::limits::MAX_TRIALS)?;
    crate::limits::check_count("max_examples", args.max_examples, crate::limits::MAX_EXAMPLES)?;
    crate::limits::check_count("views", args.views, crate::limits::MAX_VIEWS)?;
    let classes: Vec<String> = if args.classes.is_empty() {
        match args.feature {
            Feature::Size => vec!["small".into(), "large".into()],
            _ => vec!["red".into(), "blue".into()],
        }
    } else {
        args.classes.clone()
    };
    let mut unique = classes.clone();
    unique.sort();
    unique.dedup();
    if unique.len() != classes.len() {
        bail!("classes {classes:?}: a class is named twice");
    }
    if args.feature != Feature::Selection && classes.len() < 2 {
        bail!("classes {classes:?}: give at least two classes to sort");
    }
    let label_for = |cs: &[String]| {
        if cs.iter().all(|c| dexter_sim::scene::SIZE_CLASSES.contains(&c.as_str())) {
            Label::Size
        } else {
            Label::Color
        }
    };
    let label = match args.feature {
        Feature::Color => Label::Color,
        Feature::Size => Label::Size,
        _ => label_for(&classes),
    };
    let structure = match &args.structure {
        Some(s) => StructureChoice::parse(s)
            .with_context(|| format!("--structure {s:?}: expected inferred, neither, color, size or color+size"))?,
        None => match (args.feature, label) {
            (Feature::Color | Feature::Size | Feature::Relevance, Label::Color) => {
                StructureChoice::Fixed(Connectivity::parse("color").unwrap_or_default())
            }
            (Feature::Color | Feature::Size | Feature::Relevance, Label::Size) => {
                StructureChoice::Fixed(Connectivity::parse("size").unwrap_or_default())
            }
            _ => StructureChoice::Inferred,
        },
    };
    let mut hyper = Hyper {
        structure,
        color_neighbour_share: args.neighbour_share,
        ..Hyper::default()
    };
    if args.uniform_base {
        hyper.color_base = vec![1.0 / schema::procedural::COLORS as f64; schema::procedural::COLORS];
    }
    hyper
        .validate()
        .with_context(|| format!("--neighbour-share {}", args.neighbour_share))?;
    Ok((classes, label, hyper))
}

fn run_with(
    args: &SortingOptions,
    bank: &FeatureBank,
    test: Option<&FeatureBank>,
    render_secs: f64,
    progress: &dyn Progress,
) -> anyhow::Result<Summary> {
    let (classes, label, hyper) = plan(args)?;
    if test.is_some() && !matches!(args.feature, Feature::Color | Feature::Size | Feature::Relevance) {
        bail!("a held-out test catalog goes with --feature color, size or relevance");
    }
    if args.background > 0 && args.feature != Feature::Relevance {
        bail!(
            "--background {} (objects left alone, for the relevance background model) goes with --feature relevance",
            args.background
        );
    }
    let t1 = Instant::now();
    let mut summary = Summary {
        experiment: format!("{:?}", args.feature).to_lowercase(),
        catalog: match test {
            Some(t) => format!("{} (examples) → {} (held-out test objects)", bank.catalog, t.catalog),
            None => bank.catalog.clone(),
        },
        classes: classes.clone(),
        structure: hyper.structure.name().into(),
        trials: args.trials,
        seed: args.seed,
        measure: String::new(),
        rows: BTreeMap::new(),
        notes: vec![],
        files: vec![],
        figures: vec![],
        seconds: [render_secs, 0.0],
        markdown: String::new(),
        partial: None,
    };
    match args.feature {
        Feature::Color | Feature::Size => sorting(args, progress, bank, test, &classes, &mut summary)?,
        Feature::Relevance => relevance(args, progress, bank, test, &classes, &mut summary)?,
        Feature::Incremental => incremental(args, progress, bank, &hyper, label, &classes, &mut summary)?,
        Feature::Selection => selection(args, progress, bank, &hyper, &mut summary)?,
    }
    summary.seconds[1] = t1.elapsed().as_secs_f64();
    let mut md = markdown(&summary);
    if let Some(p) = &summary.partial {
        md = format!("**PARTIAL: {p}**; the tables and figures are over those trials.\n\n{md}");
    }
    let md_path = args.output.join("summary.md");
    crate::files::write_atomic(&md_path, md.as_bytes())?;
    summary.files.push(md_path.display().to_string());
    summary.markdown = md;
    if let Some(p) = &summary.partial {
        bail!(
            "{p}; the partial results are in {} (marked PARTIAL)",
            args.output.display()
        );
    }
    Ok(summary)
}

fn check_labels(catalog: &Catalog, feature: Feature, label: Label) -> anyhow::Result<()> {
    let need: &[Label] = match feature {
        Feature::Selection => &[Label::Color, Label::Size],
        _ => std::slice::from_ref(&label),
    };
    for l in need {
        let has = catalog.objects.iter().any(|o| match l {
            Label::Color => o.color_class.is_some(),
            Label::Size => o.size_class.is_some(),
        });
        if !has {
            bail!(
                "catalog {} has no `{}` labels: `--feature {}` needs them on its objects",
                catalog.path.display(),
                l.field(),
                format!("{feature:?}").to_lowercase()
            );
        }
    }
    Ok(())
}

fn write_csv(path: &Path, header: &str, rows: &[String]) -> anyhow::Result<()> {
    let mut s = String::from(header);
    s.push('\n');
    for r in rows {
        s.push_str(r);
        s.push('\n');
    }
    crate::files::write_atomic(path, s.as_bytes())
}

fn sorting(
    args: &SortingOptions,
    progress: &dyn Progress,
    bank: &FeatureBank,
    test: Option<&FeatureBank>,
    classes: &[String],
    summary: &mut Summary,
) -> anyhow::Result<()> {
    let setup = setup(args, bank, test)?;
    let max_n = setup.max_n;
    progress.phase("trials", Some((max_n * args.trials) as u64));
    let mut csv = Vec::new();
    let mut rows = Vec::new();
    let mut not_computed = Vec::new();
    let mut done = 0;
    for n in 1..=max_n {
        let mut rates = Vec::new();
        let mut ps = Vec::new();
        let (mut hits, mut tested) = (0, 0);
        for t in 0..args.trials {
            if progress.should_stop() {
                break;
            }
            done += 1;
            let (r, _, _) = run_trial(args, bank, &setup, n, t)?;
            hits += r.correct;
            tested += r.tested;
            csv.push(format!(
                "{n},{t},{},{},{:.6},{},{},{:.6}",
                r.correct,
                r.tested,
                r.success_rate,
                r.chi2_p_value.map_or("NA".to_string(), |p| format!("{p:.6e}")),
                r.map_structure,
                r.map_structure_probability
            ));
            rates.push(r.success_rate);
            match (r.chi2_p_value, r.chi2_not_computed) {
                (Some(p), _) => ps.push(p),
                (None, why) => not_computed.push(format!(
                    "{n} example(s), trial {t}: χ² not computed ({})",
                    why.unwrap_or_default()
                )),
            }
            progress.advance(1);
        }
        if rates.is_empty() {
            break;
        }
        let (mean, sd) = mean_sd(&rates);
        rows.push(Row {
            examples: n,
            mean,
            sd,
            median_p: (!ps.is_empty()).then(|| median(&ps)),
            max_p: (!ps.is_empty()).then(|| ps.iter().copied().fold(0.0, f64::max)),
            p_computed: Some(ps.len()),
            pooled: Some((
                hits as f64 / tested.max(1) as f64,
                dexter_sim::experiment::wilson(hits, tested),
            )),
        });
    }
    if done < max_n * args.trials {
        summary.partial = Some(format!("interrupted after {done} of {} trials", max_n * args.trials));
    }
    if !not_computed.is_empty() {
        summary.notes.push(format!(
            "the χ² test could not be computed in {} trial(s) (NA in success.csv; the p-value columns summarise the others): {}",
            not_computed.len(),
            not_computed.iter().take(5).cloned().collect::<Vec<_>>().join("; ")
        ));
    }
    progress.finish();
    let dir = &args.output;
    let csv_path = dir.join("success.csv");
    write_csv(
        &csv_path,
        "examples_per_class,trial,correct,tested,success_rate,chi2_p_value,map_structure,map_structure_probability",
        &csv,
    )?;
    let what = classes.join(" vs ");
    let svg = dir.join("success.svg");
    summary.figures.push((
        svg.clone(),
        Figure::Lines(LineChart {
            title: format!("sorting {what}: success rate (mean ± sd, {} trials)", args.trials),
            x_label: "examples per class".into(),
            y_label: "success rate".into(),
            x_range: (0.5, max_n as f64 + 0.5),
            y_range: (0.0, 1.05),
            log_y: false,
            series: vec![Series {
                label: String::new(),
                points: rows.iter().map(|r| (r.examples as f64, r.mean)).collect(),
                errors: rows.iter().map(|r| (r.mean - r.sd, (r.mean + r.sd).min(1.0))).collect(),
            }],
            hlines: vec![(1.0 / classes.len() as f64, "random sorter".into())],
        }),
    ));
    let psvg = dir.join("p_values.svg");
    let floor = 1e-300;
    let lo = rows.iter().filter_map(|r| r.median_p).fold(1.0, f64::min).max(floor) * 0.1;
    summary.figures.push((
        psvg.clone(),
        Figure::Lines(LineChart {
            title: format!("sorting {what}: χ² p-value against a random sorter"),
            x_label: "examples per class".into(),
            y_label: "p-value".into(),
            x_range: (0.5, max_n as f64 + 0.5),
            y_range: (lo, 1.0),
            log_y: true,
            series: vec![
                Series {
                    label: "maximum".into(),
                    points: rows
                        .iter()
                        .filter_map(|r| Some((r.examples as f64, r.max_p?.max(floor))))
                        .collect(),
                    errors: vec![],
                },
                Series {
                    label: "median".into(),
                    points: rows
                        .iter()
                        .filter_map(|r| Some((r.examples as f64, r.median_p?.max(floor))))
                        .collect(),
                    errors: vec![],
                },
            ],
            hlines: vec![(0.05, "5 %".into()), (0.01, "1 %".into())],
        }),
    ));
    summary.measure = "success rate (correctly sorted / tested)".into();
    summary.rows.insert(what, rows);
    summary
        .files
        .extend([csv_path, svg, psvg].map(|p| p.display().to_string()));
    Ok(())
}

fn relevance(
    args: &SortingOptions,
    progress: &dyn Progress,
    bank: &FeatureBank,
    test: Option<&FeatureBank>,
    classes: &[String],
    summary: &mut Summary,
) -> anyhow::Result<()> {
    let setup = setup(args, bank, test)?;
    let max_n = setup.max_n;
    progress.phase("trials", Some((max_n * args.trials) as u64));
    let mut csv = Vec::new();
    let mut rows = Vec::new();
    let mut curves = Vec::new();
    let mut accuracy_notes = Vec::new();
    let mut per_object = Vec::new();
    for n in 1..=max_n {
        let mut aucs = Vec::new();
        let mut pooled = Vec::new();
        let mut acc = Vec::new();
        for t in 0..args.trials {
            if progress.should_stop() {
                break;
            }
            let (r, scores, scored) = run_trial(args, bank, &setup, n, t)?;
            let names = setup.test.as_ref().map_or(bank, |t| t.0);
            for (&(x, task), &p) in scores.iter().zip(&scored) {
                let pr = &names.presentations[p];
                per_object.push(format!(
                    "{n},{t},{},{},{},{},{x:.6}",
                    pr.name,
                    pr.object,
                    pr.color_class.as_deref().unwrap_or(""),
                    u8::from(task)
                ));
            }
            let (a, right) = (r.auc.unwrap_or(f64::NAN), r.accuracy_at_threshold.unwrap_or(f64::NAN));
            acc.push(right);
            csv.push(format!("{n},{t},{a:.6},{right:.6}"));
            aucs.push(a);
            pooled.extend(scores);
            progress.advance(1);
        }
        if aucs.is_empty() {
            break;
        }
        let (mean, sd) = mean_sd(&aucs);
        rows.push(Row {
            examples: n,
            mean,
            sd,
            median_p: None,
            max_p: None,
            p_computed: None,
            pooled: None,
        });
        let (am, asd) = mean_sd(&acc);
        let th = setup.hyper.relevance_log_threshold;
        let right = pooled.iter().filter(|(x, pos)| (*x > th) == *pos).count();
        let (lo, hi) = dexter_sim::experiment::wilson(right, pooled.len());
        accuracy_notes.push(format!(
            "{n} example(s) per class: decision ln B10 > {th} is right for {am:.3} ± {asd:.3} of the objects \
             (pooled {right}/{} = {:.3}, 95 % CI {lo:.3}–{hi:.3})",
            pooled.len(),
            right as f64 / pooled.len().max(1) as f64
        ));
        curves.push(Series {
            label: format!("{n} per class"),
            points: roc(&pooled),
            errors: vec![],
        });
    }
    progress.finish();
    if csv.len() < max_n * args.trials {
        summary.partial = Some(format!(
            "interrupted after {} of {} trials",
            csv.len(),
            max_n * args.trials
        ));
    }
    let dir = &args.output;
    let csv_path = dir.join("relevance.csv");
    write_csv(&csv_path, "examples_per_class,trial,auc,accuracy_at_threshold", &csv)?;
    let objects_csv = dir.join("relevance_objects.csv");
    write_csv(
        &objects_csv,
        "examples_per_class,trial,presentation,object,color_class,task_object,log_b10",
        &per_object,
    )?;
    let roc_csv = dir.join("roc.csv");
    let roc_rows: Vec<String> = curves
        .iter()
        .enumerate()
        .flat_map(|(i, c)| c.points.iter().map(move |(f, t)| format!("{},{f:.6},{t:.6}", i + 1)))
        .collect();
    write_csv(
        &roc_csv,
        "examples_per_class,false_positive_rate,true_positive_rate",
        &roc_rows,
    )?;
    let svg = dir.join("roc.svg");
    summary.figures.push((
        svg.clone(),
        Figure::Lines(LineChart {
            title: format!("task relevance of {} (ROC, trials pooled)", classes.join(" + ")),
            x_label: "false positive rate".into(),
            y_label: "true positive rate".into(),
            x_range: (0.0, 1.0),
            y_range: (0.0, 1.02),
            log_y: false,
            series: curves,
            hlines: vec![],
        }),
    ));
    summary.measure = "ROC AUC of ln B10 (task objects vs all others)".into();
    summary.notes = accuracy_notes;
    summary.rows.insert(classes.join(" + "), rows);
    summary
        .files
        .extend([csv_path, objects_csv, roc_csv, svg].map(|p| p.display().to_string()));
    Ok(())
}

fn incremental(
    args: &SortingOptions,
    _progress: &dyn Progress,
    bank: &FeatureBank,
    hyper: &Hyper,
    label: Label,
    classes: &[String],
    summary: &mut Summary,
) -> anyhow::Result<()> {
    let pools = class_pools(bank, label, classes, 1)?;
    let mut rng = trial_rng(args.seed, 3, 0, 0);
    let m = args.max_examples.min(pools.iter().map(Vec::len).min().unwrap_or(1));
    // Interleave the classes: one example of each per step.
    let mut examples = Vec::new();
    for (k, pool) in pools.iter().enumerate() {
        let mut pool = pool.clone();
        pool.shuffle(&mut rng);
        for (i, &p) in pool.iter().take(m).enumerate() {
            examples.push((i, k, view(bank, &mut rng, p).clone()));
        }
    }
    examples.sort_by_key(|e| (e.0, e.1));
    let demos: Vec<Example> = examples
        .iter()
        .map(|(_, k, f)| Example {
            features: f.clone(),
            reference: classes[*k].clone(),
        })
        .collect();
    let mut model = ProceduralModel::new(hyper.clone())?;
    let mut rows: Vec<(String, Vec<Vec<f64>>)> = classes.iter().map(|c| (c.clone(), Vec::new())).collect();
    let mut csv = Vec::new();
    for (step, e) in demos.iter().enumerate() {
        model.update(e)?;
        if step % classes.len() == classes.len() - 1 {
            for (k, c) in classes.iter().enumerate() {
                let pmf = model.color_pmf(c)?;
                for (b, p) in pmf.iter().enumerate() {
                    csv.push(format!("{},{c},{b},{p:.8}", step / classes.len() + 1));
                }
                rows[k].1.push(pmf);
            }
        }
    }
    // Incremental = batch, for several orders.
    let batch = ProceduralModel::learn(hyper.clone(), &demos)?;
    let mut max_diff: f64 = 0.0;
    let mut identical = model == batch;
    for _ in 0..10 {
        let mut d = demos.clone();
        d.shuffle(&mut rng);
        let mut inc = ProceduralModel::new(hyper.clone())?;
        for e in &d {
            inc.update(e)?;
        }
        identical &= inc == batch;
        for c in classes {
            let (a, b) = (inc.color_pmf(c)?, batch.color_pmf(c)?);
            max_diff = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(max_diff, f64::max);
            let (sa, sb) = (inc.size_density(c)?, batch.size_density(c)?);
            max_diff = max_diff
                .max((sa.loc() - sb.loc()).abs())
                .max((sa.scale() - sb.scale()).abs());
        }
    }
    let dir = &args.output;
    let csv_path = dir.join("incremental_pmfs.csv");
    write_csv(&csv_path, "examples_per_class,place,bin,probability", &csv)?;
    let svg = dir.join("incremental_pmfs.svg");
    summary.figures.push((
        svg.clone(),
        Figure::PmfGrid {
            title: "colour pmf per place after each example (Fig. 5.11)".into(),
            rows,
        },
    ));
    // Swatches and size densities of the final model (Figs. 5.12, 5.5).
    let sw = dir.join("samples.svg");
    let mut srng = trial_rng(args.seed, 4, 0, 0);
    let inst = model.sample_instances(&mut srng, 36 * classes.len())?;
    let by_place: Vec<(String, Vec<Features>)> = classes
        .iter()
        .map(|c| {
            (
                c.clone(),
                inst.iter()
                    .filter(|i| &i.place == c)
                    .map(|i| i.features.clone())
                    .collect(),
            )
        })
        .collect();
    summary.figures.push((sw.clone(), Figure::Swatches(by_place)));
    let dens = dir.join("size_density.svg");
    let dists = classes
        .iter()
        .map(|c| Ok((c.clone(), model.size_density(c)?)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    summary.figures.push((
        dens.clone(),
        Figure::SizeDensities {
            places: dists,
            samples: vec![],
        },
    ));
    let ex = model.explain()?;
    summary.measure = "colour pmf per place after each example".into();
    summary.notes.push(format!(
        "incremental = batch over 10 random orders: identical statistics {identical}, max |difference| of predictive quantities {max_diff:e}"
    ));
    summary.notes.extend(ex.text.lines().map(str::to_string));
    summary
        .files
        .extend([csv_path, svg, sw, dens].map(|p| p.display().to_string()));
    Ok(())
}

/// A place of a feature-selection task: (place name, colour class, size class) constraints.
type TaskPlace = (&'static str, Option<&'static str>, Option<&'static str>);

/// The feature-selection tasks: (name, expected structure, places).
fn selection_tasks() -> Vec<(&'static str, Connectivity, Vec<TaskPlace>)> {
    vec![
        (
            "color-only (red vs blue)",
            Connectivity::parse("color").unwrap_or_default(),
            vec![("red", Some("red"), None), ("blue", Some("blue"), None)],
        ),
        (
            "size-only (small vs large)",
            Connectivity::parse("size").unwrap_or_default(),
            vec![("small", None, Some("small")), ("large", None, Some("large"))],
        ),
        (
            "color-and-size (red/green x small/large)",
            Connectivity::parse("color+size").unwrap_or_default(),
            vec![
                ("red-small", Some("red"), Some("small")),
                ("red-large", Some("red"), Some("large")),
                ("green-small", Some("green"), Some("small")),
                ("green-large", Some("green"), Some("large")),
            ],
        ),
    ]
}

fn selection(
    args: &SortingOptions,
    progress: &dyn Progress,
    bank: &FeatureBank,
    hyper: &Hyper,
    summary: &mut Summary,
) -> anyhow::Result<()> {
    let max_n = args.max_examples.min(3);
    let tasks = selection_tasks();
    progress.phase("trials", Some((tasks.len() * max_n * args.trials) as u64));
    let mut csv = Vec::new();
    let mut series = Vec::new();
    let hyper = Hyper {
        structure: StructureChoice::Inferred,
        ..hyper.clone()
    };
    for (ti, (name, expected, places)) in tasks.iter().enumerate() {
        let pools: Vec<Vec<usize>> = places
            .iter()
            .map(|(_, c, s)| {
                (0..bank.presentations.len())
                    .filter(|&i| {
                        let p = &bank.presentations[i];
                        c.is_none_or(|c| p.color_class.as_deref() == Some(c))
                            && s.is_none_or(|s| p.size_class.as_deref() == Some(s))
                    })
                    .collect()
            })
            .collect();
        if let Some((k, _)) = pools.iter().enumerate().find(|(_, p)| p.is_empty()) {
            bail!(
                "catalog {}: no presentation for place `{}` of task {name}",
                bank.catalog,
                places[k].0
            );
        }
        let names: Vec<String> = places.iter().map(|p| p.0.to_string()).collect();
        let mut rows = Vec::new();
        for n in 1..=max_n {
            let mut hits = Vec::new();
            for t in 0..args.trials {
                let mut rng = trial_rng(args.seed, 10 + ti as u64, n, t);
                let mut train = Vec::new();
                for (k, pool) in pools.iter().enumerate() {
                    let mut pool = pool.clone();
                    pool.shuffle(&mut rng);
                    for &p in pool.iter().take(n) {
                        train.push(Example {
                            features: view(bank, &mut rng, p).clone(),
                            reference: names[k].clone(),
                        });
                    }
                }
                let model = ProceduralModel::learn(hyper.clone(), &train)?;
                let sp = model.structure_posterior()?;
                let ok = sp.map() == *expected;
                hits.push(f64::from(u8::from(ok)));
                let probs: Vec<String> = sp.structures.iter().map(|s| format!("{:.6}", s.probability)).collect();
                csv.push(format!("{name},{n},{t},{},{ok},{}", sp.map().name(), probs.join(",")));
                progress.advance(1);
            }
            let (mean, sd) = mean_sd(&hits);
            rows.push(Row {
                examples: n,
                mean,
                sd,
                median_p: None,
                max_p: None,
                p_computed: None,
                pooled: None,
            });
        }
        series.push(Series {
            label: name.to_string(),
            points: rows.iter().map(|r| (r.examples as f64, r.mean)).collect(),
            errors: vec![],
        });
        summary.rows.insert(name.to_string(), rows);
    }
    progress.finish();
    let dir = &args.output;
    let csv_path = dir.join("selection.csv");
    write_csv(
        &csv_path,
        "task,examples_per_class,trial,map_structure,correct,p_neither,p_color,p_size,p_color_size",
        &csv,
    )?;
    let svg = dir.join("selection.svg");
    summary.figures.push((
        svg.clone(),
        Figure::Lines(LineChart {
            title: "feature selection: right structure named (fraction of trials)".into(),
            x_label: "examples per class".into(),
            y_label: "fraction of trials".into(),
            x_range: (0.5, max_n as f64 + 0.5),
            y_range: (0.0, 1.05),
            log_y: false,
            series,
            hlines: vec![(0.9, "0.9".into())],
        }),
    ));
    summary.measure = "fraction of trials whose MAP structure is the task's".into();
    summary.classes = tasks.iter().map(|t| t.0.to_string()).collect();
    summary.files.extend([csv_path, svg].map(|p| p.display().to_string()));
    Ok(())
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&markdown(self))
    }
}

fn markdown(s: &Summary) -> String {
    let mut md = format!(
        "# pbd experiment sorting --feature {}\n\ncatalog `{}`, classes {}, structure `{}`, {} trials, seed {}; \
         rendering {:.1} s, experiment {:.1} s.\n\nMeasure: {}.\n",
        s.experiment,
        s.catalog,
        s.classes.join(", "),
        s.structure,
        s.trials,
        s.seed,
        s.seconds[0],
        s.seconds[1],
        s.measure
    );
    for (name, rows) in &s.rows {
        md.push_str(&format!("\n## {name}\n\n"));
        let with_p = rows.iter().any(|r| r.p_computed.is_some());
        if with_p {
            md.push_str(
                "| examples per class | mean | sd | pooled (95 % CI) | median χ² p | max χ² p | χ² computed in |\n|---:|---:|---:|---:|---:|---:|---:|\n",
            );
        } else {
            md.push_str("| examples per class | mean | sd |\n|---:|---:|---:|\n");
        }
        for r in rows {
            md.push_str(&format!("| {} | {:.3} | {:.3} |", r.examples, r.mean, r.sd));
            if with_p {
                let p = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.2e}"));
                let pooled = r
                    .pooled
                    .map_or("n/a".to_string(), |(m, (lo, hi))| format!("{m:.3} ({lo:.3}–{hi:.3})"));
                md.push_str(&format!(
                    " {pooled} | {} | {} | {}/{} trials |",
                    p(r.median_p),
                    p(r.max_p),
                    r.p_computed.unwrap_or(0),
                    s.trials
                ));
            }
            md.push('\n');
        }
    }
    if !s.notes.is_empty() {
        md.push_str("\n## Notes\n\n");
        for n in &s.notes {
            md.push_str(&format!("- {n}\n"));
        }
    }
    md
}

//! The sorting experiments of §5.1–5.3 on rendered catalog features.
//!
//! A *trial* with n examples per class draws, for every class, n presentations at random as the
//! demonstrations (each in a random rendered view), learns the procedural model, and tests on the
//! class's remaining presentations (again in a random view). Everything is seeded.
//!
//! This file is the public API and the options' checks. The machinery the experiments share is
//! written once: `pools` (what a trial draws from), `trial` (one colour / size or relevance trial,
//! and running them all), `sweep` (the examples-per-class × trials loop with its progress phase and
//! stop requests), `report` (the summary rows, `summary.md`, the CSV files and figures). Each
//! experiment's file says only what is its own — what a trial measures, its rows, files and
//! figures: `sort` (colour / size), `relevance`, `incremental`, `selection`.

use std::collections::BTreeMap;
use std::time::Instant;

use anyhow::{Context, bail};
use dexter_sim::scene::Catalog;
use schema::procedural::{Connectivity, Hyper, StructureChoice};

use super::features::{FeatureBank, render_bank};
use super::{Feature, SortingOptions};
use crate::progress::Progress;

mod incremental;
mod pools;
mod relevance;
mod report;
mod selection;
mod sort;
mod sweep;
mod trial;

pub use pools::Label;
pub use report::{Row, Summary};
pub use trial::{TrialRecord, chi2_against_random};

use pools::setup;
use report::markdown;
use trial::{run_trial, run_trials};

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
        color_chromatic_share: args.chromatic_share,
        ..Hyper::default().with_size_unit(args.size_unit)
    };
    if args.uniform_base {
        hyper.color_base = vec![1.0 / schema::procedural::COLORS as f64; schema::procedural::COLORS];
    }
    hyper.validate().with_context(|| {
        format!(
            "--neighbour-share {}, --chromatic-share {}",
            args.neighbour_share, args.chromatic_share
        )
    })?;
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
        Feature::Color | Feature::Size => {
            let run = run_trials(args, progress, bank, test, &mut summary)?;
            sort::sorting(args, run, &classes, &mut summary)?
        }
        Feature::Relevance => {
            let run = run_trials(args, progress, bank, test, &mut summary)?;
            relevance::relevance(args, run, bank, &classes, &mut summary)?
        }
        Feature::Incremental => incremental::incremental(args, bank, &hyper, label, &classes, &mut summary)?,
        Feature::Selection => selection::selection(args, progress, bank, &hyper, &mut summary)?,
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

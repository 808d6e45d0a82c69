//! `pbd experiment sorting | execute | faults | perception`: the seed's procedural-learning
//! experiments (§5.1–5.3), the execution of a learned model on random new scenes, injected faults, and
//! the robot's perception of those scenes against the truth. The library writes the CSV and Markdown files;
//! this module draws the figures.

use std::io::Write;
use std::path::PathBuf;

use clap::{Args, Subcommand};
use pbd::dexter_sim::fault::FaultKind;
use pbd::experiment::execute::ExecuteExperimentOptions;
use pbd::experiment::faults::FaultsOptions;
use pbd::experiment::{Feature, SortingOptions};
use pbd::figure::Figure;

use crate::progress::Bars;

/// `pbd experiment …` subcommands.
#[derive(Debug, Subcommand)]
pub enum ExperimentCommand {
    /// Sorting experiments on rendered catalog features: success vs examples per class with χ²
    /// p-values, size sorting, relevance ROC, incremental pmfs, feature selection.
    Sorting(SortingArgs),
    /// A learned model executed by the robot on N random new scenes drawn from a catalog: per-object
    /// decisions and outcomes, placed fraction with a 95 % interval, failure causes by phase.
    Execute(ExecuteExperimentArgs),
    /// Injected faults (drop, bump, blocked arm, occlusion, sensor noise): N seeded scenes per kind,
    /// recovered fraction with 95 % intervals and what the executive did.
    Faults(FaultsArgs),
    /// The robot's eyes on N random scenes (those of `execute` with the same seed) against the
    /// truth: objects missed, duplicate and phantom segments, centroid, height and footprint errors.
    Perception(PerceptionArgs),
}

/// `pbd experiment sorting` arguments.
#[derive(Debug, Args)]
pub struct SortingArgs {
    /// The experiment.
    #[arg(long, value_enum)]
    feature: Feature,
    /// Object catalog (TOML) the examples (and, without --test-catalog, the test objects) come
    /// from; default: the built-in household catalog.
    #[arg(long, visible_alias = "train-catalog")]
    catalog: Option<PathBuf>,
    /// Trials per number of examples.
    #[arg(long, default_value_t = 10)]
    trials: usize,
    /// Largest number of examples per class.
    #[arg(long, default_value_t = 6)]
    max_examples: usize,
    /// Classes to sort (comma-separated labels); default red,blue for colour, small,large for size.
    #[arg(long, value_delimiter = ',')]
    classes: Vec<String>,
    /// Connectivity structure: inferred (feature selection) or fixed (color, size, color+size).
    /// Default: the feature under test for color, size and relevance (the seed fixes it), inferred
    /// for incremental and selection.
    #[arg(long)]
    structure: Option<String>,
    /// Rendered views per presentation (trials draw among them).
    #[arg(long, default_value_t = 4)]
    views: usize,
    /// Random seed (renders and trials).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory (CSV, SVG plots, summary.md).
    #[arg(short, long)]
    output: PathBuf,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
    /// Also write the rendered features to this JSON file (a feature bank).
    #[arg(long)]
    dump_features: Option<PathBuf>,
    /// Read the features from this JSON file (from --dump-features) instead of rendering the
    /// catalog; --catalog and --views are then ignored.
    #[arg(long, conflicts_with = "dump_features")]
    features: Option<PathBuf>,
    /// A held-out catalog to test on: examples come from --catalog (the training catalog), the test
    /// objects (and relevance negatives) are every presentation of this one.
    #[arg(long)]
    test_catalog: Option<PathBuf>,
    /// Or the held-out catalog's features (from --dump-features).
    #[arg(long, conflicts_with = "test_catalog")]
    test_features: Option<PathBuf>,
    /// Relevance: objects the teacher left alone in the demonstration scenes, per trial (drawn from
    /// the training catalog outside the task's classes); they fit the background model M₀. 0: M₀ is
    /// the prior predictive.
    #[arg(long, default_value_t = 0)]
    background: usize,
    /// The colour base measure: uniform over the colour terms instead of the household catalog's
    /// colour-term shares.
    #[arg(long)]
    uniform_base: bool,
    /// The share of an object's colour term given to each neighbouring term (hue circle, black –
    /// grey – white), in [0, 0.5].
    #[arg(long, default_value_t = pbd::schema::procedural::DEFAULT_COLOR_NEIGHBOUR_SHARE)]
    neighbour_share: f64,
    /// The chromatic rule: an object's black, grey and white pixels are left out of its colour
    /// when its chromatic terms cover at least this share of it, in [0, 1] (1 turns the rule off).
    #[arg(long, default_value_t = pbd::schema::procedural::DEFAULT_CHROMATIC_SHARE)]
    chromatic_share: f64,
    /// The unit of the size feature: `deci-pixels` (the seed's) or `cm` (the geometric mean of the
    /// measured bounding box).
    #[arg(long, default_value = "deci-pixels", value_parser = parse_size_unit)]
    size_unit: pbd::schema::procedural::SizeUnit,
}

/// `--size-unit` values.
pub fn parse_size_unit(s: &str) -> Result<pbd::schema::procedural::SizeUnit, String> {
    pbd::schema::procedural::SizeUnit::parse(s).ok_or_else(|| format!("`{s}` is not one of deci-pixels, cm"))
}

/// `pbd experiment execute` arguments.
#[derive(Debug, Args)]
pub struct ExecuteExperimentArgs {
    /// The learned procedural model (from `pbd learn`, e.g. `pbd-demo/model.json`).
    #[arg(long)]
    model: PathBuf,
    /// Base scene: its table, bins and catalog (built-in name or TOML file).
    #[arg(long, default_value = "sorting-demo")]
    scene: String,
    /// Number of random scenes.
    #[arg(long, default_value_t = 50)]
    scenes: usize,
    /// Objects per scene.
    #[arg(long, default_value_t = 3)]
    objects: usize,
    /// The intended task: class = place, comma-separated (objects of other classes are not part of the
    /// task); a class is a colour class (`red`), a size class (`small`, `medium`, `large`) or both
    /// (`red+large`), judged by the catalog's labels.
    #[arg(long, value_delimiter = ',', default_value = "red=bin-right,blue=bin-left")]
    task: Vec<String>,
    /// Random seed (scenes and every run).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory (objects.csv, summary.md, outcomes.svg).
    #[arg(short, long)]
    output: PathBuf,
    /// Run only scene K (0-based, the same scene as in the full run): to trace one scene with
    /// `-vv` or `RUST_LOG`.
    #[arg(long, value_name = "K")]
    only: Option<usize>,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// `pbd experiment perception` arguments.
#[derive(Debug, Args)]
pub struct PerceptionArgs {
    /// Base scene: its table, bins and catalog (built-in name or TOML file).
    #[arg(long, default_value = "sorting-demo")]
    scene: String,
    /// Number of random scenes.
    #[arg(long, default_value_t = 50)]
    scenes: usize,
    /// Objects per scene.
    #[arg(long, default_value_t = 3)]
    objects: usize,
    /// Random seed (the same scenes as `pbd experiment execute --seed`).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory (objects.csv, summary.md, errors.svg).
    #[arg(short, long, visible_alias = "out", default_value = "experiment-perception")]
    output: PathBuf,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// `pbd experiment faults` arguments.
#[derive(Debug, Args)]
pub struct FaultsArgs {
    /// Fault kinds, comma-separated: drop, bump, blocked_arm, occlusion, sensor_noise (default: all).
    #[arg(long, value_delimiter = ',', value_parser = parse_kind)]
    kinds: Vec<FaultKind>,
    /// Base scene: its table, bins and catalog (built-in name or TOML file).
    #[arg(long, default_value = "pick-place")]
    scene: String,
    /// Scenes per fault kind.
    #[arg(long, default_value_t = 30)]
    scenes: usize,
    /// Random seed (scenes, faults and runs).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory (faults.csv, summary.md, recovered.svg).
    #[arg(short, long, visible_alias = "out", default_value = "experiment-faults")]
    output: PathBuf,
    /// Run only scene K of each kind (0-based, the same scene as in the full run): to trace one
    /// scene with `-vv` or `RUST_LOG`.
    #[arg(long, value_name = "K")]
    only: Option<usize>,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

fn parse_kind(s: &str) -> Result<FaultKind, String> {
    FaultKind::parse(s).ok_or_else(|| {
        format!(
            "unknown fault kind `{s}`; known: {}",
            FaultKind::ALL.map(|k| k.name()).join(", ")
        )
    })
}

/// Runs a `pbd experiment` subcommand.
pub fn main(cmd: ExperimentCommand, out: &mut dyn Write) -> anyhow::Result<()> {
    match cmd {
        ExperimentCommand::Sorting(a) => sorting(a, out),
        ExperimentCommand::Execute(a) => execute(a, out),
        ExperimentCommand::Faults(a) => faults(a, out),
        ExperimentCommand::Perception(a) => perception(a, out),
    }
}

fn perception(a: PerceptionArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let options = pbd::experiment::perception::PerceptionOptions {
        scene: a.scene,
        scenes: a.scenes,
        objects: a.objects,
        seed: a.seed,
        output: a.output,
    };
    let run = pbd::experiment::perception::run(&options, &Bars::new(a.json, true)?)?;
    pbd::figure::draw(&run.output.join("errors.svg"), &run.figure)?;
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&run)?)?;
    } else {
        write!(out, "{}", run.markdown)?;
        writeln!(
            out,
            "files: objects.csv, summary.md, errors.svg in {}",
            run.output.display()
        )?;
    }
    Ok(())
}

fn faults(a: FaultsArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let options = FaultsOptions {
        kinds: if a.kinds.is_empty() {
            FaultKind::ALL.to_vec()
        } else {
            a.kinds
        },
        scene: a.scene,
        scenes: a.scenes,
        seed: a.seed,
        output: a.output,
        only: a.only,
    };
    let report = pbd::experiment::faults::run(&options, &Bars::new(a.json, true)?)?;
    for (path, figure) in &report.figures {
        pbd::figure::draw(path, figure)?;
    }
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        write!(out, "{report}")?;
    }
    Ok(())
}

fn sorting(a: SortingArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let options = SortingOptions {
        feature: a.feature,
        catalog: a.catalog,
        trials: a.trials,
        max_examples: a.max_examples,
        classes: a.classes,
        structure: a.structure,
        views: a.views,
        seed: a.seed,
        output: a.output,
        dump_features: a.dump_features,
        features: a.features,
        test_catalog: a.test_catalog,
        test_features: a.test_features,
        background: a.background,
        uniform_base: a.uniform_base,
        neighbour_share: a.neighbour_share,
        chromatic_share: a.chromatic_share,
        size_unit: a.size_unit,
    };
    let summary = pbd::experiment::sorting::run(&options, &Bars::new(a.json, true)?)?;
    for (path, figure) in &summary.figures {
        pbd::figure::draw(path, figure)?;
    }
    if a.json {
        let text = serde_json::to_string_pretty(&summary)?;
        writeln!(out, "{text}")?;
    } else {
        write!(out, "{}", summary.markdown)?;
        writeln!(out, "\nfiles:")?;
        for f in &summary.files {
            writeln!(out, "  {f}")?;
        }
    }
    Ok(())
}

fn execute(a: ExecuteExperimentArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let options = ExecuteExperimentOptions {
        model: a.model,
        scene: a.scene,
        scenes: a.scenes,
        objects: a.objects,
        task: a.task,
        seed: a.seed,
        output: a.output,
        only: a.only,
    };
    let run = pbd::experiment::execute::run(&options, &Bars::new(a.json, true)?)?;
    let s = &run.summary;
    let mut failed = vec![0.0];
    let mut categories = vec!["placed".to_string()];
    for (phase, n) in &s.failures {
        categories.push(phase.clone());
        failed.push(*n as f64);
    }
    let mut placed = vec![0.0; categories.len()];
    placed[0] = s.placed as f64;
    let figure = Figure::GroupedBars {
        title: format!(
            "placed {}/{} = {:.2} (95 % CI {:.2}-{:.2})",
            s.placed, s.executed, s.placed_fraction, s.placed_interval.0, s.placed_interval.1
        ),
        y_label: "objects".into(),
        y_max: (placed[0].max(failed.iter().copied().fold(0.0, f64::max)) * 1.15).max(1.0),
        categories,
        groups: vec![("placed".into(), placed), ("failed".into(), failed)],
        intervals: vec![],
    };
    pbd::figure::draw(&run.output.join("outcomes.svg"), &figure)?;
    if a.json {
        let text = serde_json::to_string_pretty(&run.summary)?;
        writeln!(out, "{text}")?;
    } else {
        write!(out, "{}", run.markdown)?;
        writeln!(
            out,
            "files: objects.csv, summary.md, outcomes.svg in {}",
            run.output.display()
        )?;
    }
    Ok(())
}

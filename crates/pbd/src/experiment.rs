//! `pbd experiment`: the seed's procedural-learning experiments (Sweeney 2011, §5.1–5.2) on features
//! rendered from an object catalog — colour sorting (Figs. 5.2, 5.3), size sorting (Fig. 5.6), task
//! relevance ROC (Figs. 5.8, 5.10) and incremental pmfs (Fig. 5.11), plus feature selection (§5.3.3).

use std::io::Write;
use std::path::PathBuf;

use clap::{Args, Subcommand, ValueEnum};

pub mod execute;
pub mod features;
pub mod sorting;

/// `pbd experiment …` subcommands.
#[derive(Debug, Subcommand)]
pub enum ExperimentCommand {
    /// Sorting experiments on rendered catalog features: success vs examples per class with χ²
    /// p-values, size sorting, relevance ROC, incremental pmfs, feature selection.
    Sorting(SortingArgs),
    /// A learned model executed by the robot on N random new scenes drawn from a catalog: per-object
    /// decisions and outcomes, placed fraction with a 95 % interval, failure causes by phase.
    Execute(execute::ExecuteExperimentArgs),
}

/// Which experiment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Feature {
    /// Colour sorting by the catalog's `color_class` labels (Figs. 5.2, 5.3).
    Color,
    /// Size sorting by `size_class` (Small vs Large, Fig. 5.6).
    Size,
    /// Task relevance ROC: objects of the task's classes vs all others (Figs. 5.8, 5.10).
    Relevance,
    /// Incremental learning: the pmfs after each example (Fig. 5.11); incremental = batch.
    Incremental,
    /// Feature selection: which feature type decides the place, for colour-only, size-only and
    /// colour-and-size tasks (§5.3.3).
    Selection,
}

/// `pbd experiment sorting` arguments.
#[derive(Debug, Args)]
pub struct SortingArgs {
    /// The experiment.
    #[arg(long, value_enum)]
    pub feature: Feature,
    /// Object catalog (TOML); default: the built-in household catalog.
    #[arg(long)]
    pub catalog: Option<PathBuf>,
    /// Trials per number of examples.
    #[arg(long, default_value_t = 10)]
    pub trials: usize,
    /// Largest number of examples per class.
    #[arg(long, default_value_t = 6)]
    pub max_examples: usize,
    /// Classes to sort (comma-separated labels); default red,blue for colour, small,large for size.
    #[arg(long, value_delimiter = ',')]
    pub classes: Vec<String>,
    /// Connectivity structure: inferred (feature selection) or fixed (color, size, color+size).
    /// Default: the feature under test for color, size and relevance (the seed fixes it), inferred
    /// for incremental and selection.
    #[arg(long)]
    pub structure: Option<String>,
    /// Rendered views per presentation (trials draw among them).
    #[arg(long, default_value_t = 4)]
    pub views: usize,
    /// Random seed (renders and trials).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output directory (CSV, SVG plots, summary.md).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
    /// Also write the rendered features to this JSON file.
    #[arg(long, hide = true)]
    pub dump_features: Option<PathBuf>,
}

/// Runs a `pbd experiment` subcommand.
pub fn main(cmd: ExperimentCommand, out: &mut dyn Write) -> anyhow::Result<()> {
    match cmd {
        ExperimentCommand::Sorting(args) => sorting::run(&args, out),
        ExperimentCommand::Execute(args) => execute::run(&args, out),
    }
}

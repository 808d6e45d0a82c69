//! `pbd learn`: the procedural model of a task from one to a few demonstrations (ch. 5), or
//! `--explain`: what a model learned, in words and pictures.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use pbd::learn::{LearnOptions, explain, learn};

use crate::output::emit;
use crate::progress::Bars;

/// Arguments of `pbd learn`.
#[derive(Debug, Args)]
pub struct LearnArgs {
    /// Demonstrations: inference files (`*.infer.json`) or recordings (`*.mcap`, inferred on the fly).
    demos: Vec<PathBuf>,
    /// Add the demonstrations to this model instead of starting afresh.
    #[arg(long)]
    update: Option<PathBuf>,
    /// Schema library (TOML) the demonstrations were inferred with (default: the built-in one).
    #[arg(long)]
    library: Option<PathBuf>,
    /// Output model (JSON).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Explain the model MODEL.json in plain words (no learning).
    #[arg(long, value_name = "MODEL", conflicts_with_all = ["demos", "update", "output", "relevance_threshold", "library", "no_distractors", "size_unit"])]
    explain: Option<PathBuf>,
    /// With --explain: draw N synthetic task instances from the posterior predictive and render them.
    #[arg(long, default_value_t = 0)]
    samples: usize,
    /// With --explain: directory for the pictures (default: next to the model).
    #[arg(long)]
    plots: Option<PathBuf>,
    /// Relevance decision threshold on ln B10 (5.19–5.21) for a new model: an object belongs to the
    /// task when ln B10 exceeds it. The default (1) is calibrated on development data
    /// (`schema::procedural`); 0 is the seed's rule (B10 > 1, even prior odds).
    #[arg(long, default_value_t = pbd::schema::procedural::DEFAULT_RELEVANCE_LOG_THRESHOLD, allow_negative_numbers = true)]
    relevance_threshold: f64,
    /// Leave the relevance background model M₀ (§5.1.3) at its prior instead of fitting it to the
    /// objects the teacher left alone in the demonstrations.
    #[arg(long)]
    no_distractors: bool,
    /// The unit of the size feature of a new model: `cm` (the geometric mean of the object's measured
    /// bounding box) or the seed's `deci-pixels`.
    #[arg(long, default_value = "cm", value_parser = crate::experiment::parse_size_unit)]
    size_unit: pbd::schema::procedural::SizeUnit,
    /// Seed of the posterior-predictive samples.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print the result as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs `pbd learn`.
pub fn main(a: LearnArgs, out: &mut dyn Write) -> Result<()> {
    if let Some(model) = &a.explain {
        return explain_model(model, &a, out);
    }
    if !a.relevance_threshold.is_finite() {
        bail!(
            "--relevance-threshold must be a finite number (a log Bayes factor), got {}",
            a.relevance_threshold
        );
    }
    let options = LearnOptions {
        demos: a.demos,
        update: a.update,
        library: a.library,
        output: a.output.context("pass -o model.json")?,
        relevance_threshold: a.relevance_threshold,
        distractors: !a.no_distractors,
        size_unit: a.size_unit,
    };
    let report = learn(&options, &Bars::new(a.json, false)?)?;
    emit(a.json, &report, out)
}

fn explain_model(path: &Path, a: &LearnArgs, out: &mut dyn Write) -> Result<()> {
    crate::progress::exit_on_interrupt()?;
    let e = explain(path, a.samples, a.seed)?;
    let mut pictures = Vec::new();
    if a.samples > 0 {
        let dir = a
            .plots
            .clone()
            .unwrap_or_else(|| path.parent().map(Path::to_path_buf).unwrap_or_default());
        std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let stem = path
            .file_stem()
            .map_or("model".into(), |s| s.to_string_lossy().to_string());
        let sw = dir.join(format!("{stem}.swatches.png"));
        pbd::figure::swatches(&sw, &e.samples_by_place)?;
        let sd = dir.join(format!("{stem}.sizes.png"));
        pbd::figure::size_densities(&sd, &e.size_densities, &e.sampled_sizes)?;
        pictures.push(sw.display().to_string());
        pictures.push(sd.display().to_string());
    }
    let x = &e.explanation;
    if a.json {
        let v = serde_json::json!({"explanation": x.text, "color_matters": x.color_matters, "size_matters": x.size_matters,
            "map_structure": x.map_structure, "consistency": x.consistency, "pictures": pictures});
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
        return Ok(());
    }
    writeln!(out, "{}", x.text)?;
    for p in pictures {
        writeln!(out, "picture: {p}")?;
    }
    Ok(())
}

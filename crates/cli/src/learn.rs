//! `pbd learn`: the procedural model of a task from one to a few demonstrations (ch. 5).
//!
//! Each Pick-And-Place instance found by `pbd infer` gives one example: the features the robot saw of
//! the object when its grasp converged (colour terms and histogram, size in pixels) and the place where Place
//! converged. The model (`schema::procedural`) keeps sufficient statistics, so `--update` adds new
//! demonstrations to an existing model with the same result as learning from all at once (§5.2).
//! `--explain` says in plain words (and pictures) what was learned.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use schema::Library;
use schema::procedural::{Example, Features, Hyper, ProceduralModel};
use serde::Serialize;

use crate::infer::{INFER_FORMAT, InferFile};

/// Arguments of `pbd learn`.
#[derive(Debug, Args)]
pub struct LearnArgs {
    /// Demonstrations: inference files (`*.infer.json`) or recordings (`*.mcap`, inferred on the fly).
    pub demos: Vec<PathBuf>,
    /// Add the demonstrations to this model instead of starting afresh.
    #[arg(long)]
    pub update: Option<PathBuf>,
    /// Output model (JSON).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Explain the model MODEL.json in plain words (no learning).
    #[arg(long, value_name = "MODEL")]
    pub explain: Option<PathBuf>,
    /// With --explain: draw N synthetic task instances from the posterior predictive and render them.
    #[arg(long, default_value_t = 0)]
    pub samples: usize,
    /// With --explain: directory for the pictures (default: next to the model).
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Relevance decision threshold on ln B10 (5.19–5.21) for a new model: an object belongs to the
    /// task when ln B10 exceeds it. 0 is the seed's rule (B10 > 1, even prior odds).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub relevance_threshold: f64,
    /// Seed of the posterior-predictive samples.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print the result as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Serialize)]
struct LearnReport {
    output: String,
    examples: Vec<(String, String, String)>,
    demonstrations: u64,
    explanation: String,
}

/// Examples (features, place) from the Pick-And-Place instances of a demonstration file.
pub fn examples_from(path: &Path) -> Result<Vec<Example>> {
    let file: InferFile = if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("mcap")) {
        let (percepts, _, metadata, warnings) = crate::infer::read_percepts(path)?;
        for w in &warnings {
            eprintln!("warning: {w}");
        }
        let (inference, _, _) = crate::infer::infer_percepts(&Library::builtin(), &percepts)?;
        InferFile {
            format: INFER_FORMAT.into(),
            version: crate::infer::INFER_VERSION,
            demo: path.display().to_string(),
            metadata,
            library: "<builtin>".into(),
            warnings,
            inference,
            truth: vec![],
        }
    } else {
        let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
        let file: InferFile = serde_json::from_str(&text)
            .with_context(|| format!("{} is not an inference file (from `pbd infer`)", path.display()))?;
        if file.format != INFER_FORMAT || file.version != crate::infer::INFER_VERSION {
            bail!(
                "{}: format `{}` version {} is not `{INFER_FORMAT}` version {}",
                path.display(),
                file.format,
                file.version,
                crate::infer::INFER_VERSION
            );
        }
        file
    };
    let mut out = Vec::new();
    for (i, inst) in file.inference.instances.iter().enumerate() {
        if inst.schema != "pick_and_place" {
            continue;
        }
        let (Some(seg), Some(place)) = (&inst.features, &inst.place) else {
            eprintln!(
                "warning: {}: instance {} has no {} — skipped",
                path.display(),
                i + 1,
                if inst.features.is_none() {
                    "object features"
                } else {
                    "place"
                }
            );
            continue;
        };
        out.push(Example {
            features: Features::from(seg),
            reference: place.clone(),
        });
    }
    Ok(out)
}

/// Runs `pbd learn`.
pub fn main(args: LearnArgs, out: &mut dyn Write) -> Result<()> {
    if let Some(model) = &args.explain {
        return explain(model, &args, out);
    }
    if args.demos.is_empty() {
        bail!("no demonstrations given (pass *.infer.json or *.mcap files)");
    }
    let output = args.output.clone().context("pass -o model.json")?;
    let mut examples = Vec::new();
    let mut listing = Vec::new();
    for d in &args.demos {
        let ex = examples_from(d)?;
        for e in &ex {
            let mut colors = e.features.colors.clone();
            colors.sort_by(|x, y| y.1.total_cmp(&x.1));
            let colors: Vec<String> = colors
                .iter()
                .take(3)
                .map(|&(t, w)| format!("{} {w:.2}", schema::procedural::color_name(usize::from(t))))
                .collect();
            listing.push((
                d.display().to_string(),
                e.reference.clone(),
                format!("colours {} px {:?}", colors.join(", "), e.features.pixels),
            ));
        }
        examples.extend(ex);
    }
    if examples.is_empty() {
        bail!("empty demonstration set: no Pick-And-Place instance with object features and a place in the inputs");
    }
    let model = match &args.update {
        Some(path) => {
            let mut m = ProceduralModel::load(path)?;
            for e in &examples {
                m.update(e)?;
            }
            m
        }
        None => {
            if !args.relevance_threshold.is_finite() {
                bail!("--relevance-threshold must be a number");
            }
            let hyper = Hyper {
                relevance_log_threshold: args.relevance_threshold,
                ..Hyper::default()
            };
            ProceduralModel::learn(hyper, &examples)?
        }
    };
    model.save(&output)?;
    let explanation = model.explain()?;
    let report = LearnReport {
        output: output.display().to_string(),
        examples: listing,
        demonstrations: model.num_demonstrations(),
        explanation: explanation.text.clone(),
    };
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        writeln!(
            out,
            "learned from {} demonstrations → {}",
            report.demonstrations, report.output
        )?;
        writeln!(out, "{}", explanation.text)?;
    }
    Ok(())
}

fn explain(path: &Path, args: &LearnArgs, out: &mut dyn Write) -> Result<()> {
    let model = ProceduralModel::load(path)?;
    let e = model.explain()?;
    let dir = args
        .plots
        .clone()
        .unwrap_or_else(|| path.parent().map(Path::to_path_buf).unwrap_or_default());
    let mut pictures = Vec::new();
    if args.samples > 0 {
        use rand::SeedableRng;
        let mut rng = rand::rngs::StdRng::seed_from_u64(args.seed);
        let inst = model.sample_instances(&mut rng, args.samples)?;
        let stem = path
            .file_stem()
            .map_or("model".into(), |s| s.to_string_lossy().to_string());
        let mut by_place: BTreeMap<String, Vec<Features>> = BTreeMap::new();
        let mut sizes = Vec::new();
        let names = model.place_names().iter().map(|s| s.to_string()).collect::<Vec<_>>();
        for i in &inst {
            by_place.entry(i.place.clone()).or_default().push(i.features.clone());
            if let (Some(k), Some(s)) = (names.iter().position(|n| *n == i.place), i.features.deci_pixels()) {
                sizes.push((k, s));
            }
        }
        std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let sw = dir.join(format!("{stem}.swatches.png"));
        crate::plots::swatches(&sw, &by_place.into_iter().collect::<Vec<_>>())?;
        let dens: Vec<(String, bayes::univariate::StudentT)> = names
            .iter()
            .map(|n| Ok((n.clone(), model.size_density(n)?)))
            .collect::<Result<_>>()?;
        let sd = dir.join(format!("{stem}.sizes.png"));
        crate::plots::size_densities(&sd, &dens, &sizes)?;
        pictures.push(sw.display().to_string());
        pictures.push(sd.display().to_string());
    }
    if args.json {
        let v = serde_json::json!({"explanation": e.text, "color_matters": e.color_matters, "size_matters": e.size_matters,
            "map_structure": e.map_structure, "consistency": e.consistency, "pictures": pictures});
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
        return Ok(());
    }
    writeln!(out, "{}", e.text)?;
    for p in pictures {
        writeln!(out, "picture: {p}")?;
    }
    Ok(())
}

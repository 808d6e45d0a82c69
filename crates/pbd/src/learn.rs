//! `pbd learn`: the procedural model of a task from one to a few demonstrations (ch. 5).
//!
//! Each Pick-And-Place instance found by `pbd infer` gives one example: the features the robot saw of
//! the object when its grasp converged (colour terms and histogram, size in pixels) and the place where Place
//! converged. The model (`schema::procedural`) keeps sufficient statistics, so `--update` adds new
//! demonstrations to an existing model with the same result as learning from all at once (§5.2).
//! `--explain` says in plain words (and pictures) what was learned.

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use schema::Library;
use schema::procedural::{Example, Features, Hyper, ProceduralModel};
use serde::{Deserialize, Serialize};

use crate::progress::Progress;

use crate::infer::{INFER_FORMAT, InferFile};

/// Options of [`learn`].
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LearnOptions {
    /// Demonstrations: inference files (`*.infer.json`) or recordings (`*.mcap`, inferred on the fly).
    pub demos: Vec<PathBuf>,
    /// Add the demonstrations to this model instead of starting afresh.
    pub update: Option<PathBuf>,
    /// Schema library (TOML) the demonstrations were inferred with (default: the built-in one).
    pub library: Option<PathBuf>,
    /// Output model (JSON).
    pub output: PathBuf,
    /// Relevance decision threshold on ln B10 (5.19–5.21) for a new model: an object belongs to the
    /// task when ln B10 exceeds it. 0 is the seed's rule (B10 > 1, even prior odds).
    pub relevance_threshold: f64,
}

impl Default for LearnOptions {
    fn default() -> Self {
        LearnOptions {
            demos: Vec::new(),
            update: None,
            library: None,
            output: PathBuf::from("model.json"),
            relevance_threshold: 0.0,
        }
    }
}

/// What [`learn`] learned from, and what it says about the model.
#[derive(Debug, Clone, Serialize)]
pub struct LearnReport {
    /// The model file written.
    pub output: String,
    /// (demonstration, place, the object's features in words) per example.
    pub examples: Vec<(String, String, String)>,
    /// Demonstrations the model holds (with an update, the old ones too).
    pub demonstrations: u64,
    /// The model explained in plain words.
    pub explanation: String,
}

impl fmt::Display for LearnReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "learned from {} demonstrations → {}",
            self.demonstrations, self.output
        )?;
        write!(f, "{}", self.explanation)
    }
}

/// What [`explain`] says about a model, with samples from its posterior predictive (for pictures).
#[derive(Debug, Clone, Serialize)]
pub struct ModelExplanation {
    /// The explanation (structure posterior, per-place summaries, text).
    #[serde(flatten)]
    pub explanation: schema::procedural::Explanation,
    /// Sampled task instances grouped by place: what the model expects to see in each.
    #[serde(skip)]
    pub samples_by_place: Vec<(String, Vec<Features>)>,
    /// The predictive size density (5.15) per place.
    #[serde(skip)]
    pub size_densities: Vec<(String, bayes::univariate::StudentT)>,
    /// (place index, size) of each sample.
    #[serde(skip)]
    pub sampled_sizes: Vec<(usize, f64)>,
}

/// Examples from the instances of a demonstration file, with each one's schema: (features,
/// reference) where the reference is the place the teacher put the object in, for a schema that
/// puts it somewhere (Pick-And-Place), else the arm the teacher used (Pick-And-Hold, Hand-Over,
/// Reach-And-Touch): what ψ binds from the object's features.
pub fn examples_from(path: &Path, library: &Library, progress: &dyn Progress) -> Result<Vec<(String, Example)>> {
    let file: InferFile = if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("mcap")) {
        let crate::infer::Demonstration {
            percepts,
            metadata,
            warnings,
            ..
        } = crate::infer::read_percepts(path)?;
        for w in &warnings {
            progress.warn(w);
        }
        let inference = crate::infer::infer_percepts(library, &percepts)?.inference;
        InferFile {
            format: INFER_FORMAT.into(),
            version: crate::infer::INFER_VERSION,
            demo: path.display().to_string(),
            metadata,
            library: library.origin.clone(),
            warnings,
            inference,
            truth: vec![],
        }
    } else {
        let text = bayes::input::read_text(path).with_context(|| format!("cannot read {}", path.display()))?;
        InferFile::from_json(&text, &path.display().to_string())?
    };
    let mut out = Vec::new();
    for (i, inst) in file.inference.instances.iter().enumerate() {
        let Ok(def) = library.schema(&inst.schema) else {
            progress.warn(&format!(
                "{}: instance {} is of `{}`, which the library does not hold — skipped (pass the library it was \
                 inferred with)",
                path.display(),
                i + 1,
                inst.schema
            ));
            continue;
        };
        let wants_place = dexter::task::has_place(library, def);
        let reference = if wants_place { &inst.place } else { &inst.arm };
        let (Some(seg), Some(reference)) = (&inst.features, reference) else {
            progress.warn(&format!(
                "{}: instance {} ({}) has no {} — skipped",
                path.display(),
                i + 1,
                inst.schema,
                if inst.features.is_none() {
                    "object features"
                } else if wants_place {
                    "place"
                } else {
                    "arm"
                }
            ));
            continue;
        };
        out.push((
            inst.schema.clone(),
            Example {
                features: Features::from(seg),
                reference: reference.clone(),
            },
        ));
    }
    Ok(out)
}

/// The schema most of `examples` are instances of (ties: by name); `None` for no examples.
pub fn main_schema(examples: &[(String, Example)]) -> Option<String> {
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for (s, _) in examples {
        *counts.entry(s.as_str()).or_default() += 1;
    }
    counts
        .into_iter()
        .max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(a.0)))
        .map(|(s, _)| s.to_string())
}

/// `pbd learn`: learns (or updates) the procedural model from demonstrations and saves it.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn learn(args: &LearnOptions, progress: &dyn Progress) -> crate::Result<LearnReport> {
    learn_impl(args, progress).map_err(crate::Error::from)
}

fn learn_impl(args: &LearnOptions, progress: &dyn Progress) -> Result<LearnReport> {
    if args.demos.is_empty() {
        bail!("no demonstrations given (pass *.infer.json or *.mcap files)");
    }
    let output = args.output.clone();
    let mut io = crate::files::IoPlan::new();
    for d in &args.demos {
        io.read("a demonstration", d);
    }
    if let Some(u) = &args.update {
        io.read("--update", u);
    }
    if let Some(l) = &args.library {
        io.read("--library", l);
    }
    io.write("-o", &output).check()?;
    // A demonstration given twice would count twice.
    for (i, a) in args.demos.iter().enumerate() {
        if let Some(b) = args.demos[..i].iter().find(|b| crate::files::same_file(a, b)) {
            bail!(
                "{} is given twice (also as {}): each demonstration counts once",
                a.display(),
                b.display()
            );
        }
    }
    let library = match &args.library {
        Some(p) => Library::open(p)?,
        None => Library::builtin(),
    };
    let mut examples = Vec::new();
    let mut listing = Vec::new();
    for d in &args.demos {
        let ex = examples_from(d, &library, progress)?;
        for (schema, e) in &ex {
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
                schema.clone(),
            ));
        }
        examples.extend(ex);
    }
    let Some(schema) = main_schema(&examples) else {
        bail!(
            "empty demonstration set: no instance of a schema with object features and a place (or, for a schema \
             that puts nothing anywhere, an arm) in the inputs"
        );
    };
    // One task at a time: the instances of other schemas are not this task's examples.
    let others = examples.iter().filter(|(s, _)| *s != schema).count();
    if others > 0 {
        progress.warn(&format!(
            "{others} instance(s) of schemas other than `{schema}` (the one most instances are of) — skipped"
        ));
    }
    let examples: Vec<Example> = examples
        .into_iter()
        .filter(|(s, _)| *s == schema)
        .map(|(_, e)| e)
        .collect();
    let listing: Vec<(String, String, String)> = listing
        .into_iter()
        .filter(|l| l.3 == schema)
        .map(|l| (l.0, l.1, l.2))
        .collect();
    let mut model = match &args.update {
        Some(path) => {
            let mut m = ProceduralModel::load(path)?;
            let was = m.schema_in(&library)?.to_string();
            if was != schema {
                bail!(
                    "{}: the model was learned from `{was}` instances; these demonstrations are `{schema}` — learn a \
                     new model for a new task",
                    path.display()
                );
            }
            for e in &examples {
                m.update(e)?;
            }
            m
        }
        None => {
            if !args.relevance_threshold.is_finite() {
                bail!(
                    "--relevance-threshold must be a finite number (a log Bayes factor), got {}",
                    args.relevance_threshold
                );
            }
            let hyper = Hyper {
                relevance_log_threshold: args.relevance_threshold,
                ..Hyper::default()
            };
            ProceduralModel::learn(hyper, &examples)?
        }
    };
    model.set_schema(schema);
    crate::files::write_atomic(&output, model.to_json().as_bytes())?;
    let explanation = model.explain()?;
    Ok(LearnReport {
        output: output.display().to_string(),
        examples: listing,
        demonstrations: model.num_demonstrations(),
        explanation: explanation.text,
    })
}

/// Explains a saved model; with `samples > 0`, also draws that many task instances from its posterior
/// predictive (seeded by `seed`) for pictures.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn explain(path: &Path, samples: usize, seed: u64) -> crate::Result<ModelExplanation> {
    explain_impl(path, samples, seed).map_err(crate::Error::from)
}

fn explain_impl(path: &Path, samples: usize, seed: u64) -> Result<ModelExplanation> {
    crate::limits::check_at_most("samples", samples, crate::limits::MAX_SAMPLES)?;
    let model = ProceduralModel::load(path)?;
    let explanation = model.explain()?;
    let mut out = ModelExplanation {
        explanation,
        samples_by_place: Vec::new(),
        size_densities: Vec::new(),
        sampled_sizes: Vec::new(),
    };
    if samples == 0 {
        return Ok(out);
    }
    let mut rng = crate::rng::seeded(seed);
    let inst = model.sample_instances(&mut rng, samples)?;
    let mut by_place: BTreeMap<String, Vec<Features>> = BTreeMap::new();
    let names = model.place_names().iter().map(|s| s.to_string()).collect::<Vec<_>>();
    for i in &inst {
        by_place.entry(i.place.clone()).or_default().push(i.features.clone());
        if let (Some(k), Some(s)) = (names.iter().position(|n| *n == i.place), i.features.deci_pixels()) {
            out.sampled_sizes.push((k, s));
        }
    }
    out.samples_by_place = by_place.into_iter().collect();
    out.size_densities = names
        .iter()
        .map(|n| Ok((n.clone(), model.size_density(n)?)))
        .collect::<Result<_>>()?;
    Ok(out)
}

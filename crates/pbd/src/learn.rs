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
    /// task when ln B10 exceeds it. The default (1) is calibrated on development data
    /// (`schema::procedural`); 0 is the seed's rule (B10 > 1, even prior odds).
    pub relevance_threshold: f64,
    /// Fit the relevance background model M₀ (§5.1.3) to the objects the teacher left alone in the
    /// demonstrations (`untouched` in the inference files); `false`: M₀ is the prior predictive.
    pub distractors: bool,
    /// The unit of the size feature of a new model: `cm` (the default: the geometric mean of the
    /// object's measured bounding box) or the seed's `deci-pixels`.
    pub size_unit: schema::procedural::SizeUnit,
}

impl Default for LearnOptions {
    fn default() -> Self {
        LearnOptions {
            demos: Vec::new(),
            update: None,
            library: None,
            output: PathBuf::from("model.json"),
            relevance_threshold: schema::procedural::DEFAULT_RELEVANCE_LOG_THRESHOLD,
            distractors: true,
            size_unit: schema::procedural::SizeUnit::Centimetres,
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
    /// Objects the teacher left alone that the model's M₀ is fitted to (with an update, the old ones
    /// too).
    pub background_objects: usize,
    /// The model explained in plain words.
    pub explanation: String,
}

impl fmt::Display for LearnReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "learned from {} demonstrations and {} objects the teacher left alone → {}",
            self.demonstrations, self.background_objects, self.output
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
    let file = read_demonstration(path, library, progress)?;
    examples_of(&file, path, library, progress)
}

/// The features of the objects the teacher left alone in a demonstration file
/// ([`crate::infer::untouched_segments`]; none in a version 1 inference file): the data of the
/// relevance background model M₀.
pub fn untouched_from(file: &InferFile) -> Vec<Features> {
    file.untouched.iter().map(|u| Features::from(&u.features)).collect()
}

/// Reads a demonstration: an inference file, or a recording inferred on the fly.
pub fn read_demonstration(path: &Path, library: &Library, progress: &dyn Progress) -> Result<InferFile> {
    Ok(if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("mcap")) {
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
        let untouched = crate::infer::untouched_segments(&inference, &percepts);
        InferFile {
            format: INFER_FORMAT.into(),
            version: crate::infer::INFER_VERSION,
            demo: path.display().to_string(),
            metadata,
            library: library.origin.clone(),
            warnings,
            inference,
            truth: vec![],
            untouched,
        }
    } else {
        let text = bayes::input::read_text(path).with_context(|| format!("cannot read {}", path.display()))?;
        InferFile::from_json(&text, &path.display().to_string())?
    })
}

/// The examples of the instances of a demonstration file read from `path` (see [`examples_from`]).
pub fn examples_of(
    file: &InferFile,
    path: &Path,
    library: &Library,
    progress: &dyn Progress,
) -> Result<Vec<(String, Example)>> {
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
    let mut untouched = Vec::new();
    for d in &args.demos {
        let file = read_demonstration(d, &library, progress)?;
        if args.distractors {
            if file.version < 2 && file.untouched.is_empty() {
                progress.warn(&format!(
                    "{}: an inference file of version {} holds no untouched objects (re-run `pbd infer` for them)",
                    d.display(),
                    file.version
                ));
            }
            untouched.extend(untouched_from(&file).into_iter().map(|f| (d.clone(), f)));
        }
        let ex = examples_of(&file, d, &library, progress)?;
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
                format!(
                    "colours {} px {:?}{}",
                    colors.join(", "),
                    e.features.pixels,
                    e.features
                        .size_cm()
                        .map_or(String::new(), |c| format!(" size {c:.1} cm"))
                ),
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
                ..Hyper::default().with_size_unit(args.size_unit)
            };
            ProceduralModel::learn(hyper, &examples)?
        }
    };
    for (i, (d, f)) in untouched.iter().enumerate() {
        if let Err(e) = model.observe_background(f) {
            progress.warn(&format!(
                "{}: untouched object {} left out of M₀: {e}",
                d.display(),
                i + 1
            ));
        }
    }
    model.set_schema(schema);
    crate::files::write_atomic(&output, model.to_json().as_bytes())?;
    let explanation = model.explain()?;
    Ok(LearnReport {
        output: output.display().to_string(),
        examples: listing,
        demonstrations: model.num_demonstrations(),
        background_objects: model.background_objects(),
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
        if let (Some(k), Some(s)) = (
            names.iter().position(|n| *n == i.place),
            model.hyper().size_unit.value(&i.features),
        ) {
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

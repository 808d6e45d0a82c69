//! `pbd infer`: which schema of the library explains a recorded demonstration (§4.2).
//!
//! Reads the robot's percepts from the recording (`/pbd/percept`), evaluates every monitor on them,
//! and runs schema inference (`schema::infer`): the posterior over the library and "none", the MAP
//! schema's state path, and the schema instances with their procedural facts. Writes the result as
//! JSON (`demo.infer.json`, format `pbd-inference` v1) and a companion MCAP (`demo.infer.mcap`) with
//! the inferred state on `/pbd/schema_state` — open it in Foxglove together with the demonstration
//! to scrub through and watch the schema state change.

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use schema::{Engine, Inference, InferenceConfig, Library, MonitorBank, MonitorConfig, Observation, Percept};
use serde::{Deserialize, Serialize};

use crate::mcap_log::{FileStatus, LogLevel, McapLog, Recording, read_recording};
use crate::progress::Progress;
use crate::record::{TOPIC_PERCEPT, TOPIC_TRUTH};

/// Format name and version of the inference file.
pub const INFER_FORMAT: &str = "pbd-inference";
/// Version of the inference file.
pub const INFER_VERSION: u32 = 1;

/// Options of [`infer`].
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InferOptions {
    /// The demonstration (MCAP from `pbd record`).
    pub demo: PathBuf,
    /// Output JSON (default: next to the demo, `NAME.infer.json`; the companion MCAP is `NAME.infer.mcap`).
    pub output: Option<PathBuf>,
    /// Schema library (TOML; default: the built-in library).
    pub library: Option<PathBuf>,
}

/// What [`infer`] wrote, and the inference itself.
#[derive(Debug, Clone, Serialize)]
pub struct InferRun {
    /// The inference file's content.
    pub file: InferFile,
    /// Where it was written.
    pub json_path: PathBuf,
    /// The companion MCAP (schema state over time).
    pub mcap_path: PathBuf,
    /// Schemas in the library used.
    pub schemas: usize,
}

/// The true object near an instance's object when it was grasped (from `/pbd/truth`; evaluation only).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TruthNote {
    /// Object label in the scene.
    pub object: String,
    /// Distance between the perceived centroid and the true position (m).
    pub distance: f64,
}

/// The inference file.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct InferFile {
    /// `pbd-inference`.
    pub format: String,
    /// 1.
    pub version: u32,
    /// The demonstration file.
    pub demo: String,
    /// The recording's metadata (scene, seed, tasks, …).
    pub metadata: BTreeMap<String, String>,
    /// The library used.
    pub library: String,
    /// Warnings (a recovered file, …).
    pub warnings: Vec<String>,
    /// The inference.
    pub inference: Inference,
    /// Per instance, the true object (if the recording has ground truth).
    pub truth: Vec<Option<TruthNote>>,
}

impl InferFile {
    /// Parses and validates an inference file (`pbd infer`'s output); `origin` names it in errors.
    pub fn from_json(text: &str, origin: &str) -> Result<InferFile> {
        if let Err(dup) = bayes::input::check_json_keys(text) {
            bail!("{origin}: {dup}");
        }
        let file: InferFile = serde_json::from_str(text)
            .with_context(|| format!("{origin} is not an inference file (from `pbd infer`)"))?;
        if file.format != INFER_FORMAT || file.version != INFER_VERSION {
            bail!(
                "{origin}: format `{}` version {} is not `{INFER_FORMAT}` version {INFER_VERSION}",
                file.format,
                file.version,
            );
        }
        file.inference.check(origin)?;
        Ok(file)
    }
}

/// True object positions over time: (t, [(label, position)]).
pub type TruthTrack = Vec<(f64, Vec<(String, [f64; 3])>)>;

/// What a recording holds for inference.
#[derive(Debug, Clone, Default)]
pub struct Demonstration {
    /// The robot's percepts (`/pbd/percept`), in time order.
    pub percepts: Vec<Percept>,
    /// The world's truth beside them (`/pbd/truth`), for evaluation only; empty when absent.
    pub truth: TruthTrack,
    /// The recording's `pbd` metadata (command, scene, seed, …).
    pub metadata: BTreeMap<String, String>,
    /// What the reader noticed (a file cut short, damaged chunks, foreign channels).
    pub warnings: Vec<String>,
}

/// What inference made of a percept stream ([`infer_percepts`]).
#[derive(Debug)]
pub struct PerceptInference {
    /// The instances and the posterior over schemas.
    pub inference: Inference,
    /// The monitors' observation at each percept.
    pub observations: Vec<Observation>,
    /// The engine that inferred it (its configuration and the library's models).
    pub engine: Engine,
}

#[derive(Debug, Deserialize)]
struct Truth {
    t: f64,
    objects: Vec<(String, [f64; 3])>,
}

/// Reads percepts (and ground truth, if present) from a recording.
pub fn read_percepts(path: &Path) -> Result<Demonstration> {
    let rec = read_recording(path, &[TOPIC_PERCEPT, TOPIC_TRUTH])?;
    demonstration_from(&rec, path)
}

/// The percepts, truth, metadata and warnings of a recording already read (the topics
/// [`TOPIC_PERCEPT`] and [`TOPIC_TRUTH`] at least); `path` names it in errors and warnings.
pub fn demonstration_from(rec: &Recording, path: &Path) -> Result<Demonstration> {
    let mut warnings = Vec::new();
    if let Some(FileStatus::Recovered { messages, reason }) = &rec.status {
        warnings.push(format!(
            "{} was cut short ({reason}); recovered {messages} messages up to its last complete chunk",
            path.display()
        ));
    }
    for c in &rec.skipped_chunks {
        warnings.push(format!("{}: damaged {c}", path.display()));
    }
    for c in &rec.foreign_channels {
        warnings.push(format!("{}: {c}", path.display()));
    }
    let metadata = rec.metadata.get("pbd").cloned().unwrap_or_default();
    if let Some(v) = metadata.get("percept_version")
        && v != &schema::percept::PERCEPT_VERSION.to_string()
    {
        bail!(
            "{}: percept format version {v} is not supported (this build reads {})",
            path.display(),
            schema::percept::PERCEPT_VERSION
        );
    }
    let mut percepts = Vec::new();
    for (i, (_, data)) in rec.topic(TOPIC_PERCEPT).enumerate() {
        let p: Percept = serde_json::from_slice(data)
            .with_context(|| format!("{}: {TOPIC_PERCEPT} message {i} is not a percept", path.display()))?;
        percepts.push(p);
    }
    if percepts.is_empty() {
        let foreign = rec
            .foreign_channels
            .iter()
            .find(|c| c.contains(TOPIC_PERCEPT))
            .map(|c| format!("; {c}"))
            .unwrap_or_default();
        bail!(
            "{}: empty demonstration: no {TOPIC_PERCEPT} messages pbd can read (was it recorded by `pbd record`?){foreign}",
            path.display()
        );
    }
    schema::percept::validate_stream(&percepts, &path.display().to_string())?;
    let mut truth = Vec::new();
    for (_, data) in rec.topic(TOPIC_TRUTH) {
        if let Ok(t) = serde_json::from_slice::<Truth>(data) {
            truth.push((t.t, t.objects));
        }
    }
    Ok(Demonstration {
        percepts,
        truth,
        metadata,
        warnings,
    })
}

/// The observation rate of a percept stream (Hz), from the median step.
fn rate_of(percepts: &[Percept]) -> f64 {
    let mut dt: Vec<f64> = percepts.windows(2).map(|w| w[1].t - w[0].t).collect();
    if dt.is_empty() {
        return 10.0;
    }
    dt.sort_by(f64::total_cmp);
    let m = dt[dt.len() / 2];
    if m > 0.0 { 1.0 / m } else { 10.0 }
}

/// Runs inference on a percept stream.
pub fn infer_percepts(library: &Library, percepts: &[Percept]) -> Result<PerceptInference> {
    let mut bank = MonitorBank::new(library, MonitorConfig::default());
    let obs = bank.observe_all(percepts);
    let engine = Engine::new(
        library,
        InferenceConfig {
            rate_hz: rate_of(percepts),
            ..InferenceConfig::default()
        },
    )?;
    let inference = engine.infer(&obs, percepts)?;
    Ok(PerceptInference {
        inference,
        observations: obs,
        engine,
    })
}

fn truth_for(inf: &Inference, percepts: &[Percept], truth: &TruthTrack) -> Vec<Option<TruthNote>> {
    inf.instances
        .iter()
        .map(|inst| {
            let seg = inst.object?;
            let t = inst
                .facts
                .iter()
                .find(|f| f.action == "grasp")
                .map_or(inst.t_start, |f| f.first);
            let p = percepts.iter().rev().find(|p| p.t <= t + 1e-9)?;
            let c = p.segments.iter().find(|s| s.id == seg)?.centroid;
            let (_, objects) = truth
                .iter()
                .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))?;
            objects
                .iter()
                .map(|(name, pos)| {
                    let d = ((pos[0] - c[0]).powi(2) + (pos[1] - c[1]).powi(2) + (pos[2] - c[2]).powi(2)).sqrt();
                    TruthNote {
                        object: name.clone(),
                        distance: d,
                    }
                })
                .min_by(|a, b| a.distance.total_cmp(&b.distance))
        })
        .collect()
}

fn default_output(demo: &Path, ext: &str) -> PathBuf {
    let stem = demo
        .file_stem()
        .map_or_else(|| "demo".into(), |s| s.to_string_lossy().to_string());
    demo.with_file_name(format!("{stem}.{ext}"))
}

/// `pbd infer`: reads the demonstration, infers, writes `NAME.infer.json` and its companion MCAP.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn infer(args: &InferOptions, progress: &dyn Progress) -> crate::Result<InferRun> {
    infer_impl(args, progress).map_err(crate::Error::from)
}

fn infer_impl(args: &InferOptions, progress: &dyn Progress) -> Result<InferRun> {
    let library = match &args.library {
        Some(p) => Library::open(p)?,
        None => Library::builtin(),
    };
    let Demonstration {
        percepts,
        truth,
        metadata,
        warnings,
    } = read_percepts(&args.demo)?;
    for w in &warnings {
        progress.warn(w);
    }
    progress.phase("infer", None);
    progress.message(&format!("{} percepts", percepts.len()));
    let PerceptInference {
        inference,
        observations: obs,
        engine,
    } = infer_percepts(&library, &percepts)?;
    let file = InferFile {
        format: INFER_FORMAT.into(),
        version: INFER_VERSION,
        demo: args.demo.display().to_string(),
        metadata,
        library: library.origin.clone(),
        warnings,
        truth: truth_for(&inference, &percepts, &truth),
        inference,
    };
    let json_path = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.demo, "infer.json"));
    let mcap_path = json_path.with_extension("mcap");
    let mut io = crate::files::IoPlan::new();
    io.read("the demonstration", &args.demo);
    if let Some(l) = &args.library {
        io.read("--library", l);
    }
    io.write("-o", &json_path)
        .write("its companion MCAP", &mcap_path)
        .check()?;
    write_companion(&mcap_path, &engine, &obs, &file)?;
    let text = serde_json::to_string_pretty(&file)?;
    crate::files::write_atomic(&json_path, text.as_bytes())?;
    progress.finish();
    Ok(InferRun {
        file,
        json_path,
        mcap_path,
        schemas: library.schemas.len(),
    })
}

/// The companion MCAP: the inferred state per observation step, and instance events.
fn write_companion(path: &Path, engine: &Engine, obs: &[Observation], file: &InferFile) -> Result<()> {
    let visits = engine.composite_path(obs)?;
    let names = engine.library().action_names();
    let mut log = McapLog::create(path)?;
    let schema = crate::mcap_log::schema_state_schema(&names);
    let mut v = 0;
    for o in obs {
        while v + 1 < visits.len() && visits[v].t_end < o.t {
            v += 1;
        }
        let (sch, st) = visits
            .get(v)
            .map_or(("gap", "before"), |x| (x.schema.as_str(), x.state.as_str()));
        let state_index = engine
            .library()
            .schema(sch)
            .ok()
            .and_then(|s| s.state(st))
            .map_or(-1, |i| i as i64);
        let x: BTreeMap<&str, bool> = names.iter().zip(&o.x).map(|(n, b)| (*n, *b)).collect();
        let converged: Vec<String> = o
            .hits
            .iter()
            .map(|h| {
                let mut s = names[h.action].to_string();
                for part in [
                    h.arm.clone(),
                    h.segment.map(|x| format!("segment {x}")),
                    h.place.clone(),
                ]
                .into_iter()
                .flatten()
                {
                    s.push(' ');
                    s.push_str(&part);
                }
                s
            })
            .collect();
        log.log_json(
            crate::mcap_log::TOPIC_SCHEMA_STATE,
            "pbd.SchemaState",
            &schema,
            o.t,
            &serde_json::json!({
                "timestamp": crate::mcap_log::foxglove_time(o.t),
                "schema": sch,
                "state": st,
                "state_index": state_index,
                "x": x,
                "converged": converged
            }),
        )?;
    }
    for (i, inst) in file.inference.instances.iter().enumerate() {
        log.log_text(
            inst.t_start,
            LogLevel::Info,
            &format!(
                "instance {}: {} begins (object {:?}, place {:?}, arm {:?})",
                i + 1,
                inst.schema,
                inst.object,
                inst.place,
                inst.arm
            ),
        )?;
        log.log_text(
            inst.t_end,
            LogLevel::Info,
            &format!("instance {}: {} reaches its goal", i + 1, inst.schema),
        )?;
    }
    log.finish()?;
    Ok(())
}

impl fmt::Display for InferRun {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (file, json, mcap) = (&self.file, &self.json_path, &self.mcap_path);
        let inf = &file.inference;
        writeln!(
            out,
            "{}: {:.1} s, {} observation steps, {} schemas in the library",
            file.demo, inf.duration, inf.steps, self.schemas
        )?;
        writeln!(
            out,
            "posterior over the library (each schema as one or more instances; uniform prior):"
        )?;
        let mut hyps = inf.posterior.hypotheses.clone();
        hyps.sort_by(|a, b| b.posterior.total_cmp(&a.posterior));
        for h in &hyps {
            let bar = "#".repeat((h.posterior * 30.0).round() as usize);
            let ev = h
                .log_evidence
                .map_or("impossible".to_string(), |l| format!("log p(x|S) = {l:9.2}"));
            writeln!(out, "  {:<16} {:>7.4}  {:<30} {ev}", h.schema, h.posterior, bar)?;
        }
        writeln!(
            out,
            "MAP: {} (p = {:.4}){}",
            inf.posterior.map,
            inf.posterior.map_posterior,
            if inf.posterior.map == "none" {
                " — no schema of the library explains this demonstration"
            } else {
                ""
            }
        )?;
        if !inf.state_path.is_empty() {
            let path: Vec<String> = inf
                .state_path
                .iter()
                .filter(|v| v.schema != "gap")
                .map(|v| format!("{}@{:.1}s", v.state, v.t_start))
                .collect();
            writeln!(out, "state path: {}", path.join(" → "))?;
        }
        writeln!(out, "instances: {}", inf.instances.len())?;
        for (i, inst) in inf.instances.iter().enumerate() {
            let truth = file.truth.get(i).cloned().flatten();
            writeln!(
                out,
                "  {}. {:<15} {:>6.1}–{:<6.1} s  p = {:.3}  object {}{}  place {}  arm {}",
                i + 1,
                inst.schema,
                inst.t_start,
                inst.t_end,
                inst.posterior.map_posterior,
                inst.object.map_or("-".into(), |o| format!("segment {o}")),
                truth.map_or(String::new(), |t| format!(" (= {})", t.object)),
                inst.place.as_deref().unwrap_or("-"),
                inst.arm.as_deref().unwrap_or("-"),
            )?;
        }
        writeln!(
            out,
            "wrote {} and {} (open with the demo in Foxglove)",
            json.display(),
            mcap.display()
        )?;
        Ok(())
    }
}

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
/// Version of the inference file: 2 adds [`InferFile::untouched`] (version 1 files still read,
/// with no untouched segments).
pub const INFER_VERSION: u32 = 2;

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
    /// The objects of the demonstration scene that the teacher never touched ([`untouched_segments`]):
    /// what `pbd learn` fits the relevance background model M₀ to (§5.1.3). Absent (empty) in
    /// version 1 files.
    #[serde(default)]
    pub untouched: Vec<UntouchedSegment>,
}

/// An object the teacher left alone in the demonstration ([`untouched_segments`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UntouchedSegment {
    /// Its track id.
    pub segment: u32,
    /// When the view below was taken (s).
    pub t: f64,
    /// Percepts in which both cameras saw it.
    pub frames_seen: usize,
    /// Its least occluded view (the most pixels in both cameras).
    pub features: schema::SegmentPercept,
}

impl InferFile {
    /// Parses and validates an inference file (`pbd infer`'s output); `origin` names it in errors.
    pub fn from_json(text: &str, origin: &str) -> Result<InferFile> {
        if let Err(dup) = bayes::input::check_json_keys(text) {
            bail!("{origin}: {dup}");
        }
        let file: InferFile = serde_json::from_str(text)
            .with_context(|| format!("{origin} is not an inference file (from `pbd infer`)"))?;
        if file.format != INFER_FORMAT || !(1..=INFER_VERSION).contains(&file.version) {
            bail!(
                "{origin}: format `{}` version {} is not `{INFER_FORMAT}` version 1 to {INFER_VERSION}",
                file.format,
                file.version,
            );
        }
        file.inference.check(origin)?;
        for (i, u) in file.untouched.iter().enumerate() {
            schema::infer::check_segment(&u.features, origin, &format!("untouched[{i}].features"))?;
        }
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

/// A segment is one the teacher left alone only when both cameras saw it in at least this share of
/// the demonstration's percepts (and in at least [`UNTOUCHED_MIN_FRAMES`]): a phantom or a passing
/// piece of the arm is seen in a few.
const UNTOUCHED_MIN_SHARE: f64 = 0.2;
/// See [`UNTOUCHED_MIN_SHARE`].
const UNTOUCHED_MIN_FRAMES: usize = 5;
/// An object that stayed where it was: the median of its views before the teacher acted and that of
/// its last views (the last fifth) lie within this distance (m). Views in between may stray (a box
/// seen merged with an arm passing in front of it).
const UNTOUCHED_MAX_STRAY: f64 = 0.04;
/// Tracks whose median positions lie within this (m) are one object seen again (the tracker lost it
/// behind an arm and found it anew); a track this close to where an acted-on object stood is that
/// object.
const UNTOUCHED_SAME_OBJECT: f64 = 0.06;
/// Highest median centroid (m above the table) of an object standing on the table: higher segments
/// are not objects on the table (a piece of the robot, something held up).
const UNTOUCHED_MAX_HEIGHT: f64 = 0.3;

/// The objects of a demonstration that the teacher never touched — the seed's "non-sortable
/// objects" (§5.1.3), the data `pbd learn` fits the relevance background model M₀ to.
///
/// A track counts when it was on the table before the teacher acted (seen by both cameras before the
/// first monitor of any instance converged, and in the first tenth of the demonstration), no monitor of any instance converged on it, it stayed
/// where it was (the median of its views before the teacher acted and that of its last fifth within
/// 4 cm) on the table (median centroid above
/// the table, at most 30 cm up, outside every place), and it is not where an acted-on object stood
/// (6 cm). Tracks of one object (medians within 6 cm: the tracker lost it behind an arm and found it
/// anew) count once; their seen frames add up, and together they must cover a fifth of the
/// percepts. Its view is a typical one: of its views within 2 cm of the median position (those
/// whose extent vision measured, if any), the one with the median pixel count (neither cut by an
/// arm in front nor merged with one beside it).
pub fn untouched_segments(inference: &Inference, percepts: &[Percept]) -> Vec<UntouchedSegment> {
    let mut touched: std::collections::BTreeSet<u32> = std::collections::BTreeSet::new();
    let mut first_act = f64::INFINITY;
    for inst in &inference.instances {
        touched.extend(inst.object);
        touched.extend(inst.facts.iter().filter_map(|f| f.segment));
        first_act = inst.facts.iter().map(|f| f.first).fold(first_act, f64::min);
    }
    untouched_given(&touched, first_act, percepts)
}

/// [`untouched_segments`] given the segments acted on and when the teacher first acted (s).
fn untouched_given(
    touched: &std::collections::BTreeSet<u32>,
    first_act: f64,
    percepts: &[Percept],
) -> Vec<UntouchedSegment> {
    let (Some(first), Some(last)) = (percepts.first(), percepts.last()) else {
        return Vec::new();
    };
    // "Before the teacher acted": also within the first tenth of the demonstration, so that a
    // demonstration where no monitor converged still asks for objects there from the start.
    let first_act = first_act.min(first.t + 0.1 * (last.t - first.t));
    // Per track, its seen views in time order.
    let mut tracks: BTreeMap<u32, Vec<(f64, &schema::SegmentPercept)>> = BTreeMap::new();
    for p in percepts {
        for s in p.segments.iter().filter(|s| s.seen) {
            tracks.entry(s.id).or_default().push((p.t, s));
        }
    }
    let dist =
        |a: [f64; 3], b: [f64; 3]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    let median_of = |views: &[(f64, &schema::SegmentPercept)]| -> [f64; 3] {
        let mut out = [0.0; 3];
        for (k, o) in out.iter_mut().enumerate() {
            let mut c: Vec<f64> = views.iter().map(|v| v.1.centroid[k]).collect();
            c.sort_by(f64::total_cmp);
            *o = c[c.len() / 2];
        }
        out
    };
    let medians: BTreeMap<u32, [f64; 3]> = tracks.iter().map(|(&id, v)| (id, median_of(v))).collect();
    let touched_at: Vec<[f64; 3]> = touched.iter().filter_map(|id| medians.get(id).copied()).collect();
    // Objects: tracks grouped by position, the first track of each group in time leading.
    let mut order: Vec<u32> = tracks.keys().copied().collect();
    order.sort_by(|a, b| tracks[a][0].0.total_cmp(&tracks[b][0].0).then(a.cmp(b)));
    let mut groups: Vec<(u32, Vec<u32>)> = Vec::new();
    for id in order {
        match groups
            .iter_mut()
            .find(|g| dist(medians[&g.0], medians[&id]) <= UNTOUCHED_SAME_OBJECT)
        {
            Some(g) => g.1.push(id),
            None => groups.push((id, vec![id])),
        }
    }
    let min_frames = UNTOUCHED_MIN_FRAMES.max((UNTOUCHED_MIN_SHARE * percepts.len() as f64).ceil() as usize);
    let mut out = Vec::new();
    for (lead, members) in groups {
        let views: Vec<(f64, &schema::SegmentPercept)> =
            members.iter().flat_map(|id| tracks[id].iter().copied()).collect();
        let m = median_of(&views);
        let acted_on = members.iter().any(|id| touched.contains(id))
            || touched_at.iter().any(|&a| dist(a, m) <= UNTOUCHED_SAME_OBJECT);
        let before: Vec<(f64, &schema::SegmentPercept)> = views.iter().copied().filter(|v| v.0 < first_act).collect();
        let mut by_time = views.clone();
        by_time.sort_by(|a, b| a.0.total_cmp(&b.0));
        let end = &by_time[by_time.len() - by_time.len().div_ceil(5)..];
        let still = !before.is_empty() && dist(median_of(&before), median_of(end)) <= UNTOUCHED_MAX_STRAY;
        let height = m[2] - last.table_z;
        let in_place = last.places.iter().any(|pl| {
            (m[0] - pl.center[0]).abs() <= pl.half_extents[0] + 0.02
                && (m[1] - pl.center[1]).abs() <= pl.half_extents[1] + 0.02
        });
        if acted_on || !still || views.len() < min_frames || in_place || !(0.0..=UNTOUCHED_MAX_HEIGHT).contains(&height)
        {
            continue;
        }
        let candidates = |measured: bool| -> Vec<&(f64, &schema::SegmentPercept)> {
            views
                .iter()
                .filter(|v| {
                    dist(v.1.centroid, m) <= 0.02
                        && v.1.pixels[0] > 0
                        && v.1.pixels[1] > 0
                        && !v.1.colors.is_empty()
                        && (!measured || v.1.extent.as_ref().is_some_and(|e| e.model != "coarse"))
                })
                .collect()
        };
        // Views whose extent vision measured first (a coarse one is a guess from the silhouette).
        let mut typical = candidates(true);
        if typical.is_empty() {
            typical = candidates(false);
        }
        if typical.is_empty() {
            continue;
        }
        typical.sort_by_key(|v| v.1.pixels[0].saturating_add(v.1.pixels[1]));
        let (t, view) = *typical[typical.len() / 2];
        out.push(UntouchedSegment {
            segment: lead,
            t,
            frames_seen: views.len(),
            features: view.clone(),
        });
    }
    out.sort_by_key(|u| u.segment);
    out
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
        untouched: untouched_segments(&inference, &percepts),
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

#[cfg(test)]
mod tests {
    use super::*;
    use schema::SegmentPercept;
    use schema::percept::PlacePercept;

    fn seg(id: u32, at: [f64; 3], pixels: u32) -> SegmentPercept {
        SegmentPercept {
            id,
            centroid: at,
            seen: true,
            pixels: [pixels, pixels],
            histogram: vec![(0, 1.0)],
            covariance: [0.0; 4],
            colors: vec![(6, 1.0)],
            extent: None,
        }
    }

    /// 100 percepts at 10 Hz: the teacher acts from t = 2 s on object 1 (carried into the bin),
    /// object 2 stands still, object 3 is lost behind an arm at 5 s and found again as track 13,
    /// object 4 is pushed 10 cm at 6 s, track 5 appears at 7 s (a phantom), track 6 is a piece of
    /// the robot 50 cm up, and track 7 stands in the bin.
    fn demonstration() -> Vec<Percept> {
        (0..100)
            .map(|i| {
                let t = 0.1 * f64::from(i);
                let mut segments = vec![
                    seg(1, if t < 3.0 { [0.6, 0.0, 0.8] } else { [0.55, -0.45, 0.8] }, 200),
                    seg(2, [0.5, 0.2, 0.8], if i % 7 == 0 { 400 } else { 250 }),
                    seg(if t < 5.0 { 3 } else { 13 }, [0.7, 0.1, 0.8], 180),
                    seg(4, if t < 6.0 { [0.45, -0.1, 0.8] } else { [0.45, -0.2, 0.8] }, 150),
                    seg(6, [0.3, 0.0, 1.3], 120),
                    seg(7, [0.55, 0.45, 0.78], 120),
                ];
                if t >= 7.0 {
                    segments.push(seg(5, [0.8, 0.3, 0.8], 100));
                }
                Percept {
                    t,
                    hands: Vec::new(),
                    segments,
                    places: [("bin-left", 0.45), ("bin-right", -0.45)]
                        .map(|(name, y)| PlacePercept {
                            name: name.into(),
                            center: [0.55, y, 0.75],
                            half_extents: [0.1, 0.125],
                        })
                        .to_vec(),
                    table_z: 0.75,
                    gaze: None,
                }
            })
            .collect()
    }

    #[test]
    fn untouched_objects_are_the_ones_left_where_they_stood_once_each() {
        let percepts = demonstration();
        let touched = [1u32].into_iter().collect();
        let u = untouched_given(&touched, 2.0, &percepts);
        let ids: Vec<u32> = u.iter().map(|u| u.segment).collect();
        assert_eq!(ids, vec![2, 3], "{u:?}");
        // Object 3's two tracks count once, with all their frames.
        assert_eq!(u[1].frames_seen, 100);
        // A typical view: the median pixel count, not the 400-pixel outliers.
        assert_eq!(u[0].features.pixels, [250, 250]);
        // No instance: the objects there in the first tenth of the demonstration that stayed where
        // they were (object 1 ends in a bin).
        let none = untouched_given(&Default::default(), f64::INFINITY, &percepts);
        let ids: Vec<u32> = none.iter().map(|u| u.segment).collect();
        assert_eq!(ids, vec![2, 3]);
    }
}

//! `pbd execute`: the robot does a demonstrated task in a new context (§4.3.2).
//!
//! The declarative part — which schema — comes from an inference (`--demo demo.infer.json`, its MAP
//! schema and the places its instances used) or from a learned procedural model (`--model
//! model.json`, which also decides, per object, whether it belongs to the task and which place it
//! goes to). The procedural part is bound now, in the new scene: ψ picks the arm whose workspace holds
//! the object and the place, or a hand-to-hand transfer; the executive follows the schema's policy
//! and takes its contingencies (re-grasp after a drop). Reports per object: the decision, the arm(s),
//! transfer or not, contingencies, the outcome; and an MCAP log.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use dexter_sim::physics::{DEXTER_URDF, DexterSim, SimSettings};
use dexter_sim::scene::Scene;
use schema::{Library, Percept};
use serde::{Deserialize, Serialize};

pub use dexter_sim::execute::{Decider, ExecuteReport, RunLog, Task, execute_scene, execute_scene_with};

use crate::infer::InferFile;
use crate::mcap_log::{LogLevel, McapLog};
use crate::progress::Progress;
use crate::record::{TOPIC_PERCEPT, TOPIC_TRUTH};

/// Options of [`execute`].
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ExecuteOptions {
    /// Scene to act in: a built-in name (pick-place, sorting, sorting-new) or a TOML file.
    pub scene: String,
    /// A learned procedural model (from `pbd learn`): decides relevance and place per object.
    pub model: Option<PathBuf>,
    /// An inference (from `pbd infer`): its MAP schema, with the place its first instance used.
    pub demo: Option<PathBuf>,
    /// Only this object (scene label); default: every object in the scene.
    pub object: Option<String>,
    /// Override the place (with `demo`).
    pub place: Option<String>,
    /// Schema library (TOML; default: the built-in library).
    pub library: Option<PathBuf>,
    /// Seed of every random choice; default: the scene's seed.
    pub seed: Option<u64>,
    /// Record the execution to this MCAP file.
    pub output: Option<PathBuf>,
    /// The robot's calibration of the empty workcell, from a file (`pbd calibrate`); default: the
    /// workcell is calibrated here (the same calibration `pbd calibrate` writes by default).
    pub calibration: Option<PathBuf>,
    /// Serve the run live to Foxglove as well as writing the log (default: no network listener).
    #[serde(default)]
    pub live: crate::live::LiveOptions,
}

impl Default for ExecuteOptions {
    fn default() -> Self {
        ExecuteOptions {
            scene: "sorting-new".into(),
            model: None,
            demo: None,
            object: None,
            place: None,
            library: None,
            seed: None,
            output: None,
            calibration: None,
            live: crate::live::LiveOptions::default(),
        }
    }
}

/// Logs an execution to MCAP (snapshots at 30 Hz, activities, percepts and the truth beside them,
/// outcomes) and shows progress.
pub struct McapRunLog<'a> {
    log: Option<McapLog>,
    header: dexter_sim::snapshot::SnapshotHeader,
    next_log: f64,
    error: Option<anyhow::Error>,
    progress: &'a dyn Progress,
    /// The run's diagnostics, written to `/log` at the simulated time they happened.
    capture: Option<crate::logging::Capture>,
}

impl std::fmt::Debug for McapRunLog<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapRunLog")
            .field("logging", &self.log.is_some())
            .field("next_log", &self.next_log)
            .field("error", &self.error)
            .finish_non_exhaustive()
    }
}

impl<'a> McapRunLog<'a> {
    /// A log to `log` (or none: progress only) of a run on a simulator with `header`.
    pub fn new(log: Option<McapLog>, header: dexter_sim::snapshot::SnapshotHeader, progress: &'a dyn Progress) -> Self {
        let capture = log.is_some().then(crate::logging::Capture::begin);
        McapRunLog {
            log,
            header,
            next_log: 0.0,
            error: None,
            progress,
            capture,
        }
    }

    /// Writes the diagnostics kept since the last call to `/log`, at time `t`.
    fn write_diagnostics(&mut self, t: f64) {
        let (Some(capture), Some(log)) = (self.capture.as_ref(), self.log.as_mut()) else {
            return;
        };
        let records = capture.drain();
        for r in &records {
            let w = log.log_record(
                t,
                crate::logging::log_level(r.level),
                &r.target,
                &r.message,
                r.file.unwrap_or(""),
                r.line.unwrap_or(0),
            );
            if let Err(e) = w {
                self.error.get_or_insert(e);
            }
        }
    }

    fn keep(&mut self, r: Result<()>) {
        if let Err(e) = r {
            self.error.get_or_insert(e);
        }
    }

    /// Finishes the log; the first write error, if any.
    pub fn finish(mut self) -> Result<()> {
        self.progress.finish();
        self.write_diagnostics(self.next_log);
        self.capture = None;
        if let Some(e) = self.error.take() {
            return Err(e.context("writing the MCAP log"));
        }
        if let Some(log) = self.log.take() {
            log.finish()?;
        }
        Ok(())
    }
}

impl RunLog for McapRunLog<'_> {
    fn world(&mut self, sim: &DexterSim, activity: &str) {
        self.write_diagnostics(sim.time());
        if sim.time() + 1e-9 >= self.next_log {
            self.next_log += 1.0 / 30.0;
            if let Some(log) = self.log.as_mut() {
                let r = log.log_snapshot(&self.header, &sim.snapshot(activity));
                self.keep(r);
            }
        }
    }

    fn activity(&mut self, t: f64, activity: &str) {
        self.progress.message(&format!("{activity} (t = {t:.1} s)"));
        if let Some(log) = self.log.as_mut() {
            let r = log.log_text(t, LogLevel::Info, activity);
            self.keep(r);
        }
    }

    fn percept(&mut self, t: f64, p: &Percept, truth: &[(String, [f64; 3])]) {
        let Some(log) = self.log.as_mut() else {
            return;
        };
        let schema = serde_json::json!({"type": "object"});
        let r = log
            .log_json(TOPIC_PERCEPT, "pbd.Percept", &schema, t, p)
            .and_then(|()| {
                log.log_json(
                    TOPIC_TRUTH,
                    "pbd.Truth",
                    &schema,
                    t,
                    &serde_json::json!({"t": t, "objects": truth}),
                )
            });
        self.keep(r);
    }

    fn should_stop(&mut self) -> bool {
        self.progress.should_stop()
    }

    fn step(&mut self, t: f64, e: &schema::StepEvent<'_>) {
        let Some(log) = self.log.as_mut() else {
            return;
        };
        let names = e.library.action_names();
        let x: serde_json::Map<String, serde_json::Value> = names
            .iter()
            .zip(e.x)
            .map(|(n, b)| ((*n).to_owned(), serde_json::Value::Bool(*b)))
            .collect();
        let b = e.binding;
        let msg = serde_json::json!({
            "timestamp": crate::mcap_log::foxglove_time(t),
            "schema": e.schema.name,
            "state": e.schema.states.get(e.state).map_or("", |s| s.name.as_str()),
            "state_index": e.state,
            "action": e.action,
            "arm": b.and_then(|b| b.arm.as_deref()).unwrap_or(""),
            "place": b.and_then(|b| b.place.as_deref()).unwrap_or(""),
            "transfer": b.is_some_and(|b| b.transfer),
            "contingency": e.contingency.unwrap_or(""),
            "x": x,
        });
        let schema = crate::mcap_log::schema_state_schema(&names);
        let r = log.log_json(crate::mcap_log::TOPIC_SCHEMA_STATE, "pbd.SchemaState", &schema, t, &msg);
        self.keep(r);
    }

    fn decision(&mut self, t: f64, d: &dexter_sim::execute::DecisionEvent<'_>) {
        let Some(log) = self.log.as_mut() else {
            return;
        };
        let [pick, place_arm] = d.arms.unwrap_or(["", ""]);
        let msg = serde_json::json!({
            "timestamp": crate::mcap_log::foxglove_time(t),
            "segment": d.segment,
            "decision": d.decision,
            "place": d.place.unwrap_or(""),
            "log_bayes_factor": d.log_bayes_factor,
            "pick_arm": pick,
            "place_arm": place_arm,
            "transfer": d.arms.is_some_and(|[a, b]| a != b),
            "posterior": d.posterior,
            "reason": d.reason,
        });
        let r = log.log_json(
            crate::mcap_log::TOPIC_DECISION,
            "pbd.Decision",
            &crate::mcap_log::decision_schema(),
            t,
            &msg,
        );
        self.keep(r);
    }

    fn outcome(&mut self, t: f64, object: &str, success: bool) {
        if let Some(log) = self.log.as_mut() {
            let r = log.log_text(
                t,
                if success { LogLevel::Info } else { LogLevel::Warning },
                &format!("{object}: {}", if success { "placed" } else { "not placed" }),
            );
            self.keep(r);
        }
    }
}

/// `pbd execute`: the robot does the task of a model or an inference in a scene, from its own
/// senses; the world judges every object.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn execute(args: &ExecuteOptions, progress: &dyn Progress) -> crate::Result<ExecuteReport> {
    execute_impl(args, progress).map_err(crate::Error::from)
}

/// The task a run does, owned: the library, the schema, how the robot decides per segment, and
/// the spot a user pointed at. In-process runs and robots over ROS 2 (`crate::ros2`) share it.
pub(crate) struct TaskPlan {
    pub(crate) library: Library,
    pub(crate) schema: String,
    decide: DecideBy,
    pub(crate) only_near: Option<[f64; 2]>,
}

enum DecideBy {
    Place(String),
    Every,
    Model(Box<schema::procedural::ProceduralModel>),
}

impl TaskPlan {
    /// The robot's task.
    pub(crate) fn task(&self) -> Task<'_> {
        Task {
            library: &self.library,
            schema: &self.schema,
            decider: match &self.decide {
                DecideBy::Place(p) => Decider::Place(p.clone()),
                DecideBy::Every => Decider::Every,
                DecideBy::Model(m) => Decider::Model(m),
            },
            only_near: self.only_near,
            max_actions: dexter_sim::execute::MAX_ACTIONS,
        }
    }
}

/// Reads the library and the demonstration or model of `args`: what the robot will do in `scene`.
pub(crate) fn plan_task(args: &ExecuteOptions, scene: &Scene) -> Result<TaskPlan> {
    let library = match &args.library {
        Some(p) => Library::open(p)?,
        None => Library::builtin(),
    };
    let only_near = match &args.object {
        Some(o) => Some(dexter_sim::execute::pointed_at(scene, o)?),
        None => None,
    };
    let demo_place;
    let schema_name;
    let decide = match (&args.demo, &args.model) {
        (Some(path), _) => {
            let text = bayes::input::read_text(path).with_context(|| format!("cannot read {}", path.display()))?;
            let file = InferFile::from_json(&text, &path.display().to_string())?;
            let schema = file.inference.posterior.map.clone();
            if schema == "none" {
                bail!(
                    "{}: no schema of the library explains the demonstration (MAP: none); nothing to execute",
                    path.display()
                );
            }
            let def = library
                .schema(&schema)
                .with_context(|| format!("{}: its MAP schema is not in the library", path.display()))?;
            if let Err(why) = dexter::task::runnable(&library, def) {
                bail!(
                    "{}: the demonstration was explained by `{schema}`: {why}",
                    path.display()
                );
            }
            if dexter::task::has_place(&library, def) {
                demo_place = match &args.place {
                    Some(p) => p.clone(),
                    None => file
                        .inference
                        .instances
                        .iter()
                        .find_map(|i| i.place.clone())
                        .context("the inference has no instance with a place; pass --place")?,
                };
                scene.place(&demo_place)?;
                schema_name = schema;
                DecideBy::Place(demo_place.clone())
            } else {
                if args.place.is_some() {
                    bail!("--place: the demonstration's schema `{schema}` puts nothing in a place");
                }
                schema_name = schema;
                DecideBy::Every
            }
        }
        (None, Some(path)) => {
            if args.place.is_some() {
                bail!(
                    "place overrides the place of a demonstration (--demo); a model (--model) decides the place per object"
                );
            }
            let model = schema::procedural::ProceduralModel::load(path)?;
            // The schema the model's demonstrations were instances of (older models: Pick-And-Place).
            let schema = model.schema_in(&library)?.to_string();
            let def = library.schema(&schema).with_context(|| {
                format!(
                    "{}: the model was learned from `{schema}`, which the library does not hold",
                    path.display()
                )
            })?;
            if let Err(why) = dexter::task::runnable(&library, def) {
                bail!("{}: {why}", path.display());
            }
            schema_name = schema;
            DecideBy::Model(Box::new(model))
        }
        (None, None) => bail!("pass --demo demo.infer.json or --model model.json"),
    };
    Ok(TaskPlan {
        library,
        schema: schema_name,
        decide,
        only_near,
    })
}

fn execute_impl(args: &ExecuteOptions, progress: &dyn Progress) -> Result<ExecuteReport> {
    let scene = Scene::open(&args.scene)?;
    let seed = args.seed.unwrap_or(scene.spec.seed);
    let plan = plan_task(args, &scene)?;
    let schema_name = plan.schema.clone();
    anyhow::ensure!(
        args.output.is_some() || !args.live.is_on(),
        "--live streams the execution's log: pass --output FILE.mcap too"
    );
    // Every input, the scene's catalog included, is refused as the output before anything is written.
    let mut io = crate::files::IoPlan::new();
    io.read("--scene", &scene.path)
        .read("the scene's catalog", &scene.catalog.path);
    for (what, p) in [
        ("--model", &args.model),
        ("--demo", &args.demo),
        ("--library", &args.library),
        ("--calibration", &args.calibration),
    ] {
        if let Some(p) = p {
            io.read(what, p);
        }
    }
    if let Some(p) = &args.output {
        io.write("-o", p);
    }
    io.check()?;
    // A calibration from a file is loaded and checked against the robot's cameras before
    // anything is written.
    let calibration = match &args.calibration {
        Some(path) => {
            let sim = DexterSim::new(&scene, SimSettings::default())?;
            let cameras = dexter_sim::hardware::SimCameras::new(&sim, &scene, seed)?;
            Some(std::sync::Arc::new(crate::calibrate::load_for(
                path,
                cameras.infos(),
                &scene,
                progress,
            )?))
        }
        None => None,
    };
    let log = match &args.output {
        Some(p) => {
            let sim = DexterSim::new(&scene, SimSettings::default())?;
            let mut log = McapLog::create(p)?;
            if let Some(live) = args.live.start()? {
                progress.message(&format!(
                    "live view on {} (Foxglove: Open connection → Foxglove WebSocket)",
                    live.url()
                ));
                log.stream_to(live)?;
            }
            log.attach("dexter.urdf", "application/xml", DEXTER_URDF.as_bytes())?;
            let mut meta = BTreeMap::new();
            meta.insert("command".to_string(), "execute".to_string());
            meta.insert("scene".to_string(), args.scene.clone());
            meta.insert("seed".to_string(), seed.to_string());
            meta.insert("schema".to_string(), schema_name.clone());
            if let Some(c) = &args.calibration {
                meta.insert("calibration".to_string(), c.display().to_string());
            }
            log.metadata("pbd", meta)?;
            log.log_scene(&scene, sim.header(), 0.0)?;
            log.log_robot(sim.model(), 0.0)?;
            Some(log)
        }
        None => None,
    };
    let sim = DexterSim::new(&scene, SimSettings::default())?;
    progress.phase("execute", None);
    let mut run_log = McapRunLog::new(log, sim.header().clone(), progress);
    drop(sim);
    let task = plan.task();
    let run = execute_scene_with(&scene, &args.scene, &task, seed, None, calibration, &mut run_log);
    let finished = run_log.finish();
    let mut report = run?;
    finished?;
    report.mcap = args.output.as_ref().map(|p| p.display().to_string());
    Ok(report)
}

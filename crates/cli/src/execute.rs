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
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use std::cell::RefCell;
use std::rc::Rc;

use control_basis::Hardware;
use control_basis::math::Vec3;
use dexter::exec::{ExecSink, PickPlacePolicy, RobotPlant};
use dexter::eyes::Eyes;
use dexter_sim::hardware::{SimRobot, workspace};
use dexter_sim::physics::{DEXTER_URDF, DexterSim, SimSettings};
use dexter_sim::scene::Scene;
use dexter_sim::snapshot::ObjectState;
use schema::procedural::{Features, ProceduralModel};
use schema::{ExecReport, Library, Percept};
use serde::{Deserialize, Serialize};

use crate::infer::InferFile;
use crate::mcap_log::{LogLevel, McapLog};
use crate::record::{TOPIC_PERCEPT, TOPIC_TRUTH};

/// Arguments of `pbd execute`.
#[derive(Debug, Args)]
pub struct ExecuteArgs {
    /// Scene to act in: a built-in name (pick-place, sorting, sorting-new) or a TOML file.
    #[arg(long, default_value = "sorting-new")]
    pub scene: String,
    /// A learned procedural model (from `pbd learn`): decides relevance and place per object.
    #[arg(long, conflicts_with = "demo")]
    pub model: Option<PathBuf>,
    /// An inference (from `pbd infer`): its MAP schema, with the place its first instance used.
    #[arg(long)]
    pub demo: Option<PathBuf>,
    /// Only this object (scene label); default: every object in the scene.
    #[arg(long)]
    pub object: Option<String>,
    /// Override the place (with --demo).
    #[arg(long)]
    pub place: Option<String>,
    /// Schema library (TOML; default: the built-in library).
    #[arg(long)]
    pub library: Option<PathBuf>,
    /// Seed of every random choice; default: the scene's seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Record the execution to this MCAP file.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// What happened to one object.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ObjectReport {
    /// Scene label of the object the segment was (the evaluator's matching, by the truth at the
    /// start; `-` for a segment that matches no object).
    pub object: String,
    /// The robot's segment (track id) the decision was made on; `None` for an object it never saw.
    pub segment: Option<u32>,
    /// `execute`, `ignore` (not relevant) or `skip` (unreachable).
    pub decision: String,
    /// Why (posterior, Bayes factor, reachability).
    pub reason: String,
    /// The place chosen.
    pub place: Option<String>,
    /// Posterior over places (from a model).
    pub posterior: BTreeMap<String, f64>,
    /// log Bayes factor of relevance (from a model).
    pub log_bayes_factor: Option<f64>,
    /// Arms used, in order.
    pub arms: Vec<String>,
    /// A hand-to-hand transfer was used.
    pub transfer: bool,
    /// Contingencies taken.
    pub contingencies: Vec<String>,
    /// The executive's report.
    pub execution: Option<ExecReport>,
    /// Where the object ended, and whether it is inside the chosen place.
    pub final_position: [f64; 3],
    /// Object at rest inside the chosen place.
    pub success: bool,
    /// Why it failed, by phase (`perception`, `decision`, `reach`, `grasp`, `hold`, `place`,
    /// `release`, `outcome`), when it did.
    pub failure: Option<String>,
}

impl ObjectReport {
    /// A report for an object the robot did not execute (`ignore`, `skip`, `unseen`).
    #[allow(clippy::too_many_arguments)]
    fn not_executed(
        object: String,
        segment: Option<u32>,
        decision: &str,
        reason: String,
        place: Option<String>,
        posterior: BTreeMap<String, f64>,
        log_bayes_factor: Option<f64>,
        final_position: [f64; 3],
        failure: Option<String>,
    ) -> Self {
        ObjectReport {
            object,
            segment,
            decision: decision.into(),
            reason,
            place,
            posterior,
            log_bayes_factor,
            arms: vec![],
            transfer: false,
            contingencies: vec![],
            execution: None,
            final_position,
            success: false,
            failure,
        }
    }
}

/// The whole report.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ExecuteReport {
    /// The scene.
    pub scene: String,
    /// The schema executed.
    pub schema: String,
    /// Per object.
    pub objects: Vec<ObjectReport>,
    /// Relevant objects placed in their chosen place.
    pub placed: usize,
    /// Objects decided relevant.
    pub relevant: usize,
    /// Simulated and wall time (s).
    pub sim_time: f64,
    /// Wall time (s).
    pub wall_time: f64,
    /// The MCAP log.
    pub mcap: Option<String>,
}

/// Logs an execution: robot-side events (activity, percepts) and the world (snapshots, truth).
pub struct Logger {
    log: Option<McapLog>,
    header: dexter_sim::snapshot::SnapshotHeader,
    names: Vec<String>,
    next_log: f64,
    error: Option<anyhow::Error>,
    last_activity: String,
    progress: indicatif::ProgressBar,
    objects: Vec<ObjectState>,
}

impl Logger {
    fn keep(&mut self, r: Result<()>) {
        if let Err(e) = r {
            self.error.get_or_insert(e);
        }
    }

    fn world(&mut self, sim: &DexterSim) {
        self.objects.clear();
        self.objects
            .extend((0..sim.objects().len()).map(|i| sim.object_state(i)));
        self.progress.tick();
        if sim.time() + 1e-9 >= self.next_log {
            self.next_log += 1.0 / 30.0;
            if let Some(log) = self.log.as_mut() {
                let r = log.log_snapshot(&self.header, &sim.snapshot(&self.last_activity));
                self.keep(r);
            }
        }
    }
}

/// The robot side's sink: activity changes and percepts (with the truth beside them).
struct RobotSink(Rc<RefCell<Logger>>);

impl ExecSink for RobotSink {
    fn tick(&mut self, hw: &dyn Hardware, activity: &str) {
        let mut l = self.0.borrow_mut();
        if !activity.is_empty() && activity != l.last_activity {
            l.last_activity = activity.to_string();
            let t = hw.time_secs();
            l.progress.set_message(format!("{activity} (t = {t:.1} s)"));
            if let Some(log) = l.log.as_mut() {
                let r = log.log_text(t, LogLevel::Info, activity);
                l.keep(r);
            }
        }
    }

    fn percept(&mut self, hw: &dyn Hardware, _eyes: &Eyes, p: &Percept) {
        let mut l = self.0.borrow_mut();
        let t = hw.time_secs();
        let objects: Vec<(String, [f64; 3])> = l
            .names
            .iter()
            .zip(&l.objects)
            .map(|(n, o)| {
                let v = o.pose.translation.vector;
                (n.clone(), [v.x, v.y, v.z])
            })
            .collect();
        let Some(log) = l.log.as_mut() else {
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
                    &serde_json::json!({"t": t, "objects": objects}),
                )
            });
        l.keep(r);
    }
}

/// What to do with one seen segment: a place or a reason to leave it.
pub struct Decision {
    /// The robot's segment (track id).
    pub segment: u32,
    /// Where it was seen (m, world).
    pub at: [f64; 3],
    /// `Ok(place)` to execute, `Err(reason)` to ignore.
    pub place: std::result::Result<String, String>,
    /// Posterior over places.
    pub posterior: BTreeMap<String, f64>,
    /// log B10.
    pub log_bayes_factor: Option<f64>,
    /// Why.
    pub reason: String,
}

/// How the robot decides per segment.
pub enum Decider<'a> {
    /// Every segment goes to this place (a demonstration's place).
    Place(String),
    /// A learned procedural model.
    Model(&'a std::path::Path),
}

/// `pbd execute --model`: relevance and place for every segment the robot sees (the procedural
/// model's decision on the robot's own percepts).
pub fn decide(path: &Path, places: &[String], segments: &[schema::SegmentPercept]) -> Result<(String, Vec<Decision>)> {
    let model = ProceduralModel::load(path)?;
    let mut out = Vec::new();
    for seg in segments {
        let f = Features::from(seg);
        let p = model.predict(&f)?;
        let posterior: BTreeMap<String, f64> = p.places.iter().cloned().collect();
        let lb = p.relevance.bayes_factor.log_b10;
        let place = if p.relevance.relevant {
            if !places.contains(&p.map_place) {
                Err(format!("its place `{}` is not in this scene", p.map_place))
            } else {
                Ok(p.map_place.clone())
            }
        } else {
            Err(format!(
                "not part of the task (ln B10 = {lb:.1} ≤ {:.1})",
                p.relevance.log_threshold
            ))
        };
        out.push(Decision {
            segment: seg.id,
            at: seg.centroid,
            reason: format!(
                "MAP place {} (p = {:.3}), ln B10 = {lb:.1}",
                p.map_place, p.map_probability
            ),
            place,
            posterior,
            log_bayes_factor: Some(lb),
        });
    }
    Ok(("pick_and_place".into(), out))
}

/// Gaze points (x, y) that cover the table in front of the robot.
fn scan_points(ws: &dexter::exec::Workspace) -> Vec<Vec3> {
    let mut out = Vec::new();
    let (cx, cy) = (ws.table_center[0], ws.table_center[1]);
    let hy = (ws.table_size[1] / 2.0 - 0.1).max(0.0);
    for x in [cx - 0.08, cx + 0.1] {
        for k in 0..4 {
            let y = cy - hy + 2.0 * hy * f64::from(k) / 3.0;
            out.push(Vec3::new(x, y, ws.table_z + 0.03));
        }
    }
    out
}

/// Executes the task in `scene` as the robot: look over the table, decide per seen segment, run
/// the schema with ψ on each relevant one; the evaluator matches segments to objects by the truth at
/// the start and judges each outcome by the truth at the end. `only`: restrict to the segment
/// nearest this scene object (a user pointing at it).
#[allow(clippy::too_many_arguments)]
pub fn execute_scene(
    scene: &Scene,
    scene_name: &str,
    library: &Library,
    decider: &Decider<'_>,
    seed: u64,
    only: Option<&str>,
    log: Option<McapLog>,
    progress: indicatif::ProgressBar,
) -> Result<ExecuteReport> {
    let schema_name = "pick_and_place".to_string();
    let schema = library.schema(&schema_name)?.clone();
    let mut sim = dexter_sim::hardware::parked_sim(
        scene,
        SimSettings {
            seed,
            ..SimSettings::default()
        },
    )?;
    let table_z = scene.spec.table.height;
    let truth0: Vec<ObjectState> = (0..sim.objects().len()).map(|i| sim.object_state(i)).collect();
    let names = sim.header().object_names.clone();
    let labels: Vec<String> = scene.resolved.iter().map(|r| r.label.clone()).collect();
    let logger = Rc::new(RefCell::new(Logger {
        log,
        header: sim.header().clone(),
        names,
        next_log: 0.0,
        error: None,
        last_activity: String::new(),
        progress,
        objects: truth0.clone(),
    }));
    let wall = std::time::Instant::now();
    let t_start = sim.time();
    let ws = workspace(scene);
    let hook_logger = logger.clone();
    let mut hw = SimRobot::new(&mut sim, scene, seed)?
        .with_hook(Box::new(move |s: &DexterSim| hook_logger.borrow_mut().world(s)));
    let mut sink = RobotSink(logger.clone());
    let mut reports = Vec::new();
    {
        let mut plant = RobotPlant::new(&mut hw, &ws, library, &mut sink)?;
        // Look over the table: the tracker gathers what is there.
        for at in scan_points(&ws) {
            plant.look(&at, 0.6)?;
        }
        let seen: Vec<schema::SegmentPercept> = plant
            .last_percept()
            .map(|p| {
                p.segments
                    .iter()
                    .filter(|s| !ws.places.iter().any(|pl| pl.contains([s.centroid[0], s.centroid[1]])))
                    .cloned()
                    .collect()
            })
            .unwrap_or_default();
        // The evaluator: which object each segment is (nearest at the start, within 8 cm).
        let match_object = |c: &[f64; 3]| -> Option<usize> {
            truth0
                .iter()
                .enumerate()
                .map(|(i, o)| ((o.pose.translation.vector - Vec3::from(*c)).xy().norm(), i))
                .filter(|(d, _)| *d < 0.08)
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|(_, i)| i)
        };
        let mut seen = seen;
        if let Some(label) = only {
            let i = scene.object_index(label)?;
            seen.retain(|s| match_object(&s.centroid) == Some(i));
            seen.truncate(1);
        }
        let place_names: Vec<String> = ws.places.iter().map(|p| p.name.clone()).collect();
        let decisions = match decider {
            Decider::Place(p) => seen
                .iter()
                .map(|s| Decision {
                    segment: s.id,
                    at: s.centroid,
                    place: Ok(p.clone()),
                    posterior: BTreeMap::new(),
                    log_bayes_factor: None,
                    reason: format!("the demonstration placed its object in {p}"),
                })
                .collect(),
            Decider::Model(path) => decide(path, &place_names, &seen)?.1,
        };
        let mut matched = vec![false; truth0.len()];
        for d in decisions {
            let obj = match_object(&d.at);
            if let Some(i) = obj {
                matched[i] = true;
            }
            let label = obj.map(|i| labels[i].clone()).unwrap_or_else(|| "-".into());
            let final_of = |l: &Rc<RefCell<Logger>>| {
                obj.map(|i| {
                    let v = l.borrow().objects[i].pose.translation.vector;
                    [v.x, v.y, v.z]
                })
                .unwrap_or(d.at)
            };
            let place = match d.place {
                Err(why) => {
                    reports.push(ObjectReport::not_executed(
                        label,
                        Some(d.segment),
                        "ignore",
                        why,
                        None,
                        d.posterior,
                        d.log_bayes_factor,
                        final_of(&logger),
                        None,
                    ));
                    continue;
                }
                Ok(p) => p,
            };
            logger
                .borrow()
                .progress
                .set_message(format!("{label} (segment {}) → {place}", d.segment));
            // Look where it was decided on, then find it: its track, or (the tracker may have re-identified it while
            // the head looked elsewhere) the seen segment nearest where it was decided on.
            plant.look(&Vec3::from(d.at), 0.6)?;
            let now = plant.last_percept().and_then(|p| {
                p.segments.iter().find(|s| s.id == d.segment).or_else(|| {
                    p.segments
                        .iter()
                        .map(|s| ((Vec3::from(s.centroid) - Vec3::from(d.at)).xy().norm(), s))
                        .filter(|(dist, _)| *dist < 0.08)
                        .min_by(|a, b| a.0.total_cmp(&b.0))
                        .map(|(_, s)| s)
                })
            });
            let (segment_now, at) = now
                .map(|s| (s.id, Vec3::from(s.centroid)))
                .unwrap_or((d.segment, Vec3::from(d.at)));
            plant.plan_handoff(&at)?;
            let handoff = plant.handoff();
            let policy = PickPlacePolicy::decide(&*plant.hw, &ws, &segment_now.to_string(), &at, &place, handoff)?;
            let Some(mut policy) = policy else {
                reports.push(ObjectReport::not_executed(
                    label,
                    Some(d.segment),
                    "skip",
                    format!("no arm reaches segment {}, or none reaches `{place}`", d.segment),
                    Some(place),
                    d.posterior,
                    d.log_bayes_factor,
                    final_of(&logger),
                    Some("reach: out of both arms' workspace".into()),
                ));
                continue;
            };
            let transfer = policy.is_transfer();
            plant.bind_arms(&[policy.pick_arm, policy.place_arm]);
            let arms_before = plant.arms_used.len();
            let exec = schema::execute(library, &schema, &mut plant, &mut policy, 20)?;
            let arms: Vec<String> = plant.arms_used[arms_before..]
                .iter()
                .map(|a| a.prefix().to_string())
                .collect();
            // Let the object come to rest, then judge by the truth.
            plant.settle(0.5)?;
            let (success, final_position) = match obj {
                Some(i) => {
                    let o = logger.borrow().objects[i];
                    let p = o.pose.translation.vector;
                    let spec = scene.place(&place)?;
                    (
                        spec.contains([p.x, p.y]) && o.linvel.norm() < 0.02 && p.z < table_z + spec.wall_height + 0.2,
                        [p.x, p.y, p.z],
                    )
                }
                None => (false, d.at),
            };
            let failure = (!success).then(|| failure_cause(&exec, obj.is_some()));
            {
                let mut l = logger.borrow_mut();
                let t = plant.hw.time_secs();
                if let Some(log) = l.log.as_mut() {
                    let r = log.log_text(
                        t,
                        if success { LogLevel::Info } else { LogLevel::Warning },
                        &format!("{label}: {}", if success { "placed" } else { "not placed" }),
                    );
                    l.keep(r);
                }
            }
            reports.push(ObjectReport {
                object: label,
                segment: Some(d.segment),
                decision: "execute".into(),
                reason: d.reason,
                place: Some(place),
                posterior: d.posterior,
                log_bayes_factor: d.log_bayes_factor,
                arms,
                transfer,
                contingencies: exec.contingencies.clone(),
                execution: Some(exec),
                final_position,
                success,
                failure,
            });
        }
        if only.is_none() {
            // Objects the robot never saw (the evaluator's view).
            for (i, m) in matched.iter().enumerate() {
                if !m {
                    let v = truth0[i].pose.translation.vector;
                    reports.push(ObjectReport::not_executed(
                        labels[i].clone(),
                        None,
                        "unseen",
                        "no tracked segment matched it".into(),
                        None,
                        BTreeMap::new(),
                        None,
                        [v.x, v.y, v.z],
                        Some("perception: not seen".into()),
                    ));
                }
            }
        }
    }
    let sim_time = hw.sim().time() - t_start;
    drop(hw);
    drop(sink);
    let mut l = Rc::try_unwrap(logger)
        .map_err(|_| anyhow::anyhow!("the logger is still shared"))?
        .into_inner();
    l.progress.finish_and_clear();
    if let Some(e) = l.error.take() {
        return Err(e.context("writing the MCAP log"));
    }
    if let Some(log) = l.log.take() {
        log.finish()?;
    }
    let relevant = reports
        .iter()
        .filter(|r| r.decision == "execute" || r.decision == "skip")
        .count();
    let placed = reports.iter().filter(|r| r.success).count();
    Ok(ExecuteReport {
        scene: scene_name.to_string(),
        schema: schema_name,
        objects: reports,
        placed,
        relevant,
        sim_time,
        wall_time: wall.elapsed().as_secs_f64(),
        mcap: None,
    })
}

/// The phase an unsuccessful execution failed in: the first failed action of the executive, else
/// the outcome.
fn failure_cause(exec: &ExecReport, matched: bool) -> String {
    if !matched {
        return "perception: the segment matches no object".into();
    }
    let phase = |a: &str| {
        match a {
            "reach_object" => "reach",
            "grasp" => "grasp",
            "hold" => "hold",
            "place" => "place",
            "release" => "release",
            other => other,
        }
        .to_string()
    };
    match exec.steps.iter().rev().find_map(|s| match &s.outcome {
        schema::ActionOutcome::Failed(why) => Some((phase(&s.action), why.clone())),
        _ => None,
    }) {
        Some((p, why)) => format!("{p}: {why}"),
        None if !exec.reached_goal => "executive: no goal state reached".into(),
        None => "outcome: not at rest inside the place".into(),
    }
}

/// Runs `pbd execute`.
pub fn main(args: ExecuteArgs, out: &mut dyn Write) -> Result<()> {
    let library = match &args.library {
        Some(p) => Library::open(p)?,
        None => Library::builtin(),
    };
    let scene = Scene::open(&args.scene)?;
    let seed = args.seed.unwrap_or(scene.spec.seed);
    if let Some(o) = &args.object {
        scene.object_index(o)?;
    }
    let demo_place;
    let decider = match (&args.demo, &args.model) {
        (Some(path), _) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
            let file: InferFile =
                serde_json::from_str(&text).with_context(|| format!("{} is not an inference file", path.display()))?;
            if file.format != crate::infer::INFER_FORMAT || file.version != crate::infer::INFER_VERSION {
                bail!(
                    "{}: format {} v{} is not {} v{}",
                    path.display(),
                    file.format,
                    file.version,
                    crate::infer::INFER_FORMAT,
                    crate::infer::INFER_VERSION
                );
            }
            let schema = file.inference.posterior.map.clone();
            if schema != "pick_and_place" {
                bail!(
                    "{}: the demonstration was explained by `{schema}`; `pbd execute` runs pick_and_place",
                    path.display()
                );
            }
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
            Decider::Place(demo_place.clone())
        }
        (None, Some(path)) => Decider::Model(path),
        (None, None) => bail!("pass --demo demo.infer.json or --model model.json"),
    };
    let log = match &args.output {
        Some(p) => {
            let sim = DexterSim::new(&scene, SimSettings::default())?;
            let mut log = McapLog::create(p)?;
            log.attach("dexter.urdf", "application/xml", DEXTER_URDF.as_bytes())?;
            let mut meta = BTreeMap::new();
            meta.insert("command".to_string(), "execute".to_string());
            meta.insert("scene".to_string(), args.scene.clone());
            meta.insert("seed".to_string(), seed.to_string());
            meta.insert("schema".to_string(), "pick_and_place".to_string());
            log.metadata("pbd", meta)?;
            log.log_scene(&scene, sim.header(), 0.0)?;
            Some(log)
        }
        None => None,
    };
    let mut report = execute_scene(
        &scene,
        &args.scene,
        &library,
        &decider,
        seed,
        args.object.as_deref(),
        log,
        crate::progress::spinner(args.json, "execute"),
    )?;
    report.mcap = args.output.as_ref().map(|p| p.display().to_string());
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&report)?)?;
        return Ok(());
    }
    print_report(&report, out)
}

/// Prints an execution report as a table.
pub fn print_report(r: &ExecuteReport, out: &mut dyn Write) -> Result<()> {
    writeln!(out, "{} on scene {}:", r.schema, r.scene)?;
    for o in &r.objects {
        let arms = if o.arms.is_empty() {
            "-".to_string()
        } else {
            o.arms.join("→")
        };
        writeln!(
            out,
            "  {:<16} {:<8} {:<10} arms {:<12} {:<9} {:<24} {}",
            match o.segment {
                Some(s) => format!("{} [{s}]", o.object),
                None => o.object.clone(),
            },
            o.decision,
            o.place.as_deref().unwrap_or("-"),
            arms,
            if o.transfer { "transfer" } else { "" },
            if o.contingencies.is_empty() {
                String::new()
            } else {
                format!("contingencies: {}", o.contingencies.join(", "))
            },
            match o.decision.as_str() {
                "execute" =>
                    if o.success {
                        "PLACED".to_string()
                    } else {
                        format!("FAILED ({})", o.failure.as_deref().unwrap_or("?"))
                    },
                _ => o.reason.clone(),
            }
        )?;
    }
    writeln!(
        out,
        "placed {}/{} relevant objects in {:.1} s simulated ({:.1} s wall){}",
        r.placed,
        r.relevant,
        r.sim_time,
        r.wall_time,
        r.mcap.as_ref().map(|m| format!("; log {m}")).unwrap_or_default()
    )?;
    Ok(())
}

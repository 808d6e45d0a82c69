//! The robot executing a task in a scene, evaluated: the robot side ([`dexter`]) looks over the
//! table, decides per seen segment (a learned procedural model's relevance and place, or a
//! demonstration's place) and runs Pick-And-Place with ψ on [`SimRobot`]; this module matches
//! segments to objects by the truth at the start and judges each outcome by the truth at the end —
//! the only truth it reads. `pbd execute` and `pbd experiment execute` are built on
//! [`execute_scene`].

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::Path;
use std::rc::Rc;

use control_basis::Hardware;
use control_basis::math::Vec3;
use dexter::exec::{ExecSink, PickPlacePolicy, RobotPlant};
use dexter::eyes::Eyes;
use schema::procedural::{Features, ProceduralModel};
use schema::{ExecReport, Library, Percept};
use serde::{Deserialize, Serialize};

use crate::error::{SimError, from_robot};
use crate::fault::{Fault, FaultRecord, FaultSpec};
use crate::hardware::{SimRobot, parked_sim, workspace};
use crate::physics::{DexterSim, SimSettings};
use crate::scene::Scene;
use crate::snapshot::ObjectState;

/// Receives what happens during an execution (logs, progress). Every method has a default that
/// ignores it.
pub trait RunLog {
    /// After every control period: the world (for snapshots), with the robot's current activity.
    fn world(&mut self, _sim: &DexterSim, _activity: &str) {}
    /// The robot's activity changed (or a new object is started), at time `t`.
    fn activity(&mut self, _t: f64, _activity: &str) {}
    /// A percept, with the truth beside it (object names and positions, for `/pbd/truth`).
    fn percept(&mut self, _t: f64, _percept: &Percept, _truth: &[(String, [f64; 3])]) {}
    /// The outcome of one object.
    fn outcome(&mut self, _t: f64, _object: &str, _success: bool) {}
    /// The robot decided what to do with a seen segment (before it acts on it).
    fn decision(&mut self, _t: f64, _decision: &DecisionEvent<'_>) {}
    /// Where the schema executive stands, before each action and at a goal state.
    fn step(&mut self, _t: f64, _event: &schema::StepEvent<'_>) {}
    /// Asked every control period: `true` stops the run (the robot's hardware reports
    /// [`control_basis::hardware::HardwareError::Interrupted`]).
    fn should_stop(&mut self) -> bool {
        false
    }
}

/// What the robot decided for one seen segment, from its own percepts ([`RunLog::decision`]).
#[derive(Debug, Clone, Copy)]
pub struct DecisionEvent<'a> {
    /// The robot's segment (track id).
    pub segment: u32,
    /// `execute`, `ignore` (not part of the task) or `skip` (out of reach).
    pub decision: &'a str,
    /// The place chosen, if any.
    pub place: Option<&'a str>,
    /// Posterior over places (from a model; empty otherwise).
    pub posterior: &'a BTreeMap<String, f64>,
    /// ln B10 of task relevance (from a model).
    pub log_bayes_factor: Option<f64>,
    /// The arm that picks and the arm that places (the same unless it is a hand-to-hand transfer).
    pub arms: Option<[&'a str; 2]>,
    /// Why.
    pub reason: &'a str,
}

/// A [`RunLog`] that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoLog;

impl RunLog for NoLog {}

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
    /// The injected fault and what it did (the evaluator's record), if one was armed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fault: Option<FaultRecord>,
}

/// The report as a table: per object the decision, place, arms, transfer, contingencies, outcome.
impl std::fmt::Display for ExecuteReport {
    fn fmt(&self, out: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let r = self;
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
}

/// What the hook and the robot's sink share during a run.
struct Shared<'l> {
    log: &'l mut dyn RunLog,
    names: Vec<String>,
    last_activity: String,
    objects: Vec<ObjectState>,
}

impl Shared<'_> {
    fn world(&mut self, sim: &DexterSim) {
        self.objects.clear();
        self.objects
            .extend((0..sim.objects().len()).map(|i| sim.object_state(i)));
        let Shared { log, last_activity, .. } = self;
        log.world(sim, last_activity);
    }
}

/// The robot side's sink: activity changes and percepts (with the truth beside them).
struct RobotSink<'l>(Rc<RefCell<Shared<'l>>>);

impl ExecSink for RobotSink<'_> {
    fn tick(&mut self, hw: &dyn Hardware, activity: &str) {
        let mut l = self.0.borrow_mut();
        if !activity.is_empty() && activity != l.last_activity {
            l.last_activity = activity.to_string();
            l.log.activity(hw.time_secs(), activity);
        }
    }

    fn percept(&mut self, hw: &dyn Hardware, eyes: &Eyes, p: &Percept) {
        debug_frames(hw.time_secs(), eyes);
        let mut l = self.0.borrow_mut();
        let truth: Vec<(String, [f64; 3])> = l
            .names
            .iter()
            .zip(&l.objects)
            .map(|(n, o)| {
                let v = o.pose.translation.vector;
                (n.clone(), [v.x, v.y, v.z])
            })
            .collect();
        l.log.percept(hw.time_secs(), p, &truth);
    }

    fn step(&mut self, hw: &dyn Hardware, event: &schema::StepEvent<'_>) {
        self.0.borrow_mut().log.step(hw.time_secs(), event);
    }
}

/// For debugging: with `PBD_DEBUG_FRAMES=DIR`, every percept's head images are written to `DIR` as
/// PPM files, `t<ms>-<l|r>.ppm`, with the foreground tinted green and the robot's self-mask blue.
fn debug_frames(t: f64, eyes: &Eyes) {
    static DIR: std::sync::OnceLock<Option<std::path::PathBuf>> = std::sync::OnceLock::new();
    let Some(dir) = DIR.get_or_init(|| std::env::var_os("PBD_DEBUG_FRAMES").map(Into::into)) else {
        return;
    };
    let _ = std::fs::create_dir_all(dir);
    let (images, masks) = (
        eyes.images(dexter::eyes::Pair::Head),
        eyes.self_masks(dexter::eyes::Pair::Head),
    );
    let pipeline = eyes.pipeline(dexter::eyes::Pair::Head);
    for (k, (side, image, mask)) in [
        (dexter::vision::Side::Left, images.0, masks.0),
        (dexter::vision::Side::Right, images.1, masks.1),
    ]
    .into_iter()
    .enumerate()
    {
        let fg = pipeline.segmenter(side).foreground();
        let mut out = image.clone();
        for (i, px) in out.rgb.chunks_exact_mut(3).enumerate() {
            if fg.get(i).copied().unwrap_or(false) {
                px[1] = px[1].saturating_add(90);
            }
            if mask.get(i).copied().unwrap_or(false) {
                px[2] = px[2].saturating_add(90);
            }
        }
        let name = format!("t{:06}-{}.ppm", (t * 1000.0).round() as i64, ["l", "r"][k]);
        let _ = out.save_ppm(dir.join(name));
    }
}

/// What to do with one seen segment: a place or a reason to leave it.
#[derive(Debug, Clone)]
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

impl Decision {
    /// The logged event of this decision as taken: `decision` (`execute`, `ignore`, `skip`), the
    /// place and arms if any, and why.
    fn event<'a>(
        &'a self,
        decision: &'a str,
        place: Option<&'a str>,
        arms: Option<[&'a str; 2]>,
        reason: &'a str,
    ) -> DecisionEvent<'a> {
        DecisionEvent {
            segment: self.segment,
            decision,
            place,
            posterior: &self.posterior,
            log_bayes_factor: self.log_bayes_factor,
            arms,
            reason,
        }
    }
}

/// How the robot decides per segment.
#[derive(Debug, Clone)]
pub enum Decider<'a> {
    /// Every segment goes to this place (a demonstration's place).
    Place(String),
    /// A learned procedural model.
    Model(&'a std::path::Path),
}

/// `pbd execute --model`: relevance and place for every segment the robot sees (the procedural
/// model's decision on the robot's own percepts).
pub fn decide(
    path: &Path,
    places: &[String],
    segments: &[schema::SegmentPercept],
) -> Result<(String, Vec<Decision>), SimError> {
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
    log: &mut dyn RunLog,
) -> Result<ExecuteReport, SimError> {
    execute_scene_with_fault(scene, scene_name, library, decider, seed, only, None, log)
}

/// [`execute_scene`] with `fault` armed in the world ([`crate::fault`]); the report carries what
/// the fault did.
#[allow(clippy::too_many_arguments)]
pub fn execute_scene_with_fault(
    scene: &Scene,
    scene_name: &str,
    library: &Library,
    decider: &Decider<'_>,
    seed: u64,
    only: Option<&str>,
    fault: Option<&FaultSpec>,
    log: &mut dyn RunLog,
) -> Result<ExecuteReport, SimError> {
    let schema_name = "pick_and_place".to_string();
    let schema = library.schema(&schema_name)?.clone();
    let mut sim = parked_sim(
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
    let logger = Rc::new(RefCell::new(Shared {
        log,
        names,
        last_activity: String::new(),
        objects: truth0.clone(),
    }));
    let wall = std::time::Instant::now();
    let t_start = sim.time();
    let ws = workspace(scene);
    let calibration = crate::calibrate::workcell_calibration(scene)?;
    let hook_logger = logger.clone();
    let stop_logger = logger.clone();
    let mut hw = SimRobot::new(&mut sim, scene, seed)?
        .with_hook(Box::new(move |s: &DexterSim| hook_logger.borrow_mut().world(s)))
        .with_stop(Box::new(move || stop_logger.borrow_mut().log.should_stop()));
    if let Some(spec) = fault {
        let armed = Fault::new(spec.clone(), hw.sim(), scene)?;
        hw = hw.with_fault(armed);
    }
    let mut sink = RobotSink(logger.clone());
    let mut reports = Vec::new();
    {
        let mut plant = RobotPlant::new(&mut hw, &ws, calibration, library, &mut sink).map_err(from_robot)?;
        let seen = look_over_table(&mut plant, &ws)?;
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
            // A second segment of an object already decided on (a duplicate track): whatever
            // the robot does with it, it is not a success of its own.
            let duplicate = obj.is_some_and(|i| matched[i]);
            if let Some(i) = obj {
                matched[i] = true;
            }
            let label = obj.map(|i| labels[i].clone()).unwrap_or_else(|| "-".into());
            let final_of = |l: &Rc<RefCell<Shared<'_>>>| {
                obj.map(|i| {
                    let v = l.borrow().objects[i].pose.translation.vector;
                    [v.x, v.y, v.z]
                })
                .unwrap_or(d.at)
            };
            let place = match d.place.clone() {
                Err(why) => {
                    let t = plant.hw.time_secs();
                    logger
                        .borrow_mut()
                        .log
                        .decision(t, &d.event("ignore", None, None, &why));
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
            {
                let mut l = logger.borrow_mut();
                let t = plant.hw.time_secs();
                l.log.activity(t, &format!("{label} (segment {}) → {place}", d.segment));
            }
            // Look where it was decided on, then find it: its track, or (the tracker may have lost or
            // re-identified it while the robot worked elsewhere) the seen segment nearest where it was
            // decided on, looking there and, failing that, over the table.
            plant.look(&Vec3::from(d.at), 0.6).map_err(from_robot)?;
            let by_id = plant.last_percept().and_then(|p| {
                p.segments
                    .iter()
                    .find(|s| s.id == d.segment)
                    .map(|s| (s.id, Vec3::from(s.centroid)))
            });
            let now = match by_id {
                Some(found) => Some(found),
                None => plant.find(&Vec3::from(d.at)).map_err(from_robot)?,
            };
            let (segment_now, at) = now.unwrap_or((d.segment, Vec3::from(d.at)));
            plant.set_destination(Some(&place));
            plant.plan_handoff(&at).map_err(from_robot)?;
            let handoff = plant.handoff();
            let policy = PickPlacePolicy::decide(&*plant.hw, &ws, &segment_now.to_string(), &at, &place, handoff)?;
            let Some(mut policy) = policy else {
                let why = format!("no arm reaches segment {}, or none reaches `{place}`", d.segment);
                let t = plant.hw.time_secs();
                logger
                    .borrow_mut()
                    .log
                    .decision(t, &d.event("skip", Some(&place), None, &why));
                reports.push(ObjectReport::not_executed(
                    label,
                    Some(d.segment),
                    "skip",
                    why,
                    Some(place),
                    d.posterior,
                    d.log_bayes_factor,
                    final_of(&logger),
                    Some("reach: out of both arms' workspace".into()),
                ));
                continue;
            };
            {
                let t = plant.hw.time_secs();
                let arms = [policy.pick_arm.prefix(), policy.place_arm.prefix()];
                logger
                    .borrow_mut()
                    .log
                    .decision(t, &d.event("execute", Some(&place), Some(arms), &d.reason));
            }
            plant.bind_arms(&[policy.pick_arm, policy.place_arm]);
            let arms_before = plant.arms_used.len();
            let exec = schema::execute(library, &schema, &mut plant, &mut policy, 20)?;
            let transfer = policy.is_transfer();
            let arms: Vec<String> = plant.arms_used[arms_before..]
                .iter()
                .map(|a| a.prefix().to_string())
                .collect();
            // Let the object come to rest (an object set down on its side may roll for a while
            // inside the place, until a wall stops it), then judge by the truth.
            plant.settle(0.5).map_err(from_robot)?;
            if let Some(i) = obj {
                let mut waited = 0.0;
                while waited < JUDGE_REST_SECS && logger.borrow().objects[i].linvel.norm() >= AT_REST_SPEED {
                    plant.settle(0.25).map_err(from_robot)?;
                    waited += 0.25;
                }
            }
            let (success, final_position) = match obj {
                Some(i) => {
                    let o = logger.borrow().objects[i];
                    let p = o.pose.translation.vector;
                    let spec = scene.place(&place)?;
                    (
                        spec.contains([p.x, p.y])
                            && o.linvel.norm() < AT_REST_SPEED
                            && p.z < table_z + spec.wall_height + 0.2,
                        [p.x, p.y, p.z],
                    )
                }
                None => (false, d.at),
            };
            let success = success && !duplicate;
            let failure = if duplicate {
                Some("perception: a second segment of an object already decided on (a duplicate track)".into())
            } else {
                (!success).then(|| failure_cause(&exec, obj.is_some()))
            };
            {
                let t = plant.hw.time_secs();
                logger.borrow_mut().log.outcome(t, &label, success);
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
                contingencies: exec.contingencies.iter().chain(&policy.rebindings).cloned().collect(),
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
    let fault_record = hw.fault().map(|f| f.record().clone());
    drop(hw);
    drop(sink);
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
        fault: fault_record,
    })
}

/// The robot looks over the table ([`dexter::exec::Workspace::scan_points`], 0.6 s each; the
/// tracker gathers what is there) and returns its tracked segments outside the places: what it
/// decides on before a task.
pub fn look_over_table(
    plant: &mut RobotPlant<'_>,
    ws: &dexter::exec::Workspace,
) -> Result<Vec<schema::SegmentPercept>, SimError> {
    for at in ws.scan_points() {
        plant.look(&at, 0.6).map_err(from_robot)?;
    }
    Ok(plant
        .last_percept()
        .map(|p| {
            p.segments
                .iter()
                .filter(|s| !ws.places.iter().any(|pl| pl.contains([s.centroid[0], s.centroid[1]])))
                .cloned()
                .collect()
        })
        .unwrap_or_default())
}

/// An object slower than this (m/s) is at rest (the evaluator's judgement).
const AT_REST_SPEED: f64 = 0.02;
/// How long (s), after the executive finished, the evaluator waits at most for the object to
/// come to rest before judging where it is.
const JUDGE_REST_SECS: f64 = 3.0;

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
    // The executive gave up on an action that converged by the robot's own predicate while the
    // monitors did not see the state change.
    if !exec.reached_goal
        && let Some(last) = exec.steps.last()
        && last.outcome == schema::ActionOutcome::Converged
        && exec.steps.len() >= 3
        && exec.steps[exec.steps.len() - 3..]
            .iter()
            .all(|s| s.action == last.action && s.state == last.state)
    {
        return format!(
            "executive: `{}` converged three times in state `{}` but the monitors did not see the state change",
            last.action, last.state
        );
    }
    // The schema reached its goal by the robot's own monitors (a failure on the way was
    // recovered from): what failed is the outcome.
    if exec.reached_goal {
        return "outcome: not at rest inside the place".into();
    }
    match exec.steps.iter().rev().find_map(|s| match &s.outcome {
        schema::ActionOutcome::Failed(why) => Some((phase(&s.action), why.clone())),
        _ => None,
    }) {
        Some((p, why)) => format!("{p}: {why}"),
        None => "executive: no goal state reached".into(),
    }
}

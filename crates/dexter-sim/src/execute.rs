//! The robot executing a task in a scene, evaluated. The task loop is the robot's own
//! ([`dexter::task::run_task`]: it looks over the table, decides per seen segment — a learned
//! procedural model's relevance and place, or a demonstration's place — and runs the schema with ψ);
//! here it runs on [`SimRobot`], and this module, the evaluator, matches segments to objects by the
//! truth at the start and judges each outcome by the truth at the end — the only truth it reads.
//! `pbd execute` and `pbd experiment execute` are built on [`execute_scene`].

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::rc::Rc;

use control_basis::Hardware;
use control_basis::math::Vec3;
use dexter::Arm;
use dexter::actions::{Skill, SkillMap};
use dexter::exec::{ExecSink, RobotPlant};
use dexter::eyes::Eyes;
pub use dexter::task::{Decider, Decision, DecisionEvent, Task, Verdict};
use dexter::task::{SegmentRun, Taken, TaskSink};
use schema::{ExecReport, Percept};
use serde::{Deserialize, Serialize};

use crate::error::{SimError, from_robot};
use crate::fault::model::{Fault, FaultRecord, FaultSpec};
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
    /// Execute, ignore (not relevant), skip (unreachable) or unseen.
    pub decision: Verdict,
    /// Why (posterior, Bayes factor, reachability).
    pub reason: String,
    /// The place chosen.
    pub place: Option<String>,
    /// Posterior over places (from a model).
    pub posterior: BTreeMap<String, f64>,
    /// log Bayes factor of relevance (from a model).
    pub log_bayes_factor: Option<f64>,
    /// The segment's measured size (cm) the decision was made on ([`dexter::task::Decision::size_cm`]).
    pub size_cm: Option<f64>,
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
    /// The schema's goal met in the world, judged from the truth ([`GoalKind`]): for
    /// Pick-And-Place, the object at rest inside the chosen place.
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
        decision: Verdict,
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
            decision,
            reason,
            place,
            posterior,
            log_bayes_factor,
            size_cm: None,
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
    /// Relevant objects whose outcome meets the schema's goal (placed in their chosen place, for
    /// Pick-And-Place).
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
                match o.decision {
                    Verdict::Execute =>
                        if o.success && o.place.is_some() {
                            "PLACED".to_string()
                        } else if o.success {
                            "DONE".to_string()
                        } else {
                            format!("FAILED ({})", o.failure.as_deref().unwrap_or("?"))
                        },
                    _ => o.reason.clone(),
                }
            )?;
        }
        writeln!(
            out,
            "{} {}/{} relevant objects in {:.1} s simulated ({:.1} s wall){}",
            if r.objects.iter().any(|o| o.place.is_some()) {
                "placed"
            } else {
                "done with"
            },
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
    /// The object under judgement (the evaluator's match of the segment the robot works on), with
    /// what the evaluator watches while the robot works: its highest centre (m) and the hands'
    /// parts on it.
    watched: Option<Watched>,
    /// Whether the evaluator needs to know whether and how a hand touches the watched object (any
    /// task but Pick-And-Place, whose outcome is where the object rests).
    watch_hands: bool,
}

/// What the evaluator saw of one object while the robot worked on it.
#[derive(Debug, Clone, Copy)]
struct Watched {
    object: usize,
    start: [f64; 3],
    max_z: f64,
    /// Parts of a hand (palm, fingers; the more of the two hands) touching it at the last step.
    parts_now: usize,
}

impl Shared<'_> {
    fn world(&mut self, sim: &DexterSim) {
        self.objects.clear();
        self.objects
            .extend((0..sim.objects().len()).map(|i| sim.object_state(i)));
        if let Some(w) = self.watched.as_mut() {
            w.max_z = w.max_z.max(self.objects[w.object].pose.translation.z);
            if self.watch_hands {
                w.parts_now = Arm::BOTH
                    .into_iter()
                    .map(|a| sim.hand_wrench_on_object(a, w.object).2)
                    .max()
                    .unwrap_or(0);
            }
        }
        let Shared { log, last_activity, .. } = self;
        log.world(sim, last_activity);
    }
}

/// What a schema's goal means in the world, by the skills the schema is made of — how the
/// evaluator judges it from the truth.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GoalKind {
    /// The object at rest inside the chosen place (Pick-And-Place).
    Placed,
    /// The object held in the air at the end (Pick-And-Hold): a hand touches it and it is at
    /// least [`LIFTED`] above where it stood.
    Held,
    /// The object was lifted at least [`LIFTED`] and let go (Hand-Over): no hand touches it at
    /// the end.
    HandedOver,
    /// A hand touches the object at the end and it stayed where it was (Reach-And-Touch): moved
    /// less than [`TOUCH_DISPLACEMENT`].
    Touched,
    /// The object grasped where it stands (Reach-Grasp): two parts of a hand touch it at the end.
    Grasped,
}

impl GoalKind {
    /// The goal of `schema`, from its actions' skills.
    pub fn of(library: &schema::Library, schema: &schema::Schema) -> GoalKind {
        let skills = dexter::actions::SkillMap::new(library);
        let has = |k: Skill| schema.actions.iter().any(|&a| skills.at(a) == Some(k));
        if has(Skill::Place) {
            GoalKind::Placed
        } else if has(Skill::Touch) {
            GoalKind::Touched
        } else if has(Skill::Hold) && has(Skill::Release) {
            GoalKind::HandedOver
        } else if has(Skill::Hold) {
            GoalKind::Held
        } else {
            GoalKind::Grasped
        }
    }

    /// What failed when the goal was not met in the world although the robot's monitors saw it.
    fn unmet(self) -> &'static str {
        match self {
            GoalKind::Placed => "outcome: not at rest inside the place",
            GoalKind::Held => "outcome: not held in the air at the end",
            GoalKind::HandedOver => "outcome: not lifted and let go",
            GoalKind::Touched => "outcome: not touched, or moved by the touch",
            GoalKind::Grasped => "outcome: not grasped at the end",
        }
    }
}

/// How far (m) above where it stood an object must have risen to count as lifted.
pub const LIFTED: f64 = 0.05;
/// How far (m, on the table) a touched object may have moved and still count as touched in place.
pub const TOUCH_DISPLACEMENT: f64 = 0.05;

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

/// How many actions the executive may take per segment in the experiments and `pbd execute`.
pub const MAX_ACTIONS: usize = 20;

/// Where a user pointing at scene object `label` points (its presentation's x, y on the table):
/// [`Task::only_near`] for `pbd execute --object`.
pub fn pointed_at(scene: &Scene, label: &str) -> Result<[f64; 2], SimError> {
    let i = scene.object_index(label)?;
    Ok(scene.spec.objects[i].xy)
}

/// The evaluator, listening to the robot's task loop: it matches each segment the robot takes up
/// to an object by the truth at the start, and judges each outcome by the truth once the robot is
/// done with it (waiting, the robot holding still, for the object to come to rest).
struct Judge<'s, 'l> {
    scene: &'s Scene,
    /// The schema the robot runs, and what its goal means in the world.
    schema: String,
    goal: GoalKind,
    /// The library's actions bound to the robot's skills (to name a failure's phase).
    skills: SkillMap,
    logger: Rc<RefCell<Shared<'l>>>,
    truth0: Vec<ObjectState>,
    labels: Vec<String>,
    table_z: f64,
    matched: Vec<bool>,
    /// The object the current segment is (by the truth at the start), and whether another segment
    /// was already matched to it.
    current: (Option<usize>, bool),
    reports: Vec<ObjectReport>,
}

impl Judge<'_, '_> {
    /// Whether object `i`, now `o`, meets the task's goal (`place`: the place decided;
    /// `watched`: what the evaluator saw while the robot worked on it).
    fn met(&self, i: usize, o: &ObjectState, place: Option<&str>, watched: Option<Watched>) -> bool {
        let p = o.pose.translation.vector;
        let at_rest = o.linvel.norm() < AT_REST_SPEED;
        let w = watched.filter(|w| w.object == i);
        let in_hand = || w.is_some_and(|w| w.parts_now >= 2);
        match self.goal {
            GoalKind::Placed => {
                let inside = place
                    .and_then(|name| self.scene.place(name).ok())
                    .is_some_and(|spec| spec.contains([p.x, p.y]) && p.z < self.table_z + spec.wall_height + 0.2);
                if !(inside && at_rest) {
                    tracing::debug!(
                        "truth: object {i} at ({:.3}, {:.3}, {:.3}), {:.3} m/s, tilted {:.0}°, place {place:?}: inside {inside}, at rest {at_rest}",
                        p.x,
                        p.y,
                        p.z,
                        o.linvel.norm(),
                        (o.pose.rotation * Vec3::z()).z.clamp(-1.0, 1.0).acos().to_degrees()
                    );
                }
                inside && at_rest
            }
            GoalKind::Held => w.is_some_and(|w| p.z >= w.start[2] + LIFTED) && in_hand(),
            GoalKind::HandedOver => w.is_some_and(|w| w.max_z >= w.start[2] + LIFTED && w.parts_now == 0),
            GoalKind::Touched => w.is_some_and(|w| {
                w.parts_now > 0
                    && (p.x - w.start[0]).hypot(p.y - w.start[1]) < TOUCH_DISPLACEMENT
                    && (p.z - w.start[2]).abs() < TOUCH_DISPLACEMENT
            }),
            GoalKind::Grasped => in_hand(),
        }
    }

    /// Which object a segment seen at `c` is: the nearest at the start, within 8 cm.
    fn match_object(&self, c: &[f64; 3]) -> Option<usize> {
        self.truth0
            .iter()
            .enumerate()
            .map(|(i, o)| ((o.pose.translation.vector - Vec3::from(*c)).xy().norm(), i))
            .filter(|(d, _)| *d < 0.08)
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, i)| i)
    }

    fn label(&self) -> String {
        self.current
            .0
            .map(|i| self.labels[i].clone())
            .unwrap_or_else(|| "-".into())
    }

    /// Where the current object is now (where the segment was seen, for a segment of no object).
    fn final_position(&self, at: [f64; 3]) -> [f64; 3] {
        self.current
            .0
            .map(|i| {
                let v = self.logger.borrow().objects[i].pose.translation.vector;
                [v.x, v.y, v.z]
            })
            .unwrap_or(at)
    }
}

impl TaskSink for Judge<'_, '_> {
    fn begin(&mut self, _hw: &dyn Hardware, d: &Decision) {
        let obj = self.match_object(&d.at);
        // A second segment of an object already decided on (a duplicate track): whatever the
        // robot does with it, it is not a success of its own.
        let duplicate = obj.is_some_and(|i| self.matched[i]);
        if let Some(i) = obj {
            self.matched[i] = true;
        }
        self.current = (obj, duplicate);
    }

    fn decided(&mut self, hw: &dyn Hardware, event: &DecisionEvent<'_>) {
        self.logger.borrow_mut().log.decision(hw.time_secs(), event);
    }

    fn acting(&mut self, hw: &dyn Hardware, d: &Decision, place: Option<&str>) {
        let label = self.label();
        let mut l = self.logger.borrow_mut();
        l.watched = self.current.0.map(|i| {
            let v = l.objects[i].pose.translation.vector;
            Watched {
                object: i,
                start: [v.x, v.y, v.z],
                max_z: v.z,
                parts_now: 0,
            }
        });
        let what = match place {
            Some(p) => format!("{label} (segment {}) → {p}", d.segment),
            None => format!("{label} (segment {}): {}", d.segment, self.schema),
        };
        l.log.activity(hw.time_secs(), &what);
    }

    fn done(&mut self, plant: &mut RobotPlant<'_>, run: &SegmentRun) -> Result<(), dexter::RobotError> {
        let d = &run.decision;
        let label = self.label();
        let (obj, duplicate) = self.current;
        let report = match &run.taken {
            Taken::Ignored { why } => ObjectReport {
                size_cm: d.size_cm,
                ..ObjectReport::not_executed(
                    label,
                    Some(d.segment),
                    Verdict::Ignore,
                    why.clone(),
                    None,
                    d.posterior.clone(),
                    d.log_bayes_factor,
                    self.final_position(d.at),
                    None,
                )
            },
            Taken::Skipped { place, why } => ObjectReport {
                size_cm: d.size_cm,
                ..ObjectReport::not_executed(
                    label,
                    Some(d.segment),
                    Verdict::Skip,
                    why.clone(),
                    place.clone(),
                    d.posterior.clone(),
                    d.log_bayes_factor,
                    self.final_position(d.at),
                    Some("reach: out of both arms' workspace".into()),
                )
            },
            Taken::Executed {
                place,
                arms,
                transfer,
                contingencies,
                execution,
            } => {
                // Let the object come to rest (an object set down on its side may roll for a
                // while inside the place, until a wall stops it), then judge by the truth. An
                // object held in the air is judged as it is.
                if let Some(i) = obj
                    && self.goal != GoalKind::Held
                {
                    let mut waited = 0.0;
                    while waited < JUDGE_REST_SECS && self.logger.borrow().objects[i].linvel.norm() >= AT_REST_SPEED {
                        plant.settle(0.25)?;
                        waited += 0.25;
                    }
                }
                let watched = self.logger.borrow_mut().watched.take();
                let (success, final_position) = match obj {
                    Some(i) => {
                        let o = self.logger.borrow().objects[i];
                        let p = o.pose.translation.vector;
                        (self.met(i, &o, place.as_deref(), watched), [p.x, p.y, p.z])
                    }
                    None => (false, d.at),
                };
                let success = success && !duplicate;
                let failure = if duplicate {
                    Some("perception: a second segment of an object already decided on (a duplicate track)".into())
                } else {
                    (!success).then(|| failure_cause(execution, obj.is_some(), self.goal, &self.skills))
                };
                self.logger
                    .borrow_mut()
                    .log
                    .outcome(plant.hw.time_secs(), &label, success);
                ObjectReport {
                    object: label,
                    segment: Some(d.segment),
                    decision: Verdict::Execute,
                    reason: d.reason.clone(),
                    place: place.clone(),
                    posterior: d.posterior.clone(),
                    log_bayes_factor: d.log_bayes_factor,
                    size_cm: d.size_cm,
                    arms: arms.clone(),
                    transfer: *transfer,
                    contingencies: contingencies.clone(),
                    execution: Some(execution.clone()),
                    final_position,
                    success,
                    failure,
                }
            }
        };
        self.reports.push(report);
        Ok(())
    }
}

/// Executes `task` in `scene`: the world (the robot parked, the workcell calibrated before the
/// objects were placed) is built here, the robot's own task loop ([`dexter::task::run_task`])
/// runs on it, and the evaluator judges each segment the robot took up by the truth — which object
/// it was at the start, where that object ended — and lists the objects the robot never saw.
pub fn execute_scene(
    scene: &Scene,
    scene_name: &str,
    task: &Task<'_>,
    seed: u64,
    log: &mut dyn RunLog,
) -> Result<ExecuteReport, SimError> {
    execute_scene_with_fault(scene, scene_name, task, seed, None, log)
}

/// [`execute_scene`] with `fault` armed in the world ([`crate::fault`]); the report carries what
/// the fault did.
pub fn execute_scene_with_fault(
    scene: &Scene,
    scene_name: &str,
    task: &Task<'_>,
    seed: u64,
    fault: Option<&FaultSpec>,
    log: &mut dyn RunLog,
) -> Result<ExecuteReport, SimError> {
    execute_scene_with(scene, scene_name, task, seed, fault, None, log)
}

/// [`execute_scene_with_fault`] with the robot's eyes on `calibration` (one loaded from a file, as
/// a real robot's would be) instead of the workcell's calibration computed here
/// ([`crate::calibrate::workcell_calibration`]); `None` computes it as [`execute_scene`] does. The
/// robot refuses a calibration taken with other cameras
/// ([`dexter::calibration::Calibration::check_cameras`]).
pub fn execute_scene_with(
    scene: &Scene,
    scene_name: &str,
    task: &Task<'_>,
    seed: u64,
    fault: Option<&FaultSpec>,
    calibration: Option<std::sync::Arc<dexter::calibration::Calibration>>,
    log: &mut dyn RunLog,
) -> Result<ExecuteReport, SimError> {
    let mut sim = parked_sim(
        scene,
        SimSettings {
            seed,
            ..SimSettings::default()
        },
    )?;
    let truth0: Vec<ObjectState> = (0..sim.objects().len()).map(|i| sim.object_state(i)).collect();
    let names = sim.header().object_names.clone();
    if tracing::enabled!(tracing::Level::DEBUG) {
        for (i, o) in truth0.iter().enumerate() {
            let p = o.pose.translation.vector;
            tracing::debug!(
                "truth at the start: object {i} `{}` at ({:.3}, {:.3}, {:.3}), tilted {:.0}°",
                scene.resolved.get(i).map_or("?", |r| r.label.as_str()),
                p.x,
                p.y,
                p.z,
                (o.pose.rotation * Vec3::z()).z.clamp(-1.0, 1.0).acos().to_degrees()
            );
        }
    }
    let goal = GoalKind::of(task.library, task.library.schema(task.schema)?);
    let logger = Rc::new(RefCell::new(Shared {
        log,
        names,
        last_activity: String::new(),
        objects: truth0.clone(),
        watched: None,
        watch_hands: goal != GoalKind::Placed,
    }));
    let wall = std::time::Instant::now();
    let t_start = sim.time();
    let ws = workspace(scene);
    let calibration = match calibration {
        Some(c) => c,
        None => crate::calibrate::workcell_calibration(scene)?,
    };
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
    let mut judge = Judge {
        scene,
        schema: task.schema.to_string(),
        goal,
        skills: SkillMap::new(task.library),
        logger: logger.clone(),
        matched: vec![false; truth0.len()],
        truth0,
        labels: scene.resolved.iter().map(|r| r.label.clone()).collect(),
        table_z: scene.spec.table.height,
        current: (None, false),
        reports: Vec::new(),
    };
    {
        let mut plant = RobotPlant::new(&mut hw, &ws, calibration, task.library, &mut sink).map_err(from_robot)?;
        dexter::task::run_task(&mut plant, task, &mut judge).map_err(from_robot)?;
    }
    let mut reports = std::mem::take(&mut judge.reports);
    if task.only_near.is_none() {
        // Objects the robot never saw (the evaluator's view).
        for (i, m) in judge.matched.iter().enumerate() {
            if !m {
                let v = judge.truth0[i].pose.translation.vector;
                reports.push(ObjectReport::not_executed(
                    judge.labels[i].clone(),
                    None,
                    Verdict::Unseen,
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
    drop(judge);
    let sim_time = hw.sim().time() - t_start;
    let fault_record = hw.fault().map(|f| f.record().clone());
    drop(hw);
    drop(sink);
    let relevant = reports
        .iter()
        .filter(|r| matches!(r.decision, Verdict::Execute | Verdict::Skip))
        .count();
    let placed = reports.iter().filter(|r| r.success).count();
    Ok(ExecuteReport {
        scene: scene_name.to_string(),
        schema: task.schema.to_string(),
        objects: reports,
        placed,
        relevant,
        sim_time,
        wall_time: wall.elapsed().as_secs_f64(),
        mcap: None,
        fault: fault_record,
    })
}

/// An object slower than this (m/s) is at rest (the evaluator's judgement).
const AT_REST_SPEED: f64 = 0.02;
/// How long (s), after the executive finished, the evaluator waits at most for the object to
/// come to rest before judging where it is.
const JUDGE_REST_SECS: f64 = 3.0;

/// The phase an unsuccessful execution failed in: the first failed action of the executive, else
/// the outcome.
fn failure_cause(exec: &ExecReport, matched: bool, goal: GoalKind, skills: &SkillMap) -> String {
    if !matched {
        return "perception: the segment matches no object".into();
    }
    // The phase is the skill the action bound to (whatever the library calls it).
    let phase = |a: &str| skills.skill(a).map_or_else(|| a.to_string(), |s| s.phase().to_string());
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
        return goal.unmet().into();
    }
    match exec.steps.iter().rev().find_map(|s| match &s.outcome {
        schema::ActionOutcome::Failed(why) => Some((phase(&s.action), why.clone())),
        _ => None,
    }) {
        Some((p, why)) => format!("{p}: {why}"),
        None => "executive: no goal state reached".into(),
    }
}

//! Dexter as a [`schema::SchemaPlant`]: the executive's abstract actions bound to Dexter's arms,
//! hands and the objects it sees, run with the control-basis skills of [`crate::task`], observed
//! through the same monitors that watch a teacher (§4.2) — so the robot knows which state of the
//! schema it is in from its own sensors.
//!
//! | abstract action | what runs |
//! |---|---|
//! | `reach_object` | Reach ◁ Manipulability to the pre-grasp above the seen centroid, then down |
//! | `grasp` | close until opposing contacts and still fingers |
//! | `hold` | lift 10 cm and weigh |
//! | `place` | Reach ◁ Place: carry over the place, lower until the support force reference is met; for a transfer, onto the handoff spot and open |
//! | `release` | open and retreat |
//! | `search_track` | look at the object |

use control_basis::math::Vec3;
use schema::{ActionOutcome, Binding, Library, MonitorBank, MonitorConfig, Percept, SchemaPlant};

use crate::control::{HandControl, ReachControl};
use crate::error::SimError;
use crate::perception::Eyes;
use crate::physics::DexterSim;
use crate::scene::Scene;
use crate::snapshot::Arm;
use crate::task::{
    GraspPlan, Observer, approach_grasp, close_grasp, finger_arc, lift_and_weigh, lower_until_supported, park_pose,
    plan_top_grasp, reachable, release_and_retreat, run_until, transport_over,
};
use crate::watch::Watcher;

/// The handoff spot of a hand-to-hand transfer: a table region both arms reach.
pub const HANDOFF: &str = "handoff";

/// Smallest horizontal distance (m) from the handoff spot to another object's seen centroid: room
/// for the transferred object, the other object and the open fingers between them.
pub const HANDOFF_CLEARANCE: f64 = 0.16;

/// The other arm's palm within this horizontal distance (m) of an object to reach is moved away
/// first.
const CLEAR_RADIUS: f64 = 0.25;

/// Room (m) between a placed object and a place's walls: for the opening fingers, and so that a
/// rolling object is not let go on the wall.
const WALL_ROOM: f64 = 0.03;

/// Segments within this distance (m) of the transferred object's position are that object.
const MERGE_RADIUS: f64 = 0.05;

/// Arms whose palm can reach 15 cm above `point` pointing down (IK within limits).
pub fn arms_reaching(sim: &DexterSim, table_z: f64, point: &Vec3) -> Result<Vec<Arm>, SimError> {
    let mut out = Vec::new();
    for arm in Arm::BOTH {
        let mut over = park_pose(arm, table_z);
        over.translation.vector = Vec3::new(point.x, point.y, point.z.max(table_z) + 0.15);
        if reachable(sim, arm, &over, 5)? {
            out.push(arm);
        }
    }
    Ok(out)
}

/// The set predicates (4.17) over the monitors bound to `arms` (all when `None`).
fn bound_x(o: &schema::monitor::Observation, arms: Option<&[String]>) -> Vec<bool> {
    let Some(arms) = arms else {
        return o.x.clone();
    };
    let mut x = vec![false; o.x.len()];
    for h in &o.hits {
        if h.arm.as_ref().is_none_or(|a| arms.contains(a)) {
            x[h.action] = true;
        }
    }
    x
}

/// Receives what happens during an execution (for logs).
pub trait ExecSink {
    /// After every control tick.
    fn tick(&mut self, _sim: &DexterSim, _activity: &str) {}
    /// Every percept.
    fn percept(&mut self, _sim: &DexterSim, _eyes: &Eyes, _percept: &Percept) {}
}

/// Dexter driven by the executive.
pub struct SimPlant<'a> {
    /// The simulator.
    pub sim: &'a mut DexterSim,
    scene: &'a Scene,
    watcher: Watcher,
    bank: MonitorBank,
    last_x: Vec<bool>,
    reach: [ReachControl; 2],
    hand: [HandControl; 2],
    /// The physics object being manipulated, once a reach bound it.
    object: Option<usize>,
    plan: Option<GraspPlan>,
    /// The arms the procedural policy bound (None: all); see [`SimPlant::bind_arms`].
    bound_arms: Option<Vec<String>>,
    /// Height of the object when the last grasp converged.
    grasped_z: Option<f64>,
    handoff: [f64; 2],
    sink: &'a mut dyn ExecSink,
    t0: f64,
    next_percept: f64,
    percept_period: f64,
    /// Percepts made, for the record.
    pub percepts: Vec<Percept>,
    /// Arms used, in order.
    pub arms_used: Vec<Arm>,
}

impl std::fmt::Debug for SimPlant<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimPlant")
            .field("object", &self.object)
            .finish_non_exhaustive()
    }
}

fn arm_index(arm: Arm) -> usize {
    match arm {
        Arm::Left => 0,
        Arm::Right => 1,
    }
}

fn parse_arm(s: Option<&str>) -> Result<Arm, SimError> {
    match s {
        Some("left") => Ok(Arm::Left),
        Some("right") => Ok(Arm::Right),
        other => Err(SimError::Task(format!("binding without a known arm: {other:?}"))),
    }
}

impl<'a> SimPlant<'a> {
    /// A plant on `sim` (parked, settled) in `scene`, observing with `library`'s monitors.
    pub fn new(
        sim: &'a mut DexterSim,
        scene: &'a Scene,
        library: &Library,
        seed: u64,
        sink: &'a mut dyn ExecSink,
    ) -> Result<SimPlant<'a>, SimError> {
        let watcher = Watcher::new(sim, scene, seed)?;
        let reach = [ReachControl::new(sim, Arm::Left)?, ReachControl::new(sim, Arm::Right)?];
        let hand = [HandControl::new(sim, Arm::Left)?, HandControl::new(sim, Arm::Right)?];
        let t0 = sim.time();
        let mut p = SimPlant {
            sim,
            scene,
            watcher,
            bank: MonitorBank::new(library, MonitorConfig::default()),
            last_x: vec![false; library.actions.len()],
            reach,
            hand,
            object: None,
            plan: None,
            grasped_z: None,
            bound_arms: None,
            handoff: [scene.spec.table.center[0].min(0.55), 0.0],
            sink,
            t0,
            next_percept: 0.0,
            percept_period: 0.1,
            percepts: Vec::new(),
            arms_used: Vec::new(),
        };
        p.percept_now()?;
        Ok(p)
    }

    /// Observe only the monitors bound to `arms` (and those of no arm, e.g. the head's): the
    /// executive estimates the state of *this* instance of the schema from the controllers ψ bound
    /// (§3.3.1: convergence is a property of a controller with its procedural resources), so a hand
    /// still holding something from an earlier task does not pass for this task's grasp.
    pub fn bind_arms(&mut self, arms: &[Arm]) {
        self.bound_arms = Some(arms.iter().map(|a| a.prefix().to_string()).collect());
        if let Some(p) = self.percepts.last() {
            // Recompute from the monitors' last view.
            let p = p.clone();
            let o = self.bank.observe(&p);
            self.last_x = bound_x(&o, self.bound_arms.as_deref());
        }
    }

    /// Where in a place region (centre, size) to put an object of horizontal radius `radius`: the
    /// point of a 1 cm grid inside the region (the object clear of the walls by [`WALL_ROOM`]) farthest from
    /// the objects seen in it, nearest the centre among equals — so objects already in a bin are
    /// not landed on. Segments near `carrying_palm` are the carried object itself.
    fn free_spot(&self, center: [f64; 2], size: [f64; 2], radius: f64, carrying_palm: Option<[f64; 3]>) -> [f64; 2] {
        let half = [size[0] / 2.0 - radius - WALL_ROOM, size[1] / 2.0 - radius - WALL_ROOM];
        if half[0] <= 0.0 || half[1] <= 0.0 {
            return center;
        }
        let inside: Vec<[f64; 2]> = self
            .percepts
            .last()
            .map(|p| {
                p.segments
                    .iter()
                    .filter(|s| {
                        (s.centroid[0] - center[0]).abs() <= size[0] / 2.0 + 0.05
                            && (s.centroid[1] - center[1]).abs() <= size[1] / 2.0 + 0.05
                            && carrying_palm.is_none_or(|h| {
                                (0..3).map(|i| (s.centroid[i] - h[i]).powi(2)).sum::<f64>().sqrt() > 0.15
                            })
                    })
                    .map(|s| [s.centroid[0], s.centroid[1]])
                    .collect()
            })
            .unwrap_or_default();
        if inside.is_empty() {
            return center;
        }
        let n = [(half[0] / 0.01).floor() as i32, (half[1] / 0.01).floor() as i32];
        let mut best = (f64::NEG_INFINITY, f64::INFINITY, center);
        for i in -n[0]..=n[0] {
            for j in -n[1]..=n[1] {
                let c = [center[0] + 0.01 * f64::from(i), center[1] + 0.01 * f64::from(j)];
                let clear = inside
                    .iter()
                    .map(|o| (o[0] - c[0]).hypot(o[1] - c[1]))
                    .fold(f64::INFINITY, f64::min);
                let off = (c[0] - center[0]).hypot(c[1] - center[1]);
                // Clearance counts to the nearest centimetre; then the centre wins.
                let clear = (clear * 100.0).round();
                if (clear, -off) > (best.0, -best.1) {
                    best = (clear, off, c);
                }
            }
        }
        best.2
    }

    /// The handoff spot (x, y).
    pub fn handoff(&self) -> [f64; 2] {
        self.handoff
    }

    /// Chooses the handoff spot for a transfer of the object seen near `object_at` (5.32): a free
    /// patch of table that both arms reach pointing down, as seen now — at least
    /// [`HANDOFF_CLEARANCE`] from every other segment the cameras see and clear of the places'
    /// walls — preferring the table's centre line at a comfortable reach (x = 0.55 m). Candidates
    /// lie on a 5 cm grid; the first free one both arms reach is taken. Keeps the previous spot and
    /// returns `None` if none is free.
    pub fn plan_handoff(&mut self, object_at: &Vec3) -> Result<Option<[f64; 2]>, SimError> {
        let table = &self.scene.spec.table;
        let table_z = table.height;
        let others: Vec<[f64; 2]> = self
            .percepts
            .last()
            .map(|p| {
                p.segments
                    .iter()
                    .filter(|s| (s.centroid[0] - object_at.x).hypot(s.centroid[1] - object_at.y) > MERGE_RADIUS)
                    .map(|s| [s.centroid[0], s.centroid[1]])
                    .collect()
            })
            .unwrap_or_default();
        let margin = 0.12;
        let (x0, x1) = (
            table.center[0] - table.size[0] / 2.0 + margin,
            table.center[0] + table.size[0] / 2.0 - margin,
        );
        let mut candidates = Vec::new();
        for i in 0..=((x1 - x0) / 0.05).floor() as i32 {
            for j in -4..=4 {
                let c = [x0 + 0.05 * f64::from(i), table.center[1] + 0.05 * f64::from(j)];
                let free = others
                    .iter()
                    .all(|o| (o[0] - c[0]).hypot(o[1] - c[1]) >= HANDOFF_CLEARANCE)
                    && self.scene.spec.places.iter().all(|p| {
                        (c[0] - p.center[0]).abs() > p.size[0] / 2.0 + p.wall_thickness + 0.08
                            || (c[1] - p.center[1]).abs() > p.size[1] / 2.0 + p.wall_thickness + 0.08
                    });
                if free {
                    candidates.push(c);
                }
            }
        }
        let cost = |c: &[f64; 2]| (c[1] - table.center[1]).abs() + 0.5 * (c[0] - 0.55).abs();
        candidates.sort_by(|a, b| cost(a).total_cmp(&cost(b)));
        for c in candidates {
            if arms_reaching(self.sim, table_z, &Vec3::new(c[0], c[1], table_z))?.len() == 2 {
                self.handoff = c;
                return Ok(Some(c));
            }
        }
        Ok(None)
    }

    /// The latest percept.
    pub fn last_percept(&self) -> Option<&Percept> {
        self.percepts.last()
    }

    fn percept_now(&mut self) -> Result<(), SimError> {
        let t = self.sim.time() - self.t0;
        // The handoff spot is where ψ puts objects, not a place of the task: no monitor watches it.
        let p = self.watcher.percept(self.sim, t)?;
        let o = self.bank.observe(&p);
        self.last_x = bound_x(&o, self.bound_arms.as_deref());
        self.sink.percept(self.sim, self.watcher.eyes(), &p);
        self.percepts.push(p);
        self.next_percept = t + self.percept_period;
        Ok(())
    }

    /// Runs the simulator for `seconds` with no new references, observing.
    fn settle(&mut self, seconds: f64) -> Result<(), SimError> {
        let steps = (seconds / self.sim.settings().dt).round() as usize;
        for _ in 0..steps {
            self.sim.step();
            if self.sim.time() - self.t0 + 1e-9 >= self.next_percept {
                self.percept_now()?;
            }
        }
        Ok(())
    }

    /// Runs a skill with an observer that feeds the monitors at the percept rate.
    fn with_observer<R>(
        &mut self,
        f: impl FnOnce(&mut DexterSim, &mut [ReachControl; 2], &[HandControl; 2], &mut Observer<'_>) -> R,
    ) -> Result<R, SimError> {
        let mut error: Option<SimError> = None;
        let t0 = self.t0;
        let period = self.percept_period;
        let watcher = &mut self.watcher;
        let bank = &mut self.bank;
        let last_x = &mut self.last_x;
        let percepts = &mut self.percepts;
        let next = &mut self.next_percept;
        let sink = &mut *self.sink;
        let bound_arms = self.bound_arms.clone();
        let mut callback = |s: &DexterSim, activity: &str| {
            sink.tick(s, activity);
            let t = s.time() - t0;
            if t + 1e-9 >= *next && error.is_none() {
                match watcher.percept(s, t) {
                    Ok(p) => {
                        let o = bank.observe(&p);
                        *last_x = bound_x(&o, bound_arms.as_deref());
                        sink.percept(s, watcher.eyes(), &p);
                        percepts.push(p);
                    }
                    Err(e) => error = Some(e),
                }
                *next = t + period;
            }
        };
        let r = f(self.sim, &mut self.reach, &self.hand, &mut Observer::new(&mut callback));
        match error {
            Some(e) => Err(e),
            None => Ok(r),
        }
    }

    /// The physics object nearest to the segment `id` (by its last seen centroid), or to `point`.
    fn resolve_object(&self, binding: &Binding) -> Result<usize, SimError> {
        let id: Option<u32> = binding.object.as_deref().and_then(|s| s.parse().ok());
        let seen = self
            .percepts
            .last()
            .and_then(|p| p.segments.iter().find(|s| Some(s.id) == id))
            .map(|s| Vec3::new(s.centroid[0], s.centroid[1], s.centroid[2]));
        let target = match (seen, self.object) {
            (Some(c), _) => c,
            (None, Some(o)) => return Ok(o),
            (None, None) => {
                // A scene label.
                if let Some(name) = &binding.object {
                    return self.sim.object(name);
                }
                return Err(SimError::Task("reach_object without an object".into()));
            }
        };
        (0..self.sim.objects().len())
            .min_by(|&a, &b| {
                let da = (self.sim.object_state(a).pose.translation.vector - target).norm();
                let db = (self.sim.object_state(b).pose.translation.vector - target).norm();
                da.total_cmp(&db)
            })
            .ok_or_else(|| SimError::Task("no objects".into()))
    }
}

impl SchemaPlant for SimPlant<'_> {
    type Error = SimError;

    fn observe(&mut self) -> Result<Vec<bool>, SimError> {
        Ok(self.last_x.clone())
    }

    fn run(&mut self, action: &str, binding: &Binding) -> Result<ActionOutcome, SimError> {
        let table_z = self.scene.spec.table.height;
        let outcome = match action {
            "search_track" => ActionOutcome::Converged,
            "reach_object" => {
                let arm = parse_arm(binding.arm.as_deref())?;
                self.arms_used.push(arm);
                let obj = match self.object {
                    Some(o) if binding.object.is_none() => o,
                    _ => self.resolve_object(binding)?,
                };
                self.object = Some(obj);
                let shape = self.scene.catalog.objects[self.sim.objects()[obj].catalog_index]
                    .shape
                    .clone();
                // The grasp is planned at the seen centroid (x, y) with the object's model.
                let mut pose = self.sim.object_state(obj).pose;
                if let Some(seg) = self.percepts.last().and_then(|p| {
                    p.segments
                        .iter()
                        .filter(|s| s.seen)
                        .min_by(|a, b| {
                            let d = |s: &schema::SegmentPercept| {
                                (s.centroid[0] - pose.translation.x).hypot(s.centroid[1] - pose.translation.y)
                            };
                            d(a).total_cmp(&d(b))
                        })
                        .cloned()
                }) && (seg.centroid[0] - pose.translation.x).hypot(seg.centroid[1] - pose.translation.y) < 0.03
                {
                    pose.translation.vector.x = seg.centroid[0];
                    pose.translation.vector.y = seg.centroid[1];
                }
                let target = pose.translation.vector;
                let k = arm_index(arm);
                // The other arm, if it hovers near the object (it just let go of it at the handoff),
                // is in this arm's way and in the head's view: back to its parked pose first.
                let other = 1 - k;
                let other_palm = self.reach[other].tool_pose(self.sim).translation.vector;
                if (other_palm.x - target.x).hypot(other_palm.y - target.y) < CLEAR_RADIUS {
                    let park = park_pose(Arm::BOTH[other], table_z);
                    self.with_observer(|sim, reach, _, obs| {
                        reach[other].set_goal(sim, park);
                        run_until(sim, &mut reach[other], obs, 3.0, |s, r| r.at_goal(s, 0.02, 0.1));
                    })?;
                }
                self.watcher.look_at(self.sim, &target)?;
                let arc = finger_arc(self.sim, arm)?;
                let current = self.reach[k].tool_pose(self.sim);
                let plan = plan_top_grasp(&arc, &shape, &pose, table_z, &current);
                let r = self.with_observer(|sim, reach, hand, obs| {
                    approach_grasp(sim, &mut reach[k], &hand[k], &plan, obs, &mut |_, _| {})
                })?;
                match r {
                    Ok(p) => {
                        self.plan = Some(p);
                        ActionOutcome::Converged
                    }
                    Err(why) => ActionOutcome::Failed(why),
                }
            }
            "grasp" => {
                let arm = parse_arm(binding.arm.as_deref())?;
                let k = arm_index(arm);
                match self.object {
                    None => ActionOutcome::Failed("no object to grasp (no reach yet)".into()),
                    Some(obj) => {
                        let r = self.with_observer(|sim, reach, hand, obs| {
                            close_grasp(sim, &mut reach[k], &hand[k], obj, obs)
                        })?;
                        match r {
                            Ok(_) => {
                                self.grasped_z = Some(self.sim.object_state(obj).pose.translation.z);
                                ActionOutcome::Converged
                            }
                            Err(why) => ActionOutcome::Failed(why),
                        }
                    }
                }
            }
            "hold" => {
                let arm = parse_arm(binding.arm.as_deref())?;
                let k = arm_index(arm);
                let (Some(obj), Some(plan)) = (self.object, self.plan) else {
                    return Ok(ActionOutcome::Failed("nothing grasped to hold (no reach yet)".into()));
                };
                let g = self.with_observer(|sim, reach, _, obs| lift_and_weigh(sim, &mut reach[k], obj, &plan, obs))?;
                // A hold asked for again while the object is already up (the monitors had not yet
                // seen the first one converge) rises no further: judge it from where it was grasped.
                let (_, _, parts) = self.sim.hand_wrench_on_object(arm, obj);
                let already_up = self
                    .grasped_z
                    .is_some_and(|z0| self.sim.object_state(obj).pose.translation.z - z0 > 0.08);
                if g.lifted || (already_up && parts >= 2) {
                    ActionOutcome::Converged
                } else {
                    // Let go of whatever is left so that a re-grasp starts from an open hand.
                    self.with_observer(|sim, reach, hand, obs| release_and_retreat(sim, &mut reach[k], &hand[k], obs))?;
                    ActionOutcome::Failed(g.outcome)
                }
            }
            "place" => {
                let arm = parse_arm(binding.arm.as_deref())?;
                let k = arm_index(arm);
                let Some(obj) = self.object else {
                    return Ok(ActionOutcome::Failed("nothing grasped to place (no reach yet)".into()));
                };
                let shape = self.scene.catalog.objects[self.sim.objects()[obj].catalog_index]
                    .shape
                    .clone();
                let (target, wall) = if binding.transfer {
                    (self.handoff, 0.0)
                } else {
                    let name = binding
                        .place
                        .as_deref()
                        .ok_or_else(|| SimError::Task("place without a place".into()))?;
                    let p = self.scene.place(name)?;
                    let palm = self.percepts.last().map(|q| q.hands[k].palm);
                    let r = (0..8)
                        .map(|i| {
                            let a = std::f64::consts::PI * f64::from(i) / 8.0;
                            let d = Vec3::new(a.cos(), a.sin(), 0.0);
                            let rot = self.sim.object_state(obj).pose.rotation;
                            crate::geometry::support_half_extent(&shape, &(rot.inverse() * d))
                        })
                        .fold(0.0, f64::max);
                    (self.free_spot(p.center, p.size, r, palm), p.wall_height)
                };
                self.watcher
                    .look_at(self.sim, &Vec3::new(target[0], target[1], table_z + 0.05))?;
                let transfer = binding.transfer;
                let r = self.with_observer(|sim, reach, hand, obs| {
                    transport_over(sim, &mut reach[k], obj, &shape, target, table_z, wall, obs)?;
                    lower_until_supported(sim, &mut reach[k], obj, &shape, table_z, obs);
                    if transfer {
                        // The transfer ends with the hand open: the other hand takes it from here.
                        release_and_retreat(sim, &mut reach[k], &hand[k], obs);
                    }
                    Ok::<(), String>(())
                })?;
                match r {
                    Ok(()) => ActionOutcome::Converged,
                    Err(why) => ActionOutcome::Failed(why),
                }
            }
            "release" => {
                let arm = parse_arm(binding.arm.as_deref())?;
                let k = arm_index(arm);
                self.with_observer(|sim, reach, hand, obs| release_and_retreat(sim, &mut reach[k], &hand[k], obs))?;
                // An object wedged between the half-opened fingers came up with the hand: open
                // fully, let it drop, and retreat again.
                if let Some(obj) = self.object
                    && self.sim.hand_wrench_on_object(arm, obj).2 > 0
                {
                    self.with_observer(|sim, reach, hand, obs| {
                        hand[k].set(sim, 0.0, 0.0);
                        run_until(sim, &mut reach[k], obs, 0.6, |_, _| false);
                        release_and_retreat(sim, &mut reach[k], &hand[k], obs);
                    })?;
                }
                if self
                    .object
                    .is_some_and(|obj| self.sim.hand_wrench_on_object(arm, obj).2 > 0)
                {
                    ActionOutcome::Failed("the object stays in the hand after opening".into())
                } else {
                    ActionOutcome::Converged
                }
            }
            other => ActionOutcome::Failed(format!("Dexter has no controller for `{other}`")),
        };
        // Let the monitors see the result.
        self.settle(0.3)?;
        if std::env::var_os("PBD_DEBUG_EXEC").is_some()
            && let Some(p) = self.percepts.last()
        {
            eprintln!("after {action}: x = {:?}", self.last_x);
            for h in &p.hands {
                eprintln!("  hand {} palm {:?} speed {:.3}", h.arm, h.palm, h.palm_speed);
            }
            for sg in &p.segments {
                eprintln!("  segment {} at {:?} seen {}", sg.id, sg.centroid, sg.seen);
            }
        }
        Ok(outcome)
    }
}

/// ψ for Pick-And-Place on Dexter (5.31–5.32): the arm whose workspace holds both the object and the
/// place; if none does, a transfer — the arm that reaches the object puts it on the handoff spot,
/// and the arm that reaches the place takes it from there.
#[derive(Debug, Clone)]
pub struct PickPlacePolicy {
    /// The object (segment id as text, or a scene label).
    pub object: String,
    /// The place.
    pub place: String,
    /// The arm that picks first.
    pub pick_arm: Arm,
    /// The arm that places (differs from `pick_arm` for a transfer).
    pub place_arm: Arm,
    transferred: bool,
}

impl PickPlacePolicy {
    /// Decides the arms for `object` at `object_at` and `place`: one arm if one reaches both, else a
    /// transfer. `None` if no arm reaches the object or none reaches the place.
    pub fn decide(
        sim: &DexterSim,
        scene: &Scene,
        object: &str,
        object_at: &Vec3,
        place: &str,
        handoff: [f64; 2],
    ) -> Result<Option<PickPlacePolicy>, SimError> {
        let table_z = scene.spec.table.height;
        let p = scene.place(place)?;
        let at_object = arms_reaching(sim, table_z, object_at)?;
        let at_place = arms_reaching(
            sim,
            table_z,
            &Vec3::new(p.center[0], p.center[1], table_z + p.wall_height),
        )?;
        let both: Vec<Arm> = at_object.iter().copied().filter(|a| at_place.contains(a)).collect();
        // Prefer the arm on the object's side.
        let side = if object_at.y >= 0.0 { Arm::Left } else { Arm::Right };
        let pick = |v: &[Arm]| v.iter().copied().find(|&a| a == side).or_else(|| v.first().copied());
        if let Some(arm) = pick(&both) {
            return Ok(Some(PickPlacePolicy {
                object: object.into(),
                place: place.into(),
                pick_arm: arm,
                place_arm: arm,
                transferred: false,
            }));
        }
        let hand_spot = Vec3::new(handoff[0], handoff[1], table_z);
        let at_handoff = arms_reaching(sim, table_z, &hand_spot)?;
        let a = at_object.iter().copied().find(|a| at_handoff.contains(a));
        let b = at_place.iter().copied().find(|b| at_handoff.contains(b));
        Ok(match (a, b) {
            (Some(a), Some(b)) => Some(PickPlacePolicy {
                object: object.into(),
                place: place.into(),
                pick_arm: a,
                place_arm: b,
                transferred: false,
            }),
            _ => None,
        })
    }

    /// Whether this assignment needs a transfer.
    pub fn is_transfer(&self) -> bool {
        self.pick_arm != self.place_arm
    }
}

impl schema::ProceduralPolicy for PickPlacePolicy {
    fn bind(&mut self, _schema: &schema::Schema, state: &str, action: &str) -> Binding {
        if state == "transfer_placed" {
            self.transferred = true;
        }
        let arm = if self.transferred {
            self.place_arm
        } else {
            self.pick_arm
        };
        let transfer = action == "place" && self.is_transfer() && !self.transferred;
        Binding {
            arm: Some(arm.prefix().to_string()),
            object: Some(self.object.clone()),
            place: Some(if transfer {
                HANDOFF.to_string()
            } else {
                self.place.clone()
            }),
            transfer,
        }
    }
}

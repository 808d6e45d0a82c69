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
    plan_top_grasp, reachable, release_and_retreat, transport_over,
};
use crate::watch::Watcher;

/// The handoff spot of a hand-to-hand transfer: a table region both arms reach.
pub const HANDOFF: &str = "handoff";

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

    /// The handoff spot (x, y).
    pub fn handoff(&self) -> [f64; 2] {
        self.handoff
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
        self.last_x = o.x;
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
        let mut callback = |s: &DexterSim, activity: &str| {
            sink.tick(s, activity);
            let t = s.time() - t0;
            if t + 1e-9 >= *next && error.is_none() {
                match watcher.percept(s, t) {
                    Ok(p) => {
                        let o = bank.observe(&p);
                        *last_x = o.x;
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
                self.watcher.look_at(self.sim, &target)?;
                let arc = finger_arc(self.sim, arm)?;
                let k = arm_index(arm);
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
                            Ok(_) => ActionOutcome::Converged,
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
                if g.lifted {
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
                    (p.center, p.wall_height)
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
                ActionOutcome::Converged
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

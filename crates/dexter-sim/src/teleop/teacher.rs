//! The scripted, human-like teacher: it sees the world (true object poses), plans a demonstration
//! as steps (hover, descend, close, lift, carry, lower, open, retreat …) and streams glove-rate hand
//! commands of smooth, noisy, trembling human motion.

use control_basis::math::{Iso3, Rot3, Vec3};
use nalgebra::Translation3;
use serde::{Deserialize, Serialize};

use super::stream::{HandCommand, TeleopStream};
use crate::error::SimError;
use crate::geometry;
use crate::physics::DexterSim;
use crate::pick_place::plan_top_grasp_shape as plan_top_grasp;
use crate::scene::Scene;
use crate::snapshot::Arm;
use bayes::rng::{Draw, Generator};
use dexter::control::{FLEX_CLOSED, top_down_orientation};
use dexter::skills::{GraspPlan, park_pose};

fn finger_arc(sim: &DexterSim, arm: Arm) -> Result<Vec<(f64, f64, f64)>, SimError> {
    dexter::skills::finger_arc(sim.model(), arm).map_err(crate::error::from_robot)
}

/// A task for the scripted teacher.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum TeachTask {
    /// Pick `object` and place it in `place` with `arm`; `retry`: the first grasp closes too early and
    /// is retried.
    PickPlace {
        /// Object (scene label).
        object: String,
        /// Place name.
        place: String,
        /// Arm.
        arm: Arm,
        /// Fail the first grasp and retry.
        retry: bool,
    },
    /// Pick `object` with `arm`, put it down on the table at `handoff`, and let the other arm take it
    /// from there and place it in `place` (a hand-to-hand pass; a schema a user writes).
    PassPlace {
        /// Object (scene label).
        object: String,
        /// Place name.
        place: String,
        /// The arm that picks; the other one places.
        arm: Arm,
        /// Where on the table (x, y in m) the object is put down between the hands.
        handoff: [f64; 2],
    },
    /// Pick `object` up and hold it in the air (rival schema).
    PickHold {
        /// Object.
        object: String,
        /// Arm.
        arm: Arm,
    },
    /// Pick `object` up and give it to the teacher, who takes it from the open hand (rival schema).
    HandOver {
        /// Object.
        object: String,
        /// Arm.
        arm: Arm,
    },
    /// Reach to `object` and touch its top with open fingers (rival schema).
    Touch {
        /// Object.
        object: String,
        /// Arm.
        arm: Arm,
    },
    /// Move the hands about above the table without touching anything (explained by no schema).
    Wander {
        /// Arm.
        arm: Arm,
        /// Duration (s).
        seconds: f64,
    },
}

/// A smooth move of one hand: minimum-jerk from `from` to `to` over `duration`, then hold.
#[derive(Debug, Clone, Copy)]
struct Move {
    start: f64,
    duration: f64,
    from: Iso3,
    to: Iso3,
    flex_from: f64,
    flex_to: f64,
}

impl Move {
    fn at(&self, t: f64) -> (Iso3, f64) {
        let tau = ((t - self.start) / self.duration).clamp(0.0, 1.0);
        let s = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau);
        let p = self.from.translation.vector.lerp(&self.to.translation.vector, s);
        let r = self.from.rotation.slerp(&self.to.rotation, s);
        (
            Iso3::from_parts(Translation3::from(p), r),
            self.flex_from + (self.flex_to - self.flex_from) * s,
        )
    }

    fn end(&self) -> f64 {
        self.start + self.duration
    }
}

/// The horizontal radius (m) of object `i` as it is posed now: the larger of its half extents along
/// the world's x and y.
fn footprint_radius(sim: &DexterSim, scene: &Scene, i: usize) -> f64 {
    let pose = sim.object_state(i).pose;
    let shape = &scene.catalog.objects[sim.objects()[i].catalog_index].shape;
    let along = |d: Vec3| geometry::support_half_extent(shape, &(pose.rotation.inverse() * d));
    along(Vec3::x()).max(along(Vec3::y()))
}

/// Where in place `place` the scripted teacher puts object `carried` down: the point of a 9 × 9 grid
/// over the place's floor (kept clear of the walls by the object's radius + 1.5 cm) farthest from the
/// objects already in the place (their edges), nearest the centre among equals. The centre when the
/// place is empty. (The teacher is the world: it sees the objects' true poses.)
fn free_spot(sim: &DexterSim, scene: &Scene, place: usize, carried: usize) -> [f64; 2] {
    let spec = &scene.spec.places[place];
    let r = footprint_radius(sim, scene, carried);
    let [cx, cy] = spec.center;
    let [sx, sy] = spec.size;
    let inside = |x: f64, y: f64| (x - cx).abs() <= 0.5 * sx && (y - cy).abs() <= 0.5 * sy;
    let others: Vec<([f64; 2], f64)> = (0..sim.objects().len())
        .filter(|&j| j != carried)
        .filter_map(|j| {
            let p = sim.object_state(j).pose.translation.vector;
            inside(p.x, p.y).then(|| ([p.x, p.y], footprint_radius(sim, scene, j)))
        })
        .collect();
    if others.is_empty() {
        return spec.center;
    }
    let half = |s: f64| (0.5 * s - r - 0.015).max(0.0);
    let (hx, hy) = (half(sx), half(sy));
    let mut best = (f64::NEG_INFINITY, spec.center);
    for i in 0..9 {
        for j in 0..9 {
            let x = cx + hx * (i as f64 / 4.0 - 1.0);
            let y = cy + hy * (j as f64 / 4.0 - 1.0);
            let clear = others
                .iter()
                .map(|(q, rq)| (x - q[0]).hypot(y - q[1]) - rq)
                .fold(f64::INFINITY, f64::min);
            let score = clear - 1e-3 * (x - cx).hypot(y - cy);
            if score > best.0 {
                best = (score, [x, y]);
            }
        }
    }
    best.1
}

/// Steps of the teacher's plan; each is turned into moves when it starts, from what the teacher sees
/// then (a human looks at the scene; the teacher reads true object poses, the robot does not).
#[derive(Debug, Clone, PartialEq)]
enum Step {
    Pause(f64),
    Hover { object: usize },
    Descend { object: usize, early: bool },
    Close,
    Lift { rise: f64 },
    CheckHeld { object: usize },
    OverPlace { place: usize, object: usize },
    OverSpot { xy: [f64; 2] },
    Lower { place: usize, object: usize },
    Open,
    Retreat { rise: f64 },
    TakeAway { object: usize },
    Park,
    TouchTop { object: usize },
    TouchDown { to: Iso3 },
    SwitchArm(Arm),
    WanderTo { target: Vec3 },
    Reopen,
}

/// The scripted, human-like teacher: glove-rate samples (30 Hz) of smooth minimum-jerk hand motions
/// with sensor noise (1 mm, 0.01 rad), physiological tremor (8–12 Hz, ≈1.5 mm), hesitations before
/// moves, and — when asked — a failed grasp that is retried. Deterministic for a seed.
#[derive(Debug)]
pub struct Teacher {
    arm: Arm,
    steps: Vec<Step>,
    index: usize,
    current: Option<Move>,
    pose: Iso3,
    flex: f64,
    rng: Generator,
    tremor: [(f64, f64, f64); 3],
    glove_period: f64,
    next_sample: f64,
    held: [Option<HandCommand>; 2],
    /// Grasp plan of the current object.
    plan: Option<GraspPlan>,
    /// Object carried: palm-to-object-bottom height (m).
    carry_depth: f64,
    table_z: f64,
    done: bool,
    /// Teleop samples emitted so far.
    pub log: TeleopStream,
    /// Notes on what happened (retries, failures).
    pub notes: Vec<String>,
    /// Objects the teacher took out of the robot's hand (hand-over).
    pub taken: Vec<usize>,
}

const GLOVE_HZ: f64 = 30.0;

impl Teacher {
    /// A teacher for `task` in `scene` on `sim` (already parked), seeded.
    pub fn new(sim: &DexterSim, scene: &Scene, task: &TeachTask, seed: u64) -> Result<Teacher, SimError> {
        Self::with_tasks(sim, scene, std::slice::from_ref(task), seed)
    }

    /// A teacher that does `tasks` one after the other (a sorting demo), each with its own arm; the
    /// teacher parks one hand before using the other.
    pub fn with_tasks(sim: &DexterSim, scene: &Scene, tasks: &[TeachTask], seed: u64) -> Result<Teacher, SimError> {
        let mut rng = bayes::rng::seeded(seed ^ 0x7e4c_11e5);
        let table_z = scene.spec.table.height;
        let mut steps = Vec::new();
        let mut first_arm = None;
        let mut last_arm: Option<Arm> = None;
        for task in tasks {
            let arm = match task {
                TeachTask::PickPlace { arm, .. }
                | TeachTask::PassPlace { arm, .. }
                | TeachTask::PickHold { arm, .. }
                | TeachTask::HandOver { arm, .. }
                | TeachTask::Touch { arm, .. }
                | TeachTask::Wander { arm, .. } => *arm,
            };
            if last_arm.is_some_and(|a| a != arm) {
                steps.push(Step::SwitchArm(arm));
            }
            first_arm = first_arm.or(Some(arm));
            last_arm = Some(arm);
            let hesitate = |rng: &mut Generator| Step::Pause(0.2 + 0.6 * rng.uniform());
            match task {
                TeachTask::PickPlace {
                    object, place, retry, ..
                } => {
                    let o = sim.object(object)?;
                    let p = place_index(scene, place)?;
                    steps.push(hesitate(&mut rng));
                    steps.push(Step::Hover { object: o });
                    if *retry {
                        steps.push(Step::Descend { object: o, early: true });
                        steps.push(Step::Close);
                        steps.push(Step::Lift { rise: 0.06 });
                        steps.push(Step::Pause(0.4));
                        steps.push(Step::Reopen);
                        steps.push(hesitate(&mut rng));
                        steps.push(Step::Hover { object: o });
                    }
                    steps.extend(grasp_and_lift(o));
                    steps.push(Step::OverPlace { place: p, object: o });
                    steps.push(Step::Pause(0.3));
                    steps.push(Step::Lower { place: p, object: o });
                    steps.extend(let_go_and_retreat());
                }
                TeachTask::PassPlace {
                    object, place, handoff, ..
                } => {
                    let o = sim.object(object)?;
                    let p = place_index(scene, place)?;
                    let carry = |steps: &mut Vec<Step>, rng: &mut Generator| {
                        steps.push(hesitate(rng));
                        steps.push(Step::Hover { object: o });
                        steps.extend(grasp_and_lift(o));
                    };
                    // The first hand puts it down between the hands and goes back to its park pose.
                    carry(&mut steps, &mut rng);
                    steps.push(Step::OverSpot { xy: *handoff });
                    steps.push(Step::Pause(0.3));
                    steps.push(Step::Lower { place: p, object: o });
                    steps.extend(let_go_and_retreat());
                    steps.push(Step::Park);
                    steps.push(Step::Pause(0.8));
                    // The other hand takes it from there to the place.
                    steps.push(Step::SwitchArm(arm.other()));
                    carry(&mut steps, &mut rng);
                    steps.push(Step::OverPlace { place: p, object: o });
                    steps.push(Step::Pause(0.3));
                    steps.push(Step::Lower { place: p, object: o });
                    steps.extend(let_go_and_retreat());
                    last_arm = Some(arm.other());
                }
                TeachTask::PickHold { object, .. } => {
                    let o = sim.object(object)?;
                    steps.push(hesitate(&mut rng));
                    steps.extend(pick_up(o, 0.15));
                    steps.push(Step::Pause(2.5));
                }
                TeachTask::HandOver { object, .. } => {
                    let o = sim.object(object)?;
                    steps.push(hesitate(&mut rng));
                    steps.extend(pick_up(o, 0.15));
                    steps.push(Step::Pause(0.8));
                    steps.push(Step::Open);
                    steps.push(Step::TakeAway { object: o });
                    steps.push(Step::Pause(0.5));
                    steps.push(Step::Retreat { rise: 0.10 });
                }
                TeachTask::Touch { object, .. } => {
                    let o = sim.object(object)?;
                    steps.push(hesitate(&mut rng));
                    steps.push(Step::Hover { object: o });
                    steps.push(Step::TouchTop { object: o });
                    steps.push(Step::Pause(0.8));
                    steps.push(Step::Retreat { rise: 0.12 });
                }
                TeachTask::Wander { seconds, .. } => {
                    let s = if arm == Arm::Left { 1.0 } else { -1.0 };
                    let mut t = 0.0;
                    while t < *seconds {
                        // Free space well above anything on the table.
                        let target = Vec3::new(
                            0.35 + 0.25 * rng.uniform(),
                            s * (0.05 + 0.35 * rng.uniform()),
                            table_z + 0.30 + 0.15 * rng.uniform(),
                        );
                        steps.push(Step::WanderTo { target });
                        let pause = 0.3 + 0.8 * rng.uniform();
                        steps.push(Step::Pause(pause));
                        t += 1.8 + pause;
                    }
                }
            }
            if !matches!(task, TeachTask::PickHold { .. }) {
                steps.push(Step::Park);
                steps.push(Step::Pause(0.8));
            }
        }
        let arm = first_arm.ok_or_else(|| SimError::Invalid {
            path: "<teacher>".into(),
            field: "tasks".into(),
            message: "no task for the teacher".into(),
        })?;
        let tremor = std::array::from_fn(|_| {
            (
                8.0 + 4.0 * rng.uniform(),
                std::f64::consts::TAU * rng.uniform(),
                0.0015 * (0.5 + rng.uniform()),
            )
        });
        let pose = park_pose(arm, table_z);
        Ok(Teacher {
            arm,
            steps,
            index: 0,
            current: None,
            pose,
            flex: 0.3,
            rng,
            tremor,
            glove_period: 1.0 / GLOVE_HZ,
            next_sample: 0.0,
            held: [None, None],
            plan: None,
            carry_depth: 0.1,
            table_z,
            done: false,
            log: TeleopStream::default(),
            notes: Vec::new(),
            taken: Vec::new(),
        })
    }

    /// The arm the teacher uses now.
    pub fn arm(&self) -> Arm {
        self.arm
    }

    /// Whether the script has finished.
    pub fn finished(&self) -> bool {
        self.done
    }

    /// The glove's output at time `t` (s): the latest sample, refreshed at 30 Hz. The teacher watches
    /// `sim` to decide (a human sees the scene).
    pub fn command(
        &mut self,
        sim: &mut DexterSim,
        scene: &Scene,
        t: f64,
    ) -> Result<[Option<HandCommand>; 2], SimError> {
        self.advance(sim, scene, t)?;
        if t + 1e-12 >= self.next_sample {
            self.next_sample += self.glove_period;
            let mut pose = self.pose;
            let mut d = Vec3::zeros();
            for (k, (f, phase, amp)) in self.tremor.iter().enumerate() {
                d[k] = amp * (std::f64::consts::TAU * f * t + phase).sin() + 0.001 * self.rng.normal();
            }
            pose.translation.vector += d;
            let w = Vec3::new(self.rng.normal(), self.rng.normal(), self.rng.normal()) * 0.01;
            pose.rotation = Rot3::from_scaled_axis(w) * pose.rotation;
            let c = HandCommand::new(t, self.arm, &pose, self.flex.clamp(0.0, FLEX_CLOSED));
            self.log.samples.push(c);
            self.held[self.arm.index()] = Some(c);
        }
        Ok(self.held)
    }

    fn begin(&mut self, t: f64, to: Iso3, flex_to: f64, speed: f64) {
        let dist = (to.translation.vector - self.pose.translation.vector).norm();
        let ang = self.pose.rotation.angle_to(&to.rotation);
        // Humans take longer for longer moves (Fitts); a little variability.
        let duration = (0.4 + dist / speed + ang / 1.5) * (0.9 + 0.2 * self.rng.uniform());
        self.current = Some(Move {
            start: t,
            duration: duration.max((flex_to - self.flex).abs() / 2.0),
            from: self.pose,
            to,
            flex_from: self.flex,
            flex_to,
        });
    }

    fn advance(&mut self, sim: &mut DexterSim, scene: &Scene, t: f64) -> Result<(), SimError> {
        if let Some(m) = self.current {
            let (p, f) = m.at(t);
            self.pose = p;
            self.flex = f;
            if t < m.end() {
                return Ok(());
            }
            // A teacher watches the robot: the next move waits until the robot's hand has caught up
            // with the glove (within 1.5 cm and 0.06 rad), or for at most 3 s.
            let palm = sim.link_pose_by_name(&format!("{}/bhand/palm_surface_link", self.arm.prefix()))?;
            let behind = (palm.translation.vector - self.pose.translation.vector).norm() > 0.015
                || palm.rotation.angle_to(&self.pose.rotation) > 0.06;
            if behind && t < m.end() + 3.0 {
                return Ok(());
            }
            self.current = None;
        }
        let Some(step) = self.steps.get(self.index).cloned() else {
            self.done = true;
            return Ok(());
        };
        self.index += 1;
        let here = self.pose;
        match step {
            Step::Pause(s) => self.begin_pause(t, s),
            Step::Hover { object } => {
                let plan = self.grasp_plan(sim, scene, object)?;
                self.plan = Some(plan);
                let mut hover = plan.grasp;
                hover.translation.vector.z += 0.10;
                hover.translation.vector.z = hover.translation.z.max(here.translation.z.min(self.table_z + 0.45));
                self.begin(t, hover, plan.preshape, 0.25);
            }
            Step::Descend { object, early } => {
                let plan = match self.plan {
                    Some(p) => p,
                    None => self.grasp_plan(sim, scene, object)?,
                };
                let mut g = plan.grasp;
                if early {
                    // Closes too early: the fingers shut on air above the object.
                    g.translation.vector.z += 0.12;
                    self.notes
                        .push(format!("t={t:.1}s: grasp closed too early (to be retried)"));
                }
                self.begin(t, g, plan.preshape, 0.12);
            }
            Step::Close => self.begin(t, here, FLEX_CLOSED, 1.0),
            Step::Reopen => {
                let preshape = self.plan.map_or(0.3, |p| p.preshape);
                let mut up = here;
                up.translation.vector.z += 0.04;
                self.begin(t, up, preshape, 0.2);
            }
            Step::Lift { rise } => {
                let mut up = here;
                up.translation.vector.z += rise;
                self.begin(t, up, self.flex, 0.12);
            }
            Step::CheckHeld { object } => {
                let z = sim.object_state(object).pose.translation.z;
                let rest = scene.resolved[sim.objects()[object].scene_index].pose.translation.z;
                if z < rest + 0.05 {
                    self.notes.push(format!(
                        "t={t:.1}s: the object was not lifted; the teacher gives up on it"
                    ));
                    // Skip the rest of this task: open, back off, and go on with the next task.
                    let end = self.steps[self.index..]
                        .iter()
                        .position(|s| *s == Step::Park)
                        .map_or(self.steps.len(), |k| self.index + k);
                    self.steps
                        .splice(self.index..end, [Step::Open, Step::Retreat { rise: 0.1 }]);
                } else {
                    let palm = self.pose.translation.z;
                    let op = sim.object_state(object).pose;
                    let shape = &scene.catalog.objects[sim.objects()[object].catalog_index].shape;
                    let bottom =
                        op.translation.z - geometry::support_half_extent(shape, &(op.rotation.inverse() * -Vec3::z()));
                    self.carry_depth = palm - bottom;
                }
                self.begin_pause(t, 0.05);
            }
            Step::OverPlace { place, object } => {
                let spec = &scene.spec.places[place];
                let z = (self.table_z + spec.wall_height + self.carry_depth + 0.08).max(here.translation.z);
                // The palm over a free spot of the place (the teacher sees what is already in it).
                let spot = free_spot(sim, scene, place, object);
                let to = Iso3::from_parts(Translation3::new(spot[0], spot[1], z), here.rotation);
                self.begin(t, to, self.flex, 0.22);
            }
            Step::OverSpot { xy } => {
                let z = (self.table_z + self.carry_depth + 0.08).max(here.translation.z);
                let to = Iso3::from_parts(Translation3::new(xy[0], xy[1], z), here.rotation);
                self.begin(t, to, self.flex, 0.22);
            }
            Step::Lower { place, object: _ } => {
                let spec = &scene.spec.places[place];
                let _ = spec;
                let mut down = here;
                // Down until the object sits on the floor of the place, pressing a little.
                down.translation.vector.z = self.table_z + 0.002 + self.carry_depth - 0.015;
                self.begin(t, down, self.flex, 0.08);
            }
            Step::Open => self.begin(t, here, 0.3, 1.0),
            Step::TakeAway { object } => {
                // The teacher takes the object out of the open hand and puts it aside, off the table.
                let aside = Iso3::translation(-0.6, 0.0, 0.2);
                sim.teleport_object(object, &aside);
                self.taken.push(object);
                self.notes.push(format!("t={t:.1}s: the teacher took the object"));
                self.begin_pause(t, 0.05);
            }
            Step::Retreat { rise } => {
                let mut up = here;
                up.translation.vector.z += rise;
                self.begin(t, up, 0.3, 0.25);
            }
            Step::Park => {
                let park = park_pose(self.arm, self.table_z);
                self.begin(t, park, 0.3, 0.25);
            }
            Step::TouchTop { object } => {
                // One fingertip (F3) on the object's top, the others beside it: the palm is offset
                // so that F3's tip, at the open-hand flexion, is above the centre.
                let op = sim.object_state(object).pose;
                let shape = &scene.catalog.objects[sim.objects()[object].catalog_index].shape;
                let top = op.translation.z + geometry::support_half_extent(shape, &(op.rotation.inverse() * Vec3::z()));
                let arc = finger_arc(sim, self.arm)?;
                let &(_, lateral, depth) = arc
                    .iter()
                    .min_by(|a, b| (a.0 - 0.3).abs().total_cmp(&(b.0 - 0.3).abs()))
                    .expect("the arc has samples");
                const TIP_RADIUS: f64 = 0.01;
                let mut to = here;
                let f3 = here.rotation * Vec3::new(0.0, lateral, 0.0);
                to.translation.vector.x = op.translation.x - f3.x;
                to.translation.vector.y = op.translation.y - f3.y;
                to.translation.vector.z = top + depth.abs() + TIP_RADIUS - 0.008;
                // First above the touch point, then down onto it.
                let mut above = to;
                above.translation.vector.z += 0.06;
                self.steps.insert(self.index, Step::TouchDown { to });
                self.begin(t, above, 0.3, 0.2);
            }
            Step::TouchDown { to } => self.begin(t, to, 0.3, 0.05),
            Step::SwitchArm(arm) => {
                // The teacher puts the other glove on: that hand starts from where it is parked.
                self.arm = arm;
                self.pose = park_pose(arm, self.table_z);
                self.flex = 0.3;
                self.plan = None;
                self.begin_pause(t, 0.3);
            }
            Step::WanderTo { target } => {
                let to = Iso3::from_parts(Translation3::from(target), here.rotation);
                let flex = 0.3 + 0.3 * self.rng.uniform();
                self.begin(t, to, flex, 0.2);
            }
        }
        Ok(())
    }

    fn begin_pause(&mut self, t: f64, s: f64) {
        self.current = Some(Move {
            start: t,
            duration: s,
            from: self.pose,
            to: self.pose,
            flex_from: self.flex,
            flex_to: self.flex,
        });
    }

    fn grasp_plan(&self, sim: &DexterSim, scene: &Scene, object: usize) -> Result<GraspPlan, SimError> {
        let arc = finger_arc(sim, self.arm)?;
        let shape = &scene.catalog.objects[sim.objects()[object].catalog_index].shape;
        let pose = sim.object_state(object).pose;
        let current = Iso3::from_parts(
            self.pose.translation,
            top_down_orientation(&Vec3::x(), &self.pose.rotation),
        );
        let mut plan = plan_top_grasp(&arc, shape, &pose, self.table_z, &current);
        // F1 and F2 (palm −y) spread wider than F3: put them on the side towards the middle of the
        // table, away from the bins at its sides.
        let f12 = plan.grasp.rotation * -Vec3::y();
        if f12.y * pose.translation.y > 0.0 {
            plan.grasp.rotation *= Rot3::from_axis_angle(&Vec3::z_axis(), std::f64::consts::PI);
        }
        Ok(plan)
    }
}

/// From above object `o`: down to the grasp, close, wait until the grasp feels firm, lift 12 cm,
/// and check that the object came up.
fn grasp_and_lift(o: usize) -> [Step; 6] {
    [
        Step::Descend {
            object: o,
            early: false,
        },
        Step::Close,
        Step::Pause(0.5),
        Step::Lift { rise: 0.12 },
        Step::Pause(0.6),
        Step::CheckHeld { object: o },
    ]
}

/// With the object set down: open the hand and rise 15 cm away from it.
fn let_go_and_retreat() -> [Step; 4] {
    [
        Step::Pause(0.5),
        Step::Open,
        Step::Pause(0.4),
        Step::Retreat { rise: 0.15 },
    ]
}

/// Hover over object `o`, go down to the grasp, close, and lift by `rise` (m).
fn pick_up(o: usize, rise: f64) -> [Step; 4] {
    [
        Step::Hover { object: o },
        Step::Descend {
            object: o,
            early: false,
        },
        Step::Close,
        Step::Lift { rise },
    ]
}

fn place_index(scene: &Scene, name: &str) -> Result<usize, SimError> {
    scene.place(name)?;
    Ok(scene
        .spec
        .places
        .iter()
        .position(|p| p.name == name)
        .expect("scene.place found it"))
}

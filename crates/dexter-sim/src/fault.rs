//! Injected faults (world side): the world, from its truth, decides when a fault fires and does it —
//! drops the held object, bumps the object the hand is about to grasp, blocks an arm's path to the
//! object, covers the head cameras, or sends bursts of noise through the encoders and fingertip
//! sensors. The robot is never told: it has to notice from its own sensors (the fingertips lose the
//! load, a grasp closes on nothing, a reach does not converge, the cameras lose the object) and take
//! one of the schema's contingencies (§3.3.3).
//!
//! One [`Fault`] is armed per run and hooked into [`crate::hardware::SimRobot`] at one place: its
//! trigger is evaluated after every advance of the hardware, its sensor effects are applied where
//! the robot reads. Idle (armed, or done), it allocates nothing per step; the buffers it needs are
//! made when it is armed.

use control_basis::hardware::{ForceTorque, Image};
use control_basis::math::{Iso3, Vec3};
use control_basis::{Chain, ChainBinding, ChainState};
use serde::{Deserialize, Serialize};

use crate::error::SimError;
use crate::physics::DexterSim;
use crate::scene::Scene;
use crate::snapshot::Arm;
use bayes::rng::{Draw, Generator};

/// The kinds of fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// The held object falls out of the hand during transport.
    Drop,
    /// The object is pushed 4–8 cm sideways as the hand arrives above it, so the grasp misses.
    Bump,
    /// The path of the arm that reaches for the object first is blocked near the object: that arm
    /// cannot come within [`BLOCK_RADIUS`] of where the object lay.
    BlockedArm,
    /// The head cameras are covered (black images) for a while as the hand arrives at the object.
    Occlusion,
    /// A burst of large noise on the encoders and the fingertip force/torque sensors as the object
    /// is lifted.
    SensorNoise,
}

impl FaultKind {
    /// Every kind, in report order.
    pub const ALL: [FaultKind; 5] = [
        FaultKind::Drop,
        FaultKind::Bump,
        FaultKind::BlockedArm,
        FaultKind::Occlusion,
        FaultKind::SensorNoise,
    ];

    /// The kind's name (as in files and on the command line).
    pub fn name(self) -> &'static str {
        match self {
            FaultKind::Drop => "drop",
            FaultKind::Bump => "bump",
            FaultKind::BlockedArm => "blocked_arm",
            FaultKind::Occlusion => "occlusion",
            FaultKind::SensorNoise => "sensor_noise",
        }
    }

    /// The kind named `s` (`blocked-arm` also accepted for `blocked_arm`).
    pub fn parse(s: &str) -> Option<FaultKind> {
        let s = s.trim().replace('-', "_");
        FaultKind::ALL.into_iter().find(|k| k.name() == s)
    }
}

impl std::fmt::Display for FaultKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Radius (m) of the region around the object's starting place that a blocked arm's palm cannot
/// enter.
pub const BLOCK_RADIUS: f64 = 0.12;

/// What to inject, and when.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FaultSpec {
    /// The kind.
    pub kind: FaultKind,
    /// The object it concerns (index into the world's objects).
    pub object: usize,
    /// Seed of its random choices (drop offset, bump direction, noise).
    pub seed: u64,
    /// Drop: the object must be this high (m) above where it rested, and the hand have moved this
    /// far (m) sideways since it was lifted.
    pub drop_after: (f64, f64),
    /// Bump: the push (m), uniform in this range, in a random direction.
    pub bump: (f64, f64),
    /// Occlusion and sensor noise: how long (s).
    pub duration_secs: f64,
    /// Sensor noise: encoder (rad) and force (N) standard deviations during the burst.
    pub noise: (f64, f64),
}

impl FaultSpec {
    /// A fault of `kind` on object `object` with the default parameters.
    pub fn new(kind: FaultKind, object: usize, seed: u64) -> Self {
        FaultSpec {
            kind,
            object,
            seed,
            drop_after: (0.05, 0.03),
            bump: (0.04, 0.08),
            duration_secs: match kind {
                FaultKind::Occlusion => 3.0,
                _ => 0.6,
            },
            noise: (0.01, 1.5),
        }
    }
}

/// What the fault did (for the evaluator's report; the robot never sees it).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct FaultRecord {
    /// The kind.
    pub kind: Option<FaultKind>,
    /// It fired.
    pub fired: bool,
    /// When (s, simulated).
    pub fired_at: Option<f64>,
    /// What it did.
    pub detail: String,
}

/// The blocked arm's kinematics: its chain from the world to the palm, the commanded and last
/// admissible configurations.
struct Blocked {
    arm: Arm,
    center: [f64; 2],
    chain: Chain,
    state: ChainState,
    binding: ChainBinding,
    /// The robot's commanded references (q, q̇) of every motor unit (plant order).
    q_cmd: Vec<f64>,
    qd_cmd: Vec<f64>,
    /// The arm's last commanded configuration whose palm is outside the blocked region (chain
    /// order), and a buffer.
    q_ok: Vec<f64>,
    q_chain: Vec<f64>,
}

/// An armed fault and its state during a run.
pub struct Fault {
    spec: FaultSpec,
    rng: Generator,
    table_z: f64,
    /// The object's pose and height at the start.
    rest: Iso3,
    height: f64,
    /// The two palms' links, and the six fingertips' (left F1–F3, right F1–F3).
    palms: [usize; 2],
    tips: [usize; 6],
    /// Table and places (x, y centre and half size), for where a pushed or dropped object may land.
    table: ([f64; 2], [f64; 2]),
    places: Vec<([f64; 2], [f64; 2])>,
    /// Drop: where the object was when it was first lifted.
    lifted_at: Option<[f64; 2]>,
    /// Occlusion / noise: active until this time.
    until: Option<f64>,
    blocked: Option<Blocked>,
    /// Sensor noise: the noisy encoder readings, and noise samples (force, per sensor and axis)
    /// cycled through by physics step.
    q_noisy: Vec<f64>,
    ft_noise: Vec<[f64; 3]>,
    record: FaultRecord,
}

impl std::fmt::Debug for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Fault")
            .field("spec", &self.spec)
            .field("record", &self.record)
            .finish_non_exhaustive()
    }
}

impl Fault {
    /// Arms `spec` in `sim` (of `scene`).
    pub fn new(spec: FaultSpec, sim: &DexterSim, scene: &Scene) -> Result<Fault, SimError> {
        if spec.object >= sim.objects().len() {
            return Err(SimError::Invalid {
                path: scene.path.clone(),
                field: "fault.object".into(),
                message: format!("object {} of {}", spec.object, sim.objects().len()),
            });
        }
        let table_z = scene.spec.table.height;
        let rest = sim.object_state(spec.object).pose;
        let height = (2.0 * (rest.translation.z - table_z)).max(0.02);
        let palm = |arm: Arm| sim.model().link(&dexter::control::tool_link(arm));
        let palms = [palm(Arm::Left)?, palm(Arm::Right)?];
        let mut tips = [0; 6];
        for (k, t) in tips.iter_mut().enumerate() {
            let arm = Arm::BOTH[k / 3];
            *t = sim
                .model()
                .link(&format!("{}/bhand/finger_{}/tip_link", arm.prefix(), k % 3 + 1))?;
        }
        let t = &scene.spec.table;
        let n = sim.joint_names().len();
        let (q_noisy, ft_noise) = if spec.kind == FaultKind::SensorNoise {
            (vec![0.0; n], vec![[0.0; 3]; 6 * 64])
        } else {
            (Vec::new(), Vec::new())
        };
        Ok(Fault {
            rng: bayes::rng::seeded(spec.seed),
            table_z,
            rest,
            height,
            palms,
            tips,
            table: (t.center, [t.size[0] / 2.0, t.size[1] / 2.0]),
            places: scene
                .spec
                .places
                .iter()
                .map(|p| {
                    (
                        p.center,
                        [p.size[0] / 2.0 + p.wall_thickness, p.size[1] / 2.0 + p.wall_thickness],
                    )
                })
                .collect(),
            lifted_at: None,
            until: None,
            blocked: None,
            q_noisy,
            ft_noise,
            record: FaultRecord {
                kind: Some(spec.kind),
                ..FaultRecord::default()
            },
            spec,
        })
    }

    /// What it did so far.
    pub fn record(&self) -> &FaultRecord {
        &self.record
    }

    fn fire(&mut self, t: f64, detail: String) {
        self.record.fired = true;
        self.record.fired_at = Some(t);
        self.record.detail = detail;
    }

    /// Whether an object of horizontal radius `r` may rest at `xy`: on the table, clear of the
    /// places' walls.
    fn free_on_table(&self, xy: [f64; 2], r: f64) -> bool {
        let (c, h) = self.table;
        let on = (xy[0] - c[0]).abs() < h[0] - r - 0.04 && (xy[1] - c[1]).abs() < h[1] - r - 0.04;
        on && self
            .places
            .iter()
            .all(|(pc, ph)| (xy[0] - pc[0]).abs() > ph[0] + r + 0.03 || (xy[1] - pc[1]).abs() > ph[1] + r + 0.03)
    }

    /// The object at rest on the table at `xy`, upright as it started.
    fn rest_at(&self, sim: &mut DexterSim, xy: [f64; 2]) {
        let mut pose = self.rest;
        pose.translation.vector.x = xy[0];
        pose.translation.vector.y = xy[1];
        sim.teleport_object(self.spec.object, &pose);
    }

    /// Whether the fault intercepts the robot's reference of motor unit `dof` (it then keeps it; see
    /// [`Fault::before_advance`]).
    pub fn command(&mut self, dof: usize, q: f64, qd: f64) -> bool {
        match self.blocked.as_mut() {
            Some(b) if dof < b.q_cmd.len() => {
                b.q_cmd[dof] = q;
                b.qd_cmd[dof] = qd;
                (0..b.chain.dof()).any(|i| b.binding.plant_index(i) == dof)
            }
            _ => false,
        }
    }

    /// Before the physics steps: the blocked arm gets the robot's references while they keep its
    /// palm outside the blocked region, else the last ones that did (the arm stops at the
    /// obstacle).
    pub fn before_advance(&mut self, sim: &mut DexterSim) {
        let Some(b) = self.blocked.as_mut() else {
            return;
        };
        b.binding.gather(&b.q_cmd, &mut b.q_chain);
        if b.state.set_q(&b.chain, &b.q_chain).is_err() {
            return;
        }
        control_basis::forward_kinematics(&b.chain, &mut b.state);
        let p = b.state.tip_pose().translation.vector;
        let inside = (p.x - b.center[0]).hypot(p.y - b.center[1]) < BLOCK_RADIUS;
        if !inside {
            b.q_ok.copy_from_slice(&b.q_chain);
        }
        for i in 0..b.chain.dof() {
            let d = b.binding.plant_index(i);
            if inside {
                sim.set_joint_target(d, b.q_ok[i], 0.0);
            } else {
                sim.set_joint_target(d, b.q_cmd[d], b.qd_cmd[d]);
            }
        }
    }

    /// After the physics steps: evaluates the trigger from the world's truth and applies the fault.
    pub fn after_advance(&mut self, sim: &mut DexterSim) {
        let t = sim.time();
        if debug_truth() && ((t * 1000.0).round() as u64).is_multiple_of(500) {
            let o = sim.object_state(self.spec.object);
            let p = o.pose.translation.vector;
            eprintln!("TRUTH t={t:.2} object at ({:.3}, {:.3}, {:.3})", p.x, p.y, p.z);
        }
        if let Some(until) = self.until {
            if t >= until {
                self.until = None;
            } else if self.spec.kind == FaultKind::SensorNoise {
                self.noisy_encoders(sim);
            }
        }
        if self.record.fired {
            return;
        }
        let o = sim.object_state(self.spec.object);
        let at = o.pose.translation.vector;
        let rest_z = self.rest.translation.z;
        let on_table = at.z < rest_z + 0.01 && o.linvel.norm() < 0.05;
        let palm = |arm: usize| sim.link_pose(self.palms[arm]).translation.vector;
        let nearest_palm = || {
            (0..2)
                .map(|k| (k, palm(k)))
                .min_by(|a, b| (a.1 - at).xy().norm().total_cmp(&(b.1 - at).xy().norm()))
                .expect("two arms")
        };
        match self.spec.kind {
            FaultKind::Drop | FaultKind::SensorNoise => {
                if at.z < rest_z + self.spec.drop_after.0 {
                    return;
                }
                let xy = [at.x, at.y];
                let Some(l) = self.lifted_at else {
                    self.lifted_at = Some(xy);
                    if self.spec.kind == FaultKind::SensorNoise {
                        self.until = Some(t + self.spec.duration_secs);
                        self.draw_ft_noise();
                        self.noisy_encoders(sim);
                        self.fire(
                            t,
                            format!(
                                "noise burst of {:.1} s (encoders σ = {} rad, fingertips σ = {} N) as the object rose",
                                self.spec.duration_secs, self.spec.noise.0, self.spec.noise.1
                            ),
                        );
                    }
                    return;
                };
                if self.spec.kind == FaultKind::Drop && (xy[0] - l[0]).hypot(xy[1] - l[1]) > self.spec.drop_after.1 {
                    // It slips out and lands below the hand, a little to the side.
                    let r = self.height.min(0.1) * 0.5;
                    let mut land = xy;
                    for _ in 0..8 {
                        let a = std::f64::consts::TAU * self.rng.uniform();
                        let d = 0.03 * self.rng.uniform();
                        let c = [xy[0] + d * a.cos(), xy[1] + d * a.sin()];
                        if self.free_on_table(c, r) {
                            land = c;
                            break;
                        }
                    }
                    self.rest_at(sim, land);
                    self.fire(
                        t,
                        format!(
                            "dropped {:.0} cm above the table, landed at ({:.3}, {:.3})",
                            100.0 * (at.z - rest_z),
                            land[0],
                            land[1]
                        ),
                    );
                }
            }
            FaultKind::Bump | FaultKind::Occlusion => {
                let (k, p) = nearest_palm();
                let above = p.z - (self.table_z + self.height);
                if !(on_table && (p - at).xy().norm() < 0.03 && above < 0.13) {
                    return;
                }
                if self.spec.kind == FaultKind::Occlusion {
                    self.until = Some(t + self.spec.duration_secs);
                    self.fire(
                        t,
                        format!(
                            "head cameras covered for {:.1} s as the {} hand arrived above the object",
                            self.spec.duration_secs,
                            Arm::BOTH[k]
                        ),
                    );
                    return;
                }
                let r = 0.5 * self.height.min(0.1);
                let (lo, hi) = self.spec.bump;
                // Pushed clear of the descending hand's fingertips (a push under a fingertip would
                // be a collision of the hand with the object, not a missed grasp): of 16 random
                // pushes on the table, the one farthest from the fingertips.
                let tips: [Vec3; 3] = std::array::from_fn(|f| sim.link_pose(self.tips[3 * k + f]).translation.vector);
                let mut best: Option<(f64, [f64; 2], f64)> = None;
                for _ in 0..16 {
                    let a = std::f64::consts::TAU * self.rng.uniform();
                    let d = lo + (hi - lo) * self.rng.uniform();
                    let c = [at.x + d * a.cos(), at.y + d * a.sin()];
                    if !self.free_on_table(c, r) {
                        continue;
                    }
                    let clear = tips
                        .iter()
                        .map(|t| (t.x - c[0]).hypot(t.y - c[1]))
                        .fold(f64::INFINITY, f64::min);
                    if best.is_none_or(|b| clear > b.0) {
                        best = Some((clear, c, d));
                    }
                }
                if let Some((_, c, d)) = best {
                    self.rest_at(sim, c);
                    self.fire(
                        t,
                        format!(
                            "pushed {:.1} cm to ({:.3}, {:.3}) as the {} hand arrived above it",
                            100.0 * d,
                            c[0],
                            c[1],
                            Arm::BOTH[k]
                        ),
                    );
                }
            }
            FaultKind::BlockedArm => {
                let (k, p) = nearest_palm();
                if !(on_table && (p - at).xy().norm() < 0.20) {
                    return;
                }
                let arm = Arm::BOTH[k];
                let Ok(chain) = Chain::new(sim.model(), "world", &dexter::control::tool_link(arm)) else {
                    return;
                };
                let Ok(binding) = ChainBinding::by_name(&chain, sim.joint_names()) else {
                    return;
                };
                let mut q_chain = vec![0.0; chain.dof()];
                binding.gather(sim.joint_targets(), &mut q_chain);
                self.blocked = Some(Blocked {
                    arm,
                    center: [at.x, at.y],
                    state: chain.new_state(),
                    q_cmd: sim.joint_targets().to_vec(),
                    qd_cmd: sim.joint_target_velocities().to_vec(),
                    q_ok: q_chain.clone(),
                    q_chain,
                    chain,
                    binding,
                });
                self.fire(
                    t,
                    format!(
                        "the {arm} arm's path blocked within {:.0} cm of ({:.3}, {:.3})",
                        100.0 * BLOCK_RADIUS,
                        at.x,
                        at.y
                    ),
                );
            }
        }
    }

    /// The blocked arm, once the fault fired.
    pub fn blocked_arm(&self) -> Option<Arm> {
        self.blocked.as_ref().map(|b| b.arm)
    }

    fn draw_ft_noise(&mut self) {
        let s = self.spec.noise.1;
        for f in &mut self.ft_noise {
            *f = [s * self.rng.normal(), s * self.rng.normal(), s * self.rng.normal()];
        }
    }

    fn noisy_encoders(&mut self, sim: &DexterSim) {
        let s = self.spec.noise.0;
        for (o, q) in self.q_noisy.iter_mut().zip(sim.joint_positions()) {
            *o = q + s * self.rng.normal();
        }
    }

    /// The encoder readings during a noise burst (`None`: the true sensor model's).
    pub fn joint_positions(&self) -> Option<&[f64]> {
        (self.spec.kind == FaultKind::SensorNoise && self.until.is_some()).then_some(self.q_noisy.as_slice())
    }

    /// Adds the burst's noise to fingertip readings (`step`: the physics step, which picks the
    /// samples).
    pub fn perturb_force_torque(&self, step: u64, out: &mut [ForceTorque]) {
        if !(self.spec.kind == FaultKind::SensorNoise && self.until.is_some()) || self.ft_noise.is_empty() {
            return;
        }
        let rows = self.ft_noise.len() / 6;
        let base = (step as usize % rows) * 6;
        for (k, o) in out.iter_mut().enumerate().take(6) {
            let n = self.ft_noise[base + k];
            for (f, d) in o.force.iter_mut().zip(n) {
                *f += d;
            }
            o.in_contact |= Vec3::from(n).norm() > 0.25;
        }
    }

    /// Whether camera `camera` is covered now.
    pub fn occludes(&self, camera: usize) -> bool {
        self.spec.kind == FaultKind::Occlusion && self.until.is_some() && camera < 2
    }

    /// A covered camera's image: black.
    pub fn cover(image: &mut Image) {
        image.rgb.fill(0);
    }
}

/// One scene of the fault experiment: what was injected, whether it fired, what the robot did and
/// how it ended.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FaultTrial {
    /// The fault kind.
    pub kind: FaultKind,
    /// Scene index (within the kind).
    pub scene: usize,
    /// The object (presentation) and where it started (x, y).
    pub object: String,
    /// Where it started (m, world).
    pub start: [f64; 2],
    /// The place it was to go to.
    pub place: String,
    /// The fault fired.
    pub fired: bool,
    /// When (s, simulated).
    pub fired_at: Option<f64>,
    /// What the fault did (the world's account).
    pub fault: String,
    /// The object ended at rest in its place (the evaluator's judgement by the truth).
    pub success: bool,
    /// The fault fired and the object still ended in its place.
    pub recovered: bool,
    /// What the executive did: `re_grasp`, `other_arm`, `hand_over`, `none` (carried on), or
    /// `gave_up`.
    pub response: String,
    /// Contingencies and ψ's rebindings, in order.
    pub contingencies: Vec<String>,
    /// Arms used, in order.
    pub arms: Vec<String>,
    /// Actions run by the executive.
    pub actions: usize,
    /// Why it failed (phase: reason), when it did.
    pub reason: String,
    /// Simulated time (s).
    pub sim_time: f64,
}

/// Scene `i` of the fault experiment for `kind`: one presentation of `base`'s catalog at a random
/// pose in the band both arms reach (x 0.50–0.68 m, |y| ≤ 0.12 m), and a random place of `base`
/// for it. A pure function of (`base`, `kind`, `seed`, `i`).
pub fn fault_scene(base: &Scene, kind: FaultKind, seed: u64, i: usize) -> Result<(Scene, String), SimError> {
    let k = FaultKind::ALL.iter().position(|&x| x == kind).unwrap_or(0) as u64;
    let mut rng = bayes::rng::stream(seed ^ (0xFA17 + k), i as u64);
    let names: Vec<String> = base
        .catalog
        .presentation_names()
        .iter()
        .map(|s| s.to_string())
        .collect();
    if names.is_empty() || base.spec.places.is_empty() {
        return Err(SimError::Invalid {
            path: base.path.clone(),
            field: "objects".into(),
            message: "the fault experiment needs a catalog with presentations and a scene with places".into(),
        });
    }
    let name = names[(rng.uniform() * names.len() as f64) as usize % names.len()].clone();
    let x = 0.50 + 0.18 * rng.uniform();
    let y = -0.12 + 0.24 * rng.uniform();
    let yaw = 360.0 * rng.uniform();
    let place = base.spec.places[(rng.uniform() * base.spec.places.len() as f64) as usize % base.spec.places.len()]
        .name
        .clone();
    let scene = base.with_objects(vec![crate::scene::ObjectPlacement {
        presentation: name,
        xy: [x, y],
        yaw_deg: yaw,
        z: None,
    }])?;
    Ok((scene, place))
}

/// Runs scene `i` of `kind`: the robot puts the object in its place (a demonstration's place, so
/// the decision is not under test) with the fault armed; the evaluator judges by the truth.
pub fn fault_trial(
    base: &Scene,
    base_name: &str,
    library: &schema::Library,
    kind: FaultKind,
    seed: u64,
    i: usize,
) -> Result<FaultTrial, SimError> {
    let (scene, place) = fault_scene(base, kind, seed, i)?;
    let k = FaultKind::ALL.iter().position(|&x| x == kind).unwrap_or(0) as u64;
    let mut seeds = bayes::rng::stream(seed ^ (0x5EED_FA17 + k), i as u64);
    let run_seed = rand::Rng::next_u64(&mut seeds);
    let spec = FaultSpec::new(kind, 0, rand::Rng::next_u64(&mut seeds));
    let report = crate::execute::execute_scene_with_fault(
        &scene,
        &format!("{base_name}#{kind}-{i}"),
        library,
        &crate::execute::Decider::Place(place.clone()),
        run_seed,
        None,
        Some(&spec),
        &mut crate::execute::NoLog,
    )?;
    let record = report.fault.clone().unwrap_or_default();
    // The faulted object's report (the robot may also have acted on a segment that is no object).
    let label = scene.resolved.get(spec.object).map(|r| r.label.as_str());
    let o = report
        .objects
        .iter()
        .find(|o| o.decision == "execute" && Some(o.object.as_str()) == label)
        .or_else(|| report.objects.iter().find(|o| o.decision == "execute"))
        .or(report.objects.first());
    let success = o.is_some_and(|o| o.success);
    let contingencies = o.map(|o| o.contingencies.clone()).unwrap_or_default();
    let steps = o
        .and_then(|o| o.execution.as_ref())
        .map(|e| e.steps.as_slice())
        .unwrap_or(&[]);
    let runs = |a: &str| steps.iter().filter(|s| s.action == a).count();
    let has = |c: &str| contingencies.iter().any(|x| x == c);
    let response = if !success {
        "gave_up"
    } else if has("hand_over") || has("transfer") {
        "hand_over"
    } else if has("other_arm") {
        "other_arm"
    } else if has("regrasp") || runs("grasp") > 1 || runs("reach_object") > 1 {
        "re_grasp"
    } else {
        "none"
    };
    let reason = if success {
        String::new()
    } else {
        o.map(|o| match (&o.failure, o.decision.as_str()) {
            (Some(f), _) => f.clone(),
            (None, "execute") => "outcome: not in its place".into(),
            (None, d) => format!("{d}: {}", o.reason),
        })
        .unwrap_or_else(|| "perception: the object was not seen".into())
    };
    let start = scene.spec.objects[0].xy;
    Ok(FaultTrial {
        kind,
        scene: i,
        object: scene.spec.objects[0].presentation.clone(),
        start,
        place,
        fired: record.fired,
        fired_at: record.fired_at,
        fault: record.detail,
        success,
        recovered: record.fired && success,
        response: response.into(),
        contingencies,
        arms: o.map(|o| o.arms.clone()).unwrap_or_default(),
        actions: steps.len(),
        reason,
        sim_time: report.sim_time,
    })
}

/// Whether `PBD_DEBUG_TRUTH` is set: a fault then prints the object's true position every half
/// second of simulated time to standard error, for debugging recoveries (read once).
fn debug_truth() -> bool {
    static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *ON.get_or_init(|| std::env::var_os("PBD_DEBUG_TRUTH").is_some())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hardware::parked_sim;
    use crate::physics::SimSettings;
    use control_basis::Hardware;

    fn world(xy: [f64; 2]) -> (Scene, DexterSim) {
        let base = Scene::builtin("pick-place").unwrap();
        let scene = base
            .with_objects(vec![crate::scene::ObjectPlacement {
                presentation: "jif".into(),
                xy,
                yaw_deg: 0.0,
                z: None,
            }])
            .unwrap();
        let sim = parked_sim(&scene, SimSettings::default()).unwrap();
        (scene, sim)
    }

    fn moved(sim: &mut DexterSim, dx: f64, dz: f64) {
        let mut p = sim.object_state(0).pose;
        p.translation.vector.x += dx;
        p.translation.vector.z += dz;
        sim.teleport_object(0, &p);
    }

    #[test]
    fn kinds_parse_from_their_names() {
        for k in FaultKind::ALL {
            assert_eq!(FaultKind::parse(k.name()), Some(k));
        }
        assert_eq!(FaultKind::parse("blocked-arm"), Some(FaultKind::BlockedArm));
        assert_eq!(FaultKind::parse("fire"), None);
    }

    #[test]
    fn a_drop_fires_once_the_lifted_object_moves_sideways_and_puts_it_on_the_table() {
        let (scene, mut sim) = world([0.6, 0.0]);
        let rest = sim.object_state(0).pose.translation.vector;
        let mut f = Fault::new(FaultSpec::new(FaultKind::Drop, 0, 3), &sim, &scene).unwrap();
        f.after_advance(&mut sim);
        assert!(!f.record().fired, "on the table");
        moved(&mut sim, 0.0, 0.08);
        f.after_advance(&mut sim);
        assert!(!f.record().fired, "lifted, not yet carried");
        moved(&mut sim, 0.05, 0.0);
        f.after_advance(&mut sim);
        assert!(f.record().fired, "{:?}", f.record());
        let now = sim.object_state(0).pose.translation.vector;
        assert!(
            (now.z - rest.z).abs() < 1e-9 && (now.xy() - rest.xy()).norm() < 0.09,
            "{now:?}"
        );
    }

    #[test]
    fn a_blocked_arm_keeps_its_references_outside_the_region() {
        // Near the left arm's parked palm (0.42, 0.32): the left arm is the one blocked.
        let (scene, mut sim) = world([0.5, 0.22]);
        let spec = FaultSpec::new(FaultKind::BlockedArm, 0, 1);
        let fault = Fault::new(spec, &sim, &scene).unwrap();
        let mut hw = crate::hardware::SimRobot::new(&mut sim, &scene, 1)
            .unwrap()
            .with_fault(fault);
        hw.advance(0.005).unwrap();
        let f = hw.fault().unwrap();
        assert!(f.record().fired, "{:?}", f.record());
        assert_eq!(f.blocked_arm(), Some(Arm::Left));
        // Every reference of the left arm is the fault's to pass on or hold; the right arm's are not.
        let (l, r) = (
            hw.sim().dof("left/base_yaw_joint").unwrap(),
            hw.sim().dof("right/base_yaw_joint").unwrap(),
        );
        let (ql, qr) = (hw.sim().joint_targets()[l], hw.sim().joint_targets()[r]);
        hw.set_joint_reference(l, ql + 0.1, 0.0);
        hw.set_joint_reference(r, qr + 0.1, 0.0);
        assert_eq!(
            hw.sim().joint_targets()[l],
            ql,
            "kept by the fault until the next advance"
        );
        assert_eq!(hw.sim().joint_targets()[r], qr + 0.1);
    }

    #[test]
    fn a_noise_burst_fires_as_the_object_rises_and_ends() {
        let (scene, mut sim) = world([0.6, 0.0]);
        let spec = FaultSpec::new(FaultKind::SensorNoise, 0, 2);
        let fault = Fault::new(spec, &sim, &scene).unwrap();
        let mut hw = crate::hardware::SimRobot::new(&mut sim, &scene, 1)
            .unwrap()
            .with_fault(fault);
        let mut p = hw.sim().object_state(0).pose;
        p.translation.vector.z += 0.08;
        hw.sim_mut().teleport_object(0, &p);
        hw.advance(0.001).unwrap();
        assert!(hw.fault().unwrap().record().fired);
        let truth = hw.sim().joint_positions().to_vec();
        let noisy = hw.joint_positions().to_vec();
        let rms = (truth.iter().zip(&noisy).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / truth.len() as f64).sqrt();
        assert!(rms > 0.003, "{rms}");
        let mut ft = vec![ForceTorque::default(); 6];
        hw.read_force_torque(&mut ft);
        assert!(ft.iter().any(|w| w.force_norm() > 0.3));
        hw.advance(0.7).unwrap();
        assert_eq!(hw.joint_positions(), hw.sim().joint_positions());
    }
}

//! The fault model (module docs): the kinds of fault, when each fires (from the truth) and what
//! it does through the physics and the sensors.

use control_basis::hardware::{ForceTorque, Image};
use control_basis::math::{Iso3, Rot3, Vec3};
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
    /// The holding hand's fingers open for a moment during transport (the world overrides their
    /// motor references; the robot is not told): the object falls where the physics puts it.
    Drop,
    /// An impulse pushes the object sideways as the hand arrives above it, so the grasp misses;
    /// where it ends (slid, tipped, rolled) is the physics'.
    Bump,
    /// A fixed post ([`OBSTACLE_SIZE`]) appears on the table between the object and the arm that
    /// starts to reach for it: that arm cannot get through; the other arm's side stays free.
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

/// The blocking post (m): 22 cm wide across the arm's path, 6 cm thick along it (thick enough that
/// a hand pressed against it by its motors does not pass through) and 50 cm tall (the hand of an
/// arm hovering 32–45 cm above the table on its way to the object hits it).
pub const OBSTACLE_SIZE: [f64; 3] = [0.06, 0.22, 0.50];

/// Room (m) between the object's side and the post's face: the other hand's pre-shaped fingers,
/// up to 10 cm from its palm, fit between them.
pub const OBSTACLE_GAP: f64 = 0.10;

/// How much nearer (m) to the object an arm's palm must have come since the fault was armed for
/// that arm to count as reaching for it (the blocked-arm trigger).
pub const REACH_STARTED: f64 = 0.02;

/// What to inject, and when.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FaultSpec {
    /// The kind.
    pub kind: FaultKind,
    /// The object it concerns (index into the world's objects).
    pub object: usize,
    /// Seed of its random choices (push size and direction, noise).
    pub seed: u64,
    /// Drop: the object must be this high (m) above where it rested, and the hand have moved this
    /// far (m) sideways since it was lifted.
    pub drop_after: (f64, f64),
    /// Bump: the push, uniform in this range, as the distance (m) it would move the object on the
    /// table — sliding (the impulse is `m √(2 μ g d)`) or, for a ball or a lying can pushed across
    /// its axis, rolling (`m √(2 c g d / (1 + k))`, c the rolling resistance); where it ends is
    /// the physics'.
    pub bump: (f64, f64),
    /// Drop: how long the fingers are held open; occlusion and sensor noise: how long (s).
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
                FaultKind::Drop => 0.5,
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
    /// What it did (and, for a drop or a push, where the object first came to rest).
    pub detail: String,
}

/// A drop under way: the hand whose fingers the world holds open, and the robot's latest
/// references of their flexion (kept for when the fingers are given back).
#[derive(Debug, Clone, Copy)]
struct OpenHand {
    hand: usize,
    q_cmd: [f64; 3],
    qd_cmd: [f64; 3],
}

/// An armed fault and its state during a run.
pub struct Fault {
    spec: FaultSpec,
    rng: Generator,
    table_z: f64,
    /// The object's pose, height and horizontal radius (m) at the start.
    rest: Iso3,
    height: f64,
    radius: f64,
    /// Its mass (kg) and its friction on the table (the mean of both coefficients, Rapier's rule).
    mass: f64,
    friction: f64,
    /// Whether a horizontal push rolls it — a ball, or a cylinder or capsule lying on its side
    /// (pushed across its axis, the horizontal unit vector given) — and its inertia about the
    /// rolling axis as a share `k` of m r² (2/5 for a solid ball, 1/2 for a solid cylinder).
    rolls: Option<(f64, Option<[f64; 2]>)>,
    /// The physics' rolling resistance coefficient.
    rolling_resistance: f64,
    /// The two palms' links, and the six fingertips' (left F1–F3, right F1–F3).
    palms: [usize; 2],
    tips: [usize; 6],
    /// The flexion motor units (F1–F3 medial joints) of each hand.
    flex: [[usize; 3]; 2],
    /// Each palm's horizontal distance (m) to the object when the fault was armed.
    palm_start: [f64; 2],
    /// Table and places (x, y centre and half size), for where a pushed object may be aimed.
    table: ([f64; 2], [f64; 2]),
    places: Vec<([f64; 2], [f64; 2])>,
    /// Drop: where the object was when it was first lifted.
    lifted_at: Option<[f64; 2]>,
    /// Drop, occlusion, noise: active until this time.
    until: Option<f64>,
    /// Drop: the hand held open.
    open: Option<OpenHand>,
    /// Drop and bump: the outcome is still to be noted (the object has not come to rest yet).
    settling: bool,
    /// Blocked arm: the arm, once the post is in its path.
    blocked: Option<Arm>,
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
        let object = &sim.objects()[spec.object];
        let collider = sim.world().colliders.get(object.collider);
        let (height, radius) = match collider {
            Some(c) => {
                let aabb = c.compute_aabb();
                let (lo, hi) = (aabb.mins, aabb.maxs);
                ((hi.z - table_z).max(0.02), 0.5 * (hi.x - lo.x).max(hi.y - lo.y))
            }
            None => ((2.0 * (rest.translation.z - table_z)).max(0.02), 0.04),
        };
        let friction = 0.5 * (collider.map_or(0.5, |c| c.friction()) + scene.spec.table.friction);
        let mass = object.mass;
        let axis = rest.rotation * Vec3::z();
        let rolls = scene
            .catalog
            .objects
            .get(object.catalog_index)
            .and_then(|o| match o.shape {
                crate::geometry::Shape::Sphere { .. } => Some((0.4, None)),
                crate::geometry::Shape::Cylinder { .. } | crate::geometry::Shape::Capsule { .. }
                    if axis.z.abs() < 0.5 =>
                {
                    let h = axis.xy().normalize();
                    Some((0.5, Some([h.x, h.y])))
                }
                _ => None,
            });
        let rolling_resistance = sim.settings().rolling_resistance;
        let palm = |arm: Arm| sim.model().link(&dexter::control::tool_link(arm));
        let palms = [palm(Arm::Left)?, palm(Arm::Right)?];
        let mut tips = [0; 6];
        let mut flex = [[0; 3]; 2];
        for k in 0..6 {
            let arm = Arm::BOTH[k / 3];
            let finger = format!("{}/bhand/finger_{}", arm.prefix(), k % 3 + 1);
            tips[k] = sim.model().link(&format!("{finger}/tip_link"))?;
            flex[k / 3][k % 3] = sim.dof(&format!("{finger}/med_joint"))?;
        }
        let at = rest.translation.vector;
        let palm_start = std::array::from_fn(|k| (sim.link_pose(palms[k]).translation.vector - at).xy().norm());
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
            radius,
            mass,
            friction,
            rolls,
            rolling_resistance,
            palms,
            tips,
            flex,
            palm_start,
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
            open: None,
            settling: false,
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

    /// Whether the fault intercepts the robot's reference of motor unit `dof`: during a drop, the
    /// open hand's flexion references are the world's; the robot's are kept and given back when the
    /// fingers are.
    pub fn command(&mut self, dof: usize, q: f64, qd: f64) -> bool {
        let Some(o) = self.open.as_mut() else {
            return false;
        };
        match self.flex[o.hand].iter().position(|&d| d == dof) {
            Some(f) => {
                o.q_cmd[f] = q;
                o.qd_cmd[f] = qd;
                true
            }
            None => false,
        }
    }

    /// After the physics steps: evaluates the trigger from the world's truth and applies the fault.
    pub fn after_advance(&mut self, sim: &mut DexterSim) {
        let t = sim.time();
        // The truth every half second of simulated time, for debugging recoveries
        // (`RUST_LOG=dexter_sim::truth=trace`): the world's, never the robot's.
        if tracing::enabled!(target: "dexter_sim::truth", tracing::Level::TRACE)
            && ((t * 1000.0).round() as u64).is_multiple_of(TRUTH_PERIOD_MS)
        {
            let o = sim.object_state(self.spec.object);
            let p = o.pose.translation.vector;
            let palm = |k: usize| sim.link_pose(self.palms[k]).translation.vector;
            let (l, r) = (palm(0), palm(1));
            let tips: Vec<String> = ["left", "right"]
                .iter()
                .flat_map(|a| (1..=3).map(move |f| format!("{a}/bhand/finger_{f}/tip_link")))
                .map(|n| {
                    sim.link_pose_by_name(&n)
                        .map(|q| format!("{:.3}", q.translation.z))
                        .unwrap_or_default()
                })
                .collect();
            tracing::trace!(
                target: "dexter_sim::truth",
                "t={t:.2} object at ({:.3}, {:.3}, {:.3}) palms ({:.3}, {:.3}, {:.3}) ({:.3}, {:.3}, {:.3}) tips z {}",
                p.x,
                p.y,
                p.z,
                l.x,
                l.y,
                l.z,
                r.x,
                r.y,
                r.z,
                tips.join(" ")
            );
        }
        if let Some(until) = self.until {
            if t >= until {
                self.until = None;
                if let Some(o) = self.open.take() {
                    // The fingers are the robot's again: they go where it last commanded them.
                    for (f, &d) in self.flex[o.hand].iter().enumerate() {
                        sim.set_joint_target(d, o.q_cmd[f], o.qd_cmd[f]);
                    }
                }
            } else if self.spec.kind == FaultKind::SensorNoise {
                self.noisy_encoders(sim);
            }
        }
        if self.record.fired {
            if self.settling {
                self.note_rest(sim);
            }
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
                    // The grip fails: the holding hand's fingers open (the robot's references of
                    // them are kept, not applied) and the physics lets the object fall.
                    let hand = (0..2)
                        .min_by(|&a, &b| (palm(a) - at).norm().total_cmp(&(palm(b) - at).norm()))
                        .expect("two hands");
                    let targets = sim.joint_targets();
                    let velocities = sim.joint_target_velocities();
                    let open = OpenHand {
                        hand,
                        q_cmd: self.flex[hand].map(|d| targets[d]),
                        qd_cmd: self.flex[hand].map(|d| velocities[d]),
                    };
                    for &d in &self.flex[hand] {
                        sim.set_joint_target(d, 0.0, 0.0);
                    }
                    self.open = Some(open);
                    self.until = Some(t + self.spec.duration_secs);
                    self.settling = true;
                    self.fire(
                        t,
                        format!(
                            "the {} hand's fingers opened for {:.1} s {:.0} cm above the table at ({:.3}, {:.3})",
                            Arm::BOTH[hand],
                            self.spec.duration_secs,
                            100.0 * (at.z - rest_z + 0.5 * self.height),
                            at.x,
                            at.y
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
                self.bump(sim, k, &at);
            }
            FaultKind::BlockedArm => {
                if !on_table {
                    return;
                }
                // The arm that reaches for the object: the palm that came nearer to it since the
                // fault was armed (an arm moved out of the way goes farther).
                let Some((k, d)) = (0..2)
                    .map(|k| (k, (palm(k) - at).xy().norm()))
                    .filter(|&(k, d)| d < self.palm_start[k] - REACH_STARTED)
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                else {
                    return;
                };
                self.block(sim, k, d, &at);
            }
        }
    }

    /// The push: an impulse on the object, low on its side, in the random direction (of 16) that
    /// aims it farthest from the descending hand's fingertips while it would stay on the table; its
    /// size is the one that would slide it `spec.bump` on the table. Whether it slides, tips or
    /// rolls, and where it ends, is the physics'.
    fn bump(&mut self, sim: &mut DexterSim, k: usize, at: &Vec3) {
        let (lo, hi) = self.spec.bump;
        let tips: [Vec3; 3] = std::array::from_fn(|f| sim.link_pose(self.tips[3 * k + f]).translation.vector);
        let mut best: Option<(f64, f64, f64)> = None;
        for _ in 0..16 {
            let a = std::f64::consts::TAU * self.rng.uniform();
            let d = lo + (hi - lo) * self.rng.uniform();
            let c = [at.x + d * a.cos(), at.y + d * a.sin()];
            if !self.free_on_table(c, self.radius) {
                continue;
            }
            let clear = tips
                .iter()
                .map(|t| (t.x - c[0]).hypot(t.y - c[1]))
                .fold(f64::INFINITY, f64::min);
            if best.is_none_or(|b| clear > b.0) {
                best = Some((clear, a, d));
            }
        }
        let Some((_, a, d)) = best else {
            return;
        };
        let g = sim.settings().gravity;
        let dir = Vec3::new(a.cos(), a.sin(), 0.0);
        // A sliding object stops after v² / (2 μ g). A rolling one — a ball, or a lying can pushed
        // across its axis — only by rolling resistance c, which decelerates it by c g / (1 + k):
        // the shove that slides a box 6 cm rolls a ball 4 m, off the table. Each gets the push
        // that would move it `d`; a roller at its centre's height (no spin).
        let rolling = self
            .rolls
            .filter(|(_, axis)| axis.is_none_or(|[ax, ay]| (dir.x * ax + dir.y * ay).abs() < 0.7))
            .filter(|_| self.rolling_resistance > 0.0);
        let (speed, lift) = match rolling {
            Some((k, _)) => ((2.0 * self.rolling_resistance * g / (1.0 + k) * d).sqrt(), 0.5),
            None => ((2.0 * self.friction * g * d).sqrt(), 1.0 / 3.0),
        };
        // Low on its side, facing the push: a hand's shove, not a lift.
        let point = Vec3::new(at.x, at.y, self.table_z + self.height * lift) - self.radius * dir;
        sim.push_object(self.spec.object, &(self.mass * speed * dir), &point);
        self.settling = true;
        self.fire(
            sim.time(),
            format!(
                "pushed at {speed:.2} m/s towards ({:.3}, {:.3}) (would {} {:.1} cm) as the {} hand arrived above it",
                dir.x,
                dir.y,
                if rolling.is_some() { "roll" } else { "slide" },
                100.0 * d,
                Arm::BOTH[k]
            ),
        );
    }

    /// The post: across the path of arm `k`'s palm (horizontally `d` from the object), on the
    /// palm's side of the object, [`OBSTACLE_GAP`] from its side — or nearer the object if the palm
    /// is already close. Not put while it would touch the robot or the object.
    fn block(&mut self, sim: &mut DexterSim, k: usize, d: f64, at: &Vec3) {
        let p = sim.link_pose(self.palms[k]).translation.vector;
        let u = (p - at).xy();
        let n = u.norm();
        if n < 1e-6 {
            return;
        }
        let u = Vec3::new(u.x / n, u.y / n, 0.0);
        let half = Vec3::new(0.5 * OBSTACLE_SIZE[0], 0.5 * OBSTACLE_SIZE[1], 0.5 * OBSTACLE_SIZE[2]);
        let yaw = u.y.atan2(u.x);
        for step in 0..5 {
            let gap = OBSTACLE_GAP - 0.01 * step as f64;
            let c = self.radius + gap + half.x;
            if c + half.x > d {
                continue;
            }
            let pose = Iso3::from_parts(
                (Vec3::new(at.x, at.y, self.table_z + half.z) + c * u).into(),
                Rot3::from_axis_angle(&Vec3::z_axis(), yaw),
            );
            if sim.clearance_of_box(&half, &pose, 0.02) < 0.01 {
                continue;
            }
            sim.add_obstacle(&half, &pose);
            let arm = Arm::BOTH[k];
            self.blocked = Some(arm);
            let w = pose.translation.vector;
            self.fire(
                sim.time(),
                format!(
                    "a {:.0} × {:.0} × {:.0} cm post put at ({:.3}, {:.3}), {:.0} cm from the object's side, in the {arm} arm's path",
                    100.0 * OBSTACLE_SIZE[0],
                    100.0 * OBSTACLE_SIZE[1],
                    100.0 * OBSTACLE_SIZE[2],
                    w.x,
                    w.y,
                    100.0 * gap
                ),
            );
            return;
        }
    }

    /// After a drop or a push: once the object has come to rest, notes where (and whether it lies
    /// tipped over) in the record.
    fn note_rest(&mut self, sim: &DexterSim) {
        let o = sim.object_state(self.spec.object);
        let since = self.record.fired_at.map_or(0.0, |f| sim.time() - f);
        if since < 0.3 || o.linvel.norm() > 0.01 || sim.object_angvel(self.spec.object).norm() > 0.05 {
            return;
        }
        self.settling = false;
        let up = o.pose.rotation * Vec3::z();
        let up0 = self.rest.rotation * Vec3::z();
        let tilt = up.dot(&up0).clamp(-1.0, 1.0).acos().to_degrees();
        let p = o.pose.translation.vector;
        let moved = (p - self.rest.translation.vector).xy().norm();
        self.record.detail.push_str(&format!(
            "; came to rest at ({:.3}, {:.3}, {:.3}), {:.1} cm from its start, {}",
            p.x,
            p.y,
            p.z,
            100.0 * moved,
            if tilt > 30.0 {
                format!("tipped over ({tilt:.0}°)")
            } else {
                "upright".into()
            }
        ));
    }

    /// The blocked arm, once the fault fired.
    pub fn blocked_arm(&self) -> Option<Arm> {
        self.blocked
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

/// The period (ms of simulated time) of the truth trace.
const TRUTH_PERIOD_MS: u64 = 500;

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

    #[test]
    fn kinds_parse_from_their_names() {
        for k in FaultKind::ALL {
            assert_eq!(FaultKind::parse(k.name()), Some(k));
        }
        assert_eq!(FaultKind::parse("blocked-arm"), Some(FaultKind::BlockedArm));
        assert_eq!(FaultKind::parse("fire"), None);
    }

    /// The robot's configuration with `arm`'s palm at `at` (top-down, as parked), by IK from now.
    fn palm_at(sim: &DexterSim, arm: Arm, at: Vec3) -> Vec<f64> {
        use control_basis::{Chain, ChainBinding, IkSettings, inverse_kinematics};
        let chain = Chain::new(sim.model(), "world", &dexter::control::tool_link(arm)).unwrap();
        let binding = ChainBinding::by_name(&chain, sim.joint_names()).unwrap();
        let mut guess = vec![0.0; chain.dof()];
        binding.gather(sim.joint_positions(), &mut guess);
        let rotation = dexter::skills::park_pose(arm, 0.75).rotation;
        let settings = IkSettings {
            position_tolerance: 1e-4,
            orientation_tolerance: 1e-3,
            restarts: 50,
            seed: 1,
            ..IkSettings::default()
        };
        let sol = inverse_kinematics(&chain, &Iso3::from_parts(at.into(), rotation), &guess, &settings).unwrap();
        assert!(sol.converged, "{arm} palm at {at:?}: {}", sol.position_error);
        let mut q = sim.joint_targets().to_vec();
        binding.scatter(sol.q.as_slice(), &mut q);
        q
    }

    fn palm(sim: &DexterSim, arm: Arm) -> Vec3 {
        sim.link_pose_by_name(&dexter::control::tool_link(arm))
            .unwrap()
            .translation
            .vector
    }

    #[test]
    fn a_drop_opens_the_holding_hand_once_the_lifted_object_moves_sideways_and_teleports_nothing() {
        // Nearer the left palm: the left hand is the one that "holds" it.
        let (scene, mut sim) = world([0.6, 0.1]);
        let fault = Fault::new(FaultSpec::new(FaultKind::Drop, 0, 3), &sim, &scene).unwrap();
        let flex = |h: usize| fault.flex[h];
        let (left, right) = (flex(0), flex(1));
        let mut hw = crate::hardware::SimRobot::new(&mut sim, &scene, 1)
            .unwrap()
            .with_fault(fault);
        for &d in left.iter().chain(&right) {
            hw.set_joint_reference(d, 1.2, 0.0);
        }
        hw.advance(0.001).unwrap();
        assert!(!hw.fault().unwrap().record().fired, "on the table");
        let mut p = hw.sim().object_state(0).pose;
        p.translation.vector.z += 0.08;
        hw.sim_mut().teleport_object(0, &p);
        hw.advance(0.001).unwrap();
        assert!(!hw.fault().unwrap().record().fired, "lifted, not yet carried");
        let mut p = hw.sim().object_state(0).pose;
        p.translation.vector.x += 0.05;
        hw.sim_mut().teleport_object(0, &p);
        hw.advance(0.001).unwrap();
        let record = hw.fault().unwrap().record().clone();
        assert!(record.fired, "{record:?}");
        assert!(record.detail.contains("left hand"), "{record:?}");
        // No teleport: the object is where it was, one millisecond of fall lower.
        let now = hw.sim().object_state(0).pose.translation.vector;
        assert!((now - p.translation.vector).norm() < 1e-3, "{now:?}");
        // The left hand's fingers are the world's (open); the right hand's stay the robot's.
        for &d in &left {
            assert_eq!(hw.sim().joint_targets()[d], 0.0);
            hw.set_joint_reference(d, 1.5, 0.0);
            assert_eq!(hw.sim().joint_targets()[d], 0.0, "kept by the fault");
        }
        for &d in &right {
            assert_eq!(hw.sim().joint_targets()[d], 1.2);
        }
        // After the moment, the fingers go where the robot last commanded them.
        hw.advance(0.6).unwrap();
        for &d in &left {
            assert_eq!(hw.sim().joint_targets()[d], 1.5);
            hw.set_joint_reference(d, 0.3, 0.0);
            assert_eq!(hw.sim().joint_targets()[d], 0.3);
        }
        // The object fell under gravity and lies on the table.
        hw.advance(1.0).unwrap();
        let end = hw.sim().object_state(0).pose.translation.vector;
        assert!((end.z - scene.spec.table.height - 0.05).abs() < 0.02, "{end:?}");
    }

    #[test]
    fn a_bump_pushes_the_object_as_the_hand_arrives_and_the_physics_decides_where_it_ends() {
        let (scene, mut sim) = world([0.6, 0.05]);
        let start = sim.object_state(0).pose.translation.vector;
        let fault = Fault::new(FaultSpec::new(FaultKind::Bump, 0, 5), &sim, &scene).unwrap();
        let q = palm_at(&sim, Arm::Left, Vec3::new(0.61, 0.05, 0.75 + 0.1 + 0.11));
        sim.set_configuration(&q).unwrap();
        let mut hw = crate::hardware::SimRobot::new(&mut sim, &scene, 1)
            .unwrap()
            .with_fault(fault);
        hw.advance(0.001).unwrap();
        let record = hw.fault().unwrap().record().clone();
        assert!(record.fired, "{record:?}");
        let o = hw.sim().object_state(0);
        assert!(
            (o.pose.translation.vector - start).norm() < 2e-3,
            "an impulse, not a teleport"
        );
        assert!(o.linvel.xy().norm() > 0.3, "{:?}", o.linvel);
        hw.advance(1.5).unwrap();
        let o = hw.sim().object_state(0);
        let moved = (o.pose.translation.vector - start).xy().norm();
        assert!((0.02..0.25).contains(&moved), "moved {moved}");
        assert!(o.linvel.norm() < 0.01, "at rest");
        assert!(
            hw.fault().unwrap().record().detail.contains("came to rest"),
            "{record:?}"
        );
    }

    #[test]
    fn a_blocked_arm_gets_a_post_in_its_path_that_stops_it_and_the_cameras_see() {
        let (scene, mut sim) = world([0.6, 0.06]);
        let at = sim.object_state(0).pose.translation.vector;
        let fault = Fault::new(FaultSpec::new(FaultKind::BlockedArm, 0, 1), &sim, &scene).unwrap();
        // The right arm moves away, the left palm 4 cm nearer the object: the left arm reaches.
        let park = palm(&sim, Arm::Left);
        let toward = park + 0.04 * Vec3::new(at.x - park.x, at.y - park.y, 0.0).normalize();
        let q = palm_at(&sim, Arm::Left, toward);
        sim.set_configuration(&q).unwrap();
        let mut hw = crate::hardware::SimRobot::new(&mut sim, &scene, 1)
            .unwrap()
            .with_fault(fault);
        hw.advance(0.001).unwrap();
        let record = hw.fault().unwrap().record().clone();
        assert!(record.fired, "{record:?}");
        assert_eq!(hw.fault().unwrap().blocked_arm(), Some(Arm::Left));
        assert_eq!(hw.sim().obstacles().len(), 1);
        let post = hw.sim().obstacles()[0].pose.translation.vector;
        // Between the left palm and the object, on the left arm's side.
        let (to_post, to_palm) = ((post - at).xy(), (toward - at).xy());
        assert!(
            to_post.dot(&to_palm) > 0.0 && to_post.norm() < to_palm.norm(),
            "{post:?}"
        );
        // The head cameras see it.
        let cam = hw.sim_cameras().camera(hw.sim(), 0).unwrap();
        let mut cameras = crate::hardware::SimCameras::new(hw.sim(), &scene, 1).unwrap();
        cameras.sync(hw.sim());
        let mut r = crate::vision::Renderer::new(0.0, &scene.spec.light, 1).unwrap();
        r.render(&cam, cameras.render_scene()).unwrap();
        let seen = r
            .labels()
            .iter()
            .filter(|l| **l == Some(crate::vision::ItemLabel::Obstacle(0)))
            .count();
        assert!(seen > 100, "{seen} pixels of the post");
        // The left arm driven to above the object stops at the post; the right arm gets there.
        let above = Vec3::new(at.x, at.y, park.z);
        let q_left = palm_at(hw.sim(), Arm::Left, above);
        let q_right = palm_at(hw.sim(), Arm::Right, above);
        let names = hw.sim().joint_names().to_vec();
        for (i, name) in names.iter().enumerate() {
            if name.starts_with("left/") && !name.contains("bhand") {
                hw.set_joint_reference(i, q_left[i], 0.0);
            }
            if name.starts_with("right/") && !name.contains("bhand") {
                hw.set_joint_reference(i, q_right[i], 0.0);
            }
        }
        hw.advance(3.0).unwrap();
        let (l, r) = (palm(hw.sim(), Arm::Left), palm(hw.sim(), Arm::Right));
        assert!((l - above).xy().norm() > 0.08, "the left palm got through: {l:?}");
        assert!((r - above).norm() < 0.03, "the right palm did not get there: {r:?}");
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

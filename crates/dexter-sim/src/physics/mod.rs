//! Dexter and a scene in Rapier: bodies built from the URDF, reduced-coordinate multibody joints,
//! motor units (PD on every independent DOF), mimic couplings, objects, table and bins.
//!
//! # How the URDF becomes Rapier bodies
//! Links joined by `fixed` joints are merged into one rigid body (their colliders and inertias are
//! combined in the frame of the first link of the group). Every moving joint becomes a multibody joint
//! (reduced coordinates, exact in the joint space), so each arm with its hand is one multibody rooted on
//! its fixed mounting plate, and the head is another; the torso is a fixed body. `<mimic>` joints are
//! kept as joints of their own and tied to their master by an exact DOF coupling
//! (`q_mimic = multiplier · q_master + offset`), which is how the BarrettHand's distal links follow
//! the medial ones (dist = med/3) and finger 2's spread follows finger 1's.
//!
//! # Motor units (§3.1)
//! Each independent DOF has a force-based PD motor `τ = kp (q_ref − q) + kd (q̇_ref − q̇)` clipped to
//! the URDF effort limit: the τ of a control-basis controller writes `q_ref` (and `q̇_ref`). Joint
//! position limits are enforced by the joint itself. Gravity on the robot's own links is compensated
//! exactly (ideal gravity feed-forward, as on a real WAM), so the PD only carries payloads, contacts and
//! dynamics.
//!
//! # Settings
//! The contact settings are those measured in `../shared/NOTES-grasp-physics.md`: 1 ms steps, 4
//! solver iterations, contact natural frequency 60 Hz, 2 mm contact skin, capsule fingers.
//!
//! # Files
//! `robot_build.rs` builds the robot from the URDF, `scene_build.rs` the table, bins and objects;
//! `gains.rs` holds the motor units' gains, `contacts.rs` the contact sensors and `mjcf.rs` writes
//! the world for MuJoCo. This file holds the world itself: settings, motor references, encoders,
//! stepping (with rolling resistance) and the state the rest of the crate reads.

use std::collections::HashMap;

use control_basis::RobotModel;
use control_basis::math::{Iso3, Rot3, Vec3};
use rapier3d_f64::glamx::DVec3;
use rapier3d_f64::prelude::*;

use crate::convert::{iso_from_glam, iso_to_glam, vec_from_glam, vec_to_glam};
use crate::error::SimError;
use crate::scene::Scene;
use crate::snapshot::{Arm, FingertipWrench, ObjectState, Snapshot, SnapshotHeader};
use bayes::rng::{Draw, Generator};

mod contacts;
mod gains;
mod mjcf;
mod robot_build;
mod scene_build;

pub use gains::{MotorGains, default_gains};

/// Dexter's URDF, embedded.
pub const DEXTER_URDF: &str = include_str!("../../../../assets/dexter.urdf");

/// Angular damping of objects (1/s): air and the little losses Rapier does not model.
pub const OBJECT_ANGULAR_DAMPING: f64 = 1.0;

/// The coefficient of rolling resistance ([`SimSettings::rolling_resistance`]'s default): a hard
/// ball or can on a wooden table or a plastic bin (0.001–0.01 on hard floors; 0.02 stops a ball
/// pushed at 0.3 m/s within 33 cm).
pub const ROLLING_RESISTANCE: f64 = 0.02;

/// Below this horizontal spin (rad/s) an object is not rolling: rolling resistance leaves it alone
/// (and costs nothing).
const ROLLING_MIN_SPIN: f64 = 1e-3;

/// Collision groups.
mod groups {
    use rapier3d_f64::prelude::Group;
    pub const STATIC: Group = Group::GROUP_1;
    pub const OBJECT: Group = Group::GROUP_2;
    pub const HAND: Group = Group::GROUP_3;
    pub const ARM: Group = Group::GROUP_4;
    /// Obstacles put on the table during a run ([`super::DexterSim::add_obstacle`]): they stop the
    /// arms and hands as well as objects.
    pub const OBSTACLE: Group = Group::GROUP_5;
}

/// The default tolerances of [`SimSettings::mass_matrix_reuse`]: 1e-4 rad on the joint coordinates
/// (below the change of one step of an arm moving at 0.1 rad/s), 1e-2 rad/s on the joint velocities
/// (they enter the matrix only through `dt`-scaled Coriolis and gyroscopic terms).
pub const MASS_MATRIX_REUSE: [f64; 2] = [1e-4, 1e-2];

/// Physics and motor settings.
#[derive(Debug, Clone, PartialEq)]
pub struct SimSettings {
    /// Physics step (s).
    pub dt: f64,
    /// Rapier solver iterations per step (substeps: each integrates the velocities and positions).
    pub solver_iterations: usize,
    /// Velocity (projected Gauss–Seidel) iterations in each substep (rapier's
    /// `num_internal_pgs_iterations`): more converge the contacts and joints within a substep.
    pub pgs_iterations: usize,
    /// Contact natural frequency (Hz); stiffer contacts penetrate less.
    pub contact_hz: f64,
    /// Contact skin (m).
    pub contact_skin: f64,
    /// Gravity (m/s², positive down).
    pub gravity: f64,
    /// Encoder noise, standard deviation (rad).
    pub encoder_noise: f64,
    /// Seed for every random choice of the simulator (encoder noise, placement jitter).
    pub seed: u64,
    /// Random placement jitter of each object: position (m, uniform ±) and yaw (rad, uniform ±).
    pub placement_jitter: (f64, f64),
    /// Let bodies at rest sleep (objects and robot links; a robot part is woken when its motor reference changes).
    pub allow_sleep: bool,
    /// Assemble and factorise the arms' mass matrices once per step (at the first of the
    /// `solver_iterations` substeps) instead of at every substep. The step's constraints are built
    /// with that matrix either way; see `vendor/README.md`, change 3.
    pub mass_matrix_once_per_step: bool,
    /// Keep an arm's mass matrix from an earlier step while it has not moved: `Some([dq, dv])`
    /// reuses it as long as every joint coordinate is within `dq` (rad) and every joint velocity
    /// within `dv` (rad/s) of the state it was built at (`vendor/README.md`, change 9; needs
    /// `mass_matrix_once_per_step`). `None` rebuilds it at every step.
    pub mass_matrix_reuse: Option<[f64; 2]>,
    /// Coefficient of rolling resistance of the objects on what supports them (dimensionless: the
    /// resisting torque is this times the normal force times the rolling radius); 0 turns it off.
    /// Default [`ROLLING_RESISTANCE`].
    pub rolling_resistance: f64,
}

impl Default for SimSettings {
    fn default() -> Self {
        Self {
            dt: 1e-3,
            solver_iterations: 2,
            pgs_iterations: 2,
            contact_hz: 60.0,
            contact_skin: 0.002,
            gravity: 9.81,
            encoder_noise: 1e-4,
            seed: 0,
            placement_jitter: (0.003, 0.05),
            allow_sleep: true,
            mass_matrix_once_per_step: true,
            mass_matrix_reuse: Some(MASS_MATRIX_REUSE),
            rolling_resistance: ROLLING_RESISTANCE,
        }
    }
}

/// One independent DOF (motor unit).
#[derive(Debug, Clone)]
struct Dof {
    name: String,
    /// Child body of the joint (the multibody joint handle is derived from it).
    body: RigidBodyHandle,
    lower: f64,
    upper: f64,
    velocity_limit: f64,
    gains: MotorGains,
}

/// A mimic joint, coupled to a master DOF.
#[derive(Debug, Clone)]
struct MimicDof {
    body: RigidBodyHandle,
    master: usize,
    multiplier: f64,
    offset: f64,
}

/// A placed object in the world.
#[derive(Debug, Clone)]
pub struct SimObject {
    /// Unique name (presentation, `#k` appended if repeated).
    pub name: String,
    /// Index into the scene's catalog.
    pub catalog_index: usize,
    /// Index into the scene's placed objects.
    pub scene_index: usize,
    /// The rigid body.
    pub body: RigidBodyHandle,
    /// Its collider.
    pub collider: ColliderHandle,
    /// Mass (kg).
    pub mass: f64,
}

/// A fixed box put into the world during a run ([`DexterSim::add_obstacle`]): it stops the arms,
/// the hands and the objects.
#[derive(Debug, Clone)]
pub struct SimObstacle {
    /// Half extents (m) along its own axes.
    pub half_extents: Vec3,
    /// Its pose (world).
    pub pose: Iso3,
    /// Its collider (on a fixed body).
    pub collider: ColliderHandle,
}

/// Which part of the robot a collider belongs to (for the sensors).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Part {
    Palm(Arm),
    /// Finger (1–3) of a hand: medial, distal and tip links.
    Finger(Arm, u8),
    Other,
}

/// Dexter and a scene, in Rapier.
pub struct DexterSim {
    world: PhysicsWorld,
    settings: SimSettings,
    model: RobotModel,
    dofs: Vec<Dof>,
    mimics: Vec<MimicDof>,
    dof_index: HashMap<String, usize>,
    /// For each URDF link: its body and the link's pose in the body frame.
    link_body: Vec<(RigidBodyHandle, Iso3)>,
    /// The six fingertip links (left fingers 1–3, then right), when the model has them: the F/T
    /// sensors' origins, looked up once so that reading the sensors allocates nothing.
    tip_links: [Option<usize>; 6],
    collider_part: HashMap<ColliderHandle, Part>,
    objects: Vec<SimObject>,
    object_by_collider: HashMap<ColliderHandle, usize>,
    obstacles: Vec<SimObstacle>,
    /// Motor references.
    q_ref: Vec<f64>,
    qd_ref: Vec<f64>,
    /// Encoder readings, refreshed by [`DexterSim::step`].
    q: Vec<f64>,
    qd: Vec<f64>,
    rng: Generator,
    time: f64,
    steps: u64,
    header: SnapshotHeader,
}

impl std::fmt::Debug for DexterSim {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DexterSim")
            .field("time", &self.time)
            .field("dofs", &self.dofs.len())
            .field("objects", &self.objects.len())
            .finish()
    }
}

impl DexterSim {
    /// Builds Dexter (from the embedded URDF) and `scene`.
    pub fn new(scene: &Scene, settings: SimSettings) -> Result<Self, SimError> {
        let model = RobotModel::from_urdf_str(DEXTER_URDF)?;
        Self::with_model(model, scene, settings)
    }

    /// Builds the robot `model` (a Dexter-like URDF: arm prefixes `left/`, `right/`) and `scene`.
    pub fn with_model(model: RobotModel, scene: &Scene, settings: SimSettings) -> Result<Self, SimError> {
        for (field, v) in [
            ("dt", settings.dt),
            ("contact_hz", settings.contact_hz),
            ("gravity", settings.gravity),
            ("rolling_resistance", settings.rolling_resistance),
        ] {
            let zero_ok = field == "gravity" || field == "rolling_resistance";
            if !v.is_finite() || v < 0.0 || (!zero_ok && v == 0.0) {
                return Err(SimError::Invalid {
                    path: "<settings>".into(),
                    field: field.into(),
                    message: if zero_ok {
                        format!("must be a finite number ≥ 0 (got {v})")
                    } else {
                        format!("must be a finite positive number (got {v})")
                    },
                });
            }
        }
        let mut world = PhysicsWorld::new();
        world.gravity = DVec3::new(0.0, 0.0, -settings.gravity);
        let ip = &mut world.integration_parameters;
        ip.dt = settings.dt;
        ip.num_solver_iterations = settings.solver_iterations.max(1);
        ip.num_internal_pgs_iterations = settings.pgs_iterations.max(1);
        ip.multibody_mass_matrix_once_per_step = settings.mass_matrix_once_per_step;
        ip.multibody_mass_matrix_reuse = settings.mass_matrix_reuse;
        // Bit-identical (vendor/README.md, change 12): the step's first forward kinematics is
        // skipped for an arm nothing touched since the last substep; every change pbd makes to a
        // multibody goes through `get_multibody_mut`, which marks it.
        ip.multibody_skip_unchanged_kinematics = true;
        ip.contact_softness.natural_frequency = settings.contact_hz;
        ip.static_contact_softness.natural_frequency = 2.0 * settings.contact_hz;

        let mut sim = DexterSim {
            world,
            rng: bayes::rng::seeded(settings.seed),
            settings,
            dofs: Vec::new(),
            mimics: Vec::new(),
            dof_index: HashMap::new(),
            link_body: Vec::new(),
            tip_links: [None; 6],
            collider_part: HashMap::new(),
            objects: Vec::new(),
            object_by_collider: HashMap::new(),
            obstacles: Vec::new(),
            q_ref: Vec::new(),
            qd_ref: Vec::new(),
            q: Vec::new(),
            qd: Vec::new(),
            time: 0.0,
            steps: 0,
            header: SnapshotHeader {
                joint_names: Vec::new(),
                link_names: Vec::new(),
                link_parents: Vec::new(),
                object_names: Vec::new(),
            },
            model,
        };
        for (k, t) in sim.tip_links.iter_mut().enumerate() {
            let arm = if k < 3 { Arm::Left } else { Arm::Right };
            *t = sim
                .model
                .link(&format!("{}/bhand/finger_{}/tip_link", arm.prefix(), k % 3 + 1))
                .ok();
        }
        sim.build_robot()?;
        sim.build_scene(scene)?;
        sim.read_encoders();
        sim.q_ref.clone_from(&sim.q);
        sim.apply_motor_targets();
        Ok(sim)
    }

    /// The robot model.
    pub fn model(&self) -> &RobotModel {
        &self.model
    }

    /// Settings in use.
    pub fn settings(&self) -> &SimSettings {
        &self.settings
    }

    /// Names of the independent DOFs (the motor units), in the order of every joint vector.
    pub fn joint_names(&self) -> &[String] {
        &self.header.joint_names
    }

    /// Index of a DOF by joint name.
    pub fn dof(&self, name: &str) -> Result<usize, SimError> {
        self.dof_index.get(name).copied().ok_or_else(|| SimError::Unknown {
            kind: "joint",
            name: name.into(),
            candidates: self.header.joint_names.clone(),
        })
    }

    /// Position and velocity limits of DOF `i`: (lower, upper, velocity).
    pub fn dof_limits(&self, i: usize) -> (f64, f64, f64) {
        let d = &self.dofs[i];
        (d.lower, d.upper, d.velocity_limit)
    }

    /// Motor gains of DOF `i`.
    pub fn gains(&self, i: usize) -> MotorGains {
        self.dofs[i].gains
    }

    /// Changes the gains of DOF `i`.
    pub fn set_gains(&mut self, i: usize, gains: MotorGains) {
        self.dofs[i].gains = gains;
        self.apply_motor_target(i);
    }

    /// Static names for snapshots.
    pub fn header(&self) -> &SnapshotHeader {
        &self.header
    }

    /// The objects.
    pub fn objects(&self) -> &[SimObject] {
        &self.objects
    }

    /// Index of an object by name.
    pub fn object(&self, name: &str) -> Result<usize, SimError> {
        self.objects
            .iter()
            .position(|o| o.name == name)
            .ok_or_else(|| SimError::Unknown {
                kind: "object",
                name: name.into(),
                candidates: self.objects.iter().map(|o| o.name.clone()).collect(),
            })
    }

    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Physics steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Encoder readings (rad), with noise.
    pub fn joint_positions(&self) -> &[f64] {
        &self.q
    }

    /// Joint velocities (rad/s).
    pub fn joint_velocities(&self) -> &[f64] {
        &self.qd
    }

    /// Motor references.
    pub fn joint_targets(&self) -> &[f64] {
        &self.q_ref
    }

    /// Motor velocity references (feed-forward q̇_ref of each PD).
    pub fn joint_target_velocities(&self) -> &[f64] {
        &self.qd_ref
    }

    /// Sets the motor reference of DOF `i` (clamped to its limits) with velocity feed-forward `qd`.
    pub fn set_joint_target(&mut self, i: usize, q: f64, qd: f64) {
        let d = &self.dofs[i];
        let q = if q.is_finite() {
            q.clamp(d.lower, d.upper)
        } else {
            self.q_ref[i]
        };
        if q != self.q_ref[i] || qd != self.qd_ref[i] {
            // A sleeping multibody ignores motor changes until woken.
            let body = d.body;
            self.world.wake_up(body, true);
        }
        let d = &self.dofs[i];
        self.q_ref[i] = q;
        self.qd_ref[i] = if qd.is_finite() {
            qd.clamp(-d.velocity_limit, d.velocity_limit)
        } else {
            0.0
        };
        self.apply_motor_target(i);
    }

    fn apply_motor_targets(&mut self) {
        for i in 0..self.dofs.len() {
            self.apply_motor_target(i);
        }
    }

    fn apply_motor_target(&mut self, i: usize) {
        let d = &self.dofs[i];
        let (q, qd, g) = (self.q_ref[i], self.qd_ref[i], d.gains);
        let mbj = &mut self.world.multibody_joints;
        if let Some(&id) = mbj.rigid_body_link(d.body)
            && let Some(mb) = mbj.get_multibody_mut(id.multibody)
            && let Some(link) = mb.link_mut(id.id)
        {
            link.joint.data.set_motor(JointAxis::AngX, q, qd, g.kp, g.kd);
            link.joint.data.set_motor_max_force(JointAxis::AngX, g.max_effort);
        }
    }

    /// True joint position of DOF `i` (no noise).
    fn true_position(&self, body: RigidBodyHandle) -> (f64, f64) {
        let mbj = &self.world.multibody_joints;
        if let Some(&id) = mbj.rigid_body_link(body)
            && let Some(mb) = mbj.get_multibody(id.multibody)
            && let Some(link) = mb.link(id.id)
        {
            let q = link.joint.coords()[3];
            let v = mb.joint_velocity(link);
            return (q, if v.is_empty() { 0.0 } else { v[0] });
        }
        (0.0, 0.0)
    }

    fn read_encoders(&mut self) {
        for i in 0..self.dofs.len() {
            let (q, qd) = self.true_position(self.dofs[i].body);
            let noise = self.settings.encoder_noise * self.rng.normal();
            self.q[i] = q + noise;
            self.qd[i] = qd;
        }
    }

    /// Puts the robot at configuration `q` (all independent DOFs, zero velocity) and sets the motor
    /// references there. Mimic joints follow. Use before the run starts.
    pub fn set_configuration(&mut self, q: &[f64]) -> Result<(), SimError> {
        if q.len() != self.dofs.len() {
            return Err(SimError::Size {
                what: "configuration",
                expected: self.dofs.len(),
                got: q.len(),
            });
        }
        let mut targets: Vec<(RigidBodyHandle, f64)> = Vec::new();
        for (i, d) in self.dofs.iter().enumerate() {
            targets.push((d.body, q[i].clamp(d.lower, d.upper)));
        }
        for m in &self.mimics {
            targets.push((
                m.body,
                m.multiplier * q[m.master].clamp(self.dofs[m.master].lower, self.dofs[m.master].upper) + m.offset,
            ));
        }
        let mbj = &mut self.world.multibody_joints;
        let mut touched = Vec::new();
        for (body, value) in targets {
            if let Some(&id) = mbj.rigid_body_link(body)
                && let Some(mb) = mbj.get_multibody_mut(id.multibody)
            {
                let nd = mb.ndofs();
                let Some(link) = mb.link(id.id) else { continue };
                let current = link.joint.coords()[3];
                let a = link.assembly_id();
                let mut disp = vec![0.0; nd];
                disp[a] = value - current;
                mb.apply_displacements(&disp);
                mb.generalized_velocity_mut().fill(0.0);
                if !touched.contains(&id.multibody) {
                    touched.push(id.multibody);
                }
            }
        }
        for idx in touched {
            if let Some(mb) = self.world.multibody_joints.get_multibody_mut(idx) {
                mb.forward_kinematics(&self.world.bodies, true);
                mb.update_rigid_bodies(&mut self.world.bodies, true);
            }
        }
        for (i, &v) in q.iter().enumerate() {
            self.q_ref[i] = v.clamp(self.dofs[i].lower, self.dofs[i].upper);
            self.qd_ref[i] = 0.0;
        }
        self.apply_motor_targets();
        self.world.wake_up_all(true);
        self.read_encoders();
        Ok(())
    }

    /// Advances the physics by one step.
    pub fn step(&mut self) {
        self.world.step();
        self.resist_rolling();
        self.time += self.settings.dt;
        self.steps += 1;
        self.read_encoders();
    }

    /// Rolling resistance, which Rapier lacks (MuJoCo's rolling friction): an object rolling on a
    /// support beneath it — the table, a bin or another object, contacts whose normal is within 45°
    /// of vertical, below its centre of mass — and untouched by the robot feels the torque `c N r` against its rolling, `c` =
    /// [`SimSettings::rolling_resistance`], `N` the supports' normal force in the last step, `r` the
    /// height of its centre of mass above the contacts. It turns about the contact points (inertia
    /// `I + m r²`), so its horizontal spin and speed shrink together, never past zero. A sliding box
    /// does not spin and feels nothing. No allocation.
    fn resist_rolling(&mut self) {
        let c = self.settings.rolling_resistance;
        if c <= 0.0 {
            return;
        }
        let dt = self.settings.dt;
        for o in &self.objects {
            let Some(b) = self.world.bodies.get(o.body) else {
                continue;
            };
            if b.is_sleeping() {
                continue;
            }
            // Resting (or not turning about a horizontal axis): nothing to resist, and the contacts
            // are not walked.
            let w = b.angvel();
            let spin = (w.x * w.x + w.y * w.y).sqrt();
            if spin < ROLLING_MIN_SPIN {
                continue;
            }
            let com = b.center_of_mass();
            let (mut n, mut lever) = (0.0, 0.0);
            let mut handled = false;
            for pair in self.world.narrow_phase.contact_pairs_with(o.collider) {
                let object_is_1 = pair.collider1 == o.collider;
                // An object the robot touches moves as the hand makes it (and the grasp grid's
                // contacts stay as the NOTES measured them): only a free object rolls to rest.
                let other = if object_is_1 { pair.collider2 } else { pair.collider1 };
                if self.collider_part.contains_key(&other) {
                    handled |= pair.has_any_active_contact();
                    continue;
                }
                for m in pair.solver_manifolds() {
                    // The normal points from collider 1 to collider 2: up, into the object, from a support.
                    let up = if object_is_1 { -m.data.normal } else { m.data.normal };
                    if up.z < std::f64::consts::FRAC_1_SQRT_2 {
                        continue;
                    }
                    for sc in m.data.solver_contacts.iter() {
                        let Some(pt) = m.points.get(sc.contact_indices()[0] as usize) else {
                            continue;
                        };
                        let (w1, w2) = m.data.solver_contact_world_points(sc, &self.world.bodies);
                        let h = com.z - 0.5 * (w1.z + w2.z);
                        if h > 0.0 && pt.data.impulse > 0.0 {
                            n += pt.data.impulse / dt;
                            lever += pt.data.impulse / dt * h;
                        }
                    }
                }
            }
            if n <= 0.0 || handled {
                continue;
            }
            let r = lever / n;
            let mass = b.mass();
            if mass <= 0.0 {
                continue;
            }
            // The inertia about the (horizontal) spin axis: in the principal frame, Σ Iₖ aₖ².
            let mp = &b.mass_properties().local_mprops;
            let axis =
                (*b.rotation() * mp.principal_inertia_local_frame).inverse() * DVec3::new(w.x / spin, w.y / spin, 0.0);
            let pi = mp.principal_inertia();
            let i_h = pi.x * axis.x * axis.x + pi.y * axis.y * axis.y + pi.z * axis.z * axis.z;
            // The spin lost this step, and the speed its contact point's turning takes with it
            // (r Δω; no more than there is: a sliding, barely turning body is not stopped).
            let dw = (c * n * r * dt / (i_h + mass * r * r)).min(spin);
            let keep = 1.0 - dw / spin;
            let v = b.linvel();
            let speed = (v.x * v.x + v.y * v.y).sqrt();
            let slow = if speed > 0.0 {
                1.0 - (r * dw).min(speed) / speed
            } else {
                1.0
            };
            let Some(b) = self.world.bodies.get_mut(o.body) else {
                continue;
            };
            b.set_angvel(DVec3::new(w.x * keep, w.y * keep, w.z), false);
            b.set_linvel(DVec3::new(v.x * slow, v.y * slow, v.z), false);
        }
    }

    /// World pose of URDF link `link` (index into the model's links).
    pub fn link_pose(&self, link: usize) -> Iso3 {
        let (body, offset) = &self.link_body[link];
        match self.world.bodies.get(*body) {
            Some(b) => iso_from_glam(b.position()) * offset,
            None => Iso3::identity(),
        }
    }

    /// World pose of URDF link `name`.
    pub fn link_pose_by_name(&self, name: &str) -> Result<Iso3, SimError> {
        Ok(self.link_pose(self.model.link(name)?))
    }

    /// State of object `i`.
    pub fn object_state(&self, i: usize) -> ObjectState {
        let b = &self.world.bodies[self.objects[i].body];
        ObjectState {
            pose: iso_from_glam(b.position()),
            linvel: vec_from_glam(b.linvel()),
        }
    }

    /// Gives object `i` the impulse `impulse` (N·s, world) at the world point `at`: a push, whose
    /// outcome (slide, tip, roll) is the physics'.
    pub fn push_object(&mut self, i: usize, impulse: &Vec3, at: &Vec3) {
        if let Some(b) = self.world.bodies.get_mut(self.objects[i].body) {
            b.apply_impulse_at_point(vec_to_glam(impulse), vec_to_glam(at), true);
        }
    }

    /// Puts a fixed box of half extents `half_extents` at `pose` into the world: it collides with
    /// the arms, the hands and the objects from the next step on. Returns its index in
    /// [`DexterSim::obstacles`].
    pub fn add_obstacle(&mut self, half_extents: &Vec3, pose: &Iso3) -> usize {
        let body = self
            .world
            .insert_body(RigidBodyBuilder::fixed().pose(iso_to_glam(pose)).build());
        let collider = ColliderBuilder::cuboid(half_extents.x, half_extents.y, half_extents.z)
            .friction(0.5)
            .contact_skin(self.settings.contact_skin)
            .collision_groups(InteractionGroups::new(
                groups::OBSTACLE,
                groups::OBJECT | groups::HAND | groups::ARM,
                InteractionTestMode::And,
            ))
            .build();
        let collider = self.world.insert_collider(collider, Some(body));
        self.world.wake_up_all(true);
        self.obstacles.push(SimObstacle {
            half_extents: *half_extents,
            pose: *pose,
            collider,
        });
        self.obstacles.len() - 1
    }

    /// The obstacles put into the world so far ([`DexterSim::add_obstacle`]).
    pub fn obstacles(&self) -> &[SimObstacle] {
        &self.obstacles
    }

    /// The smallest distance (m) from a box of half extents `half_extents` at `pose` to the robot's
    /// links and the objects, up to `limit` (a pair farther apart by their bounding boxes counts as
    /// `limit`); for putting an obstacle where it touches nothing. Allocates nothing.
    pub fn clearance_of_box(&self, half_extents: &Vec3, pose: &Iso3, limit: f64) -> f64 {
        use rapier3d_f64::parry::bounding_volume::BoundingVolume as _;
        let shape = rapier3d_f64::parry::shape::Cuboid::new(vec_to_glam(half_extents));
        let at = iso_to_glam(pose);
        let aabb = rapier3d_f64::parry::shape::Shape::compute_aabb(&shape, &at).loosened(limit);
        let mut best = limit;
        let colliders = self
            .collider_part
            .keys()
            .chain(self.objects.iter().map(|o| &o.collider));
        for &h in colliders {
            let Some(c) = self.world.colliders.get(h) else {
                continue;
            };
            if !c.compute_aabb().intersects(&aabb) {
                continue;
            }
            let d =
                rapier3d_f64::parry::query::distance(&at, &shape, c.position(), c.shape()).map_or(0.0, |d| d.distance);
            best = best.min(d.max(0.0));
        }
        best
    }

    /// Angular velocity of object `i` (rad/s).
    pub fn object_angvel(&self, i: usize) -> Vec3 {
        vec_from_glam(self.world.bodies[self.objects[i].body].angvel())
    }

    /// Moves object `i` to `pose` at rest (tests, resets).
    pub fn teleport_object(&mut self, i: usize, pose: &Iso3) {
        if let Some(b) = self.world.bodies.get_mut(self.objects[i].body) {
            b.set_position(iso_to_glam(pose), true);
            b.set_linvel(DVec3::ZERO, true);
            b.set_angvel(DVec3::ZERO, true);
        }
    }

    /// World position of object `i`'s centre of mass.
    pub fn object_center_of_mass(&self, i: usize) -> Vec3 {
        vec_from_glam(self.world.bodies[self.objects[i].body].center_of_mass())
    }

    /// A snapshot of everything (allocates; for logs).
    pub fn snapshot(&self, activity: &str) -> Snapshot {
        let mut tips = [FingertipWrench {
            arm: Arm::Left,
            finger: 1,
            force: [0.0; 3],
            torque: [0.0; 3],
            in_contact: false,
        }; 6];
        self.fingertip_wrenches(&mut tips);
        Snapshot {
            time: self.time,
            q: self.q.clone(),
            qd: self.qd.clone(),
            q_ref: self.q_ref.clone(),
            link_poses: (0..self.model.links.len()).map(|l| self.link_pose(l)).collect(),
            objects: (0..self.objects.len()).map(|i| self.object_state(i)).collect(),
            fingertips: tips.to_vec(),
            activity: activity.to_string(),
        }
    }

    /// The colliders of the robot's links (for rendering and self-filtering).
    pub fn robot_colliders(&self) -> impl Iterator<Item = ColliderHandle> + '_ {
        let mut v: Vec<ColliderHandle> = self.collider_part.keys().copied().collect();
        v.sort_by_key(|h| h.into_raw_parts());
        v.into_iter()
    }

    /// The Rapier world (read-only), for rendering and queries.
    pub fn world(&self) -> &PhysicsWorld {
        &self.world
    }

    /// Number of rigid bodies and colliders (for reports).
    pub fn counts(&self) -> (usize, usize) {
        (self.world.bodies.len(), self.world.colliders.len())
    }
}

impl control_basis::Plant for DexterSim {
    fn joint_names(&self) -> &[String] {
        &self.header.joint_names
    }

    fn read_joint_positions(&self, q: &mut [f64]) {
        let n = q.len().min(self.q.len());
        q[..n].copy_from_slice(&self.q[..n]);
    }

    fn command(&mut self, references: &[f64]) -> Result<(), control_basis::CbError> {
        if references.len() != self.dofs.len() {
            return Err(control_basis::CbError::DimensionMismatch {
                what: "motor references".into(),
                expected: self.dofs.len(),
                got: references.len(),
            });
        }
        control_basis::error::check_finite("motor references", references)?;
        for (i, &r) in references.iter().enumerate() {
            self.set_joint_target(i, r, 0.0);
        }
        Ok(())
    }

    /// Advances by `dt_secs`, rounded to whole physics steps (at least one).
    fn step(&mut self, dt_secs: f64) -> Result<(), control_basis::CbError> {
        if !(dt_secs.is_finite() && dt_secs >= 0.0) {
            return Err(control_basis::CbError::NotFinite {
                what: "plant step (s)".into(),
                index: 0,
                value: dt_secs,
            });
        }
        let n = ((dt_secs / self.settings.dt).round() as usize).max(1);
        for _ in 0..n {
            DexterSim::step(self);
        }
        Ok(())
    }

    fn time_secs(&self) -> f64 {
        self.time
    }
}

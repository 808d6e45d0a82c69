//! The scenes of the side-by-side benchmark against MuJoCo (issue 17): the same work for both engines.
//!
//! [`record`] runs a scenario with pbd's own skills and keeps the motor references of every control
//! period ([`Trajectory`]); [`replay`] applies them again, step by step, and times only the physics.
//! [`DexterSim::to_mjcf`] writes the same world for MuJoCo, which replays the same references
//! (`benches/peers/sim_vs_mujoco.py`; the pbd side is `examples/scene_bench.rs`, the criterion bench
//! `benches/scene.rs`).
//!
//! Scenarios, all in the built-in `sorting` scene (two arms, two hands, head, table, two bins, six
//! objects) with sleeping off, from the parked robot after [`SETTLE_STEPS`]:
//! - `hold`: both arms and hands hold the parked posture, the objects rest (5 s);
//! - `grasp`: the left arm picks `glass_cleaner` and puts it in `bin-left` ([`pick_and_place_in`]);
//! - `transfer`: a hand-to-hand transfer as the executive does it (`dexter::exec`: the first hand
//!   puts the object on a hand-off spot both reach, the other takes it from there): the left arm puts
//!   `glass_cleaner` on `handoff` (a flat 12 cm square at (0.70, 0.02)), the right arm takes it to
//!   `bin-right`.
//!
//! Trajectory file (JSON of [`Trajectory`]): the references in `periods[k]` hold for the steps
//! before `until` (and from the previous period's `until`); a reset puts the robot at `q` (all
//! DOFs, zero velocity) before step `step`.
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::hardware::park_robot;
use crate::physics::{DexterSim, SimSettings};
use crate::pick_place::{PickPlaceRequest, WorldObserver, pick_and_place_in};
use crate::scene::{PlaceSpec, Scene};
use crate::{Arm, SimError};

/// The motor references of one control period.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Period {
    /// The references hold for the steps before this one (and from the previous period's `until`).
    pub until: u64,
    /// Motor position references (DOF order of [`Trajectory::dofs`]).
    pub q_ref: Vec<f64>,
    /// Motor velocity references.
    pub qd_ref: Vec<f64>,
}

/// The robot put at a configuration (as `park_robot` does).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Reset {
    /// Before this step.
    pub step: u64,
    /// The configuration (all DOFs, zero velocity).
    pub q: Vec<f64>,
}

/// One recorded scenario: what both engines replay.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Trajectory {
    /// `hold`, `grasp` or `transfer`.
    pub scenario: String,
    /// Physics step (s).
    pub dt: f64,
    /// Physics steps of the run.
    pub steps: u64,
    /// The motor units (DOF names).
    pub dofs: Vec<String>,
    /// Their PD stiffness (N·m/rad).
    pub kp: Vec<f64>,
    /// Their PD damping (N·m·s/rad).
    pub kd: Vec<f64>,
    /// References at the start.
    pub initial_q_ref: Vec<f64>,
    /// Velocity references at the start.
    pub initial_qd_ref: Vec<f64>,
    /// One entry per control period.
    pub periods: Vec<Period>,
    /// Configuration resets (the pick-and-place skill parks the robot before it starts).
    pub resets: Vec<Reset>,
    /// The object the task moves.
    pub object: String,
    /// What the recording run reported (pick-and-place outcomes).
    pub recorded_outcome: Vec<String>,
}

/// Steps the parked robot and the objects settle before the scenarios start.
pub const SETTLE_STEPS: usize = 300;

/// The scenarios, in order.
pub const SCENARIOS: [&str; 3] = ["hold", "grasp", "transfer"];

/// The benchmark's settings: the defaults with sleeping off (MuJoCo does not sleep; a sleeping
/// world is not a physics figure).
pub fn settings() -> SimSettings {
    SimSettings {
        allow_sleep: false,
        ..SimSettings::default()
    }
}

/// The bench scene: `sorting` with a flat hand-off spot in the middle of the table.
pub fn scene() -> Result<Scene, SimError> {
    let mut scene = Scene::builtin("sorting")?;
    let mut handoff: PlaceSpec = scene.place("bin-left")?.clone();
    handoff.name = "handoff".into();
    handoff.center = [0.70, 0.02];
    handoff.size = [0.12, 0.12];
    handoff.wall_height = 0.0;
    scene.spec.places.push(handoff);
    Ok(scene)
}

/// The start of every scenario: parked, settled ([`SETTLE_STEPS`]).
pub fn start(scene: &Scene, settings: &SimSettings) -> Result<DexterSim, SimError> {
    let mut sim = DexterSim::new(scene, settings.clone())?;
    park_robot(&mut sim, scene.spec.table.height)?;
    for _ in 0..SETTLE_STEPS {
        sim.step();
    }
    Ok(sim)
}

/// Runs `scenario` with pbd's own skills from [`start`] and records its motor references.
pub fn record(scene: &Scene, settings: &SimSettings, scenario: &str) -> Result<Trajectory, SimError> {
    let mut sim = start(scene, settings)?;
    let s0 = sim.steps();
    let mut traj = Trajectory {
        scenario: scenario.into(),
        dt: sim.settings().dt,
        steps: 0,
        dofs: sim.joint_names().to_vec(),
        kp: (0..sim.joint_names().len()).map(|i| sim.gains(i).kp).collect(),
        kd: (0..sim.joint_names().len()).map(|i| sim.gains(i).kd).collect(),
        initial_q_ref: sim.joint_targets().to_vec(),
        initial_qd_ref: sim.joint_target_velocities().to_vec(),
        periods: Vec::new(),
        resets: Vec::new(),
        object: String::new(),
        recorded_outcome: Vec::new(),
    };
    let requests: Vec<PickPlaceRequest> = match scenario {
        "hold" => Vec::new(),
        "grasp" => vec![PickPlaceRequest {
            object: "glass_cleaner".into(),
            place: "bin-left".into(),
            arm: Some(Arm::Left),
        }],
        "transfer" => vec![
            PickPlaceRequest {
                object: "glass_cleaner".into(),
                place: "handoff".into(),
                arm: Some(Arm::Left),
            },
            PickPlaceRequest {
                object: "glass_cleaner".into(),
                place: "bin-right".into(),
                arm: Some(Arm::Right),
            },
        ],
        other => {
            return Err(SimError::Unknown {
                kind: "benchmark scenario",
                name: other.into(),
                candidates: SCENARIOS.iter().map(|s| s.to_string()).collect(),
            });
        }
    };
    if requests.is_empty() {
        for _ in 0..5000 {
            sim.step();
        }
        traj.object = "jif".into();
    }
    let mut periods: Vec<Period> = Vec::new();
    for (k, req) in requests.iter().enumerate() {
        if k > 0 {
            // pick_and_place_in parks the robot first: record that as a reset.
            park_robot(&mut sim, scene.spec.table.height)?;
            traj.resets.push(Reset {
                step: sim.steps() - s0,
                q: sim.joint_positions().to_vec(),
            });
        }
        let mut tick = |s: &DexterSim, _: &str| {
            periods.push(Period {
                until: s.steps() - s0,
                q_ref: s.joint_targets().to_vec(),
                qd_ref: s.joint_target_velocities().to_vec(),
            });
        };
        // The robot searches near where the scene put the object: after a hand-off, that is the
        // hand-off spot.
        let mut here = scene.clone();
        let o = sim.object(&req.object)?;
        let idx = sim.objects()[o].scene_index;
        here.resolved[idx].pose = sim.object_state(o).pose;
        let report = pick_and_place_in(&mut sim, &here, req, &mut WorldObserver::new(&mut tick))?;
        traj.recorded_outcome.push(format!(
            "{} -> {}: {} ({})",
            req.object, req.place, report.success, report.outcome
        ));
        traj.object = req.object.clone();
    }
    traj.periods = periods;
    traj.steps = sim.steps() - s0;
    Ok(traj)
}

/// What a replay measured.
#[derive(Debug, Clone, Serialize)]
pub struct ReplayStats {
    /// Steps taken.
    pub steps: u64,
    /// Wall time of the stepping (s).
    pub seconds: f64,
    /// Steps per second.
    pub steps_per_s: f64,
    /// Solver contact points, mean over every 10th step.
    pub contacts_mean: f64,
    /// Solver contact points, maximum over every 10th step.
    pub contacts_max: usize,
    /// Where the task's object ended (m, world).
    pub object_final: [f64; 3],
}

/// Replays steps `0..until` (all when `None`) of `traj` in `sim` (which must be at [`start`]):
/// the references are applied at the recorded steps, and only the stepping is timed.
pub fn replay(sim: &mut DexterSim, traj: &Trajectory, until: Option<u64>) -> Result<ReplayStats, SimError> {
    let n = sim.joint_names().len();
    if traj.dofs != sim.joint_names() {
        return Err(SimError::Unsupported("the trajectory's DOFs are not this robot's"));
    }
    // A trajectory file is input: every vector must have one entry per DOF, every number be finite.
    let vectors = [&traj.initial_q_ref, &traj.initial_qd_ref]
        .into_iter()
        .chain(traj.periods.iter().flat_map(|p| [&p.q_ref, &p.qd_ref]))
        .chain(traj.resets.iter().map(|r| &r.q));
    for v in vectors {
        if v.len() != n {
            return Err(SimError::Size {
                what: "trajectory reference vector",
                expected: n,
                got: v.len(),
            });
        }
        if v.iter().any(|x| !x.is_finite()) {
            return Err(SimError::Unsupported("a trajectory reference is not a finite number"));
        }
    }
    let steps = until.unwrap_or(traj.steps).min(traj.steps);
    let obj = sim.object(&traj.object)?;
    let t0 = Instant::now();
    let mut contacts_sum = 0usize;
    let mut contacts_max = 0usize;
    let mut samples = 0usize;
    let mut period = 0usize;
    let mut reset = 0usize;
    let mut current: (&[f64], &[f64]) = (&traj.initial_q_ref, &traj.initial_qd_ref);
    for i in 0..n {
        sim.set_joint_target(i, current.0[i], current.1[i]);
    }
    for step in 0..steps {
        if reset < traj.resets.len() && traj.resets[reset].step == step {
            sim.set_configuration(&traj.resets[reset].q)?;
            reset += 1;
        }
        while period < traj.periods.len() && traj.periods[period].until <= step {
            period += 1;
        }
        if period < traj.periods.len() {
            let p = &traj.periods[period];
            if !std::ptr::eq(current.0.as_ptr(), p.q_ref.as_ptr()) {
                current = (&p.q_ref, &p.qd_ref);
                for i in 0..n {
                    sim.set_joint_target(i, p.q_ref[i], p.qd_ref[i]);
                }
            }
        }
        sim.step();
        if step % 10 == 0 {
            let c = sim.active_contacts();
            contacts_sum += c;
            contacts_max = contacts_max.max(c);
            samples += 1;
        }
    }
    let secs = t0.elapsed().as_secs_f64();
    let p = sim.object_state(obj).pose.translation.vector;
    Ok(ReplayStats {
        steps,
        seconds: secs,
        steps_per_s: steps as f64 / secs,
        contacts_mean: contacts_sum as f64 / samples.max(1) as f64,
        contacts_max,
        object_final: [p.x, p.y, p.z],
    })
}

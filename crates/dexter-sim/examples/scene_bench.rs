//! The pbd side of the side-by-side benchmark against MuJoCo (`benches/peers/sim_vs_mujoco.py`).
//!
//! ```text
//! cargo run --release -p dexter-sim --example scene_bench -- export DIR
//! cargo run --release -p dexter-sim --example scene_bench -- run hold|grasp|transfer DIR [REPS]
//! ```
//!
//! `export` builds the built-in `sorting` scene (two arms, two hands, head, table, two bins, six
//! objects; sleeping off, as MuJoCo has none), parks the robot, lets it settle, and writes
//! - `DIR/dexter.xml`: that world as MJCF ([`DexterSim::to_mjcf`]), keyframe `now` = this state;
//! - `DIR/<scenario>.json`: the motor references of every control period of one run, recorded
//!   from pbd's own skills, for three scenarios:
//!   - `hold`: both arms and hands hold the parked posture, the objects rest (5 s);
//!   - `grasp`: the left arm picks `glass_cleaner` and puts it in `bin-left` (`pick_and_place_in`);
//!   - `transfer`: a hand-to-hand transfer as the executive does it (exec.rs: the first hand puts
//!     the object on a hand-off spot both reach, the other takes it from there): the left arm puts
//!     `glass_cleaner` on `handoff` (a flat 12 cm square at (0.70, 0.02)), the right arm takes it
//!     to `bin-right`.
//!
//! `SIM_MM_ONCE=0` sets `SimSettings::mass_matrix_once_per_step` to false (rapier's own schedule).
//!
//! `run` replays a scenario in pbd from the exported state: the references are applied at the
//! recorded steps, the physics steps are timed (REPS repetitions, default 3), and one JSON line is
//! printed: steps, seconds per repetition, steps/s, the mean and maximum number of solver contact
//! points, and where the task's object ended.
//!
//! Trajectory file (`<scenario>.json`): `{"scenario", "dt", "steps", "dofs": [names], "kp": [..],
//! "kd": [..], "initial_q_ref": [..], "initial_qd_ref": [..], "periods": [{"until": step,
//! "q_ref": [..], "qd_ref": [..]}], "resets": [{"step": k, "q": [..]}], "object": name}` — the
//! references in `periods[k]` hold for the steps before `until` (and after the previous period);
//! a reset puts the robot at `q` (all DOFs, zero velocity) before step `k`.
use dexter_sim::physics::{DexterSim, SimSettings};
use dexter_sim::pick_place::{PickPlaceRequest, WorldObserver, pick_and_place_in};
use dexter_sim::scene::{PlaceSpec, Scene};
use dexter_sim::{Arm, hardware::park_robot};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Instant;

#[derive(Debug, Clone, Serialize, Deserialize)]
struct Period {
    until: u64,
    q_ref: Vec<f64>,
    qd_ref: Vec<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
struct Reset {
    step: u64,
    q: Vec<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
struct Trajectory {
    scenario: String,
    dt: f64,
    steps: u64,
    dofs: Vec<String>,
    kp: Vec<f64>,
    kd: Vec<f64>,
    initial_q_ref: Vec<f64>,
    initial_qd_ref: Vec<f64>,
    periods: Vec<Period>,
    resets: Vec<Reset>,
    object: String,
    /// What the recording run reported (pick-and-place outcomes).
    recorded_outcome: Vec<String>,
}

const SETTLE_STEPS: usize = 300;

fn settings() -> SimSettings {
    let once = std::env::var("SIM_MM_ONCE").map(|v| v.trim() != "0").unwrap_or(true);
    SimSettings {
        allow_sleep: false,
        mass_matrix_once_per_step: once,
        ..SimSettings::default()
    }
}

/// The bench scene: `sorting` with a flat hand-off spot in the middle of the table.
fn scene() -> Result<Scene, Box<dyn std::error::Error>> {
    let mut scene = Scene::builtin("sorting")?;
    let mut handoff: PlaceSpec = scene.place("bin-left")?.clone();
    handoff.name = "handoff".into();
    handoff.center = [0.70, 0.02];
    handoff.size = [0.12, 0.12];
    handoff.wall_height = 0.0;
    scene.spec.places.push(handoff);
    Ok(scene)
}

/// The exported start: parked, settled.
fn start(scene: &Scene) -> Result<DexterSim, Box<dyn std::error::Error>> {
    let mut sim = DexterSim::new(scene, settings())?;
    park_robot(&mut sim, scene.spec.table.height)?;
    for _ in 0..SETTLE_STEPS {
        sim.step();
    }
    Ok(sim)
}

fn record(scene: &Scene, scenario: &str) -> Result<Trajectory, Box<dyn std::error::Error>> {
    let mut sim = start(scene)?;
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
        other => return Err(format!("unknown scenario `{other}` (hold, grasp, transfer)").into()),
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

fn replay(scene: &Scene, traj: &Trajectory) -> Result<serde_json::Value, Box<dyn std::error::Error>> {
    let mut sim = start(scene)?;
    let n = sim.joint_names().len();
    if traj.dofs != sim.joint_names() {
        return Err("the trajectory's DOFs are not this robot's".into());
    }
    let obj = sim.object(&traj.object)?;
    let trace = std::env::var_os("SB_TRACE").is_some();
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
    for step in 0..traj.steps {
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
        if trace && step % 1000 == 0 {
            let palm = sim.link_pose_by_name("left/wrist_palm_link")?.translation.vector;
            let o = sim.object_state(obj).pose.translation.vector;
            eprintln!(
                "trace {step}: palm ({:.3}, {:.3}, {:.3}) object ({:.3}, {:.3}, {:.3}) q {:.3?}",
                palm.x,
                palm.y,
                palm.z,
                o.x,
                o.y,
                o.z,
                &sim.joint_positions()[..11]
            );
        }
        if step % 10 == 0 {
            let c = sim.active_contacts();
            contacts_sum += c;
            contacts_max = contacts_max.max(c);
            samples += 1;
        }
    }
    let secs = t0.elapsed().as_secs_f64();
    let p = sim.object_state(obj).pose.translation.vector;
    Ok(serde_json::json!({
        "engine": "pbd",
        "scenario": traj.scenario,
        "steps": traj.steps,
        "seconds": secs,
        "steps_per_s": traj.steps as f64 / secs,
        "contacts_mean": contacts_sum as f64 / samples.max(1) as f64,
        "contacts_max": contacts_max,
        "object": traj.object,
        "object_final": [p.x, p.y, p.z],
    }))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene = scene()?;
    match args.first().map(String::as_str) {
        Some("export") => {
            let dir = Path::new(args.get(1).ok_or("export DIR")?);
            std::fs::create_dir_all(dir)?;
            let sim = start(&scene)?;
            std::fs::write(dir.join("dexter.xml"), sim.to_mjcf()?)?;
            for link in [
                "left/wrist_palm_link",
                "left/bhand/finger_3/dist_link",
                "right/wrist_palm_link",
            ] {
                let p = sim.link_pose_by_name(link)?.translation.vector;
                eprintln!("start: {link} at ({:.4}, {:.4}, {:.4})", p.x, p.y, p.z);
            }
            for scenario in ["hold", "grasp", "transfer"] {
                let t = Instant::now();
                let traj = record(&scene, scenario)?;
                std::fs::write(dir.join(format!("{scenario}.json")), serde_json::to_string(&traj)?)?;
                eprintln!(
                    "recorded {scenario}: {} steps, {} periods, {:?} ({:.1} s)",
                    traj.steps,
                    traj.periods.len(),
                    traj.recorded_outcome,
                    t.elapsed().as_secs_f64()
                );
            }
            Ok(())
        }
        Some("run") => {
            let scenario = args.get(1).ok_or("run SCENARIO DIR [REPS]")?;
            let dir = Path::new(args.get(2).ok_or("run SCENARIO DIR [REPS]")?);
            let reps: usize = args.get(3).map(|r| r.parse()).transpose()?.unwrap_or(3);
            let path = dir.join(format!("{scenario}.json"));
            let traj: Trajectory =
                serde_json::from_str(&std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?)
                    .map_err(|e| format!("{}: {e}", path.display()))?;
            for _ in 0..reps {
                println!("{}", replay(&scene, &traj)?);
            }
            Ok(())
        }
        _ => Err("usage: scene_bench export DIR | run hold|grasp|transfer DIR [REPS]".into()),
    }
}

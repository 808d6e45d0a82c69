//! The pbd side of the side-by-side benchmark against MuJoCo (`benches/peers/sim_vs_mujoco.py`;
//! scenarios and file format: `dexter_sim::bench_scene`).
//!
//! ```text
//! cargo run --release -p dexter-sim --example scene_bench -- export DIR
//! cargo run --release -p dexter-sim --example scene_bench -- run hold|grasp|transfer DIR [REPS]
//! ```
//!
//! `export` writes `DIR/dexter.xml` (the start state as MJCF, keyframe `now`) and
//! `DIR/<scenario>.json` (the recorded references) for the three scenarios. `run` replays one
//! scenario REPS times (default 3) and prints one JSON line per repetition (steps, seconds, steps/s,
//! contact points, where the object ended). `SIM_MM_ONCE=0` replays with
//! `SimSettings::mass_matrix_once_per_step = false`; `SIM_ITERATIONS=N` with N solver substeps; `SIM_MM_REUSE=0` rebuilds the mass matrices at every step (no reuse while an arm rests).
use dexter_sim::bench_scene::{SCENARIOS, Trajectory, record, replay, scene, settings, start};
use std::path::Path;
use std::time::Instant;

fn bench_settings() -> dexter_sim::physics::SimSettings {
    let mut s = settings();
    if let Ok(v) = std::env::var("SIM_MM_ONCE") {
        s.mass_matrix_once_per_step = v.trim() != "0";
    }
    if std::env::var("SIM_MM_REUSE").is_ok_and(|v| v.trim() == "0") {
        s.mass_matrix_reuse = None;
    }
    if let Some(n) = std::env::var("SIM_ITERATIONS").ok().and_then(|v| v.trim().parse().ok()) {
        s.solver_iterations = n;
    }
    s
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene = scene()?;
    let settings = bench_settings();
    match args.first().map(String::as_str) {
        Some("export") => {
            let dir = Path::new(args.get(1).ok_or("export DIR")?);
            std::fs::create_dir_all(dir)?;
            let sim = start(&scene, &settings)?;
            std::fs::write(dir.join("dexter.xml"), sim.to_mjcf()?)?;
            for scenario in SCENARIOS {
                let t = Instant::now();
                let traj = record(&scene, &settings, scenario)?;
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
                let mut sim = start(&scene, &settings)?;
                let stats = replay(&mut sim, &traj, None)?;
                let mut v = serde_json::to_value(&stats)?;
                v["engine"] = "pbd".into();
                v["scenario"] = scenario.as_str().into();
                v["object"] = traj.object.as_str().into();
                println!("{v}");
            }
            Ok(())
        }
        _ => Err("usage: scene_bench export DIR | run hold|grasp|transfer DIR [REPS]".into()),
    }
}

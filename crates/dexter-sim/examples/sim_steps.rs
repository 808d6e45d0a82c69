//! Physics steps per second of the full Dexter scene ("sorting": two arms, two hands, head, table,
//! bins, six objects), for timing whole runs and comparing settings.
//!
//! ```text
//! cargo run --release -p dexter-sim --example sim_steps -- [STEPS]
//! ```
//!
//! `STEPS` (default 10000) physics steps are taken after set-up (scene, parked robot). Options, as
//! environment variables:
//! - `SIM_ITERS=n`: `SimSettings::solver_iterations` (default: the crate's default);
//! - `SIM_SLEEP=0|1`: `SimSettings::allow_sleep` (default: the crate's default);
//! - `SIM_MOVE=1`: the left arm keeps moving (Reach tick every 5 steps, goals 10 cm apart alternating
//!   every 0.5 s), so the figure is not only about resting bodies;
//! - `SIM_MM_ONCE=0|1`: `SimSettings::mass_matrix_once_per_step` (default: the crate's default);
//! - `SIM_SETTLE=n`: steps taken before timing starts (default 0).
//!
//! Prints set-up time, stepping time, steps/s, the number of awake bodies at the end, the
//! multibodies' sizes and state sums (exact, to compare trajectories between builds).
use dexter::control::ReachControl;
use dexter_sim::Arm;
use dexter_sim::hardware::SimRobot;
use dexter_sim::hardware::park_robot;
use dexter_sim::physics::{DexterSim, SimSettings};
use dexter_sim::scene::Scene;
use std::time::Instant;

fn env<T: std::str::FromStr>(name: &str) -> Option<T> {
    std::env::var(name).ok().and_then(|v| v.trim().parse().ok())
}

fn main() {
    let steps: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(10_000);
    let mut settings = SimSettings::default();
    if let Some(n) = env::<usize>("SIM_ITERS") {
        settings.solver_iterations = n;
    }
    if let Some(s) = env::<u8>("SIM_SLEEP") {
        settings.allow_sleep = s != 0;
    }
    if let Some(s) = env::<u8>("SIM_MM_ONCE") {
        settings.mass_matrix_once_per_step = s != 0;
    }
    let moving = env::<u8>("SIM_MOVE").unwrap_or(0) != 0;
    let settle: u64 = env("SIM_SETTLE").unwrap_or(0);

    let t0 = Instant::now();
    let scene = Scene::builtin("sorting").expect("sorting scene");
    let mut sim = DexterSim::new(&scene, settings.clone()).expect("sim");
    park_robot(&mut sim, scene.spec.table.height).expect("park");
    for _ in 0..settle {
        sim.step();
    }
    let mut hw = SimRobot::new(&mut sim, &scene, 0).expect("hardware");
    let mut reach = if moving {
        Some(ReachControl::new(&hw, Arm::Left).expect("reach"))
    } else {
        None
    };
    let start = reach.as_mut().map(|r| r.tool_pose(&hw));
    let setup = t0.elapsed().as_secs_f64();

    // Control period 5 steps; goal switch every 0.5 s of simulated time.
    let per = 5u64;
    let switch = ((0.5 / settings.dt).round() as u64).max(per);
    let mut tick_time = 0.0;
    let t1 = Instant::now();
    for k in 0..steps {
        if let (Some(r), Some(start)) = (reach.as_mut(), start) {
            if k % switch == 0 {
                let mut goal = start;
                goal.translation.vector.y += if (k / switch).is_multiple_of(2) { 0.1 } else { 0.0 };
                r.set_goal(&hw, goal);
            }
            if k % per == 0 {
                let tt = Instant::now();
                r.tick(&mut hw, per as f64 * settings.dt);
                tick_time += tt.elapsed().as_secs_f64();
            }
        }
        hw.sim_mut().step();
    }
    let run = t1.elapsed().as_secs_f64();
    let goal_error = reach.as_mut().map(|r| r.goal_error(&hw));
    drop(hw);
    let awake = sim.world().islands.num_active_bodies();
    let (bodies, colliders) = sim.counts();
    // Final state, to check that a speed change leaves the trajectory unchanged: the joint positions
    // and object positions, printed exactly, plus the left arm's goal error (moving mode).
    let q_sum: f64 = sim.joint_positions().iter().sum();
    let obj_sum: f64 = (0..sim.objects().len())
        .map(|i| sim.object_state(i).pose.translation.vector.sum())
        .sum();
    let goal_err = goal_error.map(|e| e.0);
    let multibodies: Vec<String> = sim
        .world()
        .multibody_joints
        .multibodies()
        .map(|m| format!("{}/{}", m.num_links(), m.ndofs()))
        .collect();
    println!(
        "sim_steps: iters {} sleep {} moving {} settle {} | setup {:.3} s | {} steps in {:.3} s = {:.0} steps/s \
         ({:.1} us/step, reach ticks {:.3} s) | awake bodies {}/{} colliders {} multibodies (links/dofs) {} \
         | state sum q {:e} objects {:e} goal error {:?}",
        settings.solver_iterations,
        settings.allow_sleep,
        moving,
        settle,
        setup,
        steps,
        run,
        steps as f64 / run.max(1e-12),
        run / (steps.max(1) as f64) * 1e6,
        tick_time,
        awake,
        bodies,
        colliders,
        multibodies.join(" "),
        q_sum,
        obj_sum,
        goal_err
    );
}

//! Physics steps per second of the full Dexter scene (two arms, two hands, head, table, two bins,
//! six objects), and a whole control period (one control-basis Reach tick + 5 physics steps).
use control_basis::Hardware;
use criterion::{Criterion, criterion_group, criterion_main};
use dexter::control::ReachControl;
use dexter::eyes::{Eyes, Pair};
use dexter_sim::Arm;
use dexter_sim::hardware::SimRobot;
use dexter_sim::hardware::park_robot;
use dexter_sim::physics::{DexterSim, SimSettings};
use dexter_sim::scene::Scene;
use std::hint::black_box;

fn scene() -> Scene {
    let s = Scene::builtin("sorting").expect("sorting scene");
    assert!(s.resolved.len() >= 5, "sorting scene has {} objects", s.resolved.len());
    s
}

fn sim(settings: SimSettings) -> DexterSim {
    let scene = scene();
    let mut sim = DexterSim::new(&scene, settings).expect("sim");
    park_robot(&mut sim, scene.spec.table.height).expect("park");
    for _ in 0..300 {
        sim.step();
    }
    sim
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("dexter_sim");
    for (name, settings) in [
        (
            "step_full_scene_awake_objects",
            SimSettings {
                allow_sleep: false,
                ..SimSettings::default()
            },
        ),
        ("step_full_scene_default", SimSettings::default()),
    ] {
        let mut s = sim(settings);
        g.bench_function(name, |b| b.iter(|| black_box(&mut s).step()));
    }
    let scene0 = scene();
    let mut s0 = sim(SimSettings::default());
    let mut s = SimRobot::new(&mut s0, &scene0, 1).expect("hardware");
    let mut reach = ReachControl::new(&s, Arm::Left).expect("reach");
    let goal = reach.tool_pose(&s);
    reach.set_goal(&s, goal);
    g.bench_function("control_period_reach_tick_plus_5_steps", |b| {
        b.iter(|| {
            reach.tick(&mut s, 0.005);
            s.advance(0.005).expect("advance");
        })
    });
    drop(s);
    // Real-time factor with everything at its rate: physics 1 kHz, Reach ◁ Manipulability at 200 Hz
    // on the moving arm, head stereo render + segmentation + matching at 10 Hz; 0.1 s of simulated
    // time per iteration (RTF = 0.1 s / time).
    let scene = scene();
    let mut s1 = sim(SimSettings::default());
    let mut s = SimRobot::new(&mut s1, &scene, 1).expect("hardware");
    let calibration = dexter_sim::calibrate::workcell_calibration(&scene).expect("calibration");
    let mut eyes = Eyes::new(&s, scene.spec.table.height, calibration).expect("eyes");
    let mut reach = ReachControl::new(&s, Arm::Left).expect("reach");
    let start = reach.tool_pose(&s);
    let mut k = 0u64;
    g.bench_function("sim_100ms_physics_1khz_control_200hz_stereo_10hz", |b| {
        b.iter(|| {
            // Keep the arm moving: alternate between two goals 10 cm apart.
            let mut goal = start;
            goal.translation.vector.y += if k.is_multiple_of(2) { 0.1 } else { 0.0 };
            k += 1;
            reach.set_goal(&s, goal);
            black_box(eyes.perceive(&mut s, Pair::Head).expect("perceive").len());
            for _ in 0..20 {
                reach.tick(&mut s, 0.005);
                s.advance(0.005).expect("advance");
            }
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(4));
    targets = bench
}
criterion_main!(benches);

//! The scenes of the side-by-side benchmark against MuJoCo (`dexter_sim::bench_scene`;
//! `benches/peers/sim_vs_mujoco.py` runs both engines in one go). Sleeping is off.
//!
//! ```text
//! cargo bench -p dexter-sim --bench scene
//! ```
//! - `hold_step`: one physics step of the full scene holding its posture (scene a);
//! - `grasp_replay_6000_steps`: the first 6 s of the recorded left-arm pick (reach, close, lift;
//!   scene b), from the parked start each time (set-up not timed).
//!
//! The hand-to-hand transfer (scene c) is 26 s long; the Python script times it.
use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use dexter_sim::bench_scene::{record, replay, scene, settings, start};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let scene = scene().expect("bench scene");
    let settings = settings();
    let mut g = c.benchmark_group("scene");
    let mut sim = start(&scene, &settings).expect("start");
    g.bench_function("hold_step", |b| b.iter(|| black_box(&mut sim).step()));
    let grasp = record(&scene, &settings, "grasp").expect("record the grasp");
    g.bench_function("grasp_replay_6000_steps", |b| {
        b.iter_batched(
            || start(&scene, &settings).expect("start"),
            |mut sim| black_box(replay(&mut sim, &grasp, Some(6000)).expect("replay")),
            BatchSize::PerIteration,
        )
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10).measurement_time(std::time::Duration::from_secs(20));
    targets = bench
}
criterion_main!(benches);

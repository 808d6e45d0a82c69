//! Gibbs sweeps per second (the DESIGN's "Gibbs sweeps per second for M objects × N grasps × A
//! prototypes") and how the time per sweep scales with M·N·A.
//!
//! Run: `cargo bench -p grasp-topics --bench gibbs`.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use grasp_topics::synthetic::{SyntheticSpec, sample_dataset, well_separated_prototypes};
use grasp_topics::{Dataset, DpState, GibbsState, Hyperparameters};
use std::hint::black_box;

fn data(m: usize, n: usize) -> Dataset {
    let mut rng = bayes::rng::seeded(1);
    let spec = SyntheticSpec {
        objects: m,
        grasps_per_object: n,
        alpha: 0.3,
        appearance_dof: 20.0,
        prototypes: well_separated_prototypes(10, 6, 20.0),
    };
    sample_dataset(&spec, &mut rng).unwrap().data
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("gibbs_sweep");
    g.sample_size(20);
    for &(m, n, a) in &[
        (100, 20, 20),
        (25, 20, 20),
        (50, 20, 20),
        (200, 20, 20),
        (100, 20, 5),
        (100, 20, 10),
        (100, 20, 40),
        (100, 20, 80),
    ] {
        let d = data(m, n);
        let hyper = Hyperparameters::from_data(&d);
        let mut rng = bayes::rng::seeded(2);
        let mut state = GibbsState::new(&d, &hyper, a).unwrap();
        state.initialise(&d, &mut rng);
        g.throughput(Throughput::Elements((m * n * a) as u64));
        g.bench_with_input(BenchmarkId::new("finite", format!("M{m}_N{n}_A{a}")), &(), |b, _| {
            b.iter(|| state.sweep(black_box(&d), &mut rng))
        });
    }
    // The DP variant (algorithm 8, m = 3 auxiliaries) on the headline size.
    let d = data(100, 20);
    let hyper = Hyperparameters::from_data(&d);
    let mut rng = bayes::rng::seeded(3);
    let mut dp = DpState::new(&d, &hyper, 1.0, 3).unwrap();
    dp.initialise(&d, &mut rng);
    g.throughput(Throughput::Elements(2000));
    g.bench_function(BenchmarkId::new("dp_alg8", "M100_N20"), |b| {
        b.iter(|| dp.sweep(black_box(&d), &mut rng))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

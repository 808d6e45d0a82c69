//! Schema inference throughput: a 10-minute demonstration at the recording rate (10 Hz → 6,000
//! observation steps), scored by every schema of the built-in library and "none" (the posterior), and
//! segmented by the composite model. Observation vectors follow Pick-And-Place cycles with monitor
//! noise (false alarms and misses), like a long sorting demonstration.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use schema::{Engine, InferenceConfig, Library, Observation};

fn demonstration(lib: &Library, steps: usize) -> Vec<Observation> {
    let idx = |n: &str| lib.action(n).unwrap();
    // One pick-and-place cycle of 30 s: (duration in steps, converged actions).
    let cycle: Vec<(usize, Vec<usize>)> = vec![
        (40, vec![]),
        (10, vec![idx("search_track"), idx("reach_object")]),
        (20, vec![idx("search_track"), idx("grasp")]),
        (30, vec![idx("grasp"), idx("hold")]),
        (60, vec![idx("grasp")]),
        (20, vec![idx("grasp"), idx("reach_place"), idx("place")]),
        (20, vec![idx("release"), idx("reach_place")]),
        (100, vec![]),
    ];
    let mut out = Vec::with_capacity(steps);
    let mut rng = 0x9e3779b97f4a7c15u64;
    let mut next = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    'outer: loop {
        for (n, on) in &cycle {
            for _ in 0..*n {
                if out.len() == steps {
                    break 'outer;
                }
                let mut x = vec![false; lib.actions.len()];
                for &a in on {
                    x[a] = next() > 0.02;
                }
                if next() < 0.01 {
                    let k = (next() * x.len() as f64) as usize % x.len();
                    x[k] = !x[k];
                }
                out.push(Observation {
                    t: out.len() as f64 * 0.1,
                    x,
                    hits: vec![],
                });
            }
        }
    }
    out
}

fn bench(c: &mut Criterion) {
    let lib = Library::builtin();
    let engine = Engine::new(&lib, InferenceConfig::default()).unwrap();
    let obs = demonstration(&lib, 6000);
    let mut g = c.benchmark_group("infer_10min_demo");
    g.sample_size(10);
    g.throughput(Throughput::Elements(obs.len() as u64));
    g.bench_function("posterior_library_and_none", |b| {
        b.iter(|| engine.posterior(&obs).unwrap())
    });
    g.bench_function("segment_composite_viterbi", |b| {
        b.iter(|| engine.segment(&obs, &[]).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

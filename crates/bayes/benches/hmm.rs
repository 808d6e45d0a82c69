//! HMM throughput in observation-steps per second: N = 16 states, T = 100 000 steps
//! (dense and left-to-right transition matrices).
//!
//! - `forward_scaled`: the scaled linear-domain forward pass on a precomputed *linear* emission
//!   lattice — the same input, work and flushing as hmmlearn's compiled `_hmmc.forward_scaling`
//!   (hmmlearn 0.3.3 `implementation="scaling"`), the figure to compare with it;
//! - `forward_linear`: the same with the exactness guarantee (reruns in log space when the flush
//!   bound exceeds 1e-13: the left-to-right model with its absorbing last state does);
//! - `forward`: log emissions in (one `exp` per lattice entry, then the scaled pass);
//! - `forward_exact`: the exact log-space recursion (pbd's forward pass before the scaled kernels;
//!   compare hmmlearn's `forward_log`);
//! - filters, Viterbi, forward–backward.
//!
//! `benches/peers/hmm.sh` runs hmmlearn (both modes) beside this bench, pinned to one core, and
//! prints the ratios.

use bayes::hmm::{ForwardFilter, Hmm, ScaledFilter};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;

const N: usize = 16;
const T: usize = 100_000;

/// Uniform (0, 1] draws from pbd's seeded generator: deterministic inputs.
struct Uniform(bayes::rng::Generator);
impl Uniform {
    fn next(&mut self) -> f64 {
        use bayes::rng::Draw;
        self.0.uniform() + 1e-12
    }
}

fn normalised_log(row: &[f64]) -> Vec<f64> {
    let s: f64 = row.iter().sum();
    row.iter().map(|p| (p / s).ln()).collect()
}

fn dense(rng: &mut Uniform) -> Hmm {
    let start = normalised_log(&(0..N).map(|_| rng.next()).collect::<Vec<_>>());
    let trans = (0..N)
        .flat_map(|_| normalised_log(&(0..N).map(|_| rng.next()).collect::<Vec<_>>()))
        .collect();
    Hmm::new(start, trans).unwrap()
}

/// Left-to-right: stay or advance by one or two states (3 non-zeros per row).
fn left_to_right(rng: &mut Uniform) -> Hmm {
    let mut start = [f64::NEG_INFINITY; N];
    start[0] = 0.0;
    let mut trans = vec![0.0; N * N];
    for i in 0..N {
        for j in i..(i + 3).min(N) {
            trans[i * N + j] = rng.next();
        }
        let s: f64 = trans[i * N..(i + 1) * N].iter().sum();
        trans[i * N..(i + 1) * N].iter_mut().for_each(|p| *p /= s);
    }
    Hmm::from_probabilities(&start.iter().map(|l| l.exp()).collect::<Vec<_>>(), &trans).unwrap()
}

fn bench(c: &mut Criterion) {
    let mut rng = Uniform(bayes::rng::seeded(20110201));
    // Emissions favour the early states a little so the left-to-right model moves along slowly.
    let log_e: Vec<f64> = (0..T * N).map(|_| rng.next().ln()).collect();
    let lin_e: Vec<f64> = log_e.iter().map(|l| l.exp()).collect();
    let models = [("dense", dense(&mut rng)), ("left_to_right", left_to_right(&mut rng))];
    let mut g = c.benchmark_group("hmm_n16_t100k");
    g.throughput(Throughput::Elements(T as u64));
    g.sample_size(10);
    for (name, hmm) in &models {
        g.bench_with_input(BenchmarkId::new("forward", name), hmm, |b, hmm| {
            b.iter(|| black_box(hmm.forward(black_box(&log_e)).unwrap()))
        });
        g.bench_with_input(BenchmarkId::new("forward_linear", name), hmm, |b, hmm| {
            b.iter(|| black_box(hmm.forward_linear(black_box(&lin_e)).unwrap()))
        });
        g.bench_with_input(BenchmarkId::new("forward_scaled", name), hmm, |b, hmm| {
            b.iter(|| black_box(hmm.forward_scaled(black_box(&lin_e)).unwrap()))
        });
        g.bench_with_input(BenchmarkId::new("forward_exact", name), hmm, |b, hmm| {
            b.iter(|| black_box(hmm.forward_exact(black_box(&log_e)).unwrap()))
        });
        g.bench_with_input(BenchmarkId::new("scaled_filter_step", name), hmm, |b, hmm| {
            let mut f = ScaledFilter::new(hmm);
            b.iter(|| {
                f.reset(hmm);
                for row in lin_e.chunks_exact(N) {
                    f.step(hmm, row).unwrap();
                }
                black_box(f.log_likelihood())
            })
        });
        g.bench_with_input(BenchmarkId::new("filter_step", name), hmm, |b, hmm| {
            let mut f = ForwardFilter::new(hmm);
            b.iter(|| {
                f.reset(hmm);
                for row in log_e.chunks_exact(N) {
                    f.step(hmm, row).unwrap();
                }
                black_box(f.log_likelihood())
            })
        });
        g.bench_with_input(BenchmarkId::new("viterbi", name), hmm, |b, hmm| {
            b.iter(|| black_box(hmm.viterbi(black_box(&log_e)).unwrap()))
        });
        g.bench_with_input(BenchmarkId::new("forward_backward", name), hmm, |b, hmm| {
            b.iter(|| black_box(hmm.forward_backward(black_box(&log_e)).unwrap()))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

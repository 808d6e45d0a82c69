//! Geweke's (2004) joint-distribution test of the collapsed Gibbs sampler.
//!
//! Two ways of simulating p(z, 𝒟): *marginal-conditional* draws everything forward from the model
//! (6.9–6.13); *successive-conditional* alternates a Gibbs sweep z | 𝒟 with redrawing the
//! parameters given (z, 𝒟) and then 𝒟 given (z, parameters). If the sweep leaves p(z | 𝒟) invariant
//! both produce the same joint distribution, so every test statistic g(z, 𝒟) has the same mean. The
//! z-score compares the means, with the successive chain's variance from batch means.
//!
//! The test has power: the same machinery rejects the seed's moment-matched normal (6.18–6.21),
//! which is not the exact conditional.

use grasp_topics::synthetic::{SyntheticSpec, posterior_prototypes, prior_prototypes, redraw_data, sample_dataset};
use grasp_topics::{AppearancePrior, Dataset, GibbsState, Hyperparameters, PositionPredictive, PositionPrior};

const M: usize = 2;
const N: usize = 3;
const A: usize = 3;
const Q: usize = 2;

fn hyper() -> Hyperparameters {
    Hyperparameters {
        alpha: 1.0,
        beta: 1.0,
        position: PositionPrior {
            mean: [0.0; 3],
            kappa: 1.0,
            dof: 6.0,
            scale: [[0.02, 0.0, 0.0], [0.0, 0.02, 0.0], [0.0, 0.0, 0.02]],
        },
        appearance: AppearancePrior {
            dof: 8.0,
            scale_dof: 5.0,
            scale: [[1.0, 0.0], [0.0, 1.0]],
        },
        position_predictive: PositionPredictive::StudentT,
    }
}

const NAMES: [&str; 9] = [
    "occupied",
    "z0==z1",
    "z0==z3",
    "x0.x",
    "x0.x^2",
    "ln|b0|",
    "same-z pairs: |xi-xk|^2",
    "same-z pairs: wi==wk",
    "same-z pairs: (ln|bi|-ln|bk|)^2",
];

fn stats(z: &[usize], d: &Dataset) -> [f64; 9] {
    let n = d.len();
    let mut occ = [false; A];
    for &j in z {
        occ[j] = true;
    }
    let (mut sx, mut sw, mut sb) = (0.0, 0.0, 0.0);
    for i in 0..n {
        for k in (i + 1)..n {
            if z[i] == z[k] {
                sx += (d.position(i) - d.position(k)).norm_squared();
                sw += (d.orientation(i) == d.orientation(k)) as u8 as f64;
                sb += (d.appearance(i).determinant().ln() - d.appearance(k).determinant().ln()).powi(2);
            }
        }
    }
    let x0 = d.position(0).x;
    [
        occ.iter().filter(|&&o| o).count() as f64,
        (z[0] == z[1]) as u8 as f64,
        (z[0] == z[3]) as u8 as f64,
        x0,
        x0 * x0,
        d.appearance(0).determinant().ln(),
        sx,
        sw,
        sb,
    ]
}

/// Runs both simulators; returns the z-score of every statistic.
fn geweke(sampler: &Hyperparameters, draws: usize, seed: u64) -> Vec<f64> {
    let truth = hyper();
    let mut rng = bayes::rng::seeded(seed);
    let forward = |rng: &mut bayes::rng::Generator| {
        let spec = SyntheticSpec {
            objects: M,
            grasps_per_object: N,
            alpha: truth.alpha,
            appearance_dof: truth.appearance.dof,
            prototypes: prior_prototypes(&truth, A, Q, rng).unwrap(),
        };
        sample_dataset(&spec, rng).unwrap()
    };
    // Marginal-conditional.
    let mut mc = vec![Vec::<f64>::new(); 9];
    for _ in 0..draws {
        let s = forward(&mut rng);
        for (k, v) in stats(&s.truth, &s.data).into_iter().enumerate() {
            mc[k].push(v);
        }
    }
    // Successive-conditional.
    let s = forward(&mut rng);
    let (mut data, mut z) = (s.data, s.truth);
    let mut sc = vec![Vec::<f64>::new(); 9];
    for _ in 0..draws {
        let mut state = GibbsState::with_assignments(&data, sampler, A, &z).unwrap();
        state.sweep(&data, &mut rng);
        z = state.assignments();
        let params = posterior_prototypes(&data, &z, &truth, A, &mut rng).unwrap();
        redraw_data(&mut data, &z, &params, truth.appearance.dof, &mut rng).unwrap();
        for (k, v) in stats(&z, &data).into_iter().enumerate() {
            sc[k].push(v);
        }
    }
    (0..9)
        .map(|k| {
            let (m1, v1) = mean_var(&mc[k]);
            let (m2, _) = mean_var(&sc[k]);
            let v2 = batch_means_variance(&sc[k], 50);
            (m1 - m2) / (v1 / draws as f64 + v2).sqrt()
        })
        .collect()
}

fn mean_var(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    (m, x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0))
}

/// Variance of the mean of an autocorrelated series by batch means.
fn batch_means_variance(x: &[f64], batches: usize) -> f64 {
    let len = x.len() / batches;
    let means: Vec<f64> = (0..batches)
        .map(|b| x[b * len..(b + 1) * len].iter().sum::<f64>() / len as f64)
        .collect();
    mean_var(&means).1 / batches as f64
}

/// Bonferroni over 9 statistics at family-wise level 0.001: |z| < 3.87.
const CRITICAL: f64 = 3.87;

/// Draws per simulator: unoptimised builds run a shorter (still valid, less powerful) test.
const DRAWS: usize = if cfg!(debug_assertions) { 10_000 } else { 40_000 };

#[test]
fn collapsed_gibbs_targets_the_posterior() {
    let z = geweke(&hyper(), DRAWS, 2024);
    for (n, v) in NAMES.iter().zip(&z) {
        println!("geweke exact t   {n:34} z = {v:+.2}");
    }
    let worst = z.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    assert!(worst < CRITICAL, "max |z| = {worst}");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "needs 40 000 draws; run with --release")]
fn geweke_test_detects_the_moment_matched_approximation() {
    let mm = Hyperparameters {
        position_predictive: PositionPredictive::MomentMatched,
        ..hyper()
    };
    let z = geweke(&mm, 40_000, 2024);
    for (n, v) in NAMES.iter().zip(&z) {
        println!("geweke moment-m. {n:34} z = {v:+.2}");
    }
    let worst = z.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    assert!(worst > CRITICAL, "the approximation went unnoticed: max |z| = {worst}");
}

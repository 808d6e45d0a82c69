//! The scaled linear-domain HMM kernels (`forward_linear`, `ScaledFilter`, `forward_shared`, the
//! scaled forward–backward) against hmmlearn's reference values (tests/data/hmm_forward.json) and
//! against the exact log-space recursion on models built to stress them: bands, sparse columns,
//! absorbing start states that decay below the flush floor, long sequences, impossible steps.

use crate::common;
use bayes::hmm::{
    ForwardFilter, Hmm, ScaledFilter, SharedModel, categorical_emissions, categorical_log_emissions, forward_shared,
};
use common::*;
use proptest::prelude::*;

#[test]
fn linear_forward_matches_hmmlearn_on_every_reference_case() {
    let data = load("hmm_forward.json");
    let mut worst = Worst::default();
    for (i, c) in data["cases"].as_array().unwrap().iter().enumerate() {
        let n = c["n_states"].as_u64().unwrap() as usize;
        let (_, trans) = fm(&c["transmat"]);
        let hmm = Hmm::from_probabilities(&fv(&c["startprob"]), &trans).unwrap();
        let (_, emis) = fm(&c["emissionprob"]);
        let obs = uv(&c["obs"]);
        let e = categorical_emissions(&emis, n, &obs).unwrap();
        let want = f(&c["log_prob"]);
        let label = format!("case {i} ({}, n={n})", c["kind"].as_str().unwrap());
        let got = hmm.forward_linear(&e).unwrap();
        if c["impossible"].as_bool().unwrap() {
            assert_eq!(got, f64::NEG_INFINITY, "{label}");
            continue;
        }
        let d = scaled_diff(got, want);
        worst.see(d, || label.clone());
        assert!(d <= 1e-12, "{label}: {got} vs {want}");
        // The log-emission entry point and the exact recursion agree with it.
        let log_e: Vec<f64> = e.iter().map(|p| p.ln()).collect();
        assert!(scaled_diff(hmm.forward(&log_e).unwrap(), want) <= 1e-12, "{label}");
        assert!(
            scaled_diff(hmm.forward_exact(&log_e).unwrap(), want) <= 1e-12,
            "{label}"
        );
        // The streaming scaled filter gives the same sum of one-step terms.
        let mut filter = ScaledFilter::new(&hmm);
        let mut sum = 0.0;
        for row in e.chunks(n) {
            sum += filter.step(&hmm, row).unwrap();
        }
        assert_eq!(filter.error_bound(), 0.0, "{label}");
        assert!(scaled_diff(sum, want) <= 1e-12, "{label}");
        assert!(scaled_diff(filter.log_likelihood(), want) <= 1e-12, "{label}");
        // Same categorical model in log form.
        let log_emis: Vec<f64> = emis.iter().map(|p| p.ln()).collect();
        assert_eq!(categorical_log_emissions(&log_emis, n, &obs).unwrap().len(), e.len());
    }
    worst.report("linear forward scaled diff");
}

/// Uniform draws in (0, 1] from a small xorshift: deterministic test inputs.
struct Draws(u64);
impl Draws {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 1.0) / (1u64 << 53) as f64
    }
}

/// A model family: 0 dense, 1 left-to-right band, 2 sparse with an absorbing decaying start state
/// (the shape of pbd's composite schema models: a "gap before" that is never re-entered).
fn model(kind: u8, n: usize, d: &mut Draws) -> Hmm {
    let mut trans = vec![0.0; n * n];
    let mut start = vec![0.0; n];
    match kind {
        0 => {
            trans.iter_mut().for_each(|p| *p = d.next());
            start.iter_mut().for_each(|p| *p = d.next());
        }
        1 => {
            for i in 0..n {
                for j in i..(i + 3).min(n) {
                    trans[i * n + j] = d.next();
                }
            }
            start[0] = 1.0;
        }
        _ => {
            // State 0: stays (0.9) or leaves for 1; states 1..n cycle sparsely and never return to 0.
            trans[1] = 0.1;
            trans[0] = 0.9;
            for i in 1..n {
                trans[i * n + i] = d.next();
                trans[i * n + 1 + i % (n - 1)] += d.next();
                trans[i * n + 1 + (i + 2) % (n - 1)] += d.next();
            }
            start[0] = 0.5;
            start[1] = 0.5;
        }
    }
    for row in trans.chunks_mut(n) {
        let s: f64 = row.iter().sum();
        row.iter_mut().for_each(|p| *p /= s);
    }
    let s: f64 = start.iter().sum();
    start.iter_mut().for_each(|p| *p /= s);
    Hmm::from_probabilities(&start, &trans).unwrap()
}

/// Log emissions that punish state 0 hard (so it decays far below the flush floor) and are
/// otherwise random; `holes` adds impossible entries.
fn emissions(n: usize, t_len: usize, d: &mut Draws, holes: bool) -> Vec<f64> {
    (0..t_len * n)
        .map(|k| {
            let j = k % n;
            if holes && d.next() < 0.05 {
                f64::NEG_INFINITY
            } else if j == 0 {
                -3.0 - 5.0 * d.next()
            } else {
                -5.0 * d.next()
            }
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn scaled_paths_equal_the_exact_recursion(kind in 0u8..3, n in 2usize..20, t_len in 1usize..3000,
                                              seed in 1u64..u64::MAX, holes in any::<bool>()) {
        let mut d = Draws(seed);
        let hmm = model(kind, n, &mut d);
        let log_e = emissions(n, t_len, &mut d, holes);
        let exact = hmm.forward_exact(&log_e).unwrap();
        let fast = hmm.forward(&log_e).unwrap();
        prop_assert!(scaled_diff(fast, exact) <= 1e-9 || (fast == exact), "{fast} vs {exact}");
        let lin: Vec<f64> = log_e.iter().map(|l| l.exp()).collect();
        let fast_lin = hmm.forward_linear(&lin).unwrap();
        // exp() of the inputs differs from the shifted exponentials by rounding only.
        prop_assert!(scaled_diff(fast_lin, exact) <= 1e-9 || fast_lin == exact, "{fast_lin} vs {exact}");
        match (hmm.forward_backward(&log_e).unwrap(), exact) {
            (None, e) => prop_assert_eq!(e, f64::NEG_INFINITY),
            (Some(s), e) => {
                prop_assert!(scaled_diff(s.log_likelihood, e) <= 1e-9);
                let mut f = ForwardFilter::new(&hmm);
                for row in log_e.chunks(n) { f.step(&hmm, row).unwrap(); }
                for (a, b) in s.at(t_len - 1).iter().zip(f.filtered()) {
                    prop_assert!((a - b).abs() <= 1e-9);
                }
                for t in 0..t_len {
                    prop_assert!((s.at(t).iter().sum::<f64>() - 1.0).abs() < 1e-12);
                }
            }
        }
    }
}

#[test]
fn scaled_forward_backward_equals_exact_posteriors_on_a_decaying_start_state() {
    let mut d = Draws(99);
    let n = 9;
    let hmm = model(2, n, &mut d);
    let log_e = emissions(n, 1500, &mut d, false);
    let s = hmm.forward_backward(&log_e).unwrap().unwrap();
    let exact = hmm.forward_backward_exact(&log_e).unwrap().unwrap();
    assert!(scaled_diff(s.log_likelihood, exact.log_likelihood) <= 1e-12);
    for (a, b) in s.posteriors.iter().zip(&exact.posteriors) {
        assert!((a - b).abs() <= 1e-10, "{a} vs {b}");
    }
}

#[test]
fn decaying_state_is_tracked_exactly() {
    // State 0 decays by ≥ e^-2 per step relative to the others: after ~300 steps it is below
    // 1e-280. The exact scaled filter carries it in log space (it reads 0 in `filtered`).
    let mut d = Draws(7);
    let n = 6;
    let hmm = model(2, n, &mut d);
    for t_len in [500, 3000] {
        let log_e = emissions(n, t_len, &mut d, false);
        let mut filter = ScaledFilter::new(&hmm);
        for row in log_e.chunks(n) {
            let e: Vec<f64> = row.iter().map(|l| l.exp()).collect();
            filter.step(&hmm, &e).unwrap();
        }
        assert_eq!(filter.filtered()[0], 0.0);
        assert!(filter.error_bound() < 1e-250, "{}", filter.error_bound());
        // Its exact log value is kept.
        let mut log_f = vec![0.0; n];
        filter.log_filtered_into(&mut log_f);
        let mut reference = ForwardFilter::new(&hmm);
        for row in log_e.chunks(n) {
            reference.step(&hmm, row).unwrap();
        }
        assert!(log_f[0] < -600.0 && log_f[0].is_finite(), "{}", log_f[0]);
        for (a, b) in log_f.iter().zip(reference.log_filtered()) {
            assert!((a - b).abs() <= 1e-9 * b.abs().max(1.0), "{a} vs {b}");
        }
        let exact = hmm.forward_exact(&log_e).unwrap();
        assert!(scaled_diff(filter.log_likelihood(), exact) <= 1e-12);
        assert!(scaled_diff(hmm.forward(&log_e).unwrap(), exact) <= 1e-12);
        // The flushing pass (hmmlearn's semantics) reports a worst-case bound instead.
        let lin: Vec<f64> = log_e.iter().map(|l| l.exp()).collect();
        let flushed = hmm.forward_scaled(&lin).unwrap();
        assert!(flushed.error_bound > 0.0);
    }
}

#[test]
fn a_state_below_the_floor_that_regains_is_not_lost() {
    // Two independent absorbing states. For 200 steps state 0 explains the data e^4 times worse
    // per step (it ends ~e^-800 behind, far below 1e-280); for the next 400 steps it explains it e^4
    // times better and wins: log p = ln 0.5 − 800 exactly (+ e^-800). Flushing loses state 0 and
    // gets ln 0.5 − 1600; the tracked pass must not.
    let hmm = Hmm::from_probabilities(&[0.5, 0.5], &[1.0, 0.0, 0.0, 1.0]).unwrap();
    let mut log_e = Vec::new();
    for _ in 0..200 {
        log_e.extend([-4.0, 0.0]);
    }
    for _ in 0..400 {
        log_e.extend([0.0, -4.0]);
    }
    let want = 0.5f64.ln() - 800.0;
    let exact = hmm.forward_exact(&log_e).unwrap();
    assert!((exact - want).abs() < 1e-9, "{exact}");
    assert!((hmm.forward(&log_e).unwrap() - want).abs() < 1e-9);
    let lin: Vec<f64> = log_e.iter().map(|l| l.exp()).collect();
    assert!((hmm.forward_linear(&lin).unwrap() - want).abs() < 1e-9);
    let mut filter = ScaledFilter::new(&hmm);
    for row in lin.chunks(2) {
        filter.step(&hmm, row).unwrap();
    }
    assert!((filter.log_likelihood() - want).abs() < 1e-9);
    assert!((filter.filtered()[0] - 1.0).abs() < 1e-12);
    let smoothed = hmm.forward_backward(&log_e).unwrap().unwrap();
    assert!((smoothed.log_likelihood - want).abs() < 1e-9);
    assert!((smoothed.at(0)[0] - 1.0).abs() < 1e-12);
    // hmmlearn-style flushing loses the winning path; its bound says so.
    let flushed = hmm.forward_scaled(&lin).unwrap();
    assert!((flushed.log_likelihood - (0.5f64.ln() - 1600.0)).abs() < 1e-6);
    assert!(flushed.error_bound > 1.0, "{}", flushed.error_bound);
}

#[test]
fn shared_pass_equals_each_model_alone() {
    let mut d = Draws(3);
    let width = 7;
    let t_len = 800;
    let shared: Vec<f64> = (0..t_len * width).map(|_| -6.0 * d.next()).collect();
    let m1 = model(0, 4, &mut d);
    let m2 = model(1, 12, &mut d);
    let m3 = model(2, 5, &mut d);
    let cols1 = [0, 1, 2, 3];
    let cols2 = [6, 5, 4, 3, 2, 1, 0, 0, 1, 2, 3, 4];
    let cols3 = [0, 6, 6, 1, 2];
    let models = [
        SharedModel {
            hmm: &m1,
            columns: &cols1,
        },
        SharedModel {
            hmm: &m2,
            columns: &cols2,
        },
        SharedModel {
            hmm: &m3,
            columns: &cols3,
        },
    ];
    let out = forward_shared(&models, &shared, width).unwrap();
    for (m, r) in models.iter().zip(&out) {
        let own: Vec<f64> = shared
            .chunks(width)
            .flat_map(|row| m.columns.iter().map(|&c| row[c]))
            .collect();
        let exact = m.hmm.forward_exact(&own).unwrap();
        assert!(
            scaled_diff(r.log_likelihood, exact) <= 1e-12,
            "{} vs {exact}",
            r.log_likelihood
        );
        let mut f = ForwardFilter::new(m.hmm);
        for row in own.chunks(m.columns.len()) {
            f.step(m.hmm, row).unwrap();
        }
        // States flushed below 1e-280 read -inf here: compare probabilities.
        for (a, b) in r.log_filtered.iter().zip(f.log_filtered()) {
            assert!((a.exp() - b.exp()).abs() <= 1e-12, "{a} vs {b}");
        }
    }
    // Bad shapes are errors, not panics.
    assert!(forward_shared(&models, &shared[..width * 3 - 1], width).is_err());
    assert!(forward_shared(&models, &shared, 0).is_err());
    let bad = [SharedModel {
        hmm: &m1,
        columns: &[0, 1, 2, 7],
    }];
    assert!(forward_shared(&bad, &shared, width).is_err());
    let short = [SharedModel {
        hmm: &m1,
        columns: &[0, 1],
    }];
    assert!(forward_shared(&short, &shared, width).is_err());
}

#[test]
fn linear_inputs_are_checked() {
    let hmm = Hmm::from_probabilities(&[0.5, 0.5], &[0.9, 0.1, 0.2, 0.8]).unwrap();
    assert!(hmm.forward_linear(&[]).is_err());
    assert!(hmm.forward_linear(&[0.5, 0.5, 0.5]).is_err());
    assert!(hmm.forward_linear(&[0.5, -0.1]).is_err());
    assert!(hmm.forward_linear(&[0.5, f64::NAN]).is_err());
    assert!(hmm.forward_linear(&[0.5, f64::INFINITY]).is_err());
    assert_eq!(hmm.forward_linear(&[0.0, 0.0]).unwrap(), f64::NEG_INFINITY);
    let mut f = ScaledFilter::new(&hmm);
    assert!(f.step(&hmm, &[1.0]).is_err());
    assert_eq!(f.steps(), 0);
    assert!(categorical_emissions(&[0.5, 0.5], 2, &[1]).is_err());
    assert!(categorical_emissions(&[0.5, -0.5], 1, &[0]).is_err());
}

#[test]
fn many_tiny_states_hand_over_to_log_space_and_come_back() {
    // A dense model; for 50 steps only state 0 can explain the data (the others at e^-800, so
    // seven of eight states fall far below 1e-280 and the pass continues in log space), then every
    // state explains it equally and all come back above the floor (the pass returns to linear).
    let mut d = Draws(11);
    let n = 8;
    let hmm = model(0, n, &mut d);
    let mut log_e = Vec::new();
    for t in 0..300 {
        for j in 0..n {
            log_e.push(if (50..100).contains(&t) && j > 0 {
                -800.0
            } else {
                -2.0 * d.next()
            });
        }
    }
    let exact = hmm.forward_exact(&log_e).unwrap();
    assert!(scaled_diff(hmm.forward(&log_e).unwrap(), exact) <= 1e-12);
    let mut filter = ScaledFilter::new(&hmm);
    let mut f = ForwardFilter::new(&hmm);
    for row in log_e.chunks(n) {
        let e: Vec<f64> = row.iter().map(|l| l.exp()).collect();
        let a = filter.step(&hmm, &e).unwrap();
        let b = f.step(&hmm, row).unwrap();
        assert!((a - b).abs() <= 1e-9 * b.abs().max(1.0), "{a} vs {b}");
    }
    assert!(scaled_diff(filter.log_likelihood(), exact) <= 1e-12);
    for (a, b) in filter.filtered().iter().zip(f.filtered()) {
        assert!((a - b).abs() <= 1e-12);
    }
}

/// A left-to-right band of 8 states (its kernel is a band) whose first state falls e^-1200 behind
/// — far below any fixed floor — and then wins: the extended-range pass keeps it, as the log-space
/// recursion does; flushing loses it.
#[test]
fn a_band_state_far_below_the_floor_that_regains_is_not_lost() {
    let n = 8;
    let mut trans = vec![0.0; n * n];
    for i in 0..n {
        if i + 1 < n {
            trans[i * n + i] = 0.999;
            trans[i * n + i + 1] = 0.001;
        } else {
            trans[i * n + i] = 1.0;
        }
    }
    let mut start = vec![0.0; n];
    start[0] = 0.5;
    start[3] = 0.5;
    let hmm = Hmm::from_probabilities(&start, &trans).unwrap();
    let mut log_e = Vec::new();
    for t in 0..900 {
        for j in 0..n {
            // First 300 steps: state 0 explains the data e^4 times worse than the rest; then e^4
            // times better for 600 steps.
            let worse = if t < 300 { j == 0 } else { j != 0 };
            log_e.push(if worse { -4.0 } else { 0.0 });
        }
    }
    let exact = hmm.forward_exact(&log_e).unwrap();
    let lin: Vec<f64> = log_e.iter().map(|l| l.exp()).collect();
    let got = hmm.forward_linear(&lin).unwrap();
    assert!(scaled_diff(got, exact) <= 1e-12, "{got} vs {exact}");
    let flushed = hmm.forward_scaled(&lin).unwrap();
    assert!(
        (flushed.log_likelihood - exact).abs() > 100.0,
        "{} vs {exact}",
        flushed.log_likelihood
    );
}

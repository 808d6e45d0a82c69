//! `bayes::hmm` against tests/data/hmm_forward.json (hmmlearn 0.3.3 log-mode score and Viterbi,
//! cross-checked by a numpy scaled forward pass; see tests/data/PROVENANCE.md).

use crate::common;
use bayes::hmm::{ForwardFilter, Hmm, categorical_log_emissions};
use common::*;

struct Case {
    label: String,
    hmm: Hmm,
    log_e: Vec<f64>,
    n: usize,
    json: serde_json::Value,
}

fn cases() -> Vec<Case> {
    let data = load("hmm_forward.json");
    data["cases"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let n = c["n_states"].as_u64().unwrap() as usize;
            let (_, trans) = fm(&c["transmat"]);
            let hmm = Hmm::from_probabilities(&fv(&c["startprob"]), &trans).unwrap();
            let (_, emis) = fm(&c["emissionprob"]);
            let log_emis: Vec<f64> = emis.iter().map(|p| p.ln()).collect();
            let log_e = categorical_log_emissions(&log_emis, n, &uv(&c["obs"])).unwrap();
            let label = format!("case {i} ({}, n={n}, T={})", c["kind"].as_str().unwrap(), c["T"]);
            Case {
                label,
                hmm,
                log_e,
                n,
                json: c.clone(),
            }
        })
        .collect()
}

/// Plain log-space forward–backward (no scaling, no sparse tricks): the independent check.
fn naive_log_posteriors(hmm: &Hmm, e: &[f64]) -> (f64, Vec<f64>) {
    let n = hmm.n_states();
    let t_len = e.len() / n;
    let a = hmm.log_transitions();
    let lse = |xs: &[f64]| bayes::special::log_sum_exp(xs);
    let mut alpha = vec![0.0; t_len * n];
    for j in 0..n {
        alpha[j] = hmm.log_start()[j] + e[j];
    }
    let mut tmp = vec![0.0; n];
    for t in 1..t_len {
        for j in 0..n {
            for i in 0..n {
                tmp[i] = alpha[(t - 1) * n + i] + a[i * n + j];
            }
            alpha[t * n + j] = lse(&tmp) + e[t * n + j];
        }
    }
    let mut beta = vec![0.0; t_len * n];
    for t in (0..t_len - 1).rev() {
        for i in 0..n {
            for j in 0..n {
                tmp[j] = a[i * n + j] + e[(t + 1) * n + j] + beta[(t + 1) * n + j];
            }
            beta[t * n + i] = lse(&tmp);
        }
    }
    let ll = lse(&alpha[(t_len - 1) * n..]);
    let post = alpha.iter().zip(&beta).map(|(a, b)| (a + b - ll).exp()).collect();
    (ll, post)
}

#[test]
fn forward_log_likelihood_matches_hmmlearn() {
    let mut worst = Worst::default();
    for c in cases() {
        let want = f(&c.json["log_prob"]);
        let got = c.hmm.forward(&c.log_e).unwrap();
        if c.json["impossible"].as_bool().unwrap() {
            assert_eq!(got, f64::NEG_INFINITY, "{}", c.label);
            continue;
        }
        let d = scaled_diff(got, want);
        worst.see(d, || c.label.clone());
        assert!(d <= 1e-12, "{}: got {got}, want {want}, scaled diff {d:e}", c.label);
        // The numpy scaled forward pass agrees too.
        assert!(
            scaled_diff(got, f(&c.json["log_prob_scaled_forward"])) <= 1e-12,
            "{}",
            c.label
        );
    }
    worst.report("forward scaled diff");
}

#[test]
fn streaming_filter_matches_batch_and_fails_at_impossible_at() {
    for c in cases() {
        let mut filter = ForwardFilter::new(&c.hmm);
        let mut sum = 0.0;
        let impossible_at = c.json["impossible_at"].as_u64().map(|v| v as usize);
        for (t, row) in c.log_e.chunks(c.n).enumerate() {
            let step = filter.step(&c.hmm, row).unwrap();
            assert!(!step.is_nan(), "{}", c.label);
            sum += step;
            assert_eq!(
                filter.is_impossible(),
                impossible_at.is_some_and(|k| t >= k),
                "{} at t = {t}",
                c.label
            );
            if !filter.is_impossible() {
                let s: f64 = filter.filtered().iter().sum();
                assert!((s - 1.0).abs() < 1e-13, "{}", c.label);
            }
        }
        let batch = c.hmm.forward(&c.log_e).unwrap();
        assert!(scaled_diff(filter.log_likelihood(), batch) <= 1e-13, "{}", c.label);
        assert!(scaled_diff(sum, batch) <= 1e-12, "{}", c.label);
    }
}

#[test]
fn viterbi_matches_hmmlearn() {
    let mut worst = Worst::default();
    for c in cases() {
        let got = c.hmm.viterbi(&c.log_e).unwrap();
        if c.json["impossible"].as_bool().unwrap() {
            assert!(got.is_none(), "{}", c.label);
            assert!(c.json["viterbi_path"].is_null());
            continue;
        }
        let got = got.unwrap_or_else(|| panic!("{}: no path", c.label));
        let want = f(&c.json["viterbi_log_prob"]);
        let d = scaled_diff(got.log_prob, want);
        worst.see(d, || c.label.clone());
        assert!(d <= 1e-12, "{}: got {}, want {want}", c.label, got.log_prob);
        assert_eq!(got.path, uv(&c.json["viterbi_path"]), "{}", c.label);
    }
    worst.report("Viterbi scaled diff");
}

#[test]
fn smoothed_posteriors_match_naive_log_space_recursion() {
    let mut worst = Worst::default();
    for c in cases() {
        let got = c.hmm.forward_backward(&c.log_e).unwrap();
        if c.json["impossible"].as_bool().unwrap() {
            assert!(got.is_none(), "{}", c.label);
            continue;
        }
        let got = got.unwrap();
        let (ll, post) = naive_log_posteriors(&c.hmm, &c.log_e);
        assert!(scaled_diff(got.log_likelihood, ll) <= 1e-12, "{}", c.label);
        assert_eq!(got.len(), c.log_e.len() / c.n);
        for (k, (a, b)) in got.posteriors.iter().zip(&post).enumerate() {
            let d = (a - b).abs();
            worst.see(d, || format!("{} entry {k}", c.label));
            assert!(d <= 1e-10, "{} entry {k}: {a} vs {b}", c.label);
        }
        for t in 0..got.len() {
            assert!((got.at(t).iter().sum::<f64>() - 1.0).abs() < 1e-13);
        }
    }
    worst.report("smoothed posterior abs diff");
}

//! Property tests: updating one observation (or one demonstration) at a time, in any order,
//! and merging per-demonstration statistics all give the same posterior and marginal as
//! learning from all the data at once (to 1e-12), and the statistics round-trip through JSON.

use bayes::dirichlet::{CategoryCounts, SymmetricDirichlet};
use bayes::univariate::{GaussianStats, NormalInverseGamma};
use proptest::prelude::*;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1.0)
}

/// A permutation of 0..n from proptest-chosen sort keys.
fn permutation(keys: &[u64]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..keys.len()).collect();
    idx.sort_by_key(|&i| (keys[i], i));
    idx
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn gaussian_stats_are_order_and_batch_independent(
        data in prop::collection::vec((-1e3f64..1e3, any::<u64>(), 0usize..4), 1..60),
        mu in -100f64..100.0, kappa in 0.01f64..50.0, alpha in 0.1f64..20.0, beta in 0.01f64..100.0,
    ) {
        let xs: Vec<f64> = data.iter().map(|d| d.0).collect();
        let keys: Vec<u64> = data.iter().map(|d| d.1).collect();
        let prior = NormalInverseGamma::new(mu, kappa, alpha, beta).unwrap();
        let all = GaussianStats::from_slice(&xs).unwrap();

        // One at a time, in a random order.
        let mut one = GaussianStats::new();
        for i in permutation(&keys) {
            one.update(xs[i]).unwrap();
        }
        // Random "demonstrations" (batches), each summarised then merged, in reverse order.
        let mut batches = vec![GaussianStats::new(); 4];
        for (x, _, b) in &data {
            batches[*b].update(*x).unwrap();
        }
        let mut merged = GaussianStats::new();
        for b in batches.iter().rev() {
            merged.merge(b);
        }
        // Sequential posteriors: each demonstration's posterior is the prior of the next (A.25).
        let mut seq = prior;
        for b in &batches {
            seq = seq.posterior(b);
        }
        let p_all = prior.posterior(&all);
        for s in [one, merged] {
            prop_assert_eq!(s.n(), all.n());
            prop_assert!(close(s.mean(), all.mean(), 1e-12));
            // M2's rounding error scales with the data's magnitude squared, not with M2.
            let scale = xs.iter().fold(1.0f64, |m, x| m.max(x * x));
            prop_assert!((s.m2() - all.m2()).abs() <= 1e-12 * all.m2().max(scale));
            let p = prior.posterior(&s);
            prop_assert!(close(p.mu(), p_all.mu(), 1e-12));
            prop_assert!(close(p.beta(), p_all.beta(), 1e-12));
            prop_assert!(close(prior.log_marginal_likelihood(&s), prior.log_marginal_likelihood(&all), 1e-12));
        }
        prop_assert!(close(seq.mu(), p_all.mu(), 1e-12));
        prop_assert!(close(seq.kappa(), p_all.kappa(), 1e-12));
        prop_assert!(close(seq.alpha(), p_all.alpha(), 1e-12));
        prop_assert!(close(seq.beta(), p_all.beta(), 1e-12));
        // Chain rule of marginals over the demonstrations.
        let mut acc = GaussianStats::new();
        let mut chain = 0.0;
        for b in &batches {
            chain += prior.log_posterior_marginal(&acc, b);
            acc.merge(b);
        }
        prop_assert!(close(chain, prior.log_marginal_likelihood(&all), 1e-12));

        let json = serde_json::to_string(&all).unwrap();
        prop_assert_eq!(serde_json::from_str::<GaussianStats>(&json).unwrap(), all);
        let json = serde_json::to_string(&prior).unwrap();
        prop_assert_eq!(serde_json::from_str::<NormalInverseGamma>(&json).unwrap(), prior);
    }

    #[test]
    fn category_counts_are_order_and_batch_independent(
        data in prop::collection::vec((0usize..7, any::<u64>(), 0usize..3), 0..80),
        gamma in 1e-3f64..1e3,
    ) {
        let l = 7;
        let seq: Vec<usize> = data.iter().map(|d| d.0).collect();
        let keys: Vec<u64> = data.iter().map(|d| d.1).collect();
        let prior = SymmetricDirichlet::new(l, gamma).unwrap();
        let all = CategoryCounts::from_sequence(l, &seq).unwrap();
        let mut one = prior.empty_counts();
        for i in permutation(&keys) {
            one.update(seq[i]).unwrap();
        }
        let mut batches = vec![prior.empty_counts(); 3];
        for (k, _, b) in &data {
            batches[*b].update(*k).unwrap();
        }
        let mut merged = prior.empty_counts();
        for b in batches.iter().rev() {
            merged.merge(b).unwrap();
        }
        prop_assert_eq!(&one, &all);
        prop_assert_eq!(&merged, &all);
        // The marginal is a function of the counts: the chain of sequential predictives along
        // any order equals the closed form.
        let lml = prior.log_marginal_likelihood(&all).unwrap();
        let mut c = prior.empty_counts();
        let mut chain = 0.0;
        for i in permutation(&keys) {
            chain += prior.predictive(&c, seq[i]).unwrap().ln();
            c.update(seq[i]).unwrap();
        }
        prop_assert!(close(chain, lml, 1e-12), "chain {} vs {}", chain, lml);
        // Demonstration by demonstration.
        let mut acc = prior.empty_counts();
        let mut chain = 0.0;
        for (b, batch) in batches.iter().enumerate() {
            let obs: Vec<usize> = data.iter().filter(|d| d.2 == b).map(|d| d.0).collect();
            chain += prior.log_posterior_marginal(&acc, &obs).unwrap();
            acc.merge(batch).unwrap();
        }
        prop_assert!(close(chain, lml, 1e-12));

        let json = serde_json::to_string(&all).unwrap();
        prop_assert_eq!(serde_json::from_str::<CategoryCounts>(&json).unwrap(), all.clone());
        let json = serde_json::to_string(&prior).unwrap();
        prop_assert_eq!(serde_json::from_str::<SymmetricDirichlet>(&json).unwrap(), prior);
    }
}

#[test]
fn deserialisation_validates() {
    assert!(serde_json::from_str::<NormalInverseGamma>(r#"{"mu":0,"kappa":-1,"alpha":1,"beta":1}"#).is_err());
    assert!(serde_json::from_str::<SymmetricDirichlet>(r#"{"num_categories":0,"gamma":1}"#).is_err());
    assert!(serde_json::from_str::<GaussianStats>(r#"{"n":2,"mean":0,"m2":-1}"#).is_err());
    assert!(serde_json::from_str::<CategoryCounts>(r#"{"counts":[]}"#).is_err());
    let c: CategoryCounts = serde_json::from_str(r#"{"counts":[1,2,3]}"#).unwrap();
    assert_eq!(c.total(), 6);
}

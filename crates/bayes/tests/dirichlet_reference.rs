//! `bayes::dirichlet` against tests/data/dirichlet_multinomial.json (mpmath closed forms and
//! scipy's dirichlet_multinomial). Tolerance: scaled diff ≤ 1e-12 + 10·2.2e-16 against `*_mp`
//! (and against the mpmath `log_ml_sequence`).

use crate::common;
use bayes::dirichlet::*;
use common::*;

#[test]
fn dirichlet_multinomial_matches_mpmath() {
    let data = load("dirichlet_multinomial.json");
    let (mut w_seq, mut w_pmf) = (Worst::default(), Worst::default());
    for (i, c) in data["cases"].as_array().unwrap().iter().enumerate() {
        let label = || format!("case {i} ({}, L = {}, gamma = {})", c["kind"], c["L"], c["gamma"]);
        let l = c["L"].as_u64().unwrap() as usize;
        let d = SymmetricDirichlet::new(l, f(&c["gamma"])).unwrap();
        let seq = uv(&c["sequence"]);
        let counts = CategoryCounts::from_sequence(l, &seq).unwrap();
        let want_counts: Vec<u64> = uv(&c["counts"]).into_iter().map(|v| v as u64).collect();
        assert_eq!(counts.counts(), &want_counts[..], "{}", label());
        assert_eq!(counts.total(), c["N"].as_u64().unwrap());

        for (got, want) in d.predictive_probs(&counts).unwrap().iter().zip(fv(&c["predictive"])) {
            assert!(
                scaled_diff(*got, want) <= 1e-15,
                "{}: predictive {got} vs {want}",
                label()
            );
        }
        let lml = d.log_marginal_likelihood(&counts).unwrap();
        let ds = scaled_diff(lml, f(&c["log_ml_sequence"]));
        w_seq.see(ds, label);
        assert!(
            ds <= tol(1.0),
            "{}: log p(sequence) {lml} vs {}",
            label(),
            c["log_ml_sequence"]
        );
        // The chain of sequential predictives (5.14) gives the same number.
        let mut cc = d.empty_counts();
        let mut chain = 0.0;
        for &k in &seq {
            chain += d.predictive(&cc, k).unwrap().ln();
            cc.update(k).unwrap();
        }
        assert!(scaled_diff(chain, lml) <= 1e-12, "{}: chain {chain} vs {lml}", label());
        assert!(
            scaled_diff(chain, f(&c["log_ml_sequence_chain"])) <= 1e-12,
            "{}",
            label()
        );
        let pmf = d.log_pmf_counts(&counts).unwrap();
        let dp = scaled_diff(pmf, f(&c["log_pmf_counts_mp"]));
        w_pmf.see(dp, label);
        assert!(
            dp <= tol(1.0),
            "{}: log pmf {pmf} vs {}",
            label(),
            c["log_pmf_counts_mp"]
        );
    }
    w_seq.report("log p(sequence) scaled diff");
    w_pmf.report("log pmf(counts) scaled diff");
}

//! `bayes::univariate` against scipy / mpmath (tests/data/{student_t,nig_posterior}.json).
//! Tolerance: scaled diff ≤ 1e-12 + 10·2.2e-16 (the README's rule with cond = 1).

use crate::common;
use bayes::univariate::*;
use common::*;

#[test]
fn student_t_matches_mpmath_for_df_1e_minus_3_to_1e10() {
    let data = load("student_t.json");
    let mut worst = Worst::default();
    for (i, c) in data["cases"].as_array().unwrap().iter().enumerate() {
        let (x, df, loc, scale) = (f(&c["x"]), f(&c["df"]), f(&c["loc"]), f(&c["scale"]));
        let got = student_t_log_pdf(x, df, loc, scale).unwrap();
        let want = f(&c["logpdf_mp"]);
        let d = scaled_diff(got, want);
        worst.see(d, || format!("case {i} ({}, df = {df:e})", c["kind"]));
        assert!(
            d <= tol(1.0),
            "case {i} ({}): got {got}, want {want}, diff {d:e}",
            c["kind"]
        );
    }
    worst.report("Student-t scaled diff");
}

#[test]
fn nig_posterior_marginal_and_predictive_match_reference() {
    let data = load("nig_posterior.json");
    let (mut w_ml, mut w_post, mut w_pred) = (Worst::default(), Worst::default(), Worst::default());
    for (i, c) in data["cases"].as_array().unwrap().iter().enumerate() {
        let label = || format!("case {i} ({})", c["kind"]);
        let prior = NormalInverseGamma::new(f(&c["mu0"]), f(&c["kappa0"]), f(&c["alpha0"]), f(&c["beta0"])).unwrap();
        let xs = fv(&c["x"]);
        let stats = GaussianStats::from_slice(&xs).unwrap();
        assert_eq!(stats.n(), c["n"].as_u64().unwrap());
        let post = prior.posterior(&stats);
        for (got, key) in [
            (post.mu(), "mu_n"),
            (post.kappa(), "kappa_n"),
            (post.alpha(), "alpha_n"),
            (post.beta(), "beta_n"),
        ] {
            let d = scaled_diff(got, f(&c[key]));
            w_post.see(d, || format!("{} {key}", label()));
            assert!(d <= 1e-12, "{} {key}: got {got}, want {}", label(), c[key]);
        }
        // log_marginal_likelihood is mpmath's closed form: the truth.
        let lml = prior.log_marginal_likelihood(&stats);
        let d = scaled_diff(lml, f(&c["log_marginal_likelihood"]));
        w_ml.see(d, label);
        assert!(
            d <= tol(1.0),
            "{}: lml {lml}, want {}",
            label(),
            c["log_marginal_likelihood"]
        );
        assert!(scaled_diff(lml, f(&c["log_ml_chain_rule"])) <= 1e-12, "{}", label());
        // Chain rule through our own predictive, one observation at a time (A.25).
        let mut s = GaussianStats::new();
        let mut chain = 0.0;
        for &x in &xs {
            chain += prior.posterior_predictive(&s).log_pdf(x);
            s.update(x).unwrap();
        }
        assert!(scaled_diff(chain, lml) <= 1e-12, "{}: chain {chain} vs {lml}", label());
        let t = prior.posterior_predictive(&stats);
        for (got, key) in [
            (t.df(), "predictive_df"),
            (t.loc(), "predictive_loc"),
            (t.scale(), "predictive_scale"),
        ] {
            assert!(
                scaled_diff(got, f(&c[key])) <= 1e-12,
                "{} {key}: got {got}, want {}",
                label(),
                c[key]
            );
        }
        for (q, want) in fv(&c["query"]).into_iter().zip(fv(&c["predictive_logpdf"])) {
            let d = scaled_diff(t.log_pdf(q), want);
            w_pred.see(d, label);
            assert!(
                d <= tol(1.0),
                "{}: predictive at {q}: {} vs {want}",
                label(),
                t.log_pdf(q)
            );
        }
    }
    w_ml.report("NIG log marginal likelihood scaled diff");
    w_post.report("NIG posterior parameter scaled diff");
    w_pred.report("NIG predictive log pdf scaled diff");
}

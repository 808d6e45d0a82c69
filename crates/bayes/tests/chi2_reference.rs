//! `bayes::chi2` against tests/data/chi2_contingency.json (scipy.stats.chi2_contingency and
//! chisquare; p-values also from mpmath).
//!
//! Statistics must match scipy to 1e-12 (scaled). p-values are compared *relatively* with the
//! mpmath values: a p-value's relative condition number with respect to the statistic is about
//! stat/2, so the tolerance is 1e-12 + 2e-15·stat; p-values scipy flushes to 0 (< 1e-308) must
//! be < 1e-300 here.

use crate::common;
use bayes::chi2::*;
use common::*;

fn check_p(label: &str, got: f64, want: f64, stat: f64, worst: &mut Worst) {
    if want == 0.0 {
        assert!(got < 1e-300, "{label}: p {got}, want 0");
        return;
    }
    let rel = (got - want).abs() / want;
    worst.see(rel, || label.to_string());
    assert!(
        rel <= 1e-12 + 2e-15 * stat,
        "{label}: p {got}, want {want}, rel {rel:e}"
    );
}

#[test]
fn contingency_tables_match_scipy_and_mpmath() {
    let data = load("chi2_contingency.json");
    let mut worst = Worst::default();
    for (i, c) in data["cases"].as_array().unwrap().iter().enumerate() {
        let table: Vec<Vec<f64>> = c["table"].as_array().unwrap().iter().map(fv).collect();
        for (yates, suffix) in [(false, "uncorrected"), (true, "corrected")] {
            let label = format!("case {i} ({}) {suffix}", c["kind"]);
            let t = chi2_contingency(&table, yates).unwrap();
            assert_eq!(t.dof as u64, c["dof"].as_u64().unwrap(), "{label}");
            let want_stat = f(&c[format!("statistic_{suffix}").as_str()]);
            assert!(
                scaled_diff(t.statistic, want_stat) <= 1e-12,
                "{label}: stat {} vs {want_stat}",
                t.statistic
            );
            check_p(
                &label,
                t.p_value,
                f(&c[format!("pvalue_{suffix}_mp").as_str()]),
                t.statistic,
                &mut worst,
            );
            let (_, expected) = fm(&c["expected"]);
            for (a, b) in t.expected.iter().zip(&expected) {
                assert!(scaled_diff(*a, *b) <= 1e-14, "{label}: expected {a} vs {b}");
            }
        }
    }
    worst.report("contingency p-value relative error");
}

#[test]
fn uniform_goodness_of_fit_matches_scipy_and_mpmath() {
    let data = load("chi2_contingency.json");
    let mut worst = Worst::default();
    for (i, c) in data["gof_cases"].as_array().unwrap().iter().enumerate() {
        let label = format!("gof case {i} ({})", c["kind"]);
        let t = chi2_uniform_fit(&fv(&c["f_obs"])).unwrap();
        assert_eq!(t.dof as u64, c["dof"].as_u64().unwrap());
        assert!(scaled_diff(t.expected[0], f(&c["expected_each"])) <= 1e-15, "{label}");
        assert!(
            scaled_diff(t.statistic, f(&c["statistic"])) <= 1e-12,
            "{label}: {} vs {}",
            t.statistic,
            c["statistic"]
        );
        check_p(&label, t.p_value, f(&c["pvalue_mp"]), t.statistic, &mut worst);
    }
    worst.report("goodness-of-fit p-value relative error");
}

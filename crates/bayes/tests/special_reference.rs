//! `bayes::special` against mpmath (tests/data/special.json, made by tests/data/make_special.py).

use crate::common;
use bayes::special::*;
use common::*;

/// Relative error, with an absolute floor for values near zero.
fn rel(a: f64, b: f64, floor: f64) -> f64 {
    if a == b {
        return 0.0;
    }
    if !a.is_finite() || !b.is_finite() {
        return f64::INFINITY;
    }
    (a - b).abs() / b.abs().max(floor)
}

#[test]
fn ln_gamma_matches_mpmath() {
    let data = load("special.json");
    let mut worst = Worst::default();
    for c in data["ln_gamma"].as_array().unwrap() {
        let (x, want) = (f(&c["x"]), f(&c["value"]));
        let got = ln_gamma(x);
        // Relative accuracy everywhere except the reflected negative arguments (absolute there:
        // sin(πx) loses relative accuracy with |x|).
        let e = if x > 0.0 {
            rel(got, want, 1e-300)
        } else {
            rel(got, want, 1.0)
        };
        worst.see(e, || format!("x = {x}"));
        assert!(e <= 1e-15, "ln_gamma({x}) = {got}, want {want}, error {e:e}");
    }
    worst.report("ln_gamma relative error");
}

#[test]
fn digamma_matches_mpmath() {
    let data = load("special.json");
    let mut worst = Worst::default();
    for c in data["digamma"].as_array().unwrap() {
        let (x, want) = (f(&c["x"]), f(&c["value"]));
        let e = rel(digamma(x), want, 1.0);
        worst.see(e, || format!("x = {x}"));
        assert!(e <= 4e-15, "digamma({x}) = {}, want {want}", digamma(x));
    }
    worst.report("digamma scaled error");
}

#[test]
fn ln_gamma_diff_matches_mpmath() {
    let data = load("special.json");
    let mut worst = Worst::default();
    for c in data["ln_gamma_diff"].as_array().unwrap() {
        let (x, d, want) = (f(&c["x"]), f(&c["d"]), f(&c["value"]));
        let got = ln_gamma_diff(x, d);
        let e = rel(got, want, 1e-300);
        worst.see(e, || format!("x = {x}, d = {d}"));
        assert!(e <= 1e-14, "ln_gamma_diff({x}, {d}) = {got}, want {want}, rel {e:e}");
    }
    worst.report("ln_gamma_diff relative error");
}

#[test]
fn ln_multigamma_matches_mpmath() {
    let data = load("special.json");
    for c in data["ln_multigamma"].as_array().unwrap() {
        let (p, a, want) = (c["p"].as_u64().unwrap() as usize, f(&c["a"]), f(&c["value"]));
        let got = ln_multigamma(p, a);
        assert!(
            rel(got, want, 1.0) <= 1e-15,
            "ln_multigamma({p}, {a}) = {got}, want {want}"
        );
    }
    assert_eq!(ln_multigamma(0, 2.0), 0.0);
}

#[test]
fn incomplete_gamma_matches_mpmath() {
    let data = load("special.json");
    let (mut wq, mut wp) = (Worst::default(), Worst::default());
    for c in data["gamma_inc"].as_array().unwrap() {
        let (a, x, q, p) = (f(&c["a"]), f(&c["x"]), f(&c["q"]), f(&c["p"]));
        // Relative accuracy of each tail wherever it is representable (> 1e-300), whether it
        // was computed directly or as 1 − (the other).
        for (name, got, want, w) in [("Q", gamma_q(a, x), q, &mut wq), ("P", gamma_p(a, x), p, &mut wp)] {
            if want > 1e-300 {
                let e = rel(got, want, 0.0);
                w.see(e, || format!("a = {a}, x = {x}"));
                // The prefactor x^a e^−x is exp of a number of size x + a·|ln x|, whose
                // rounding is amplified by that size: allow a few ulp times it.
                assert!(
                    e <= 4e-16 * (x + a + a * x.ln().abs()).max(25.0),
                    "{name}({a}, {x}) = {got}, want {want}, rel {e:e}"
                );
            } else {
                assert!(got <= 1e-299, "{name}({a}, {x}) = {got}, want {want}");
            }
        }
        assert!((chi2_sf(2.0 * x, 2.0 * a) - gamma_q(a, x)).abs() <= 1e-300 + 1e-15 * q);
    }
    wq.report("Q relative error");
    wp.report("P relative error");
}

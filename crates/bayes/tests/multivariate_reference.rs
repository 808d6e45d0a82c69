//! `bayes::multivariate` against scipy / mpmath (tests/data/{mvn,multivariate_t,invwishart}.json).
//! Tolerance (the reference README's): scaled diff ≤ 1e-12 + 10·cond·2.2e-16 against `*_mp`.

use crate::common;
use bayes::multivariate::*;
use common::*;
use nalgebra::{DMatrix, DVector};

fn vec_of(v: &serde_json::Value) -> DVector<f64> {
    DVector::from_vec(fv(v))
}

fn mat_of(v: &serde_json::Value) -> DMatrix<f64> {
    let (rows, data) = fm(v);
    DMatrix::from_row_slice(rows, data.len() / rows, &data)
}

#[test]
fn mvn_matches_mpmath() {
    let data = load("mvn.json");
    let mut worst = Worst::default();
    for (i, c) in data["cases"].as_array().unwrap().iter().enumerate() {
        let got = mvn_log_pdf(&vec_of(&c["x"]), &vec_of(&c["mean"]), &mat_of(&c["cov"])).unwrap();
        let (want, cond) = (f(&c["logpdf_mp"]), f(&c["cond"]));
        let d = scaled_diff(got, want);
        worst.see(d / tol(cond), || {
            format!("case {i} ({}), scaled diff {d:.2e}", c["kind"])
        });
        assert!(
            d <= tol(cond),
            "case {i} ({}): got {got}, want {want}, diff {d:e}, cond {cond:e}",
            c["kind"]
        );
    }
    worst.report("mvn diff / tolerance");
}

#[test]
fn multivariate_t_matches_mpmath() {
    let data = load("multivariate_t.json");
    let mut worst = Worst::default();
    for (i, c) in data["cases"].as_array().unwrap().iter().enumerate() {
        let got = mvt_log_pdf(&vec_of(&c["x"]), &vec_of(&c["loc"]), &mat_of(&c["shape"]), f(&c["df"])).unwrap();
        let (want, cond) = (f(&c["logpdf_mp"]), f(&c["cond"]));
        let d = scaled_diff(got, want);
        worst.see(d / tol(cond), || {
            format!("case {i} ({}), scaled diff {d:.2e}", c["kind"])
        });
        assert!(
            d <= tol(cond),
            "case {i} ({}): got {got}, want {want}, diff {d:e}",
            c["kind"]
        );
    }
    worst.report("mvt diff / tolerance");
}

#[test]
fn inverse_wishart_matches_mpmath() {
    let data = load("invwishart.json");
    let mut worst = Worst::default();
    for (i, c) in data["cases"].as_array().unwrap().iter().enumerate() {
        let got = inv_wishart_log_pdf(&mat_of(&c["X"]), f(&c["df"]), &mat_of(&c["scale"])).unwrap();
        let (want, cond) = (f(&c["logpdf_mp"]), f(&c["cond_X"]));
        let d = scaled_diff(got, want);
        worst.see(d / tol(cond), || {
            format!("case {i} ({}), scaled diff {d:.2e}", c["kind"])
        });
        assert!(
            d <= tol(cond),
            "case {i} ({}): got {got}, want {want}, diff {d:e}",
            c["kind"]
        );
    }
    worst.report("inverse-Wishart diff / tolerance");
}

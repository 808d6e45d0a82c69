//! Pearson χ² tests for experiment reports (the sorting-significance tests of Fig. 5.3):
//! contingency tables with optional Yates correction and goodness of fit against a uniform
//! expectation, with scipy's semantics (`chi2_contingency`, `chisquare`).
//!
//! Statistic Σ(O − E)²/E; p-value = χ² survival function Q(dof/2, stat/2)
//! ([`crate::special::chi2_sf`]), accurate in relative terms down to ~1e-300.

use serde::{Deserialize, Serialize};

use crate::error::{BayesError, Result};
use crate::special::chi2_sf;

/// The outcome of a χ² test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChiSquareTest {
    /// The Pearson statistic Σ(O − E)²/E (after Yates' correction when it was applied).
    pub statistic: f64,
    /// Degrees of freedom.
    pub dof: usize,
    /// P(χ²_dof ≥ statistic).
    pub p_value: f64,
    /// Expected frequencies, row-major (contingency: row_sum·col_sum/N; fit: N/k each).
    pub expected: Vec<f64>,
}

fn check_counts(what: &'static str, xs: impl Iterator<Item = f64>) -> Result<()> {
    for (index, v) in xs.enumerate() {
        if !(v.is_finite() && v >= 0.0) {
            return Err(BayesError::NonFinite {
                what,
                index,
                value: v,
                requirement: "a finite count >= 0",
            });
        }
    }
    Ok(())
}

/// Pearson's χ² test of independence on an R×K contingency table (rows given as slices of equal
/// length; R, K ≥ 2), scipy `chi2_contingency(table, correction)`.
///
/// `dof = (R−1)(K−1)`. With `yates = true` and dof = 1 (a 2×2 table) each observed count moves
/// towards its expectation by ½, but never past it: `O' = O + sign(E−O)·min(½, |E−O|)`; for
/// dof > 1 the flag has no effect (as in scipy). Errors: ragged or too small tables, negative or
/// non-finite counts, a zero row or column sum (a zero expected frequency).
pub fn chi2_contingency<R: AsRef<[f64]>>(table: &[R], yates: bool) -> Result<ChiSquareTest> {
    const WHAT: &str = "chi-square contingency table";
    let r = table.len();
    if r < 2 {
        return Err(BayesError::DimensionMismatch {
            what: "contingency table rows (at least 2)",
            expected: 2,
            got: r,
        });
    }
    let k = table[0].as_ref().len();
    if k < 2 {
        return Err(BayesError::DimensionMismatch {
            what: "contingency table columns (at least 2)",
            expected: 2,
            got: k,
        });
    }
    for row in table {
        if row.as_ref().len() != k {
            return Err(BayesError::DimensionMismatch {
                what: "contingency table row length",
                expected: k,
                got: row.as_ref().len(),
            });
        }
    }
    check_counts(WHAT, table.iter().flat_map(|row| row.as_ref().iter().copied()))?;
    let row_sums: Vec<f64> = table.iter().map(|row| row.as_ref().iter().sum()).collect();
    let col_sums: Vec<f64> = (0..k).map(|j| table.iter().map(|row| row.as_ref()[j]).sum()).collect();
    let n: f64 = row_sums.iter().sum();
    let mut expected = Vec::with_capacity(r * k);
    for (i, rs) in row_sums.iter().enumerate() {
        for (j, cs) in col_sums.iter().enumerate() {
            let e = rs * cs / n;
            if e.is_nan() || e <= 0.0 {
                return Err(BayesError::ZeroExpected {
                    what: WHAT,
                    row: i,
                    col: j,
                });
            }
            expected.push(e);
        }
    }
    let dof = (r - 1) * (k - 1);
    let correct = yates && dof == 1;
    let mut statistic = 0.0;
    for (i, row) in table.iter().enumerate() {
        for (j, &o) in row.as_ref().iter().enumerate() {
            let e = expected[i * k + j];
            let o = if correct {
                o + (e - o).signum() * (e - o).abs().min(0.5)
            } else {
                o
            };
            statistic += (o - e) * (o - e) / e;
        }
    }
    Ok(ChiSquareTest {
        statistic,
        dof,
        p_value: chi2_sf(statistic, dof as f64),
        expected,
    })
}

/// χ² goodness of fit of observed counts against the uniform expectation N/k (k ≥ 2),
/// scipy `chisquare(f_obs)`. dof = k − 1. Errors: fewer than 2 cells, negative or non-finite
/// counts, all counts zero.
pub fn chi2_uniform_fit(f_obs: &[f64]) -> Result<ChiSquareTest> {
    let k = f_obs.len();
    if k < 2 {
        return Err(BayesError::DimensionMismatch {
            what: "goodness-of-fit cells (at least 2)",
            expected: 2,
            got: k,
        });
    }
    check_counts("chi-square observed counts", f_obs.iter().copied())?;
    let e = f_obs.iter().sum::<f64>() / k as f64;
    if e.is_nan() || e <= 0.0 {
        return Err(BayesError::ZeroExpected {
            what: "chi-square goodness of fit",
            row: 0,
            col: 0,
        });
    }
    let statistic = f_obs.iter().map(|o| (o - e) * (o - e) / e).sum::<f64>();
    let dof = k - 1;
    Ok(ChiSquareTest {
        statistic,
        dof,
        p_value: chi2_sf(statistic, dof as f64),
        expected: vec![e; k],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_tables_are_errors() {
        assert!(chi2_contingency(&[[1.0, 2.0]], false).is_err());
        assert!(chi2_contingency(&[vec![1.0, 2.0], vec![1.0]], false).is_err());
        assert!(chi2_contingency(&[[1.0, -2.0], [1.0, 1.0]], false).is_err());
        assert!(chi2_contingency(&[[1.0, f64::NAN], [1.0, 1.0]], false).is_err());
        assert!(matches!(
            chi2_contingency(&[[0.0, 2.0], [0.0, 1.0]], false),
            Err(BayesError::ZeroExpected { .. })
        ));
        assert!(chi2_uniform_fit(&[3.0]).is_err());
        assert!(chi2_uniform_fit(&[0.0, 0.0]).is_err());
    }
}

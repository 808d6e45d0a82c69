//! Multivariate densities and samplers through the Cholesky factor: the multivariate normal
//! (eq. A.1), the multivariate Student-t and the inverse-Wishart, all in scipy's
//! parameterisation.
//!
//! * `mvn_log_pdf(x, μ, Σ) = −½(d·ln 2π + ln|Σ| + (x−μ)ᵀΣ⁻¹(x−μ))` (A.1).
//! * `mvt_log_pdf(x, loc, Σ, ν) = ln Γ((ν+d)/2) − ln Γ(ν/2) − (d/2) ln(νπ) − ½ ln|Σ|
//!   − ((ν+d)/2)·ln1p(m/ν)`, m = (x−loc)ᵀΣ⁻¹(x−loc); Σ is the *shape* (scale) matrix, the
//!   covariance is Σν/(ν−2).
//! * `inv_wishart_log_pdf(X, ν, Ψ) = (ν/2) ln|Ψ| − (νp/2) ln 2 − ln Γ_p(ν/2) − ((ν+p+1)/2) ln|X|
//!   − ½ tr(ΨX⁻¹)`, X ~ IW(ν, Ψ) ⇔ X⁻¹ ~ Wishart(ν, Ψ⁻¹), E\[X\] = Ψ/(ν−p−1); ν > p − 1.
//!
//! Every matrix goes through a Cholesky factorisation L Lᵀ: `ln|A| = 2 Σ ln Lᵢᵢ`, quadratic
//! forms are `|L⁻¹v|²` by forward substitution, and `tr(ΨX⁻¹) = ‖L_X⁻¹ L_Ψ‖²_F`, so nothing is
//! ever inverted. The `*_chol` variants take factors computed once with [`cholesky`] for hot
//! loops. Accuracy is limited by the conditioning of the matrix (about cond·eps relative).

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use rand::Rng;
use rand_distr::{ChiSquared, Distribution, StandardNormal};

use crate::error::{BayesError, Result, check_len, check_positive};
use crate::special::{ln_gamma_diff, ln_multigamma};

/// ln(2π).
const LN_2PI: f64 = 1.837_877_066_409_345_5;
/// ln π.
const LN_PI: f64 = 1.144_729_885_849_400_2;
/// Relative asymmetry tolerated in a symmetric matrix.
const SYMMETRY_TOL: f64 = 1e-10;

/// A lower Cholesky factor (nalgebra's), as taken by the `*_chol` functions.
pub type CholeskyFactor = Cholesky<f64, Dyn>;

/// Validates a symmetric positive-definite matrix and returns its Cholesky factor.
///
/// Errors: empty or non-square, non-finite entries, asymmetry above 1e-10 (relative to the
/// diagonal), or not positive definite.
pub fn cholesky(what: &'static str, a: &DMatrix<f64>) -> Result<CholeskyFactor> {
    let (rows, cols) = a.shape();
    if rows != cols {
        return Err(BayesError::NotSquare { what, rows, cols });
    }
    if rows == 0 {
        return Err(BayesError::Empty { what });
    }
    if let Some(index) = a.iter().position(|v| !v.is_finite()) {
        return Err(BayesError::NonFinite {
            what,
            index,
            value: a[index],
            requirement: "finite",
        });
    }
    for i in 0..rows {
        for j in 0..i {
            let d = (a[(i, j)] - a[(j, i)]).abs();
            let scale = (a[(i, i)] * a[(j, j)]).abs().sqrt().max(a[(i, j)].abs());
            if d > SYMMETRY_TOL * scale {
                return Err(BayesError::NotSymmetric {
                    what,
                    row: i,
                    col: j,
                    asymmetry: d,
                });
            }
        }
    }
    let chol = Cholesky::new(a.clone()).ok_or(BayesError::NotPositiveDefinite { what })?;
    let l = chol.l_dirty();
    if (0..rows).any(|i| !(l[(i, i)] > 0.0 && l[(i, i)].is_finite())) {
        return Err(BayesError::NotPositiveDefinite { what });
    }
    Ok(chol)
}

/// ln|A| = 2 Σ ln Lᵢᵢ from A's Cholesky factor.
pub fn log_det(chol: &CholeskyFactor) -> f64 {
    let l = chol.l_dirty();
    2.0 * (0..l.nrows()).map(|i| l[(i, i)].ln()).sum::<f64>()
}

/// |L⁻¹(x − m)|² by forward substitution (the Mahalanobis distance squared).
fn mahalanobis_sq(chol: &CholeskyFactor, x: &DVector<f64>, m: &DVector<f64>) -> f64 {
    let l = chol.l_dirty();
    let d = l.nrows();
    let mut y = vec![0.0; d];
    let mut sum = 0.0;
    for i in 0..d {
        let mut s = x[i] - m[i];
        for k in 0..i {
            s -= l[(i, k)] * y[k];
        }
        y[i] = s / l[(i, i)];
        sum += y[i] * y[i];
    }
    sum
}

fn check_vector(what: &'static str, v: &DVector<f64>, d: usize) -> Result<()> {
    check_len(what, d, v.len())?;
    if let Some(index) = v.iter().position(|x| !x.is_finite()) {
        return Err(BayesError::NonFinite {
            what,
            index,
            value: v[index],
            requirement: "finite",
        });
    }
    Ok(())
}

/// Multivariate normal log density (A.1), scipy `multivariate_normal.logpdf(x, mean, cov)`.
pub fn mvn_log_pdf(x: &DVector<f64>, mean: &DVector<f64>, cov: &DMatrix<f64>) -> Result<f64> {
    mvn_log_pdf_chol(x, mean, &cholesky("covariance", cov)?)
}

/// [`mvn_log_pdf`] with the covariance given by its Cholesky factor.
pub fn mvn_log_pdf_chol(x: &DVector<f64>, mean: &DVector<f64>, cov_chol: &CholeskyFactor) -> Result<f64> {
    let d = cov_chol.l_dirty().nrows();
    check_vector("mvn point x", x, d)?;
    check_vector("mvn mean", mean, d)?;
    Ok(-0.5 * (d as f64 * LN_2PI + log_det(cov_chol) + mahalanobis_sq(cov_chol, x, mean)))
}

/// Multivariate Student-t log density, scipy `multivariate_t.logpdf(x, loc, shape, df)`.
/// `shape` is the scale matrix Σ (covariance Σ·df/(df−2)); df > 0 and finite.
pub fn mvt_log_pdf(x: &DVector<f64>, loc: &DVector<f64>, shape: &DMatrix<f64>, df: f64) -> Result<f64> {
    check_positive("df", df)?;
    mvt_log_pdf_chol(x, loc, &cholesky("multivariate t shape", shape)?, df)
}

/// [`mvt_log_pdf`] with the shape matrix given by its Cholesky factor.
pub fn mvt_log_pdf_chol(x: &DVector<f64>, loc: &DVector<f64>, shape_chol: &CholeskyFactor, df: f64) -> Result<f64> {
    check_positive("df", df)?;
    let d = shape_chol.l_dirty().nrows();
    check_vector("mvt point x", x, d)?;
    check_vector("mvt location", loc, d)?;
    let p = d as f64;
    let m = mahalanobis_sq(shape_chol, x, loc);
    // ln Γ((ν+p)/2) − ln Γ(ν/2) without cancellation at large ν.
    Ok(ln_gamma_diff(df / 2.0, p / 2.0)
        - 0.5 * p * (df.ln() + LN_PI)
        - 0.5 * log_det(shape_chol)
        - 0.5 * (df + p) * (m / df).ln_1p())
}

/// Inverse-Wishart log density, scipy `invwishart.logpdf(X, df, scale)` (see the module docs).
/// Requires df > p − 1 (may be non-integer).
pub fn inv_wishart_log_pdf(x: &DMatrix<f64>, df: f64, scale: &DMatrix<f64>) -> Result<f64> {
    inv_wishart_log_pdf_chol(
        &cholesky("inverse-Wishart X", x)?,
        df,
        &cholesky("inverse-Wishart scale", scale)?,
    )
}

/// [`inv_wishart_log_pdf`] with X and the scale Ψ given by their Cholesky factors.
pub fn inv_wishart_log_pdf_chol(x_chol: &CholeskyFactor, df: f64, scale_chol: &CholeskyFactor) -> Result<f64> {
    let lx = x_chol.l_dirty();
    let ls = scale_chol.l_dirty();
    let p = lx.nrows();
    check_len("inverse-Wishart scale dimension", p, ls.nrows())?;
    let pf = p as f64;
    if !(df.is_finite() && df > pf - 1.0) {
        return Err(BayesError::InvalidParameter {
            name: "df",
            value: df,
            requirement: "finite and > p - 1",
        });
    }
    // tr(Ψ X⁻¹) = ‖L_X⁻¹ L_Ψ‖²_F: forward substitution column by column (L_Ψ is lower).
    let mut trace = 0.0;
    let mut z = vec![0.0; p];
    for c in 0..p {
        for i in 0..p {
            let mut s = if i >= c { ls[(i, c)] } else { 0.0 };
            for k in 0..i {
                s -= lx[(i, k)] * z[k];
            }
            z[i] = s / lx[(i, i)];
            trace += z[i] * z[i];
        }
    }
    let half = 0.5 * df;
    Ok(half * log_det(scale_chol)
        - half * pf * std::f64::consts::LN_2
        - ln_multigamma(p, half)
        - 0.5 * (df + pf + 1.0) * log_det(x_chol)
        - 0.5 * trace)
}

/// One draw from N(mean, LLᵀ): `mean + L z`, z standard normal.
pub fn sample_mvn<R: Rng + ?Sized>(
    rng: &mut R,
    mean: &DVector<f64>,
    cov_chol: &CholeskyFactor,
) -> Result<DVector<f64>> {
    let l = cov_chol.l_dirty();
    let d = l.nrows();
    check_vector("mvn mean", mean, d)?;
    let z: DVector<f64> = DVector::from_fn(d, |_, _| StandardNormal.sample(rng));
    let mut out = mean.clone();
    for i in 0..d {
        for k in 0..=i {
            out[i] += l[(i, k)] * z[k];
        }
    }
    Ok(out)
}

/// One draw X ~ IW(df, Ψ) (scipy's convention) by the Bartlett decomposition.
///
/// With Ψ = C Cᵀ and A lower-triangular, Aᵢᵢ² ~ χ²(df − i) (i from 0), Aᵢⱼ ~ N(0, 1) below the
/// diagonal, `C⁻ᵀ A Aᵀ C⁻¹ ~ Wishart(df, Ψ⁻¹)`, so its inverse `X = (C A⁻ᵀ)(C A⁻ᵀ)ᵀ` is the draw;
/// no matrix is inverted except the triangular A.
pub fn sample_inv_wishart<R: Rng + ?Sized>(rng: &mut R, df: f64, scale_chol: &CholeskyFactor) -> Result<DMatrix<f64>> {
    let c = scale_chol.l();
    let p = c.nrows();
    if !(df.is_finite() && df > p as f64 - 1.0) {
        return Err(BayesError::InvalidParameter {
            name: "df",
            value: df,
            requirement: "finite and > p - 1",
        });
    }
    let mut a = DMatrix::zeros(p, p);
    for i in 0..p {
        let chi = ChiSquared::new(df - i as f64).map_err(|_| BayesError::InvalidParameter {
            name: "df",
            value: df,
            requirement: "> p - 1",
        })?;
        a[(i, i)] = chi.sample(rng).sqrt();
        for j in 0..i {
            a[(i, j)] = StandardNormal.sample(rng);
        }
    }
    // A⁻¹ (lower); a zero diagonal has probability zero but would make the draw infinite.
    let a_inv = a
        .solve_lower_triangular(&DMatrix::identity(p, p))
        .ok_or(BayesError::NotPositiveDefinite {
            what: "Bartlett factor (degenerate draw)",
        })?;
    let t = &c * a_inv.transpose();
    Ok(&t * t.transpose())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_matrices_are_errors() {
        let x = DVector::from_vec(vec![0.0, 0.0]);
        let not_pd = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        assert!(matches!(
            mvn_log_pdf(&x, &x, &not_pd),
            Err(BayesError::NotPositiveDefinite { .. })
        ));
        let asym = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]);
        assert!(matches!(
            mvn_log_pdf(&x, &x, &asym),
            Err(BayesError::NotSymmetric { .. })
        ));
        let nan = DMatrix::from_row_slice(2, 2, &[1.0, f64::NAN, f64::NAN, 1.0]);
        assert!(mvn_log_pdf(&x, &x, &nan).is_err());
        let eye = DMatrix::identity(2, 2);
        assert!(mvn_log_pdf(&DVector::zeros(3), &x, &eye).is_err());
        assert!(mvt_log_pdf(&x, &x, &eye, 0.0).is_err());
        assert!(inv_wishart_log_pdf(&eye, 0.5, &eye).is_err());
        assert!(cholesky("m", &DMatrix::zeros(2, 3)).is_err());
        assert!(cholesky("m", &DMatrix::zeros(0, 0)).is_err());
    }

    #[test]
    fn inverse_wishart_samples_have_the_right_mean() {
        let psi = DMatrix::from_row_slice(2, 2, &[2.0, 0.3, 0.3, 1.0]);
        let chol = cholesky("psi", &psi).unwrap();
        let df = 9.5;
        let mut rng = crate::rng::seeded(7);
        let n = 40_000;
        let mut mean = DMatrix::zeros(2, 2);
        for _ in 0..n {
            mean += sample_inv_wishart(&mut rng, df, &chol).unwrap();
        }
        mean /= n as f64;
        let want = &psi / (df - 3.0);
        assert!((mean - &want).abs().max() < 0.02 * want.abs().max(), "{want}");
    }

    #[test]
    fn mvn_samples_have_the_right_moments_and_are_deterministic() {
        let cov = DMatrix::from_row_slice(2, 2, &[1.0, 0.8, 0.8, 2.0]);
        let chol = cholesky("cov", &cov).unwrap();
        let mean = DVector::from_vec(vec![1.0, -2.0]);
        let draw = |seed| {
            let mut rng = crate::rng::seeded(seed);
            (0..20_000)
                .map(|_| sample_mvn(&mut rng, &mean, &chol).unwrap())
                .collect::<Vec<_>>()
        };
        let xs = draw(3);
        assert_eq!(xs, draw(3));
        let m = xs.iter().fold(DVector::zeros(2), |a, x| a + x) / xs.len() as f64;
        assert!((&m - &mean).abs().max() < 0.04);
        let c01 = xs.iter().map(|x| (x[0] - m[0]) * (x[1] - m[1])).sum::<f64>() / xs.len() as f64;
        assert!((c01 - 0.8).abs() < 0.05);
    }
}

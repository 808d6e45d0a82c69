//! Per-prototype sufficient statistics and the cached predictive densities of the collapsed Gibbs
//! update (6.18–6.24), plus the marginal likelihoods used by the log-joint trace.
//!
//! A prototype's statistics change by one datum at a time, so they are updated in O(1) (Welford
//! updates for the position mean and scatter, running sums for the appearance); the predictive's
//! Cholesky factor and normaliser are then recomputed from them. For 3×3 and 2×2 matrices the
//! recomputation is a few dozen flops — as cheap as a rank-one Cholesky update/downdate and free of
//! the drift that repeated downdates accumulate. Scoring a datum against a cached prototype is a
//! triangular solve and one logarithm, so an assignment update is O(A) with no allocation.

use nalgebra::{Matrix2, Matrix3, Vector3};

use crate::math::{DX, cholesky, det2, ln_det_from_chol, ln_multigamma, mahalanobis_sq, symmetrize};
use crate::prior::Derived;

/// n, mean and scatter Σ(x − x̄)(x − x̄)ᵀ of the positions assigned to a prototype.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PositionStats {
    pub n: u32,
    pub mean: Vector3<f64>,
    pub scatter: Matrix3<f64>,
}

impl Default for PositionStats {
    fn default() -> Self {
        Self {
            n: 0,
            mean: Vector3::zeros(),
            scatter: Matrix3::zeros(),
        }
    }
}

impl PositionStats {
    #[inline]
    pub fn add(&mut self, x: &Vector3<f64>) {
        let n0 = self.n as f64;
        self.n += 1;
        let d = x - self.mean;
        self.mean += d / (n0 + 1.0);
        self.scatter += d * d.transpose() * (n0 / (n0 + 1.0));
    }

    #[inline]
    pub fn remove(&mut self, x: &Vector3<f64>) {
        debug_assert!(self.n > 0);
        if self.n <= 1 {
            *self = Self::default();
            return;
        }
        let n = self.n as f64;
        self.n -= 1;
        self.mean = (self.mean * n - x) / (n - 1.0);
        let d = x - self.mean;
        self.scatter -= d * d.transpose() * ((n - 1.0) / n);
    }

    /// NIW posterior (κ_n, ν_n, μ_n, Λ_n).
    pub fn posterior(&self, p: &Derived) -> (f64, f64, Vector3<f64>, Matrix3<f64>) {
        let n = self.n as f64;
        let kn = p.kappa0 + n;
        let nun = p.nu0 + n;
        if self.n == 0 {
            return (kn, nun, p.mu0, p.xi);
        }
        let mun = (p.mu0 * p.kappa0 + self.mean * n) / kn;
        let dm = self.mean - p.mu0;
        let lam = p.xi + self.scatter + dm * dm.transpose() * (p.kappa0 * n / kn);
        (kn, nun, mun, symmetrize(&lam))
    }

    /// Marginal likelihood ln p(x₁…x_n) under the NIW prior (0 for an empty prototype).
    pub fn log_marginal(&self, p: &Derived) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        let d = DX as f64;
        let n = self.n as f64;
        let (kn, nun, _, lam) = self.posterior(p);
        let ln_det_lam = cholesky(&lam).map(|l| ln_det_from_chol(&l)).unwrap_or(f64::INFINITY);
        -n * d / 2.0 * std::f64::consts::PI.ln() + ln_multigamma(nun / 2.0, DX) - ln_multigamma(p.nu0 / 2.0, DX)
            + p.nu0 / 2.0 * p.ln_det_xi
            - nun / 2.0 * ln_det_lam
            + d / 2.0 * (p.kappa0.ln() - kn.ln())
    }
}

/// Cached predictive density of a new position given a prototype's data: the exact multivariate
/// Student-t t_{ν_n−2}(μ_n, Λ_n (κ_n+1)/(κ_n (ν_n−2))), or (seed) the normal with its moments.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PositionCache {
    pub mean: Vector3<f64>,
    pub chol: Matrix3<f64>,
    pub dof: f64,
    /// (ν + d)/2 for the t; 1/2 for the normal.
    pub coef: f64,
    pub log_norm: f64,
    pub normal: bool,
}

impl PositionCache {
    pub fn new(s: &PositionStats, p: &Derived) -> Self {
        let d = DX as f64;
        let (kn, nun, mun, lam) = s.posterior(p);
        let dof = nun - d + 1.0;
        let mut scale = lam * ((kn + 1.0) / (kn * dof));
        if p.moment_matched {
            // Covariance of the t: scale · ν/(ν − 2).
            scale *= dof / (dof - 2.0);
        }
        let chol = cholesky(&scale).unwrap_or_else(|| Matrix3::identity() * scale.diagonal().amax().max(1e-12).sqrt());
        let ln_det = ln_det_from_chol(&chol);
        if p.moment_matched {
            Self {
                mean: mun,
                chol,
                dof,
                coef: 0.5,
                log_norm: -d / 2.0 * (2.0 * std::f64::consts::PI).ln() - 0.5 * ln_det,
                normal: true,
            }
        } else {
            Self {
                mean: mun,
                chol,
                dof,
                coef: (dof + d) / 2.0,
                log_norm: crate::math::ln_gamma((dof + d) / 2.0)
                    - crate::math::ln_gamma(dof / 2.0)
                    - d / 2.0 * (dof * std::f64::consts::PI).ln()
                    - 0.5 * ln_det,
                normal: false,
            }
        }
    }

    /// ln p(x | prototype's data).
    #[inline]
    pub fn log_pred(&self, x: &Vector3<f64>) -> f64 {
        let q = mahalanobis_sq(&self.chol, &(x - self.mean));
        if self.normal {
            self.log_norm - 0.5 * q
        } else {
            self.log_norm - self.coef * (q / self.dof).ln_1p()
        }
    }
}

/// n, Σ b⁻¹ and Σ ln|b| of the appearances assigned to a prototype.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AppearanceStats {
    pub n: u32,
    pub sum_inv: Matrix2<f64>,
    pub sum_ln_det: f64,
}

impl Default for AppearanceStats {
    fn default() -> Self {
        Self {
            n: 0,
            sum_inv: Matrix2::zeros(),
            sum_ln_det: 0.0,
        }
    }
}

impl AppearanceStats {
    #[inline]
    pub fn add(&mut self, b_inv: &Matrix2<f64>, ln_det_b: f64) {
        self.n += 1;
        self.sum_inv += b_inv;
        self.sum_ln_det += ln_det_b;
    }

    #[inline]
    pub fn remove(&mut self, b_inv: &Matrix2<f64>, ln_det_b: f64) {
        debug_assert!(self.n > 0);
        if self.n <= 1 {
            *self = Self::default();
            return;
        }
        self.n -= 1;
        self.sum_inv -= b_inv;
        self.sum_ln_det -= ln_det_b;
    }

    /// Posterior of ψ: Wishart(ν_n, P⁻¹) with ν_n = ν_ψ + n u and P = S₀⁻¹ + Σ b⁻¹.
    pub fn posterior(&self, p: &Derived) -> (f64, Matrix2<f64>) {
        (p.nu_psi + self.n as f64 * p.u, symmetrize(&(p.s0_inv + self.sum_inv)))
    }

    /// ln p(b₁…b_n) with ψ integrated out:
    /// Σᵢ[−(u+3)/2 ln|bᵢ| − ln Γ₂(u/2)] + ln Γ₂(ν_n/2) − ln Γ₂(ν_ψ/2) − ν_n/2 ln|P| + ν_ψ/2 ln|S₀⁻¹|.
    pub fn log_marginal(&self, p: &Derived) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        let n = self.n as f64;
        let (nun, pm) = self.posterior(p);
        -(p.u + 3.0) / 2.0 * self.sum_ln_det - n * p.ln_multigamma_u + ln_multigamma(nun / 2.0, 2)
            - ln_multigamma(p.nu_psi / 2.0, 2)
            - nun / 2.0 * det2(&pm).ln()
            + p.nu_psi / 2.0 * p.ln_det_s0_inv
    }
}

/// Cached predictive of a new appearance b given a prototype's data (the collapsed form of 6.22):
/// p(b) = Γ₂((u+ν_n)/2) / (Γ₂(u/2) Γ₂(ν_n/2)) · |b|^{−(u+3)/2} |P|^{ν_n/2} |P + b⁻¹|^{−(u+ν_n)/2}.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AppearanceCache {
    pub p: Matrix2<f64>,
    pub coef: f64,
    pub log_norm: f64,
    pub half_u3: f64,
}

impl AppearanceCache {
    pub fn new(s: &AppearanceStats, p: &Derived) -> Self {
        let (nun, pm) = s.posterior(p);
        Self::from_posterior(nun, pm, p)
    }

    /// From the posterior (ν_n, P) directly.
    pub fn from_posterior(nun: f64, pm: Matrix2<f64>, p: &Derived) -> Self {
        Self {
            p: pm,
            coef: (p.u + nun) / 2.0,
            log_norm: ln_multigamma((p.u + nun) / 2.0, 2) - p.ln_multigamma_u - ln_multigamma(nun / 2.0, 2)
                + nun / 2.0 * det2(&pm).ln(),
            half_u3: (p.u + 3.0) / 2.0,
        }
    }

    /// ln p(b | prototype's data), given b⁻¹ and ln|b|.
    #[inline]
    pub fn log_pred(&self, b_inv: &Matrix2<f64>, ln_det_b: f64) -> f64 {
        self.log_norm - self.half_u3 * ln_det_b - self.coef * det2(&(self.p + b_inv)).ln()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prior::{AppearancePrior, Hyperparameters, PositionPredictive, PositionPrior};
    use approx::assert_relative_eq;

    fn prior() -> Derived {
        Derived::new(&Hyperparameters {
            alpha: 1.0,
            beta: 1.0,
            position: PositionPrior {
                mean: [0.0, 0.01, 0.1],
                kappa: 0.3,
                dof: 5.5,
                scale: [[0.002, 0.0003, 0.0], [0.0003, 0.001, 0.0001], [0.0, 0.0001, 0.003]],
            },
            appearance: AppearancePrior {
                dof: 9.0,
                scale_dof: 3.5,
                scale: [[2.0, 0.3], [0.3, 1.0]],
            },
            position_predictive: PositionPredictive::StudentT,
        })
        .unwrap()
    }

    /// The cached predictive equals the ratio of marginals, p(x | D) = p(D ∪ x)/p(D), for both the
    /// position (Student-t) and the appearance term.
    #[test]
    fn predictive_is_ratio_of_marginals() {
        let p = prior();
        let xs = [
            Vector3::new(0.01, 0.02, 0.12),
            Vector3::new(-0.03, 0.0, 0.09),
            Vector3::new(0.0, 0.05, 0.11),
        ];
        let bs = [
            Matrix2::new(3.0, 0.5, 0.5, 1.2),
            Matrix2::new(2.0, -0.2, -0.2, 0.8),
            Matrix2::new(1.0, 0.0, 0.0, 1.5),
        ];
        let mut ps = PositionStats::default();
        let mut aps = AppearanceStats::default();
        for k in 0..3 {
            let x = xs[k];
            let b = bs[k];
            let bi = crate::math::inv2(&b);
            let ld = det2(&b).ln();
            let pred_x = PositionCache::new(&ps, &p).log_pred(&x);
            let pred_b = AppearanceCache::new(&aps, &p).log_pred(&bi, ld);
            let (mx0, mb0) = (ps.log_marginal(&p), aps.log_marginal(&p));
            ps.add(&x);
            aps.add(&bi, ld);
            assert_relative_eq!(pred_x, ps.log_marginal(&p) - mx0, epsilon = 1e-9);
            assert_relative_eq!(pred_b, aps.log_marginal(&p) - mb0, epsilon = 1e-9);
        }
        // The cached t agrees with bayes' reference density.
        let (kn, nun, mun, lam) = ps.posterior(&p);
        let dof = nun - 2.0;
        let shape = lam * ((kn + 1.0) / (kn * dof));
        let x = Vector3::new(0.02, -0.01, 0.1);
        let reference = bayes::multivariate::mvt_log_pdf(
            &nalgebra::DVector::from_column_slice(x.as_slice()),
            &nalgebra::DVector::from_column_slice(mun.as_slice()),
            &nalgebra::DMatrix::from_column_slice(3, 3, shape.as_slice()),
            dof,
        )
        .unwrap();
        assert_relative_eq!(PositionCache::new(&ps, &p).log_pred(&x), reference, epsilon = 1e-10);
        // Removing undoes adding.
        let mut ps2 = ps;
        ps2.add(&Vector3::new(0.3, -0.2, 0.0));
        ps2.remove(&Vector3::new(0.3, -0.2, 0.0));
        assert!((ps2.mean - ps.mean).norm() < 1e-15);
        assert!((ps2.scatter - ps.scatter).abs().max() < 1e-15);
    }
}

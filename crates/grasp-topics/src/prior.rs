//! Hyperparameters Ω of the model (§6.3) and the conjugate priors chosen where the seed is vague.
//!
//! | variable | seed | here |
//! |---|---|---|
//! | θ_m (6.9) | symmetric Dirichlet(α) | same |
//! | φ_j (6.12) | symmetric Dirichlet(β) | same |
//! | Σ_j (6.13) | inverse-Wishart(Ξ, ν) | same |
//! | μ_j (6.13) | "uniform" | Normal(μ₀, Σ_j/κ₀): Normal–inverse-Wishart with Σ_j's prior |
//! | u_j (6.11) | "u₀", grown as u₀ + n_j in (6.23) | a fixed shape u shared by all prototypes |
//! | ψ_j (6.11) | "inverse-Wishart with scale Ψ and u₀" | Wishart(ν_ψ, S₀) |
//!
//! Why the changes:
//! - A uniform (improper) prior on μ_j leaves an empty prototype without a predictive density, so
//!   neither (6.18–6.21) nor the exact Student-t can score a datum against it (δ_j in 6.21 is
//!   infinite at n_j = 0). The Normal–inverse-Wishart prior is the conjugate proper choice; with a
//!   small κ₀ it is nearly flat in μ. μ₀ = 0 is the object centroid, the natural centre of the
//!   object frame.
//! - With b ~ Inv-Wishart_u(ψ) and u known, the likelihood in ψ has the Wishart kernel
//!   |ψ|^{u/2} exp(−½ tr(ψ b⁻¹)), so a Wishart prior on ψ_j is conjugate:
//!   ψ_j | b ~ Wishart(ν_ψ + n u, (S₀⁻¹ + Σ b⁻¹)⁻¹), and the collapsed predictive of a new b is
//!   closed-form (see `stats`). The seed's (6.23–6.24) instead grows the degrees of freedom with n_j
//!   and divides the scale by n_j, which is not the predictive of any model where b ~ IW(u_j, ψ_j):
//!   its mean ψ̂_j/(û_j − 3) shrinks like 1/n_j.

use nalgebra::{Matrix2, Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::data::Dataset;
use crate::error::{GraspError, Result, check_finite, invalid};
use crate::math::{DX, a2, a3, cholesky, m2, m3};

/// How a datum's position is scored against a prototype in the collapsed Gibbs update.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum PositionPredictive {
    /// The exact posterior predictive of the Normal–inverse-Wishart model: a multivariate Student-t
    /// (the default; the collapsed Gibbs chain then targets the exact posterior).
    #[default]
    StudentT,
    /// The seed's moment-matched normal (6.18–6.21): a normal with the Student-t's mean and
    /// covariance. Kept to reproduce the seed; it makes the chain target a slightly different
    /// distribution (too light tails for small prototypes).
    MomentMatched,
}

/// Normal–inverse-Wishart prior on a prototype's hand-position distribution (6.13):
/// Σ_j ~ Inv-Wishart(ν, Ξ), μ_j | Σ_j ~ Normal(μ₀, Σ_j / κ₀).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PositionPrior {
    /// μ₀ (m, object frame).
    pub mean: [f64; 3],
    /// κ₀ > 0: prior pseudo-count on the mean.
    pub kappa: f64,
    /// ν > 2: degrees of freedom of Σ_j's inverse-Wishart prior (> 4 for the moment-matched normal).
    pub dof: f64,
    /// Ξ (m², SPD): scale of Σ_j's inverse-Wishart prior; E(Σ_j) = Ξ/(ν − 4).
    pub scale: [[f64; 3]; 3],
}

/// Prior on a prototype's appearance distribution (6.11): b ~ Inv-Wishart(u, ψ_j),
/// ψ_j ~ Wishart(ν_ψ, S₀).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AppearancePrior {
    /// u > 1: degrees of freedom of b given ψ_j (larger = prototypes more specific in appearance;
    /// the coefficient of variation of b's diagonal is about √(2/(u − 5))).
    pub dof: f64,
    /// ν_ψ > 1: degrees of freedom of ψ_j's Wishart prior.
    pub scale_dof: f64,
    /// S₀ (SPD): scale of ψ_j's Wishart prior; E(ψ_j) = ν_ψ S₀ and E(b) = E(ψ_j)/(u − 3).
    pub scale: [[f64; 2]; 2],
}

/// All hyperparameters Ω of the model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Hyperparameters {
    /// α > 0: symmetric Dirichlet prior on each object's prototype weights θ_m (6.9).
    pub alpha: f64,
    /// β > 0: symmetric Dirichlet prior on each prototype's orientation weights φ_j (6.12).
    pub beta: f64,
    /// Prior on (μ_j, Σ_j).
    pub position: PositionPrior,
    /// Prior on ψ_j and the shape u.
    pub appearance: AppearancePrior,
    /// Exact Student-t (default) or the seed's moment-matched normal.
    #[serde(default)]
    pub position_predictive: PositionPredictive,
}

impl Hyperparameters {
    /// Weakly informative defaults scaled to the data (empirical Bayes in scale only):
    /// α = β = 0.5; μ₀ = 0 (the centroid), κ₀ = 1/16, ν = 6 and Ξ = 2·diag(s²)/16 where s² is the
    /// per-axis second moment of the positions about the centroid (floored at (1 cm)²), so a
    /// prototype's spread is a quarter of the data's and prototype means spread like the data;
    /// u = 20, ν_ψ = 4 and S₀ = b̄ (u − 3)/ν_ψ, so E(b) is the mean appearance b̄.
    pub fn from_data(data: &Dataset) -> Self {
        let n = data.len().max(1) as f64;
        let mut s2 = Vector3::zeros();
        let mut bbar = Matrix2::zeros();
        for i in 0..data.len() {
            s2 += data.x[i].component_mul(&data.x[i]);
            bbar += data.b[i];
        }
        s2 /= n;
        bbar /= n;
        let s2 = s2.map(|v| v.max(1e-4));
        let dof = 6.0;
        let xi = Matrix3::from_diagonal(&s2) * ((dof - DX as f64 - 1.0) / 16.0);
        let u = 20.0;
        let nu_psi = 4.0;
        if cholesky(&bbar).is_none() {
            bbar = Matrix2::identity();
        }
        Self {
            alpha: 0.5,
            beta: 0.5,
            position: PositionPrior {
                mean: [0.0; 3],
                kappa: 1.0 / 16.0,
                dof,
                scale: a3(&xi),
            },
            appearance: AppearancePrior {
                dof: u,
                scale_dof: nu_psi,
                scale: a2(&(bbar * ((u - 3.0) / nu_psi))),
            },
            position_predictive: PositionPredictive::StudentT,
        }
    }

    /// Checks every hyperparameter's range (field names as in the model file).
    pub fn validate(&self) -> Result<()> {
        let pos = |x: f64, f: &str| -> Result<()> {
            check_finite(|| f.to_string(), &[x])?;
            if x <= 0.0 {
                return Err(invalid(f, format!("must be > 0, got {x}")));
            }
            Ok(())
        };
        pos(self.alpha, "hyperparameters.alpha")?;
        pos(self.beta, "hyperparameters.beta")?;
        pos(self.position.kappa, "hyperparameters.position.kappa")?;
        check_finite(|| "hyperparameters.position.mean".into(), &self.position.mean)?;
        let min_dof = match self.position_predictive {
            PositionPredictive::StudentT => DX as f64 - 1.0,
            PositionPredictive::MomentMatched => DX as f64 + 1.0,
        };
        check_finite(|| "hyperparameters.position.dof".into(), &[self.position.dof])?;
        if self.position.dof <= min_dof {
            return Err(invalid(
                "hyperparameters.position.dof",
                format!("must be > {min_dof}, got {}", self.position.dof),
            ));
        }
        let xi = m3(&self.position.scale);
        check_finite(|| "hyperparameters.position.scale".into(), xi.as_slice())?;
        if (xi - xi.transpose()).abs().max() > 1e-12 * xi.abs().max() || cholesky(&xi).is_none() {
            return Err(GraspError::NotPositiveDefinite {
                field: "hyperparameters.position.scale".into(),
                reason: "Ξ must be symmetric positive definite".into(),
            });
        }
        for (x, f) in [
            (self.appearance.dof, "hyperparameters.appearance.dof"),
            (self.appearance.scale_dof, "hyperparameters.appearance.scale_dof"),
        ] {
            check_finite(|| f.to_string(), &[x])?;
            if x <= 1.0 {
                return Err(invalid(f, format!("must be > 1, got {x}")));
            }
        }
        crate::corpus::validate_spd2("hyperparameters.appearance.scale", &self.appearance.scale)?;
        Ok(())
    }
}

/// Quantities derived once from validated hyperparameters (Cholesky factors, log-determinants).
#[derive(Debug, Clone)]
pub(crate) struct Derived {
    pub mu0: Vector3<f64>,
    pub kappa0: f64,
    pub nu0: f64,
    pub xi: Matrix3<f64>,
    pub ln_det_xi: f64,
    pub u: f64,
    pub nu_psi: f64,
    /// S₀⁻¹.
    pub s0_inv: Matrix2<f64>,
    pub s0_chol: Matrix2<f64>,
    pub ln_det_s0_inv: f64,
    /// ln Γ₂(u/2), the same for every datum.
    pub ln_multigamma_u: f64,
    pub moment_matched: bool,
}

impl Derived {
    pub(crate) fn new(h: &Hyperparameters) -> Result<Self> {
        h.validate()?;
        let xi = m3(&h.position.scale);
        let s0 = m2(&h.appearance.scale);
        let xi_chol = cholesky(&xi).ok_or_else(|| invalid("hyperparameters.position.scale", "not SPD"))?;
        let s0_chol = cholesky(&s0).ok_or_else(|| invalid("hyperparameters.appearance.scale", "not SPD"))?;
        let s0_inv = crate::math::inv2(&s0);
        Ok(Self {
            mu0: Vector3::from(h.position.mean),
            kappa0: h.position.kappa,
            nu0: h.position.dof,
            xi,
            ln_det_xi: crate::math::ln_det_from_chol(&xi_chol),
            u: h.appearance.dof,
            nu_psi: h.appearance.scale_dof,
            s0_inv,
            s0_chol,
            ln_det_s0_inv: crate::math::det2(&s0_inv).ln(),
            ln_multigamma_u: crate::math::ln_multigamma(h.appearance.dof / 2.0, 2),
            moment_matched: h.position_predictive == PositionPredictive::MomentMatched,
        })
    }
}

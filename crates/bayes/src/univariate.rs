//! The univariate Gaussian feature model of §5.1.2.2: a Normal likelihood with the conjugate
//! Normal–Inverse-Gamma prior, its sufficient statistics, closed-form marginal likelihood and
//! the Student-t posterior predictive (the components of the size model in Figs. 5.5–5.7).
//!
//! Parameterisation (that of the reference vectors): `μ | σ² ~ N(μ₀, σ²/κ₀)`,
//! `σ² ~ InvGamma(α₀, β₀)` (shape, scale: density `β^α/Γ(α) (σ²)^−(α+1) e^(−β/σ²)`),
//! `xᵢ | μ, σ² ~ N(μ, σ²)` iid. With n points of mean x̄ and M2 = Σ(xᵢ − x̄)² (A.5, A.6):
//!
//! ```text
//!   κₙ = κ₀ + n        μₙ = (κ₀μ₀ + n x̄)/κₙ        αₙ = α₀ + n/2
//!   βₙ = β₀ + ½M2 + κ₀ n (x̄ − μ₀)² / (2κₙ)
//!   ln p(x) = ln Γ(αₙ) − ln Γ(α₀) + α₀ ln β₀ − αₙ ln βₙ + ½(ln κ₀ − ln κₙ) − (n/2) ln 2π
//!   p(x̃ | x) = Student-t(ν = 2αₙ, loc = μₙ, scale² = βₙ(κₙ+1)/(αₙκₙ))
//! ```
//!
//! The marginal is evaluated as `ln_gamma_diff(α₀, n/2) − α₀ ln1p(Δβ/β₀) − (n/2) ln βₙ
//! − ½ ln1p(n/κ₀) − (n/2) ln 2π` (Δβ = βₙ − β₀), which stays accurate when α₀ or κ₀ is huge.
//! Sequential updating (A.25) is exact: the posterior after some data is the prior for the
//! next, so `posterior(a ⊕ b) = posterior(a).posterior(b)` and the chain rule holds.

use rand::Rng;
use rand_distr::{Distribution, Gamma, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::error::{BayesError, Result, check_finite, check_positive};
use crate::special::ln_gamma_diff;

/// ½ ln(2π).
const LN_SQRT_2PI: f64 = 0.918_938_533_204_672_8;
/// ln π.
const LN_PI: f64 = 1.144_729_885_849_400_2;

/// Student-t log density, scipy `t.logpdf(x, df, loc, scale)`:
/// `ln Γ((ν+1)/2) − ln Γ(ν/2) − ½ ln(νπ) − ln s − ((ν+1)/2)·ln1p(z²/ν)`, z = (x − loc)/s.
///
/// Accurate for ν from 1e-3 to 1e10 and beyond (the gamma ratio is taken without cancellation);
/// ν = +inf gives the Normal density. x = ±inf gives `-inf`. Errors: NaN x, ν ≤ 0 or NaN,
/// non-finite loc, scale ≤ 0 or non-finite.
pub fn student_t_log_pdf(x: f64, df: f64, loc: f64, scale: f64) -> Result<f64> {
    if x.is_nan() {
        return Err(BayesError::NonFinite {
            what: "Student-t point x",
            index: 0,
            value: x,
            requirement: "not NaN",
        });
    }
    Ok(StudentT::new(df, loc, scale)?.log_pdf(x))
}

/// A location–scale Student-t distribution (the NIG posterior predictive).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "StudentTRaw")]
pub struct StudentT {
    df: f64,
    loc: f64,
    scale: f64,
}

#[derive(Deserialize)]
struct StudentTRaw {
    df: f64,
    loc: f64,
    scale: f64,
}

impl TryFrom<StudentTRaw> for StudentT {
    type Error = BayesError;
    fn try_from(r: StudentTRaw) -> Result<Self> {
        Self::new(r.df, r.loc, r.scale)
    }
}

impl StudentT {
    /// ν > 0 (may be +inf: the Normal limit), loc finite, scale > 0 and finite.
    pub fn new(df: f64, loc: f64, scale: f64) -> Result<Self> {
        if df.is_nan() || df <= 0.0 {
            return Err(BayesError::InvalidParameter {
                name: "df",
                value: df,
                requirement: "> 0",
            });
        }
        check_finite("Student-t loc", 0, loc)?;
        check_positive("scale", scale)?;
        Ok(Self { df, loc, scale })
    }

    /// Degrees of freedom ν.
    pub fn df(&self) -> f64 {
        self.df
    }

    /// Location.
    pub fn loc(&self) -> f64 {
        self.loc
    }

    /// Scale s (the standard deviation is s·√(ν/(ν−2)) for ν > 2).
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Log density at x (NaN for NaN x, `-inf` for x = ±inf).
    pub fn log_pdf(&self, x: f64) -> f64 {
        let z = (x - self.loc) / self.scale;
        let nu = self.df;
        if nu == f64::INFINITY {
            return -LN_SQRT_2PI - self.scale.ln() - 0.5 * z * z;
        }
        let az = z.abs();
        // ln1p(z²/ν), without overflowing z² in the far tail.
        let log_kernel = if az > 1e150 {
            2.0 * az.ln() - nu.ln() + (nu / az / az).ln_1p()
        } else {
            (z * z / nu).ln_1p()
        };
        ln_gamma_diff(0.5 * nu, 0.5) - 0.5 * (nu.ln() + LN_PI) - self.scale.ln() - 0.5 * (nu + 1.0) * log_kernel
    }

    /// One draw: loc + s·Z/√(G/ν), Z standard normal, G ~ χ²(ν) (Normal when ν = +inf).
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        let z: f64 = StandardNormal.sample(rng);
        if self.df == f64::INFINITY {
            return self.loc + self.scale * z;
        }
        // Gamma(ν/2, scale 2/ν) = χ²(ν)/ν; parameters are valid by construction.
        let g = Gamma::new(0.5 * self.df, 2.0 / self.df)
            .map(|g| g.sample(rng))
            .unwrap_or(1.0);
        self.loc + self.scale * z / g.sqrt()
    }
}

/// Sufficient statistics of univariate data: count n, mean x̄ and M2 = Σ(xᵢ − x̄)² (A.5, A.6),
/// kept by Welford's update and Chan's merge, so one observation or one demonstration at a time
/// gives the same statistics as all at once (to rounding), in any order.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(try_from = "GaussianStatsRaw")]
pub struct GaussianStats {
    n: u64,
    mean: f64,
    m2: f64,
}

#[derive(Deserialize)]
struct GaussianStatsRaw {
    n: u64,
    mean: f64,
    m2: f64,
}

impl TryFrom<GaussianStatsRaw> for GaussianStats {
    type Error = BayesError;
    fn try_from(r: GaussianStatsRaw) -> Result<Self> {
        Self::from_parts(r.n, r.mean, r.m2)
    }
}

impl GaussianStats {
    /// No data.
    pub fn new() -> Self {
        Self::default()
    }

    /// From stored parts: mean and M2 finite, M2 ≥ 0, and both 0 when n = 0.
    pub fn from_parts(n: u64, mean: f64, m2: f64) -> Result<Self> {
        check_finite("GaussianStats mean", 0, mean)?;
        if !(m2.is_finite() && m2 >= 0.0) {
            return Err(BayesError::InvalidParameter {
                name: "m2",
                value: m2,
                requirement: "finite and >= 0",
            });
        }
        if n == 0 && (mean != 0.0 || m2 != 0.0) {
            return Err(BayesError::InvalidParameter {
                name: "mean/m2 with n = 0",
                value: mean,
                requirement: "0",
            });
        }
        Ok(Self { n, mean, m2 })
    }

    /// Statistics of a slice (Err on a non-finite value).
    pub fn from_slice(xs: &[f64]) -> Result<Self> {
        let mut s = Self::new();
        for &x in xs {
            s.update(x)?;
        }
        Ok(s)
    }

    /// Adds one observation (Welford). Err (and no change) for a non-finite x.
    pub fn update(&mut self, x: f64) -> Result<()> {
        check_finite("observation", 0, x)?;
        self.n += 1;
        let delta = x - self.mean;
        self.mean += delta / self.n as f64;
        self.m2 += delta * (x - self.mean);
        Ok(())
    }

    /// Adds another batch's statistics (Chan et al.'s parallel update).
    pub fn merge(&mut self, other: &Self) {
        if other.n == 0 {
            return;
        }
        if self.n == 0 {
            *self = *other;
            return;
        }
        let n = self.n + other.n;
        let (na, nb, nf) = (self.n as f64, other.n as f64, n as f64);
        let delta = other.mean - self.mean;
        self.mean += delta * (nb / nf);
        self.m2 += other.m2 + delta * delta * (na * nb / nf);
        self.n = n;
    }

    /// Number of observations n.
    pub fn n(&self) -> u64 {
        self.n
    }

    /// Sample mean x̄ (0 when n = 0).
    pub fn mean(&self) -> f64 {
        self.mean
    }

    /// M2 = Σ(xᵢ − x̄)².
    pub fn m2(&self) -> f64 {
        self.m2
    }
}

/// The Normal–Inverse-Gamma distribution over (μ, σ²): a prior, or a posterior after
/// [`NormalInverseGamma::posterior`] (see the module docs for the parameterisation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "NigRaw")]
pub struct NormalInverseGamma {
    mu: f64,
    kappa: f64,
    alpha: f64,
    beta: f64,
}

#[derive(Deserialize)]
struct NigRaw {
    mu: f64,
    kappa: f64,
    alpha: f64,
    beta: f64,
}

impl TryFrom<NigRaw> for NormalInverseGamma {
    type Error = BayesError;
    fn try_from(r: NigRaw) -> Result<Self> {
        Self::new(r.mu, r.kappa, r.alpha, r.beta)
    }
}

impl NormalInverseGamma {
    /// μ₀ finite; κ₀, α₀, β₀ finite and > 0.
    pub fn new(mu: f64, kappa: f64, alpha: f64, beta: f64) -> Result<Self> {
        check_finite("NIG mu", 0, mu)?;
        check_positive("kappa", kappa)?;
        check_positive("alpha", alpha)?;
        check_positive("beta", beta)?;
        Ok(Self { mu, kappa, alpha, beta })
    }

    /// Location μ of the mean.
    pub fn mu(&self) -> f64 {
        self.mu
    }

    /// Pseudo-count κ of the mean.
    pub fn kappa(&self) -> f64 {
        self.kappa
    }

    /// Shape α of σ².
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    /// Scale β of σ².
    pub fn beta(&self) -> f64 {
        self.beta
    }

    /// β increment ½M2 + κ₀n(x̄ − μ₀)²/(2κₙ).
    fn delta_beta(&self, s: &GaussianStats) -> f64 {
        let n = s.n as f64;
        let d = s.mean - self.mu;
        0.5 * s.m2 + 0.5 * self.kappa * n / (self.kappa + n) * d * d
    }

    /// The posterior after data with statistics `s` (conjugate update, see the module docs).
    pub fn posterior(&self, s: &GaussianStats) -> Self {
        if s.n == 0 {
            return *self;
        }
        let n = s.n as f64;
        let kappa = self.kappa + n;
        Self {
            mu: self.mu + (s.mean - self.mu) * (n / kappa),
            kappa,
            alpha: self.alpha + 0.5 * n,
            beta: self.beta + self.delta_beta(s),
        }
    }

    /// ln p(x₁..ₙ), the marginal likelihood with μ and σ² integrated out (closed form, see the
    /// module docs). 0 for no data.
    pub fn log_marginal_likelihood(&self, s: &GaussianStats) -> f64 {
        if s.n == 0 {
            return 0.0;
        }
        let n = s.n as f64;
        let db = self.delta_beta(s);
        let beta_n = self.beta + db;
        ln_gamma_diff(self.alpha, 0.5 * n)
            - self.alpha * (db / self.beta).ln_1p()
            - 0.5 * n * beta_n.ln()
            - 0.5 * (n / self.kappa).ln_1p()
            - n * LN_SQRT_2PI
    }

    /// The predictive distribution of one new observation under this distribution:
    /// Student-t(2α, μ, √(β(κ+1)/(ακ))). For the posterior predictive call it on
    /// `posterior(stats)`, or use [`NormalInverseGamma::posterior_predictive`].
    pub fn predictive(&self) -> StudentT {
        StudentT {
            df: 2.0 * self.alpha,
            loc: self.mu,
            scale: (self.beta * (self.kappa + 1.0) / (self.alpha * self.kappa)).sqrt(),
        }
    }

    /// p(x̃ | data): the Student-t predictive of the posterior.
    pub fn posterior_predictive(&self, s: &GaussianStats) -> StudentT {
        self.posterior(s).predictive()
    }

    /// ln p(new data | data) = ln p(data ⊕ new) − ln p(data), computed as the marginal of `new`
    /// under the posterior (exact by conjugacy, no cancellation).
    pub fn log_posterior_marginal(&self, data: &GaussianStats, new: &GaussianStats) -> f64 {
        self.posterior(data).log_marginal_likelihood(new)
    }

    /// Log density of (μ, σ²) under this distribution (σ² > 0; `-inf` otherwise).
    pub fn log_pdf(&self, mu: f64, sigma2: f64) -> f64 {
        if mu.is_nan() || sigma2.is_nan() {
            return f64::NAN;
        }
        if sigma2 <= 0.0 {
            return f64::NEG_INFINITY;
        }
        let d = mu - self.mu;
        // N(μ; μ₀, σ²/κ) · InvGamma(σ²; α, β)
        -LN_SQRT_2PI + 0.5 * (self.kappa / sigma2).ln() - 0.5 * self.kappa * d * d / sigma2
            + self.alpha * self.beta.ln()
            - crate::special::ln_gamma(self.alpha)
            - (self.alpha + 1.0) * sigma2.ln()
            - self.beta / sigma2
    }

    /// One draw (μ, σ²): σ² = β/G with G ~ Gamma(α, 1), then μ ~ N(μ₀, σ²/κ).
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> (f64, f64) {
        let g = Gamma::new(self.alpha, 1.0).map(|g| g.sample(rng)).unwrap_or(self.alpha);
        // G can underflow to 0 for a tiny shape; σ² is then +inf, which is the honest limit.
        let sigma2 = self.beta / g;
        let z: f64 = StandardNormal.sample(rng);
        (self.mu + z * (sigma2 / self.kappa).sqrt(), sigma2)
    }

    /// One draw of a new observation from the predictive: (μ, σ²) from [`Self::sample`], then
    /// x ~ N(μ, σ²). Call on `posterior(stats)` for the posterior predictive (§5.2).
    pub fn sample_predictive<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        let (mu, sigma2) = self.sample(rng);
        let z: f64 = StandardNormal.sample(rng);
        mu + z * sigma2.sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invalid_parameters_are_errors() {
        assert!(NormalInverseGamma::new(0.0, 0.0, 1.0, 1.0).is_err());
        assert!(NormalInverseGamma::new(f64::NAN, 1.0, 1.0, 1.0).is_err());
        assert!(NormalInverseGamma::new(0.0, 1.0, -1.0, 1.0).is_err());
        assert!(StudentT::new(0.0, 0.0, 1.0).is_err());
        assert!(StudentT::new(1.0, 0.0, 0.0).is_err());
        assert!(student_t_log_pdf(f64::NAN, 1.0, 0.0, 1.0).is_err());
        assert!(GaussianStats::from_slice(&[1.0, f64::INFINITY]).is_err());
        assert!(GaussianStats::from_parts(0, 1.0, 0.0).is_err());
        assert!(GaussianStats::from_parts(3, 1.0, -1.0).is_err());
    }

    #[test]
    fn chain_rule_equals_closed_form_marginal() {
        let prior = NormalInverseGamma::new(1.0, 0.5, 2.0, 3.0).unwrap();
        let xs = [0.3, 2.5, -1.0, 4.0, 1.1];
        let mut s = GaussianStats::new();
        let mut chain = 0.0;
        for &x in &xs {
            chain += prior.posterior_predictive(&s).log_pdf(x);
            s.update(x).unwrap();
        }
        assert!((chain - prior.log_marginal_likelihood(&s)).abs() < 1e-13);
        let new = GaussianStats::from_slice(&[0.7, 0.9]).unwrap();
        let mut all = s;
        all.merge(&new);
        let direct = prior.log_marginal_likelihood(&all) - prior.log_marginal_likelihood(&s);
        assert!((prior.log_posterior_marginal(&s, &new) - direct).abs() < 1e-12);
    }

    #[test]
    fn predictive_samples_match_student_t_moments() {
        let post = NormalInverseGamma::new(2.0, 3.0, 6.0, 4.0).unwrap();
        let t = post.predictive();
        let mut rng = crate::rng::seeded(11);
        let n = 100_000;
        let xs: Vec<f64> = (0..n).map(|_| post.sample_predictive(&mut rng)).collect();
        let ys: Vec<f64> = (0..n).map(|_| t.sample(&mut rng)).collect();
        let var_t = t.scale() * t.scale() * t.df() / (t.df() - 2.0);
        for v in [&xs, &ys] {
            let m = v.iter().sum::<f64>() / n as f64;
            let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n as f64;
            assert!((m - 2.0).abs() < 0.02, "{m}");
            assert!((var / var_t - 1.0).abs() < 0.03, "{var} vs {var_t}");
        }
    }
}

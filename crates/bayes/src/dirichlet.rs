//! The discrete feature model of §5.1.2.1: categorical observations over L categories with a
//! symmetric Dirichlet(γ) prior (each category's concentration is γ), counts as sufficient
//! statistics. The same model gives the place-category posterior (5.12)–(5.14) with β in place
//! of γ.
//!
//! With counts nₖ and N = Σnₖ:
//!
//! ```text
//!   p(õ = k | counts)   = (nₖ + γ) / (N + Lγ)                                  (5.14), (5.18)
//!   ln p(sequence)      = ln Γ(Lγ) − ln Γ(N + Lγ) + Σₖ [ln Γ(nₖ + γ) − ln Γ(γ)]
//!   ln p(counts)        = ln p(sequence) + ln N! − Σₖ ln nₖ!      (Dirichlet–multinomial pmf)
//! ```
//!
//! The sequence probability depends on the counts only (exchangeability, §5.1), which is why
//! the counts are sufficient and the posterior is the same whatever the order of the
//! demonstrations (§5.2.1). Gamma-function differences go through
//! [`crate::special::ln_gamma_diff`], so huge γ keeps full accuracy.

use rand::{Rng, RngExt};
use rand_distr::{Distribution, Gamma};
use serde::{Deserialize, Serialize};

use crate::error::{BayesError, Result, check_positive};
use crate::special::{ln_gamma, ln_gamma_diff};

/// Category counts over L categories: the sufficient statistics of categorical data.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "CountsRaw")]
pub struct CategoryCounts {
    counts: Vec<u64>,
    #[serde(skip)]
    total: u64,
}

#[derive(Deserialize)]
struct CountsRaw {
    counts: Vec<u64>,
}

impl TryFrom<CountsRaw> for CategoryCounts {
    type Error = BayesError;
    fn try_from(r: CountsRaw) -> Result<Self> {
        Self::from_counts(r.counts)
    }
}

impl CategoryCounts {
    /// All-zero counts over `num_categories` categories (Err when 0).
    pub fn new(num_categories: usize) -> Result<Self> {
        if num_categories == 0 {
            return Err(BayesError::Empty { what: "category set" });
        }
        Ok(Self {
            counts: vec![0; num_categories],
            total: 0,
        })
    }

    /// From explicit counts (Err when empty or the total overflows u64).
    pub fn from_counts(counts: Vec<u64>) -> Result<Self> {
        if counts.is_empty() {
            return Err(BayesError::Empty { what: "category set" });
        }
        let total = counts
            .iter()
            .try_fold(0u64, |a, &c| a.checked_add(c))
            .ok_or(BayesError::InvalidParameter {
                name: "total count",
                value: f64::INFINITY,
                requirement: "< 2^64",
            })?;
        Ok(Self { counts, total })
    }

    /// Counts of a sequence of category indices.
    pub fn from_sequence(num_categories: usize, seq: &[usize]) -> Result<Self> {
        let mut c = Self::new(num_categories)?;
        for &k in seq {
            c.update(k)?;
        }
        Ok(c)
    }

    /// Adds one observation of category k (Err and no change when k ≥ L).
    pub fn update(&mut self, k: usize) -> Result<()> {
        self.check_category(k)?;
        self.counts[k] += 1;
        self.total += 1;
        Ok(())
    }

    /// Adds another batch's counts (Err when the category sets differ in size).
    pub fn merge(&mut self, other: &Self) -> Result<()> {
        if other.counts.len() != self.counts.len() {
            return Err(BayesError::DimensionMismatch {
                what: "category counts to merge",
                expected: self.counts.len(),
                got: other.counts.len(),
            });
        }
        for (a, b) in self.counts.iter_mut().zip(&other.counts) {
            *a += b;
        }
        self.total += other.total;
        Ok(())
    }

    /// The counts nₖ.
    pub fn counts(&self) -> &[u64] {
        &self.counts
    }

    /// N = Σₖ nₖ.
    pub fn total(&self) -> u64 {
        self.total
    }

    /// L.
    pub fn num_categories(&self) -> usize {
        self.counts.len()
    }

    fn check_category(&self, k: usize) -> Result<()> {
        if k < self.counts.len() {
            Ok(())
        } else {
            Err(BayesError::IndexOutOfRange {
                what: "category",
                index: k,
                len: self.counts.len(),
            })
        }
    }
}

/// A symmetric Dirichlet(γ, …, γ) prior over L category probabilities, with the
/// Dirichlet–multinomial predictive and marginal (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "DirichletRaw")]
pub struct SymmetricDirichlet {
    num_categories: usize,
    gamma: f64,
}

#[derive(Deserialize)]
struct DirichletRaw {
    num_categories: usize,
    gamma: f64,
}

impl TryFrom<DirichletRaw> for SymmetricDirichlet {
    type Error = BayesError;
    fn try_from(r: DirichletRaw) -> Result<Self> {
        Self::new(r.num_categories, r.gamma)
    }
}

impl SymmetricDirichlet {
    /// L ≥ 1 categories, each with concentration γ > 0 (finite).
    pub fn new(num_categories: usize, gamma: f64) -> Result<Self> {
        if num_categories == 0 {
            return Err(BayesError::Empty { what: "category set" });
        }
        check_positive("gamma", gamma)?;
        Ok(Self { num_categories, gamma })
    }

    /// L.
    pub fn num_categories(&self) -> usize {
        self.num_categories
    }

    /// γ (per-category concentration).
    pub fn gamma(&self) -> f64 {
        self.gamma
    }

    /// Empty counts of the right size.
    pub fn empty_counts(&self) -> CategoryCounts {
        CategoryCounts {
            counts: vec![0; self.num_categories],
            total: 0,
        }
    }

    fn check(&self, c: &CategoryCounts) -> Result<()> {
        if c.counts.len() == self.num_categories {
            Ok(())
        } else {
            Err(BayesError::DimensionMismatch {
                what: "category counts for this Dirichlet",
                expected: self.num_categories,
                got: c.counts.len(),
            })
        }
    }

    /// p(õ = k | counts) = (nₖ + γ)/(N + Lγ), eqs. (5.14), (5.18).
    pub fn predictive(&self, c: &CategoryCounts, k: usize) -> Result<f64> {
        self.check(c)?;
        c.check_category(k)?;
        Ok((c.counts[k] as f64 + self.gamma) / (c.total as f64 + self.num_categories as f64 * self.gamma))
    }

    /// The whole predictive vector (5.14) / (5.18); sums to 1.
    pub fn predictive_probs(&self, c: &CategoryCounts) -> Result<Vec<f64>> {
        self.check(c)?;
        let denom = c.total as f64 + self.num_categories as f64 * self.gamma;
        Ok(c.counts.iter().map(|&n| (n as f64 + self.gamma) / denom).collect())
    }

    /// ln p(o₁..ₙ) of any ordered sequence with these counts, with the probabilities integrated
    /// out (module docs). 0 for no data.
    pub fn log_marginal_likelihood(&self, c: &CategoryCounts) -> Result<f64> {
        self.check(c)?;
        let l_gamma = self.num_categories as f64 * self.gamma;
        let mut s = -ln_gamma_diff(l_gamma, c.total as f64);
        for &n in &c.counts {
            if n > 0 {
                s += ln_gamma_diff(self.gamma, n as f64);
            }
        }
        Ok(s)
    }

    /// ln p(counts): the Dirichlet–multinomial pmf (scipy `dirichlet_multinomial.logpmf`),
    /// the sequence probability times the number of orderings N!/Πnₖ!.
    pub fn log_pmf_counts(&self, c: &CategoryCounts) -> Result<f64> {
        let mut s = self.log_marginal_likelihood(c)? + ln_gamma(c.total as f64 + 1.0);
        for &n in &c.counts {
            s -= ln_gamma(n as f64 + 1.0);
        }
        Ok(s)
    }

    /// Σⱼ ln p(õⱼ | counts): new observations scored *independently* against fixed counts, the
    /// product (5.16)–(5.18) the dissertation uses for a presented object.
    pub fn log_predictive_product(&self, c: &CategoryCounts, obs: &[usize]) -> Result<f64> {
        self.check(c)?;
        let denom = (c.total as f64 + self.num_categories as f64 * self.gamma).ln();
        obs.iter().try_fold(0.0, |acc, &k| {
            c.check_category(k)?;
            Ok(acc + (c.counts[k] as f64 + self.gamma).ln() - denom)
        })
    }

    /// ln p(õ₁..ₘ | counts), the *joint* posterior predictive of new observations (each one
    /// updating the counts before the next: the exact Bayesian marginal, = ln p(D ∪ õ) − ln p(D),
    /// computed without that subtraction).
    pub fn log_posterior_marginal(&self, c: &CategoryCounts, obs: &[usize]) -> Result<f64> {
        self.check(c)?;
        let new = CategoryCounts::from_sequence(self.num_categories, obs)?;
        let l_gamma = self.num_categories as f64 * self.gamma;
        let mut s = -ln_gamma_diff(c.total as f64 + l_gamma, new.total as f64);
        for (&n, &m) in c.counts.iter().zip(&new.counts) {
            if m > 0 {
                s += ln_gamma_diff(n as f64 + self.gamma, m as f64);
            }
        }
        Ok(s)
    }

    /// One draw θ ~ Dirichlet(n₁ + γ, …, n_L + γ), the posterior over category probabilities.
    ///
    /// Gamma variates are drawn in log space (Gamma(a) = Gamma(a+1)·U^{1/a} for a < 1), so a
    /// tiny γ never makes every component underflow to zero.
    pub fn sample_posterior<R: Rng + ?Sized>(&self, rng: &mut R, c: &CategoryCounts) -> Result<Vec<f64>> {
        self.check(c)?;
        let logs: Vec<f64> = c
            .counts
            .iter()
            .map(|&n| sample_log_gamma(rng, n as f64 + self.gamma))
            .collect();
        let m = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut theta: Vec<f64> = logs.iter().map(|l| (l - m).exp()).collect();
        let s: f64 = theta.iter().sum();
        theta.iter_mut().for_each(|t| *t /= s);
        Ok(theta)
    }

    /// One draw of a new observation from the posterior predictive (5.14) / (5.18).
    pub fn sample_predictive<R: Rng + ?Sized>(&self, rng: &mut R, c: &CategoryCounts) -> Result<usize> {
        let probs = self.predictive_probs(c)?;
        Ok(sample_categorical(rng, &probs))
    }

    /// m observations drawn sequentially from the posterior predictive (a Pólya urn: each draw
    /// joins the counts before the next), i.e. one synthetic demonstration p(D̃ | D) (§5.2).
    pub fn sample_predictive_sequence<R: Rng + ?Sized>(
        &self,
        rng: &mut R,
        c: &CategoryCounts,
        m: usize,
    ) -> Result<Vec<usize>> {
        self.check(c)?;
        let mut counts = c.clone();
        let mut out = Vec::with_capacity(m);
        let l_gamma = self.num_categories as f64 * self.gamma;
        for _ in 0..m {
            let u = rng.random::<f64>() * (counts.total as f64 + l_gamma);
            let mut acc = 0.0;
            let mut k = self.num_categories - 1;
            for (i, &n) in counts.counts.iter().enumerate() {
                acc += n as f64 + self.gamma;
                if u < acc {
                    k = i;
                    break;
                }
            }
            counts.update(k)?;
            out.push(k);
        }
        Ok(out)
    }
}

/// ln G for G ~ Gamma(shape, 1), valid for tiny shapes.
pub(crate) fn sample_log_gamma<R: Rng + ?Sized>(rng: &mut R, shape: f64) -> f64 {
    if shape >= 1.0 {
        return Gamma::new(shape, 1.0).map(|g| g.sample(rng)).unwrap_or(shape).ln();
    }
    // Gamma(a) = Gamma(a+1) · U^{1/a}  ⇒  ln G = ln Gamma(a+1) + ln(U)/a
    let g = Gamma::new(shape + 1.0, 1.0)
        .map(|g| g.sample(rng))
        .unwrap_or(shape + 1.0);
    // U in (0, 1]: avoid ln 0.
    let u = 1.0 - rng.random::<f64>();
    g.ln() + u.ln() / shape
}

/// Index drawn with probabilities `probs` (assumed to sum to 1).
pub(crate) fn sample_categorical<R: Rng + ?Sized>(rng: &mut R, probs: &[f64]) -> usize {
    let u = rng.random::<f64>();
    let mut acc = 0.0;
    for (i, p) in probs.iter().enumerate() {
        acc += p;
        if u < acc {
            return i;
        }
    }
    probs.len() - 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_input_is_an_error() {
        assert!(SymmetricDirichlet::new(0, 1.0).is_err());
        assert!(SymmetricDirichlet::new(3, 0.0).is_err());
        assert!(SymmetricDirichlet::new(3, f64::NAN).is_err());
        let d = SymmetricDirichlet::new(3, 1.0).unwrap();
        let c = CategoryCounts::new(4).unwrap();
        assert!(d.predictive(&c, 0).is_err());
        assert!(d.predictive(&d.empty_counts(), 3).is_err());
        assert!(CategoryCounts::from_sequence(3, &[0, 3]).is_err());
        let mut a = CategoryCounts::new(3).unwrap();
        assert!(a.merge(&c).is_err());
        assert!(d.log_predictive_product(&d.empty_counts(), &[5]).is_err());
    }

    #[test]
    fn joint_predictive_is_chain_of_predictives() {
        let d = SymmetricDirichlet::new(4, 0.7).unwrap();
        let c = CategoryCounts::from_sequence(4, &[0, 0, 2, 3, 0]).unwrap();
        let obs = [2, 0, 1, 2];
        let mut cc = c.clone();
        let mut chain = 0.0;
        for &k in &obs {
            chain += d.predictive(&cc, k).unwrap().ln();
            cc.update(k).unwrap();
        }
        assert!((d.log_posterior_marginal(&c, &obs).unwrap() - chain).abs() < 1e-13);
        let diff = d.log_marginal_likelihood(&cc).unwrap() - d.log_marginal_likelihood(&c).unwrap();
        assert!((chain - diff).abs() < 1e-12);
    }

    #[test]
    fn posterior_samples_have_the_posterior_mean_even_for_tiny_gamma() {
        let mut rng = crate::rng::seeded(5);
        for gamma in [1e-7, 0.5, 30.0] {
            let d = SymmetricDirichlet::new(3, gamma).unwrap();
            let c = CategoryCounts::from_counts(vec![2, 0, 5]).unwrap();
            let n = 20_000;
            let mut mean = [0.0; 3];
            for _ in 0..n {
                let th = d.sample_posterior(&mut rng, &c).unwrap();
                assert!((th.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                for k in 0..3 {
                    mean[k] += th[k] / n as f64;
                }
            }
            let want = d.predictive_probs(&c).unwrap();
            for k in 0..3 {
                assert!((mean[k] - want[k]).abs() < 0.01, "gamma {gamma}: {mean:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn predictive_sampling_is_deterministic_and_has_the_right_frequencies() {
        let d = SymmetricDirichlet::new(3, 1.0).unwrap();
        let c = CategoryCounts::from_counts(vec![6, 1, 0]).unwrap();
        let draw = |seed| {
            let mut rng = crate::rng::seeded(seed);
            (0..30_000)
                .map(|_| d.sample_predictive(&mut rng, &c).unwrap())
                .collect::<Vec<_>>()
        };
        let xs = draw(9);
        assert_eq!(xs, draw(9));
        let want = d.predictive_probs(&c).unwrap();
        for (k, w) in want.iter().enumerate() {
            let f = xs.iter().filter(|&&x| x == k).count() as f64 / xs.len() as f64;
            assert!((f - w).abs() < 0.01);
        }
        let mut rng = crate::rng::seeded(1);
        let seq = d.sample_predictive_sequence(&mut rng, &c, 50).unwrap();
        assert_eq!(seq.len(), 50);
        assert!(seq.iter().all(|&k| k < 3));
    }
}

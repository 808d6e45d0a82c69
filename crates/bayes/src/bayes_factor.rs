//! Bayes factors for task relevance, §5.1.3, eqs. (5.19)–(5.23): is a presented object one the
//! demonstrated task model M₁ explains, or a background object (M₀)?
//!
//! What is computed, exactly:
//!
//! * `ln B₁₀ = ln p₁(õ) − ln p₀(õ)` (5.19), for the features õ = (õ₁..õₙ) of one object.
//! * Background M₀ for a categorical feature with L values: every value equally likely,
//!   `ln p₀(õ) = −n ln L` (5.20)–(5.21) ([`uniform_background_log_likelihood`]).
//! * Task model M₁: a mixture over the K place categories q of the demonstration,
//!   `p₁(õ) = Σᵢ ψ(i) Πⱼ φᵢ(õⱼ)` (5.22)–(5.23) ([`log_mixture_marginal`]), where ψ(i) is the
//!   posterior probability of place i (5.14, a Dirichlet–multinomial predictive over the places)
//!   and φᵢ is category i's feature model *with its parameters integrated out* (a conjugate
//!   posterior predictive given that category's demonstrations).
//! * [`PredictiveMode`] chooses how the n features of one object are scored under φᵢ:
//!   `Independent` is the dissertation's product (5.16)–(5.18) of single-feature predictives
//!   against the demonstration counts; `Joint` is the exact posterior marginal
//!   p(õ₁..ₙ | demonstrations of i), where each feature of the object also informs the next
//!   (the Pólya-urn chain). For n = 1 they coincide.
//!
//! B₁₀ > 1 (ln B₁₀ > 0) means M₁ explains the object better; the robot then runs the schema.

use serde::{Deserialize, Serialize};

use crate::dirichlet::{CategoryCounts, SymmetricDirichlet};
use crate::error::{BayesError, Result};
use crate::univariate::{GaussianStats, NormalInverseGamma};

/// How an object's several features are scored under one category's feature model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum PredictiveMode {
    /// Πⱼ p(õⱼ | D): each feature against the demonstrations only, eqs. (5.16)–(5.18).
    #[default]
    Independent,
    /// p(õ₁..ₙ | D): the exact joint posterior predictive (each feature updates the next).
    Joint,
}

/// The evidence for "task object" against "background object" for one presented object.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BayesFactor {
    /// ln p₁(õ) under the task model (5.22)–(5.23).
    pub log_p_task: f64,
    /// ln p₀(õ) under the background model (5.20)–(5.21).
    pub log_p_background: f64,
    /// ln B₁₀ = ln p₁ − ln p₀ (5.19); `+inf` when only M₀ gives the object zero probability,
    /// `-inf` when only M₁ does.
    pub log_b10: f64,
}

impl BayesFactor {
    /// From the two log marginal likelihoods (5.19). Errors: NaN or `+inf` inputs, or both
    /// `-inf` (the object is impossible under both models, and B₁₀ is undefined).
    pub fn new(log_p_task: f64, log_p_background: f64) -> Result<Self> {
        for (index, v) in [log_p_task, log_p_background].into_iter().enumerate() {
            if v.is_nan() || v == f64::INFINITY {
                return Err(BayesError::NonFinite {
                    what: "log marginal likelihood (task, background)",
                    index,
                    value: v,
                    requirement: "not NaN and not +inf",
                });
            }
        }
        if log_p_task == f64::NEG_INFINITY && log_p_background == f64::NEG_INFINITY {
            return Err(BayesError::InvalidParameter {
                name: "log marginal likelihoods",
                value: f64::NEG_INFINITY,
                requirement: "not -inf under both models (B10 undefined)",
            });
        }
        Ok(Self {
            log_p_task,
            log_p_background,
            log_b10: log_p_task - log_p_background,
        })
    }

    /// True when M₁ (the task) explains the object better: B₁₀ > 1.
    pub fn favours_task(&self) -> bool {
        self.log_b10 > 0.0
    }
}

/// ln p₀(õ₁..ₙ) = −n ln L for a uniform background over L categories (5.20)–(5.21).
pub fn uniform_background_log_likelihood(n_features: usize, num_categories: usize) -> Result<f64> {
    if num_categories == 0 {
        return Err(BayesError::Empty { what: "category set" });
    }
    Ok(-(n_features as f64) * (num_categories as f64).ln())
}

/// ln Σᵢ exp(ln ψ(i) + ln p(õ | q = i)): the task model's marginal (5.22)–(5.23) from the log
/// place weights and the per-place log likelihoods of the object. Errors: different lengths,
/// empty, NaN or `+inf` entries.
pub fn log_mixture_marginal(log_weights: &[f64], log_likelihoods: &[f64]) -> Result<f64> {
    if log_weights.is_empty() {
        return Err(BayesError::Empty {
            what: "mixture weights",
        });
    }
    if log_weights.len() != log_likelihoods.len() {
        return Err(BayesError::DimensionMismatch {
            what: "per-place log likelihoods",
            expected: log_weights.len(),
            got: log_likelihoods.len(),
        });
    }
    let terms: Vec<f64> = log_weights.iter().zip(log_likelihoods).map(|(w, l)| w + l).collect();
    if let Some(index) = terms.iter().position(|v| v.is_nan() || *v == f64::INFINITY) {
        return Err(BayesError::NonFinite {
            what: "log weight + log likelihood",
            index,
            value: terms[index],
            requirement: "not NaN and not +inf",
        });
    }
    Ok(crate::special::log_sum_exp(&terms))
}

/// Log place weights ln ψ(i) (5.14) from the place-category prior and the demonstrated counts.
pub fn log_place_weights(place_prior: &SymmetricDirichlet, place_counts: &CategoryCounts) -> Result<Vec<f64>> {
    Ok(place_prior
        .predictive_probs(place_counts)?
        .into_iter()
        .map(f64::ln)
        .collect())
}

/// B₁₀ for a categorical feature (the colour task of §5.1.3): task model = places weighted by
/// (5.14) with a Dirichlet–multinomial feature model per place (5.18); background = uniform over
/// the L feature values (5.20)–(5.21). `feature_counts[i]` are place i's demonstrated feature
/// counts; `features` are the presented object's feature values.
pub fn categorical_bayes_factor(
    place_prior: &SymmetricDirichlet,
    place_counts: &CategoryCounts,
    feature_prior: &SymmetricDirichlet,
    feature_counts: &[CategoryCounts],
    features: &[usize],
    mode: PredictiveMode,
) -> Result<BayesFactor> {
    let log_w = log_place_weights(place_prior, place_counts)?;
    if feature_counts.len() != log_w.len() {
        return Err(BayesError::DimensionMismatch {
            what: "feature counts per place",
            expected: log_w.len(),
            got: feature_counts.len(),
        });
    }
    let log_l = feature_counts
        .iter()
        .map(|c| match mode {
            PredictiveMode::Independent => feature_prior.log_predictive_product(c, features),
            PredictiveMode::Joint => feature_prior.log_posterior_marginal(c, features),
        })
        .collect::<Result<Vec<_>>>()?;
    let log_p1 = log_mixture_marginal(&log_w, &log_l)?;
    let log_p0 = uniform_background_log_likelihood(features.len(), feature_prior.num_categories())?;
    BayesFactor::new(log_p1, log_p0)
}

/// B₁₀ for a continuous feature (the size task of §5.1.3): task model = places weighted by
/// (5.14) with a Normal–Inverse-Gamma feature model per place (Student-t predictives);
/// background = the NIG `background` with no data, i.e. the prior predictive of "any object"
/// (a continuous feature has no uniform distribution, so M₀ must be given). The object's
/// features are scored as chosen by `mode` under both models.
pub fn gaussian_bayes_factor(
    place_prior: &SymmetricDirichlet,
    place_counts: &CategoryCounts,
    feature_prior: &NormalInverseGamma,
    feature_stats: &[GaussianStats],
    background: &NormalInverseGamma,
    features: &[f64],
    mode: PredictiveMode,
) -> Result<BayesFactor> {
    let log_w = log_place_weights(place_prior, place_counts)?;
    if feature_stats.len() != log_w.len() {
        return Err(BayesError::DimensionMismatch {
            what: "feature statistics per place",
            expected: log_w.len(),
            got: feature_stats.len(),
        });
    }
    let object = GaussianStats::from_slice(features)?;
    let score = |model: &NormalInverseGamma, data: &GaussianStats| match mode {
        PredictiveMode::Independent => {
            let t = model.posterior_predictive(data);
            features.iter().map(|&x| t.log_pdf(x)).sum::<f64>()
        }
        PredictiveMode::Joint => model.log_posterior_marginal(data, &object),
    };
    let log_l: Vec<f64> = feature_stats.iter().map(|s| score(feature_prior, s)).collect();
    let log_p1 = log_mixture_marginal(&log_w, &log_l)?;
    let log_p0 = score(background, &GaussianStats::new());
    BayesFactor::new(log_p1, log_p0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_place_single_feature_is_the_predictive_ratio() {
        let places = SymmetricDirichlet::new(1, 1.0).unwrap();
        let pc = CategoryCounts::from_counts(vec![3]).unwrap();
        let feat = SymmetricDirichlet::new(4, 0.5).unwrap();
        let fc = vec![CategoryCounts::from_counts(vec![5, 0, 1, 0]).unwrap()];
        for mode in [PredictiveMode::Independent, PredictiveMode::Joint] {
            let b = categorical_bayes_factor(&places, &pc, &feat, &fc, &[0], mode).unwrap();
            let want = (feat.predictive(&fc[0], 0).unwrap() * 4.0).ln();
            assert!((b.log_b10 - want).abs() < 1e-14);
            assert!(b.favours_task());
        }
        let b = categorical_bayes_factor(&places, &pc, &feat, &fc, &[1, 3], PredictiveMode::Independent).unwrap();
        assert!(!b.favours_task());
    }

    #[test]
    fn mixture_weights_follow_place_counts() {
        // Two places, object features seen only at place 1: p1 ≈ ψ(1)·φ₁.
        let places = SymmetricDirichlet::new(2, 1.0).unwrap();
        let pc = CategoryCounts::from_counts(vec![1, 3]).unwrap();
        let feat = SymmetricDirichlet::new(3, 1.0).unwrap();
        let fc = vec![
            CategoryCounts::from_counts(vec![4, 0, 0]).unwrap(),
            CategoryCounts::from_counts(vec![0, 0, 4]).unwrap(),
        ];
        let b = categorical_bayes_factor(&places, &pc, &feat, &fc, &[2], PredictiveMode::Independent).unwrap();
        let p1: f64 = 2.0 / 6.0 * (1.0 / 7.0) + 4.0 / 6.0 * (5.0 / 7.0);
        assert!((b.log_p_task - p1.ln()).abs() < 1e-14);
        assert!((b.log_p_background - (1.0f64 / 3.0).ln()).abs() < 1e-15);
    }

    #[test]
    fn gaussian_factor_prefers_demonstrated_sizes() {
        let places = SymmetricDirichlet::new(2, 1.0).unwrap();
        let pc = CategoryCounts::from_counts(vec![3, 3]).unwrap();
        let prior = NormalInverseGamma::new(1300.0, 0.01, 2.0, 2.0e5).unwrap();
        let stats = vec![
            GaussianStats::from_slice(&[500.0, 520.0, 480.0]).unwrap(),
            GaussianStats::from_slice(&[2500.0, 2450.0, 2550.0]).unwrap(),
        ];
        for mode in [PredictiveMode::Independent, PredictiveMode::Joint] {
            let near = gaussian_bayes_factor(&places, &pc, &prior, &stats, &prior, &[505.0, 498.0], mode).unwrap();
            let medium = gaussian_bayes_factor(&places, &pc, &prior, &stats, &prior, &[1500.0, 1480.0], mode).unwrap();
            assert!(near.favours_task(), "{near:?}");
            assert!(!medium.favours_task(), "{medium:?}");
        }
    }

    #[test]
    fn undefined_factors_are_errors() {
        assert!(BayesFactor::new(f64::NEG_INFINITY, f64::NEG_INFINITY).is_err());
        assert!(BayesFactor::new(f64::NAN, 0.0).is_err());
        assert_eq!(
            BayesFactor::new(-1.0, f64::NEG_INFINITY).unwrap().log_b10,
            f64::INFINITY
        );
        assert!(log_mixture_marginal(&[0.0], &[0.0, 1.0]).is_err());
        assert!(log_mixture_marginal(&[], &[]).is_err());
        assert!(uniform_background_log_likelihood(3, 0).is_err());
    }
}

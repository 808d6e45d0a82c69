//! Conjugate Bayesian models with sufficient statistics, Bayes factors, χ² tests and log-space
//! HMMs: the statistics of Sweeney (2011), ch. 5 and appendix A. This crate knows nothing of
//! robots.
//!
//! The central idea (§5.2, A.1.2) is that a robot learning from demonstration should keep only
//! *sufficient statistics* of what it has seen and a *conjugate prior*: then the posterior after
//! every demonstration is in closed form, it can be updated one observation or one
//! demonstration at a time, and the result does not depend on the order in which the teacher
//! showed the examples (exchangeability). The marginal likelihood of the data, with the model's
//! parameters integrated out, is also in closed form, which gives posterior predictives for
//! classification (5.9)–(5.18) and Bayes factors for task relevance (5.19)–(5.23).
//!
//! | module | what | dissertation |
//! | --- | --- | --- |
//! | [`dirichlet`] | categorical features with a symmetric Dirichlet prior: counts, predictive, marginals, sampling | (5.12)–(5.18) |
//! | [`univariate`] | Normal likelihood with a Normal–Inverse-Gamma prior: (n, x̄, M2), Student-t predictive, marginal | §5.1.2.2, (A.5)–(A.6) |
//! | [`multivariate`] | multivariate normal, multivariate t, inverse-Wishart densities and samplers via Cholesky | (A.1), (A.19)–(A.24) |
//! | [`bayes_factor`] | ln B₁₀ of task model against background | (5.19)–(5.23) |
//! | [`chi2`] | Pearson χ² contingency / goodness-of-fit tests for experiment reports | Fig. 5.3 |
//! | [`hmm`] | HMMs: scaled linear-domain and log-space forward passes (exact), streaming filters, smoothing, Viterbi, a batched pass over shared emissions | §4.3, (4.10)–(4.21) |
//! | [`special`] | ln Γ, ln Γ differences, Γ_p, ψ, incomplete gamma | — |
//!
//! Conventions: hyper-parameters and statistics are validated at construction
//! (`new(..) -> Result<_, BayesError>`) and serialise with serde (deserialisation validates
//! too); invalid input is an [`BayesError`], never a panic; outcomes such as "impossible
//! observation" are values (`-inf`, `None`). Samplers take the caller's RNG, so a seeded RNG
//! gives the same draws every time.
//! Every random choice of pbd comes from [`rng`]: one named generator (xoshiro256++) and one way to
//! split a seed into independent streams, so results are reproducible across machines, versions
//! and thread counts. [`contingency`] (Fisher's exact test) and [`roc`] (ROC curves, AUC) serve the
//! experiment reports.
//!
//! Learning a size model from three demonstrations and asking how likely a new size is — and that
//! learning one at a time gives exactly the batch posterior:
//!
//! ```
//! use bayes::univariate::{GaussianStats, NormalInverseGamma};
//!
//! let prior = NormalInverseGamma::new(10.0, 0.1, 2.0, 4.0)?; // vague prior on a size (deci-pixels)
//! let batch = GaussianStats::from_slice(&[12.0, 13.5, 11.8])?;
//! let mut incremental = GaussianStats::new();
//! for x in [12.0, 13.5, 11.8] {
//!     incremental.update(x)?;
//! }
//! let (a, b) = (prior.posterior_predictive(&batch), prior.posterior_predictive(&incremental));
//! assert!((a.log_pdf(12.5) - b.log_pdf(12.5)).abs() < 1e-12);
//! assert!(a.log_pdf(12.5) > a.log_pdf(30.0)); // a size like the demonstrations is more likely
//! // Log marginal likelihood of the data, parameters integrated out (A.6): the evidence for Bayes factors.
//! assert!(prior.log_marginal_likelihood(&batch).is_finite());
//! # Ok::<(), bayes::BayesError>(())
//! ```
#![warn(missing_docs)]

pub mod bayes_factor;
pub mod chi2;
pub mod contingency;
pub mod dirichlet;
pub mod error;
pub mod hmm;
pub mod input;
pub mod multivariate;
pub mod rng;
pub mod roc;
pub mod special;
pub mod univariate;

pub use error::{BayesError, Result};

//! Conjugate Bayesian models with sufficient statistics (Sweeney 2011, ch. 5 and appendix A).
#![warn(missing_docs)]

pub mod chi2;
pub mod dirichlet;
pub mod error;
pub mod hmm;
pub mod multivariate;
pub mod special;
pub mod univariate;

pub use error::{BayesError, Result};

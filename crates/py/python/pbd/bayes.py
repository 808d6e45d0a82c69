"""Conjugate Bayesian models with sufficient statistics, Bayes factors and log-space HMMs on numpy
arrays (Sweeney 2011, ch. 5 and app. A).

- :class:`GaussianStats` + :class:`NormalInverseGamma`: Normal data, NIG prior (A.5), Student-t
  predictive and marginal likelihood (A.6) (§5.1.2.2, sizes).
- :class:`CategoryCounts` + :class:`SymmetricDirichlet`: categorical data, the Dirichlet–multinomial
  predictive (5.15)–(5.18) (§5.1.2.1, colours).
- :func:`categorical_bayes_factor`, :func:`gaussian_bayes_factor`: task relevance ln B₁₀ (5.19)–(5.23).
- :class:`Hmm`: forward (4.10), smoothing and Viterbi on a T×n array of log emissions;
  :func:`categorical_log_emissions` builds one from symbol observations.
"""

from ._pbd import bayes as _b

GaussianStats = _b.GaussianStats
StudentT = _b.StudentT
NormalInverseGamma = _b.NormalInverseGamma
CategoryCounts = _b.CategoryCounts
SymmetricDirichlet = _b.SymmetricDirichlet
Hmm = _b.Hmm
categorical_bayes_factor = _b.categorical_bayes_factor
gaussian_bayes_factor = _b.gaussian_bayes_factor
categorical_log_emissions = _b.categorical_log_emissions

__all__ = [
    "CategoryCounts",
    "GaussianStats",
    "Hmm",
    "NormalInverseGamma",
    "StudentT",
    "SymmetricDirichlet",
    "categorical_bayes_factor",
    "categorical_log_emissions",
    "gaussian_bayes_factor",
]

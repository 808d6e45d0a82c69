//! `pbd.bayes`: conjugate models with sufficient statistics, Bayes factors and log-space HMMs on
//! numpy arrays (Sweeney 2011, ch. 5 and app. A; the `bayes` crate).

use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pbd::bayes::bayes_factor::{self as bf, PredictiveMode};
use pbd::bayes::dirichlet as dir;
use pbd::bayes::hmm;
use pbd::bayes::univariate as uni;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{matrix, vector};
use crate::errors::{IntoPy, value_error};

fn indices(obs: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<usize>> {
    let v = vector(obs, what)?;
    v.iter()
        .enumerate()
        .map(|(i, &x)| {
            if x.is_finite() && x >= 0.0 && x.fract() == 0.0 && x < u32::MAX as f64 {
                Ok(x as usize)
            } else {
                Err(value_error(format!(
                    "{what}: entry {i} ({x}) is not a non-negative integer"
                )))
            }
        })
        .collect()
}

/// Sufficient statistics (n, x̄, M2) of Normal observations (Welford), §5.1.2.2.
#[pyclass(module = "pbd.bayes", from_py_object)]
#[derive(Debug, Clone, Copy)]
pub struct GaussianStats(uni::GaussianStats);

#[pymethods]
impl GaussianStats {
    /// The statistics of `data` (a 1-D array; empty by default).
    #[new]
    #[pyo3(signature = (data=None))]
    fn new(data: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        Ok(GaussianStats(match data {
            Some(d) => uni::GaussianStats::from_slice(&vector(d, "data")?).py_err()?,
            None => uni::GaussianStats::new(),
        }))
    }
    /// Adds one observation.
    fn update(&mut self, x: f64) -> PyResult<()> {
        self.0.update(x).py_err()
    }
    /// Adds the statistics of other data.
    fn merge(&mut self, other: &GaussianStats) {
        self.0.merge(&other.0);
    }
    /// Number of observations.
    #[getter]
    fn n(&self) -> u64 {
        self.0.n()
    }
    /// Sample mean.
    #[getter]
    fn mean(&self) -> f64 {
        self.0.mean()
    }
    /// Sum of squared deviations from the mean.
    #[getter]
    fn m2(&self) -> f64 {
        self.0.m2()
    }
    fn __repr__(&self) -> String {
        format!(
            "GaussianStats(n={}, mean={}, m2={})",
            self.0.n(),
            self.0.mean(),
            self.0.m2()
        )
    }
}

/// Student-t density (location–scale), the predictive of the Normal–Inverse-Gamma model (A.6).
#[pyclass(module = "pbd.bayes", frozen)]
#[derive(Debug, Clone, Copy)]
pub struct StudentT(uni::StudentT);

#[pymethods]
impl StudentT {
    #[new]
    fn new(df: f64, loc: f64, scale: f64) -> PyResult<Self> {
        Ok(StudentT(uni::StudentT::new(df, loc, scale).py_err()?))
    }
    #[getter]
    fn df(&self) -> f64 {
        self.0.df()
    }
    #[getter]
    fn loc(&self) -> f64 {
        self.0.loc()
    }
    #[getter]
    fn scale(&self) -> f64 {
        self.0.scale()
    }
    /// ln p(x), elementwise over an array (or one float).
    fn log_pdf(&self, py: Python<'_>, x: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        if let Ok(v) = x.extract::<f64>() {
            return Ok(self.0.log_pdf(v).into_pyobject(py)?.into_any().unbind());
        }
        let xs = vector(x, "x")?;
        Ok(Array1::from_iter(xs.iter().map(|&v| self.0.log_pdf(v)))
            .into_pyarray(py)
            .into_any()
            .unbind())
    }
    fn __repr__(&self) -> String {
        format!(
            "StudentT(df={}, loc={}, scale={})",
            self.0.df(),
            self.0.loc(),
            self.0.scale()
        )
    }
}

/// Normal likelihood with a Normal–Inverse-Gamma prior NIG(μ, κ, α, β) (A.5): closed-form posterior,
/// Student-t predictive and marginal likelihood (A.6).
#[pyclass(module = "pbd.bayes", frozen)]
#[derive(Debug, Clone, Copy)]
pub struct NormalInverseGamma(uni::NormalInverseGamma);

#[pymethods]
impl NormalInverseGamma {
    #[new]
    fn new(mu: f64, kappa: f64, alpha: f64, beta: f64) -> PyResult<Self> {
        Ok(NormalInverseGamma(
            uni::NormalInverseGamma::new(mu, kappa, alpha, beta).py_err()?,
        ))
    }
    #[getter]
    fn mu(&self) -> f64 {
        self.0.mu()
    }
    #[getter]
    fn kappa(&self) -> f64 {
        self.0.kappa()
    }
    #[getter]
    fn alpha(&self) -> f64 {
        self.0.alpha()
    }
    #[getter]
    fn beta(&self) -> f64 {
        self.0.beta()
    }
    /// The posterior after data with statistics `stats`.
    fn posterior(&self, stats: &GaussianStats) -> Self {
        NormalInverseGamma(self.0.posterior(&stats.0))
    }
    /// ln p(data), the parameters integrated out (A.6).
    fn log_marginal_likelihood(&self, stats: &GaussianStats) -> f64 {
        self.0.log_marginal_likelihood(&stats.0)
    }
    /// The prior predictive.
    fn predictive(&self) -> StudentT {
        StudentT(self.0.predictive())
    }
    /// The posterior predictive after `stats`.
    fn posterior_predictive(&self, stats: &GaussianStats) -> StudentT {
        StudentT(self.0.posterior_predictive(&stats.0))
    }
    /// ln p(μ, σ²) of the prior.
    fn log_pdf(&self, mu: f64, sigma2: f64) -> f64 {
        self.0.log_pdf(mu, sigma2)
    }
    fn __repr__(&self) -> String {
        format!(
            "NormalInverseGamma(mu={}, kappa={}, alpha={}, beta={})",
            self.0.mu(),
            self.0.kappa(),
            self.0.alpha(),
            self.0.beta()
        )
    }
}

/// Counts of a categorical variable with K categories (the sufficient statistics of (5.12)).
#[pyclass(module = "pbd.bayes", from_py_object)]
#[derive(Debug, Clone)]
pub struct CategoryCounts(dir::CategoryCounts);

#[pymethods]
impl CategoryCounts {
    /// From counts (a 1-D array of non-negative integers), or empty with `num_categories`.
    #[new]
    #[pyo3(signature = (counts=None, *, num_categories=None))]
    fn new(counts: Option<&Bound<'_, PyAny>>, num_categories: Option<usize>) -> PyResult<Self> {
        match (counts, num_categories) {
            (Some(c), None) => {
                let c = indices(c, "counts")?;
                Ok(CategoryCounts(
                    dir::CategoryCounts::from_counts(c.into_iter().map(|x| x as u64).collect()).py_err()?,
                ))
            }
            (None, Some(k)) => Ok(CategoryCounts(dir::CategoryCounts::new(k).py_err()?)),
            _ => Err(value_error("give either counts or num_categories")),
        }
    }
    /// Counts of a sequence of category indices.
    #[staticmethod]
    fn from_sequence(num_categories: usize, seq: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(CategoryCounts(
            dir::CategoryCounts::from_sequence(num_categories, &indices(seq, "seq")?).py_err()?,
        ))
    }
    /// Counts one observation of category `k`.
    fn update(&mut self, k: usize) -> PyResult<()> {
        self.0.update(k).py_err()
    }
    /// The counts as an int64 array (K,).
    #[getter]
    fn counts<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        Array1::from_iter(self.0.counts().iter().map(|&c| c as i64)).into_pyarray(py)
    }
    #[getter]
    fn total(&self) -> u64 {
        self.0.total()
    }
    #[getter]
    fn num_categories(&self) -> usize {
        self.0.num_categories()
    }
    fn __repr__(&self) -> String {
        format!("CategoryCounts({:?})", self.0.counts())
    }
}

/// Symmetric Dirichlet prior Dir(γ, …, γ) over K categories: the Dirichlet–multinomial predictive
/// (5.15)–(5.18) and marginal likelihood.
#[pyclass(module = "pbd.bayes", frozen)]
#[derive(Debug, Clone, Copy)]
pub struct SymmetricDirichlet(dir::SymmetricDirichlet);

#[pymethods]
impl SymmetricDirichlet {
    #[new]
    fn new(num_categories: usize, gamma: f64) -> PyResult<Self> {
        Ok(SymmetricDirichlet(
            dir::SymmetricDirichlet::new(num_categories, gamma).py_err()?,
        ))
    }
    #[getter]
    fn num_categories(&self) -> usize {
        self.0.num_categories()
    }
    #[getter]
    fn gamma(&self) -> f64 {
        self.0.gamma()
    }
    /// Posterior predictive probabilities (K,) after `counts` (5.15).
    fn predictive_probs<'py>(&self, py: Python<'py>, counts: &CategoryCounts) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(Array1::from_vec(self.0.predictive_probs(&counts.0).py_err()?).into_pyarray(py))
    }
    /// ln p(counts), the probabilities integrated out (the Dirichlet–multinomial marginal).
    fn log_marginal_likelihood(&self, counts: &CategoryCounts) -> PyResult<f64> {
        self.0.log_marginal_likelihood(&counts.0).py_err()
    }
    /// Σ ln p(o_j | counts), each new observation scored against the counts only (5.16)–(5.18).
    fn log_predictive_product(&self, counts: &CategoryCounts, obs: &Bound<'_, PyAny>) -> PyResult<f64> {
        self.0.log_predictive_product(&counts.0, &indices(obs, "obs")?).py_err()
    }
    /// ln p(o_1..n | counts), the exact joint posterior predictive.
    fn log_posterior_marginal(&self, counts: &CategoryCounts, obs: &Bound<'_, PyAny>) -> PyResult<f64> {
        self.0.log_posterior_marginal(&counts.0, &indices(obs, "obs")?).py_err()
    }
    fn __repr__(&self) -> String {
        format!(
            "SymmetricDirichlet(num_categories={}, gamma={})",
            self.0.num_categories(),
            self.0.gamma()
        )
    }
}

fn mode(m: &str) -> PyResult<PredictiveMode> {
    match m {
        "independent" => Ok(PredictiveMode::Independent),
        "joint" => Ok(PredictiveMode::Joint),
        _ => Err(value_error(format!("mode must be 'independent' or 'joint', got {m:?}"))),
    }
}

fn factor_dict<'py>(py: Python<'py>, b: &bf::BayesFactor) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("log_p_task", b.log_p_task)?;
    d.set_item("log_p_background", b.log_p_background)?;
    d.set_item("log_b10", b.log_b10)?;
    Ok(d)
}

/// ln B₁₀ for a categorical feature (5.19)–(5.21): places weighted by (5.14), a Dirichlet–multinomial
/// feature model per place (5.18), against a uniform background. Returns `{log_p_task,
/// log_p_background, log_b10}`.
#[pyfunction]
#[pyo3(signature = (place_prior, place_counts, feature_prior, feature_counts, features, mode="independent"))]
fn categorical_bayes_factor<'py>(
    py: Python<'py>,
    place_prior: &SymmetricDirichlet,
    place_counts: &CategoryCounts,
    feature_prior: &SymmetricDirichlet,
    feature_counts: Vec<CategoryCounts>,
    features: &Bound<'py, PyAny>,
    mode: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let fc: Vec<dir::CategoryCounts> = feature_counts.into_iter().map(|c| c.0).collect();
    let b = bf::categorical_bayes_factor(
        &place_prior.0,
        &place_counts.0,
        &feature_prior.0,
        &fc,
        &indices(features, "features")?,
        self::mode(mode)?,
    )
    .py_err()?;
    factor_dict(py, &b)
}

/// ln B₁₀ for a continuous feature (5.19), (5.22)–(5.23): places weighted by (5.14), a NIG feature
/// model per place (Student-t predictives), against the `background` NIG with no data.
#[pyfunction]
#[pyo3(signature = (place_prior, place_counts, feature_prior, feature_stats, background, features, mode="independent"))]
#[allow(clippy::too_many_arguments)]
fn gaussian_bayes_factor<'py>(
    py: Python<'py>,
    place_prior: &SymmetricDirichlet,
    place_counts: &CategoryCounts,
    feature_prior: &NormalInverseGamma,
    feature_stats: Vec<GaussianStats>,
    background: &NormalInverseGamma,
    features: &Bound<'py, PyAny>,
    mode: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let fs: Vec<uni::GaussianStats> = feature_stats.into_iter().map(|s| s.0).collect();
    let b = bf::gaussian_bayes_factor(
        &place_prior.0,
        &place_counts.0,
        &feature_prior.0,
        &fs,
        &background.0,
        &vector(features, "features")?,
        self::mode(mode)?,
    )
    .py_err()?;
    factor_dict(py, &b)
}

/// A hidden Markov model in log space (§4.3, (4.10)–(4.21)): start distribution π (n,) and
/// transitions A (n×n, rows sum to 1). Emissions are given per call as a T×n array of
/// ln p(o_t | z_t = j).
#[pyclass(module = "pbd.bayes", frozen)]
#[derive(Debug, Clone)]
pub struct Hmm(hmm::Hmm);

impl Hmm {
    fn emissions(&self, log_emissions: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
        let (t, n, e) = matrix(log_emissions, "log_emissions")?;
        if n != self.0.n_states() {
            return Err(value_error(format!(
                "log_emissions: expected T x {} (one column per state), got {t} x {n}",
                self.0.n_states()
            )));
        }
        if t == 0 {
            return Err(value_error("log_emissions: no observations (T = 0)"));
        }
        if let Some(i) = e.iter().position(|v| v.is_nan() || *v == f64::INFINITY) {
            return Err(value_error(format!(
                "log_emissions: entry ({}, {}) is {} (log-probabilities are finite or -inf)",
                i / n,
                i % n,
                e[i]
            )));
        }
        Ok(e)
    }
}

#[pymethods]
impl Hmm {
    /// From probabilities: `start` (n,) and `transitions` (n×n).
    #[new]
    fn new(start: &Bound<'_, PyAny>, transitions: &Bound<'_, PyAny>) -> PyResult<Self> {
        let (r, c, a) = matrix(transitions, "transitions")?;
        let s = vector(start, "start")?;
        if r != c || r != s.len() {
            return Err(value_error(format!(
                "transitions must be n x n with n = len(start) = {}, got {r} x {c}",
                s.len()
            )));
        }
        Ok(Hmm(hmm::Hmm::from_probabilities(&s, &a).py_err()?))
    }
    /// From log-probabilities.
    #[staticmethod]
    fn from_log(log_start: &Bound<'_, PyAny>, log_transitions: &Bound<'_, PyAny>) -> PyResult<Self> {
        let (r, c, a) = matrix(log_transitions, "log_transitions")?;
        let s = vector(log_start, "log_start")?;
        if r != c || r != s.len() {
            return Err(value_error(format!(
                "log_transitions must be n x n with n = len(log_start) = {}, got {r} x {c}",
                s.len()
            )));
        }
        Ok(Hmm(hmm::Hmm::new(s, a).py_err()?))
    }
    /// Number of states n.
    #[getter]
    fn n_states(&self) -> usize {
        self.0.n_states()
    }
    /// ln π (n,).
    #[getter]
    fn log_start<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_vec(self.0.log_start().to_vec()).into_pyarray(py)
    }
    /// ln A (n×n).
    #[getter]
    fn log_transitions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = self.0.n_states();
        let a = Array2::from_shape_vec((n, n), self.0.log_transitions().to_vec())
            .map_err(|e| value_error(e.to_string()))?;
        Ok(a.into_pyarray(py))
    }
    /// ln p(o_1..T) by the forward recursion (4.10); `-inf` when the observations are impossible.
    fn forward(&self, py: Python<'_>, log_emissions: &Bound<'_, PyAny>) -> PyResult<f64> {
        let e = self.emissions(log_emissions)?;
        py.detach(|| self.0.forward(&e)).py_err()
    }
    /// The most probable state path: `(path (T,) int64, ln p(path, o))`, or None when impossible.
    fn viterbi<'py>(
        &self,
        py: Python<'py>,
        log_emissions: &Bound<'py, PyAny>,
    ) -> PyResult<Option<(Bound<'py, PyArray1<i64>>, f64)>> {
        let e = self.emissions(log_emissions)?;
        let v = py.detach(|| self.0.viterbi(&e)).py_err()?;
        Ok(v.map(|v| {
            (
                Array1::from_iter(v.path.iter().map(|&s| s as i64)).into_pyarray(py),
                v.log_prob,
            )
        }))
    }
    /// Smoothed posteriors: `(ln p(o), p(z_t = j | o) as T×n)`, or None when impossible.
    fn forward_backward<'py>(
        &self,
        py: Python<'py>,
        log_emissions: &Bound<'py, PyAny>,
    ) -> PyResult<Option<(f64, Bound<'py, PyArray2<f64>>)>> {
        let e = self.emissions(log_emissions)?;
        let n = self.0.n_states();
        let s = py.detach(|| self.0.forward_backward(&e)).py_err()?;
        match s {
            None => Ok(None),
            Some(s) => {
                let t = s.len();
                let a = Array2::from_shape_vec((t, n), s.posteriors).map_err(|e| value_error(e.to_string()))?;
                Ok(Some((s.log_likelihood, a.into_pyarray(py))))
            }
        }
    }
    fn __repr__(&self) -> String {
        format!(
            "Hmm(n_states={}, nonzero_transitions={})",
            self.0.n_states(),
            self.0.nonzero_transitions()
        )
    }
}

/// T×n log emissions of categorical observations: `log_emission_probs` (n×m, ln p(symbol | state)),
/// `obs` (T,) symbol indices.
#[pyfunction]
fn categorical_log_emissions<'py>(
    py: Python<'py>,
    log_emission_probs: &Bound<'py, PyAny>,
    obs: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let (n, _, p) = matrix(log_emission_probs, "log_emission_probs")?;
    let obs = indices(obs, "obs")?;
    let e = hmm::categorical_log_emissions(&p, n, &obs).py_err()?;
    let t = obs.len();
    Ok(Array2::from_shape_vec((t, n), e)
        .map_err(|e| value_error(e.to_string()))?
        .into_pyarray(py))
}

/// Adds the classes and functions to the `pbd.bayes` module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<GaussianStats>()?;
    m.add_class::<StudentT>()?;
    m.add_class::<NormalInverseGamma>()?;
    m.add_class::<CategoryCounts>()?;
    m.add_class::<SymmetricDirichlet>()?;
    m.add_class::<Hmm>()?;
    m.add_function(wrap_pyfunction!(categorical_bayes_factor, m)?)?;
    m.add_function(wrap_pyfunction!(gaussian_bayes_factor, m)?)?;
    m.add_function(wrap_pyfunction!(categorical_log_emissions, m)?)?;
    Ok(())
}

//! Discrete-time hidden Markov models: forward log-likelihood, streaming allocation-free forward
//! filters, forward–backward smoothing, Viterbi decoding, and a batched forward pass of several
//! models over shared emissions (library-wide schema inference).
//!
//! The model ([`Hmm`]) holds the log start distribution π and the log transition matrix A
//! (`A[i][j] = p(z_{t+1} = j | z_t = i)`, row = from). Emissions are *not* part of the model: the
//! caller supplies, for every time step, the log likelihood `log p(o_t | z_t = j)` of each state
//! j, so any emission model works (categorical, Gaussian, a miss/false-alarm model over
//! predicate vectors, …). [`categorical_log_emissions`] builds them for a categorical model.
//! These are the quantities of the schema HMMs in Sweeney (2011) §4.3, eqs. (4.10)–(4.21).
//!
//! ## Which pass
//! | entry point | input | arithmetic | exact? |
//! | --- | --- | --- | --- |
//! | [`Hmm::forward`], [`Hmm::forward_backward`] | log emissions | one `exp` per lattice entry, then the scaled linear recursion | yes (below) |
//! | [`Hmm::forward_linear`], [`ScaledFilter`], [`forward_shared`], [`forward_shared_linear`] | linear emissions (or shared columns) | scaled linear recursion, no `exp`/`ln` per element (`forward_linear` over a band: extended-range arithmetic, below) | yes |
//! | [`Hmm::forward_scaled`] | linear emissions | the same recursion with hmmlearn's flushing, and a worst-case bound | to its bound |
//! | [`Hmm::forward_exact`], [`ForwardFilter`], [`Hmm::viterbi`] | log emissions | log space (Viterbi: max-plus, no transcendental at all) | yes |
//!
//! The scaled recursion (module `scaled`: dense rows in register blocks, bands of diagonals for
//! left-to-right models, CSC columns for the rest) carries α̂_t = p(z_t | o_1..t) and the product of
//! the step normalisers c_t = p(o_t | o_<t) (Rabiner 1989 §V.A). States whose probability falls
//! below 1e-280 of the distribution leave the linear vector and are carried exactly in log space
//! until they come back (a quarter of the states or more: the pass continues as the log-space
//! recursion), so the exact entry points agree with the log-space recursion to rounding (the
//! tests check 1e-12 against it and against hmmlearn). A step linear arithmetic cannot represent
//! at all (c_t < 1e-280) reruns in log space.
//!
//! Over a band (a left-to-right model), most states fall below any fixed floor in a long sequence
//! and the scaled pass would spend an `exp` per tiny state and step. [`Hmm::forward_linear`] runs
//! such models in extended-range arithmetic instead: each α_t,j is its own mantissa and binary
//! exponent, a state's incoming terms are aligned to the largest by a power of two (built from its
//! bits), and nothing is lost that a double could hold — exact, with no transcendental per element
//! (N = 16, T = 100 000: 13.8 ms, was 77 ms; `cargo bench -p bayes --bench hmm`).
//!
//! ## The log-space recursion
//! Probabilities are carried as normalised *filtered* posteriors `p(z_t | o_1..t)` (both as logs
//! and as plain numbers) plus the running `log p(o_1..t)`. One step is
//!
//! ```text
//!   pred_j  = Σ_i p(z_{t-1}=i | o_<t) · A_ij            (plain arithmetic, sparse rows)
//!   u_j     = ln pred_j + log p(o_t | z_t=j)
//!   c_t     = log Σ_j exp(u_j)  = log p(o_t | o_<t)     (log-sum-exp)
//!   log p(z_t=j | o_1..t) = u_j − c_t
//! ```
//!
//! The plain-arithmetic prediction is exact to rounding whenever `pred_j ≥ 1e-250`: every term it
//! could have lost to underflow is below 1e-307. When `pred_j` is smaller (or zero), that one
//! entry is recomputed by a log-sum-exp over the state's incoming transitions, so no probability
//! is ever rounded to zero that the log-space recursion would keep. A step costs one `ln` and one
//! `exp` per state plus one multiply-add per non-zero transition.
//!
//! `-inf` is allowed everywhere (impossible starts, transitions, observations). When an
//! observation has zero probability under every reachable state, the log-likelihood becomes
//! `-inf` and stays there, the filtered posterior becomes all zeros, smoothing and Viterbi return
//! `None`, and no NaN is produced.

use crate::error::{BayesError, Result, check_len};

mod scaled;
use scaled::{BOUND_TOL, Kernel, MIN_LINEAR_PROBABILITY, Scaled, Tiny};

/// A state prediction below this is recomputed exactly in log space (see the module docs).
const LINEAR_MIN: f64 = 1e-250;
/// |log Σ p| allowed for a row that must sum to one.
const NORMALISATION_TOL: f64 = 1e-8;

/// A discrete-time HMM: log start probabilities and a (possibly sparse) log transition matrix.
///
/// Immutable once built; the working state of a streaming filter lives in [`ForwardFilter`].
#[derive(Debug, Clone, PartialEq)]
pub struct Hmm {
    n: usize,
    log_start: Vec<f64>,
    /// n×n row-major, row = from.
    log_trans: Vec<f64>,
    /// exp(log_trans), dense; used when the matrix is dense.
    trans: Vec<f64>,
    dense: bool,
    /// Outgoing non-zero transitions (CSR): for source i, `out_ptr[i]..out_ptr[i+1]`.
    out_ptr: Vec<usize>,
    out_to: Vec<usize>,
    out_lin: Vec<f64>,
    out_log: Vec<f64>,
    /// Incoming non-zero transitions (CSC): for destination j, `in_ptr[j]..in_ptr[j+1]`,
    /// sources in increasing order.
    in_ptr: Vec<usize>,
    in_from: Vec<usize>,
    in_log: Vec<f64>,
    in_lin: Vec<f64>,
    /// exp(log_start).
    start_lin: Vec<f64>,
    /// The layout of the linear (scaled) prediction step.
    kernel: Kernel,
    /// Whether the scaled linear path can represent every non-zero start and transition
    /// probability (all ≥ 1e-20); if not, every pass takes the exact log-space path.
    linear_ok: bool,
}

impl Hmm {
    /// Builds an HMM from the log start distribution (length n) and the log transition matrix
    /// (n×n, row-major, row = from state).
    ///
    /// Errors: n = 0, wrong sizes, NaN or `+inf` entries, or a distribution (the start vector or
    /// a transition row) whose probabilities do not sum to 1 within 1e-8 (in log).
    pub fn new(log_start: Vec<f64>, log_trans: Vec<f64>) -> Result<Self> {
        let n = log_start.len();
        if n == 0 {
            return Err(BayesError::Empty {
                what: "HMM start distribution",
            });
        }
        check_len("HMM log transition matrix (n×n)", n * n, log_trans.len())?;
        check_log_distribution("HMM log start distribution", 0, &log_start)?;
        for i in 0..n {
            check_log_distribution("HMM log transition matrix", i, &log_trans[i * n..(i + 1) * n])?;
        }
        let trans: Vec<f64> = log_trans.iter().map(|&l| l.exp()).collect();
        let mut out_ptr = Vec::with_capacity(n + 1);
        let (mut out_to, mut out_lin, mut out_log) = (Vec::new(), Vec::new(), Vec::new());
        out_ptr.push(0);
        for i in 0..n {
            for j in 0..n {
                let l = log_trans[i * n + j];
                if l > f64::NEG_INFINITY {
                    out_to.push(j);
                    out_lin.push(l.exp());
                    out_log.push(l);
                }
            }
            out_ptr.push(out_to.len());
        }
        let mut in_ptr = Vec::with_capacity(n + 1);
        let (mut in_from, mut in_log, mut in_lin) = (Vec::new(), Vec::new(), Vec::new());
        in_ptr.push(0);
        for j in 0..n {
            for i in 0..n {
                let l = log_trans[i * n + j];
                if l > f64::NEG_INFINITY {
                    in_from.push(i);
                    in_log.push(l);
                    in_lin.push(l.exp());
                }
            }
            in_ptr.push(in_from.len());
        }
        // The dense loop vectorises; the sparse one wins once most entries are zero.
        let dense = 2 * out_to.len() > n * n;
        let start_lin: Vec<f64> = log_start.iter().map(|l| l.exp()).collect();
        let representable = |l: &f64| *l == f64::NEG_INFINITY || l.exp() >= MIN_LINEAR_PROBABILITY;
        let linear_ok = log_start.iter().all(representable) && log_trans.iter().all(representable);
        let kernel = Kernel::choose(n, &trans, out_to.len());
        Ok(Self {
            n,
            log_start,
            log_trans,
            trans,
            dense,
            out_ptr,
            out_to,
            out_lin,
            out_log,
            in_ptr,
            in_from,
            in_log,
            in_lin,
            start_lin,
            kernel,
            linear_ok,
        })
    }

    /// Builds an HMM from probabilities (start: n, transitions: n×n row-major, row = from); takes
    /// logs and calls [`Hmm::new`]. Negative entries are an error.
    pub fn from_probabilities(start: &[f64], trans: &[f64]) -> Result<Self> {
        for (what, xs) in [
            ("HMM start probabilities", start),
            ("HMM transition probabilities", trans),
        ] {
            if let Some((index, &value)) = xs.iter().enumerate().find(|&(_, &p)| p.is_nan() || p < 0.0) {
                return Err(BayesError::NonFinite {
                    what,
                    index,
                    value,
                    requirement: "a probability ≥ 0",
                });
            }
        }
        Self::new(
            start.iter().map(|p| p.ln()).collect(),
            trans.iter().map(|p| p.ln()).collect(),
        )
    }

    /// Number of hidden states n.
    pub fn n_states(&self) -> usize {
        self.n
    }

    /// log π, length n.
    pub fn log_start(&self) -> &[f64] {
        &self.log_start
    }

    /// The log transition matrix, n×n row-major, row = from.
    pub fn log_transitions(&self) -> &[f64] {
        &self.log_trans
    }

    /// Number of transitions with non-zero probability.
    pub fn nonzero_transitions(&self) -> usize {
        self.out_to.len()
    }

    /// log p(o_1..T) by the forward algorithm, (4.11)–(4.13).
    ///
    /// `log_emissions` is T×n row-major: entry (t, j) = log p(o_t | z_t = j). Returns `-inf` when
    /// the sequence is impossible. Errors: T = 0, a length not a multiple of n, NaN or `+inf`.
    ///
    /// Runs the scaled linear recursion (one `exp` per emission entry, none in the recursion) and
    /// falls back to the exact log-space recursion when its error bound exceeds 1e-13 (module docs).
    pub fn forward(&self, log_emissions: &[f64]) -> Result<f64> {
        self.check_emissions(log_emissions)?;
        if self.linear_ok {
            let mut s = Scaled::new(self, Tiny::Track);
            let mut row = vec![0.0; self.n];
            let mut shift = 0.0;
            for le in log_emissions.chunks_exact(self.n) {
                let m = shift_exp(le, &mut row);
                if m == f64::NEG_INFINITY {
                    return Ok(f64::NEG_INFINITY);
                }
                shift += m;
                s.step(self, &row);
                if s.dead {
                    break;
                }
            }
            if !s.collapsed && s.bound <= BOUND_TOL {
                return Ok(if s.dead {
                    f64::NEG_INFINITY
                } else {
                    s.log_likelihood() + shift
                });
            }
        }
        Ok(self.forward_log_unchecked(log_emissions))
    }

    /// log p(o_1..T) from *linear* emission likelihoods: `emissions` is T×n row-major, entry (t, j)
    /// = p(o_t | z_t = j) (finite, ≥ 0; densities may exceed 1). The scaled forward pass with no
    /// `exp` or `ln` per element while every state stays above 1e-280 of the filtered
    /// distribution; states below that are carried exactly in log space (module docs of
    /// `hmm::scaled`), so the result is the exact one. A band of diagonals (a left-to-right model)
    /// runs in extended-range arithmetic, exact without any log (module docs). A step linear arithmetic cannot represent
    /// at all (c_t < 1e-280) reruns the log-space recursion.
    /// Errors: T = 0, a length not a multiple of n, a negative, NaN or infinite entry.
    pub fn forward_linear(&self, emissions: &[f64]) -> Result<f64> {
        self.check_linear_emissions(emissions)?;
        if self.linear_ok && matches!(self.kernel, Kernel::Banded { .. }) {
            // A band (left-to-right schemas): most states fall below any fixed floor over a long
            // sequence, where the scaled pass would carry them in log space one `exp` at a time.
            return Ok(self.forward_banded_extended(emissions, &mut scaled::ExtendedScratch::default()));
        }
        if self.linear_ok {
            let mut s = Scaled::new(self, Tiny::Track);
            for e in emissions.chunks_exact(self.n) {
                s.step(self, e);
                if s.dead {
                    break;
                }
            }
            if !s.collapsed && s.bound <= BOUND_TOL {
                return Ok(s.log_likelihood());
            }
        }
        let log: Vec<f64> = emissions.iter().map(|e| e.ln()).collect();
        Ok(self.forward_log_unchecked(&log))
    }

    /// The scaled forward pass alone, as hmmlearn's `implementation="scaling"` computes it, with a
    /// certificate: linear emissions in (as [`Hmm::forward_linear`]), log p(o_1..T) and a bound on
    /// its relative error out.
    ///
    /// States whose filtered probability falls below 1e-280 are flushed to zero (every scaled
    /// implementation loses them; the log-space recursion keeps them). The returned
    /// `error_bound` is a worst case for what that can have cost — it assumes the flushed mass
    /// received the best emission of every later step — so it is 0 when nothing was flushed and may
    /// be pessimistic for long sequences with absorbing states. A step the linear path cannot
    /// represent at all (every carried state impossible after a flush, c_t < 1e-280, or a model
    /// with a non-zero probability below 1e-20) is rerun exactly, with bound 0.
    pub fn forward_scaled(&self, emissions: &[f64]) -> Result<ScaledForward> {
        self.check_linear_emissions(emissions)?;
        if self.linear_ok {
            let mut s = Scaled::new(self, Tiny::Flush);
            for e in emissions.chunks_exact(self.n) {
                s.step(self, e);
                if s.dead {
                    break;
                }
            }
            if !s.collapsed {
                return Ok(ScaledForward {
                    log_likelihood: s.log_likelihood(),
                    error_bound: s.bound,
                });
            }
        }
        let log: Vec<f64> = emissions.iter().map(|e| e.ln()).collect();
        Ok(ScaledForward {
            log_likelihood: self.forward_log_unchecked(&log),
            error_bound: 0.0,
        })
    }

    /// Smoothed state posteriors p(z_t | o_1..T) by the scaled forward–backward algorithm
    /// (Rabiner's α̂/β̂ recursions in the linear domain, exact log-space fallback as in
    /// [`Hmm::forward`]).
    ///
    /// Same input as [`Hmm::forward`]. Returns `None` when the sequence is impossible
    /// (p(o_1..T) = 0), where the posterior is undefined.
    pub fn forward_backward(&self, log_emissions: &[f64]) -> Result<Option<Smoothed>> {
        self.check_emissions(log_emissions)?;
        if self.linear_ok
            && let Some(result) = self.forward_backward_scaled(log_emissions)
        {
            return Ok(result);
        }
        Ok(self.forward_backward_log_unchecked(log_emissions))
    }

    /// The scaled forward–backward pass; `None` when its bound fails (the caller reruns exactly),
    /// `Some(None)` for an impossible sequence.
    fn forward_backward_scaled(&self, log_emissions: &[f64]) -> Option<Option<Smoothed>> {
        let n = self.n;
        let t_len = log_emissions.len() / n;
        let mut lin = vec![0.0; log_emissions.len()];
        let mut alphas = vec![0.0; log_emissions.len()];
        let mut c = vec![0.0; t_len];
        let mut s = Scaled::new(self, Tiny::Track);
        let mut shift = 0.0;
        for (t, (le, e)) in log_emissions.chunks_exact(n).zip(lin.chunks_exact_mut(n)).enumerate() {
            let m = shift_exp(le, e);
            if m == f64::NEG_INFINITY {
                return Some(None);
            }
            shift += m;
            c[t] = s.step(self, e);
            if s.ever_tiny {
                return None;
            }
            if s.dead {
                return (!s.collapsed && s.bound <= BOUND_TOL).then_some(None);
            }
            alphas[t * n..(t + 1) * n].copy_from_slice(s.alpha());
        }
        if s.collapsed || s.bound > BOUND_TOL || s.ever_tiny {
            // A state below 1e-280 is tracked in log space by the forward pass; the backward pass
            // would need the same care: the log-space recursion does it.
            return None;
        }
        let mut posteriors = alphas;
        let mut beta = vec![1.0; n];
        let mut w = vec![0.0; n];
        normalise(&mut posteriors[(t_len - 1) * n..]);
        for t in (0..t_len - 1).rev() {
            for ((w, e), b) in w.iter_mut().zip(&lin[(t + 1) * n..(t + 2) * n]).zip(&beta) {
                *w = e * b;
            }
            self.pull_back(&w, &mut beta);
            let inv = 1.0 / c[t + 1];
            let mut top = 0.0f64;
            for b in beta.iter_mut() {
                *b *= inv;
                top = top.max(*b);
            }
            if top.is_nan() || top >= 1e250 {
                return None;
            }
            let row = &mut posteriors[t * n..(t + 1) * n];
            for (p, b) in row.iter_mut().zip(&beta) {
                *p *= b;
            }
            normalise(row);
        }
        Some(Some(Smoothed {
            n_states: n,
            log_likelihood: s.log_likelihood() + shift,
            posteriors,
        }))
    }

    /// log p(o_1..T) by the exact log-space recursion alone (module docs): the reference the
    /// scaled paths are checked against, never faster than [`Hmm::forward`]. Same input and errors.
    pub fn forward_exact(&self, log_emissions: &[f64]) -> Result<f64> {
        self.check_emissions(log_emissions)?;
        Ok(self.forward_log_unchecked(log_emissions))
    }

    /// [`Hmm::forward_backward`] by the exact log-space recursion alone.
    pub fn forward_backward_exact(&self, log_emissions: &[f64]) -> Result<Option<Smoothed>> {
        self.check_emissions(log_emissions)?;
        Ok(self.forward_backward_log_unchecked(log_emissions))
    }

    /// The most probable state path and its log joint probability max_z log p(z, o_1..T)
    /// (Viterbi). Ties go to the lowest state index. `None` when the sequence is impossible.
    pub fn viterbi(&self, log_emissions: &[f64]) -> Result<Option<ViterbiPath>> {
        self.check_emissions(log_emissions)?;
        let n = self.n;
        let t_len = log_emissions.len() / n;
        let mut delta: Vec<f64> = self
            .log_start
            .iter()
            .zip(&log_emissions[..n])
            .map(|(s, e)| s + e)
            .collect();
        let mut next = vec![f64::NEG_INFINITY; n];
        let mut back = vec![0u32; t_len * n];
        for t in 1..t_len {
            let e = &log_emissions[t * n..(t + 1) * n];
            let bp = &mut back[t * n..(t + 1) * n];
            for j in 0..n {
                let (mut best, mut arg) = (f64::NEG_INFINITY, 0usize);
                if e[j] > f64::NEG_INFINITY {
                    for k in self.in_ptr[j]..self.in_ptr[j + 1] {
                        let s = delta[self.in_from[k]] + self.in_log[k];
                        if s > best {
                            best = s;
                            arg = self.in_from[k];
                        }
                    }
                }
                next[j] = best + e[j];
                bp[j] = arg as u32;
            }
            std::mem::swap(&mut delta, &mut next);
            if delta.iter().all(|&d| d == f64::NEG_INFINITY) {
                return Ok(None);
            }
        }
        let (mut state, mut best) = (0usize, f64::NEG_INFINITY);
        for (j, &d) in delta.iter().enumerate() {
            if d > best {
                best = d;
                state = j;
            }
        }
        if best == f64::NEG_INFINITY {
            return Ok(None);
        }
        let mut path = vec![0usize; t_len];
        path[t_len - 1] = state;
        for t in (1..t_len).rev() {
            state = back[t * n + state] as usize;
            path[t - 1] = state;
        }
        Ok(Some(ViterbiPath { path, log_prob: best }))
    }

    /// The exact log-space forward pass (see the module docs); input already checked.
    fn forward_log_unchecked(&self, log_emissions: &[f64]) -> f64 {
        let mut filter = ForwardFilter::new(self);
        for row in log_emissions.chunks_exact(self.n) {
            filter.step_unchecked(self, row);
            if filter.is_impossible() {
                break;
            }
        }
        filter.log_likelihood()
    }

    /// The exact log-space forward–backward pass; input already checked.
    fn forward_backward_log_unchecked(&self, log_emissions: &[f64]) -> Option<Smoothed> {
        let n = self.n;
        let t_len = log_emissions.len() / n;
        // Forward pass, keeping every normalised log α_t and c_t.
        let mut filter = ForwardFilter::new(self);
        let mut log_alpha = vec![0.0; t_len * n];
        let mut c = vec![0.0; t_len];
        for (t, row) in log_emissions.chunks_exact(n).enumerate() {
            c[t] = filter.step_unchecked(self, row);
            if filter.is_impossible() {
                return None;
            }
            log_alpha[t * n..(t + 1) * n].copy_from_slice(&filter.log_alpha);
        }
        // Backward pass with scaled β̂_t = β_t / p(o_{t+1..T} | o_1..t).
        let mut log_beta = vec![0.0; n];
        let mut v = vec![0.0; n];
        let mut w = vec![0.0; n];
        let mut posteriors = vec![0.0; t_len * n];
        write_posterior(
            &log_alpha[(t_len - 1) * n..],
            &log_beta,
            &mut posteriors[(t_len - 1) * n..],
        );
        for t in (0..t_len - 1).rev() {
            let e_next = &log_emissions[(t + 1) * n..(t + 2) * n];
            let mut m = f64::NEG_INFINITY;
            for j in 0..n {
                v[j] = e_next[j] + log_beta[j];
                m = m.max(v[j]);
            }
            for j in 0..n {
                w[j] = (v[j] - m).exp();
            }
            for (i, log_beta_i) in log_beta.iter_mut().enumerate() {
                let b = if self.dense {
                    self.trans[i * n..(i + 1) * n]
                        .iter()
                        .zip(&w)
                        .map(|(a, w)| a * w)
                        .sum::<f64>()
                } else {
                    let r = self.out_ptr[i]..self.out_ptr[i + 1];
                    self.out_to[r.clone()]
                        .iter()
                        .zip(&self.out_lin[r])
                        .map(|(&j, a)| a * w[j])
                        .sum::<f64>()
                };
                let lb = if b >= LINEAR_MIN {
                    m + b.ln()
                } else {
                    let r = self.out_ptr[i]..self.out_ptr[i + 1];
                    lse_iter(
                        self.out_to[r.clone()]
                            .iter()
                            .zip(&self.out_log[r])
                            .map(|(&j, l)| l + v[j]),
                    )
                };
                *log_beta_i = lb - c[t + 1];
            }
            write_posterior(
                &log_alpha[t * n..(t + 1) * n],
                &log_beta,
                &mut posteriors[t * n..(t + 1) * n],
            );
        }
        Some(Smoothed {
            n_states: n,
            log_likelihood: filter.log_likelihood(),
            posteriors,
        })
    }

    fn check_emissions(&self, log_emissions: &[f64]) -> Result<()> {
        if log_emissions.is_empty() {
            return Err(BayesError::Empty {
                what: "log emission sequence",
            });
        }
        if !log_emissions.len().is_multiple_of(self.n) {
            return Err(BayesError::DimensionMismatch {
                what: "log emission matrix (T×n, a multiple of n)",
                expected: log_emissions.len().div_ceil(self.n) * self.n,
                got: log_emissions.len(),
            });
        }
        check_log_emission(log_emissions)
    }

    fn check_linear_emissions(&self, emissions: &[f64]) -> Result<()> {
        if emissions.is_empty() {
            return Err(BayesError::Empty {
                what: "emission sequence",
            });
        }
        if !emissions.len().is_multiple_of(self.n) {
            return Err(BayesError::DimensionMismatch {
                what: "emission matrix (T×n, a multiple of n)",
                expected: emissions.len().div_ceil(self.n) * self.n,
                got: emissions.len(),
            });
        }
        check_linear_emission(emissions)
    }

    /// Exact log Σ_i exp(log_alpha_i + log A_ij) over the incoming transitions of j.
    fn exact_predict(&self, j: usize, log_alpha: &[f64]) -> f64 {
        let r = self.in_ptr[j]..self.in_ptr[j + 1];
        lse_iter(
            self.in_from[r.clone()]
                .iter()
                .zip(&self.in_log[r])
                .map(|(&i, l)| log_alpha[i] + l),
        )
    }
}

/// The result of [`Hmm::forward_scaled`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaledForward {
    /// log p(o_1..T) (`-inf` when impossible).
    pub log_likelihood: f64,
    /// Bound on the relative error of p(o_1..T) (≈ the absolute error of its log) from flushed
    /// probability mass; 0 when no state was flushed.
    pub error_bound: f64,
}

/// Smoothed posteriors from [`Hmm::forward_backward`].
#[derive(Debug, Clone, PartialEq)]
pub struct Smoothed {
    n_states: usize,
    /// log p(o_1..T).
    pub log_likelihood: f64,
    /// p(z_t = j | o_1..T), T×n row-major; each row sums to 1.
    pub posteriors: Vec<f64>,
}

impl Smoothed {
    /// The posterior row of time step t (length n).
    ///
    /// # Panics
    /// If t ≥ T.
    pub fn at(&self, t: usize) -> &[f64] {
        &self.posteriors[t * self.n_states..(t + 1) * self.n_states]
    }

    /// Number of time steps T.
    pub fn len(&self) -> usize {
        self.posteriors.len() / self.n_states
    }

    /// Always false (a smoothing result has at least one step).
    pub fn is_empty(&self) -> bool {
        self.posteriors.is_empty()
    }
}

/// The result of [`Hmm::viterbi`].
#[derive(Debug, Clone, PartialEq)]
pub struct ViterbiPath {
    /// The most probable state sequence z_1..T.
    pub path: Vec<usize>,
    /// log p(path, o_1..T).
    pub log_prob: f64,
}

/// Streaming forward filter: the working state for one observation stream of an [`Hmm`].
///
/// Holds the filtered posterior p(z_t | o_1..t) and the running log p(o_1..t). `step` allocates
/// nothing. The filter does not borrow the model (so both can live in one struct); pass the same
/// `Hmm` it was made for to every `step`.
#[derive(Debug, Clone, PartialEq)]
pub struct ForwardFilter {
    n: usize,
    steps: usize,
    log_likelihood: f64,
    log_alpha: Vec<f64>,
    post: Vec<f64>,
    pred: Vec<f64>,
}

impl ForwardFilter {
    /// A filter at t = 0 (no observation yet) for `hmm`.
    pub fn new(hmm: &Hmm) -> Self {
        let n = hmm.n;
        let mut f = Self {
            n,
            steps: 0,
            log_likelihood: 0.0,
            log_alpha: vec![0.0; n],
            post: vec![0.0; n],
            pred: vec![0.0; n],
        };
        f.reset(hmm);
        f
    }

    /// Back to t = 0; the state distribution is the start distribution again.
    pub fn reset(&mut self, hmm: &Hmm) {
        self.steps = 0;
        self.log_likelihood = 0.0;
        self.log_alpha.copy_from_slice(&hmm.log_start);
        for (p, l) in self.post.iter_mut().zip(&hmm.log_start) {
            *p = l.exp();
        }
    }

    /// Absorbs one observation given as its log likelihood under each state (length n) and
    /// returns log p(o_t | o_1..t−1) (`-inf` if the observation is impossible, and for every step
    /// after that). Allocates nothing.
    ///
    /// Errors: wrong length or a NaN / `+inf` entry (the filter is then unchanged).
    pub fn step(&mut self, hmm: &Hmm, log_emission: &[f64]) -> Result<f64> {
        check_len("log emission row (one entry per state)", self.n, log_emission.len())?;
        check_len("HMM state count of this filter", self.n, hmm.n)?;
        check_log_emission(log_emission)?;
        Ok(self.step_unchecked(hmm, log_emission))
    }

    fn step_unchecked(&mut self, hmm: &Hmm, e: &[f64]) -> f64 {
        debug_assert_eq!(e.len(), self.n);
        if self.is_impossible() {
            self.steps += 1;
            return f64::NEG_INFINITY;
        }
        let n = self.n;
        // u_j (unnormalised log posterior) goes into log_alpha in place, via pred.
        if self.steps == 0 {
            for ((a, s), ej) in self.log_alpha.iter_mut().zip(&hmm.log_start).zip(e) {
                *a = s + ej;
            }
        } else {
            self.pred.fill(0.0);
            if hmm.dense {
                for i in 0..n {
                    let p = self.post[i];
                    if p == 0.0 {
                        continue;
                    }
                    for (acc, a) in self.pred.iter_mut().zip(&hmm.trans[i * n..(i + 1) * n]) {
                        *acc += p * a;
                    }
                }
            } else {
                for i in 0..n {
                    let p = self.post[i];
                    if p == 0.0 {
                        continue;
                    }
                    let r = hmm.out_ptr[i]..hmm.out_ptr[i + 1];
                    for (&j, a) in hmm.out_to[r.clone()].iter().zip(&hmm.out_lin[r]) {
                        self.pred[j] += p * a;
                    }
                }
            }
            for (j, (p, &ej)) in self.pred.iter_mut().zip(e).enumerate() {
                // Park u_j in pred: log_alpha (t−1) is still needed by exact_predict.
                *p = if ej == f64::NEG_INFINITY {
                    f64::NEG_INFINITY
                } else if *p >= LINEAR_MIN {
                    p.ln() + ej
                } else {
                    hmm.exact_predict(j, &self.log_alpha) + ej
                };
            }
            self.log_alpha.copy_from_slice(&self.pred);
        }
        self.steps += 1;
        let m = self.log_alpha.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if m == f64::NEG_INFINITY {
            self.log_likelihood = f64::NEG_INFINITY;
            self.post.fill(0.0);
            return f64::NEG_INFINITY;
        }
        let mut s = 0.0;
        for (p, &u) in self.post.iter_mut().zip(&self.log_alpha) {
            *p = (u - m).exp();
            s += *p;
        }
        let c = m + s.ln();
        let inv = 1.0 / s;
        for (p, l) in self.post.iter_mut().zip(self.log_alpha.iter_mut()) {
            *p *= inv;
            *l -= c;
        }
        self.log_likelihood += c;
        c
    }

    /// log p(o_1..t) so far (0 before the first step, `-inf` once impossible).
    pub fn log_likelihood(&self) -> f64 {
        self.log_likelihood
    }

    /// p(z_t = j | o_1..t), length n; sums to 1 (all zeros once the stream is impossible).
    /// Before the first step this is the start distribution.
    pub fn filtered(&self) -> &[f64] {
        &self.post
    }

    /// log p(z_t = j | o_1..t), length n (all `-inf` once the stream is impossible).
    pub fn log_filtered(&self) -> &[f64] {
        &self.log_alpha
    }

    /// Number of observations absorbed.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// True once an observation had probability zero (the log-likelihood is `-inf`).
    pub fn is_impossible(&self) -> bool {
        self.log_likelihood == f64::NEG_INFINITY
    }
}

/// Streaming scaled forward filter over *linear* emission likelihoods: the allocation-free
/// counterpart of [`ForwardFilter`] without `exp`/`ln` per state (one `ln` per step for the
/// returned log p(o_t | o_<t)).
///
/// Exact like [`ForwardFilter`]: a state whose filtered probability falls below 1e-280 reads 0 in
/// [`ScaledFilter::filtered`] but is carried in log space (a few `exp` per transition out of it per
/// step) and comes back when it rises again. [`ScaledFilter::error_bound`] bounds what can still
/// be lost (contributions below the smallest normal double, ~1e-300 relative); it is infinite if
/// a step could not be represented in linear arithmetic at all (c_t < 1e-280, or a model with a
/// non-zero probability below 1e-20) — use [`ForwardFilter`] there.
#[derive(Debug, Clone, PartialEq)]
pub struct ScaledFilter {
    inner: Scaled,
}

impl ScaledFilter {
    /// A filter at t = 0 for `hmm`.
    pub fn new(hmm: &Hmm) -> Self {
        ScaledFilter {
            inner: Scaled::new(hmm, Tiny::Track),
        }
    }

    /// Back to t = 0.
    pub fn reset(&mut self, hmm: &Hmm) {
        self.inner.reset(hmm);
    }

    /// Absorbs one observation given as its likelihood under each state (length n, finite, ≥ 0)
    /// and returns log p(o_t | o_1..t−1) (`-inf` once impossible). Allocates nothing.
    ///
    /// Errors: wrong length, or a negative, NaN or infinite entry (the filter is then unchanged).
    pub fn step(&mut self, hmm: &Hmm, emission: &[f64]) -> Result<f64> {
        let n = self.inner.n();
        check_len("emission row (one entry per state)", n, emission.len())?;
        check_len("HMM state count of this filter", n, hmm.n)?;
        check_linear_emission(emission)?;
        let c = self.inner.step(hmm, emission);
        Ok(if self.inner.dead {
            f64::NEG_INFINITY
        } else if self.inner.log_c.is_nan() {
            c.ln()
        } else {
            self.inner.log_c
        })
    }

    /// log p(o_1..t) so far (0 before the first step, `-inf` once impossible).
    pub fn log_likelihood(&self) -> f64 {
        self.inner.log_likelihood()
    }

    /// p(z_t = j | o_1..t), length n (the start distribution before the first step; all zeros once
    /// the stream is impossible).
    pub fn filtered(&self) -> &[f64] {
        self.inner.alpha()
    }

    /// log p(z_t = j | o_1..t) into `out` (length n), exact also for the states that read 0 in
    /// [`Self::filtered`] because they are below 1e-280. Allocates nothing.
    ///
    /// # Panics
    /// If `out.len()` ≠ n.
    pub fn log_filtered_into(&self, out: &mut [f64]) {
        assert_eq!(out.len(), self.inner.n(), "one entry per state");
        self.inner.log_alpha_into(out);
    }

    /// Bound on the relative error of p(o_1..t) (and the absolute error of [`Self::filtered`])
    /// from flushed probability mass: 0 unless a state fell below 1e-280; infinite once a step
    /// could not be represented in linear arithmetic at all (see [`Hmm::forward_scaled`]).
    pub fn error_bound(&self) -> f64 {
        if self.inner.collapsed {
            f64::INFINITY
        } else {
            self.inner.bound
        }
    }

    /// Number of observations absorbed.
    pub fn steps(&self) -> usize {
        self.inner.steps
    }

    /// True once an observation had probability zero.
    pub fn is_impossible(&self) -> bool {
        self.inner.dead
    }
}

/// One model of a batched forward pass ([`forward_shared`]): an HMM and, for each of its states,
/// the column of the shared emission row that the state reads.
#[derive(Debug, Clone, Copy)]
pub struct SharedModel<'a> {
    /// The model.
    pub hmm: &'a Hmm,
    /// Length n: state j emits with column `columns[j]` of each shared row.
    pub columns: &'a [usize],
}

/// The result of one model of [`forward_shared`].
#[derive(Debug, Clone, PartialEq)]
pub struct SharedForward {
    /// log p(o_1..T) (`-inf` when impossible).
    pub log_likelihood: f64,
    /// log p(z_T = j | o_1..T), length n (all `-inf` when impossible).
    pub log_filtered: Vec<f64>,
}

/// The forward pass of several HMMs over one observation sequence whose emissions they share: the
/// library-wide schema inference of §4.3 (every schema model scores the same demonstration, and
/// states of different models emit with the same few distributions).
///
/// `log_emissions` is T×width row-major: the distinct log emission likelihoods of each step. Each
/// row is exponentiated once (width `exp`s per step, shifted by its maximum) and every model steps
/// its scaled filter on the columns it reads; a model whose flush bound exceeds 1e-13 is rerun
/// exactly in log space, so each result equals [`Hmm::forward`] on that model's own emissions.
///
/// Errors: width 0, T = 0, a length not a multiple of width, a column count ≠ n or a column ≥
/// width, NaN or `+inf` emissions.
pub fn forward_shared(models: &[SharedModel<'_>], log_emissions: &[f64], width: usize) -> Result<Vec<SharedForward>> {
    check_shared_shape(models, log_emissions.len(), width)?;
    check_log_emission(log_emissions)?;
    Ok(shared_core(
        models,
        log_emissions.len() / width,
        width,
        |t, row| shift_exp(&log_emissions[t * width..(t + 1) * width], row),
        |t, c| log_emissions[t * width + c],
    ))
}

/// [`forward_shared`] with *linear* shared emissions: `emissions` is T×width (finite, ≥ 0) and
/// the likelihood of column c at step t is `emissions[t·width + c] · exp(log_scales[t])`, so
/// callers that build emissions as products of precomputed factors take no `exp` at all. Same
/// results (exact) and errors, plus: `log_scales` must have T finite entries.
pub fn forward_shared_linear(
    models: &[SharedModel<'_>],
    emissions: &[f64],
    log_scales: &[f64],
    width: usize,
) -> Result<Vec<SharedForward>> {
    check_shared_shape(models, emissions.len(), width)?;
    check_linear_emission(emissions)?;
    let t_len = emissions.len() / width;
    check_len("shared log scales (one per step)", t_len, log_scales.len())?;
    if let Some(index) = log_scales.iter().position(|l| !l.is_finite()) {
        return Err(BayesError::NonFinite {
            what: "shared log scale",
            index,
            value: log_scales[index],
            requirement: "finite",
        });
    }
    Ok(shared_core(
        models,
        t_len,
        width,
        |t, row| {
            let src = &emissions[t * width..(t + 1) * width];
            if src.iter().all(|&e| e == 0.0) {
                return f64::NEG_INFINITY;
            }
            row.copy_from_slice(src);
            log_scales[t]
        },
        |t, c| emissions[t * width + c].ln() + log_scales[t],
    ))
}

fn check_shared_shape(models: &[SharedModel<'_>], len: usize, width: usize) -> Result<()> {
    if width == 0 || len == 0 {
        return Err(BayesError::Empty {
            what: "shared emission matrix",
        });
    }
    if !len.is_multiple_of(width) {
        return Err(BayesError::DimensionMismatch {
            what: "shared emission matrix (T×width, a multiple of width)",
            expected: len.div_ceil(width) * width,
            got: len,
        });
    }
    for m in models {
        check_len(
            "emission columns of a shared model (one per state)",
            m.hmm.n,
            m.columns.len(),
        )?;
        if let Some(&index) = m.columns.iter().find(|&&c| c >= width) {
            return Err(BayesError::IndexOutOfRange {
                what: "shared emission column",
                index,
                len: width,
            });
        }
    }
    Ok(())
}

/// The batched pass: `row(t, out)` writes step t's linear shared row (up to a factor) and returns
/// the log of that factor (`-inf`: every column impossible); `log_at(t, c)` is the exact log
/// emission, for the models that must rerun in log space.
fn shared_core(
    models: &[SharedModel<'_>],
    t_len: usize,
    width: usize,
    mut row_at: impl FnMut(usize, &mut [f64]) -> f64,
    log_at: impl Fn(usize, usize) -> f64,
) -> Vec<SharedForward> {
    let mut filters: Vec<Scaled> = models.iter().map(|m| Scaled::new(m.hmm, Tiny::Track)).collect();
    let mut rows: Vec<Vec<f64>> = models.iter().map(|m| vec![0.0; m.hmm.n]).collect();
    let mut lin = vec![0.0; width];
    let mut shift = 0.0;
    let mut all_impossible = false;
    for t in 0..t_len {
        let m = row_at(t, &mut lin);
        if m == f64::NEG_INFINITY {
            all_impossible = true;
            break;
        }
        shift += m;
        for ((model, f), row) in models.iter().zip(&mut filters).zip(&mut rows) {
            if f.dead || f.collapsed {
                continue;
            }
            for (r, &c) in row.iter_mut().zip(model.columns) {
                *r = lin[c];
            }
            f.step(model.hmm, row);
        }
    }
    models
        .iter()
        .zip(&filters)
        .map(|(model, f)| {
            let n = model.hmm.n;
            let exact_enough = !f.collapsed && f.bound <= BOUND_TOL;
            if all_impossible || (f.dead && exact_enough) {
                return SharedForward {
                    log_likelihood: f64::NEG_INFINITY,
                    log_filtered: vec![f64::NEG_INFINITY; n],
                };
            }
            if exact_enough {
                let mut log_filtered = Vec::with_capacity(n);
                f.log_alpha(&mut log_filtered);
                return SharedForward {
                    log_likelihood: f.log_likelihood() + shift,
                    log_filtered,
                };
            }
            let mut exact = ForwardFilter::new(model.hmm);
            let mut row = vec![0.0; n];
            for t in 0..t_len {
                for (r, &c) in row.iter_mut().zip(model.columns) {
                    *r = log_at(t, c);
                }
                exact.step_unchecked(model.hmm, &row);
                if exact.is_impossible() {
                    break;
                }
            }
            SharedForward {
                log_likelihood: exact.log_likelihood(),
                log_filtered: exact.log_filtered().to_vec(),
            }
        })
        .collect()
}

/// Emission matrix (T×n row-major) for a categorical emission model, linear:
/// entry (t, j) = `emission_probs[j * n_symbols + obs[t]]`, for [`Hmm::forward_linear`].
///
/// `emission_probs` is n×K row-major (row = state), p(symbol k | state j), each finite and ≥ 0.
pub fn categorical_emissions(emission_probs: &[f64], n_states: usize, obs: &[usize]) -> Result<Vec<f64>> {
    if n_states == 0 || emission_probs.is_empty() {
        return Err(BayesError::Empty {
            what: "categorical emission model",
        });
    }
    if !emission_probs.len().is_multiple_of(n_states) {
        return Err(BayesError::DimensionMismatch {
            what: "categorical emission matrix (n×K)",
            expected: n_states * emission_probs.len().div_ceil(n_states),
            got: emission_probs.len(),
        });
    }
    check_linear_emission(emission_probs)?;
    categorical_lattice(emission_probs, n_states, obs)
}

/// Log emission matrix (T×n row-major) for a categorical emission model:
/// entry (t, j) = `log_emission_probs[j * n_symbols + obs[t]]`.
///
/// `log_emission_probs` is n×K row-major (row = state), log p(symbol k | state j).
pub fn categorical_log_emissions(log_emission_probs: &[f64], n_states: usize, obs: &[usize]) -> Result<Vec<f64>> {
    if n_states == 0 {
        return Err(BayesError::Empty {
            what: "categorical emission model (states)",
        });
    }
    if !log_emission_probs.len().is_multiple_of(n_states) || log_emission_probs.is_empty() {
        return Err(BayesError::DimensionMismatch {
            what: "categorical log emission matrix (n×K)",
            expected: n_states * log_emission_probs.len().div_ceil(n_states).max(1),
            got: log_emission_probs.len(),
        });
    }
    check_log_emission(log_emission_probs)?;
    categorical_lattice(log_emission_probs, n_states, obs)
}

/// Entry (t, j) = `table[j · K + obs[t]]` for an n×K table (checked by the caller).
fn categorical_lattice(table: &[f64], n_states: usize, obs: &[usize]) -> Result<Vec<f64>> {
    let k = table.len() / n_states;
    let mut out = Vec::with_capacity(obs.len() * n_states);
    for &o in obs {
        if o >= k {
            return Err(BayesError::IndexOutOfRange {
                what: "observation symbol",
                index: o,
                len: k,
            });
        }
        out.extend((0..n_states).map(|j| table[j * k + o]));
    }
    Ok(out)
}

/// out_j = exp(l_j − max l); returns max l (`-inf` when every entry is, and out is then all 0).
#[inline]
fn shift_exp(l: &[f64], out: &mut [f64]) -> f64 {
    let m = l.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if m == f64::NEG_INFINITY {
        out.fill(0.0);
        return m;
    }
    for (o, &x) in out.iter_mut().zip(l) {
        *o = (x - m).exp();
    }
    m
}

/// Divides a non-negative row by its sum.
fn normalise(row: &mut [f64]) {
    let s: f64 = row.iter().sum();
    let inv = 1.0 / s;
    row.iter_mut().for_each(|x| *x *= inv);
}

fn check_linear_emission(xs: &[f64]) -> Result<()> {
    // A branch-free pass first (it vectorises; NaN fails both comparisons), the search only on error.
    if xs.iter().fold(true, |ok, &v| ok & (0.0..=f64::MAX).contains(&v)) {
        return Ok(());
    }
    match xs.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
        None => Ok(()),
        Some(index) => Err(BayesError::NonFinite {
            what: "emission likelihood",
            index,
            value: xs[index],
            requirement: "finite and ≥ 0",
        }),
    }
}

/// Posterior row ∝ exp(log α + log β), normalised.
fn write_posterior(log_alpha: &[f64], log_beta: &[f64], out: &mut [f64]) {
    let m = log_alpha
        .iter()
        .zip(log_beta)
        .map(|(a, b)| a + b)
        .fold(f64::NEG_INFINITY, f64::max);
    let mut s = 0.0;
    for ((o, a), b) in out.iter_mut().zip(log_alpha).zip(log_beta) {
        *o = (a + b - m).exp();
        s += *o;
    }
    for o in out.iter_mut() {
        *o /= s;
    }
}

/// log-sum-exp of an iterator (two passes would need a clone; this is the streaming form).
fn lse_iter(it: impl Iterator<Item = f64> + Clone) -> f64 {
    let m = it.clone().fold(f64::NEG_INFINITY, f64::max);
    if m == f64::NEG_INFINITY {
        return m;
    }
    m + it.map(|x| (x - m).exp()).sum::<f64>().ln()
}

fn check_log_emission(xs: &[f64]) -> Result<()> {
    if xs.iter().fold(true, |ok, &v| ok & (v < f64::INFINITY)) {
        return Ok(());
    }
    match xs.iter().position(|v| v.is_nan() || *v == f64::INFINITY) {
        None => Ok(()),
        Some(index) => Err(BayesError::NonFinite {
            what: "log emission likelihood",
            index,
            value: xs[index],
            requirement: "not NaN and not +inf (-inf means impossible)",
        }),
    }
}

fn check_log_distribution(what: &'static str, row: usize, xs: &[f64]) -> Result<()> {
    if let Some(index) = xs.iter().position(|v| v.is_nan() || *v == f64::INFINITY) {
        return Err(BayesError::NonFinite {
            what,
            index,
            value: xs[index],
            requirement: "a log probability: not NaN and not +inf",
        });
    }
    let log_sum = lse_iter(xs.iter().copied());
    if log_sum.abs() > NORMALISATION_TOL {
        return Err(BayesError::NotNormalised { what, row, log_sum });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_state() -> Hmm {
        Hmm::from_probabilities(&[0.6, 0.4], &[0.7, 0.3, 0.4, 0.6]).unwrap()
    }

    /// Brute force over all paths: log p(o) and the best path.
    fn brute(hmm: &Hmm, e: &[f64]) -> (f64, f64, Vec<usize>) {
        let n = hmm.n_states();
        let t_len = e.len() / n;
        let mut total = 0.0;
        let mut best = (f64::NEG_INFINITY, vec![]);
        for code in 0..n.pow(t_len as u32) {
            let path: Vec<usize> = (0..t_len).map(|t| code / n.pow(t as u32) % n).collect();
            let mut lp = hmm.log_start()[path[0]] + e[path[0]];
            for t in 1..t_len {
                lp += hmm.log_transitions()[path[t - 1] * n + path[t]] + e[t * n + path[t]];
            }
            total += lp.exp();
            if lp > best.0 {
                best = (lp, path);
            }
        }
        (total.ln(), best.0, best.1)
    }

    #[test]
    fn forward_and_viterbi_match_brute_force() {
        let hmm = two_state();
        let e = [-0.1, -2.0, -1.5, -0.3, -0.2, -0.9, -3.0, -0.05];
        let (lp, vp, path) = brute(&hmm, &e);
        assert!((hmm.forward(&e).unwrap() - lp).abs() < 1e-14);
        let v = hmm.viterbi(&e).unwrap().unwrap();
        assert!((v.log_prob - vp).abs() < 1e-14);
        assert_eq!(v.path, path);
    }

    #[test]
    fn smoothed_rows_sum_to_one_and_last_equals_filtered() {
        let hmm = two_state();
        let e = [-0.1, -2.0, -1.5, -0.3, -0.2, -0.9];
        let s = hmm.forward_backward(&e).unwrap().unwrap();
        let mut f = ForwardFilter::new(&hmm);
        for row in e.chunks(2) {
            f.step(&hmm, row).unwrap();
        }
        for t in 0..3 {
            assert!((s.at(t).iter().sum::<f64>() - 1.0).abs() < 1e-14);
        }
        for j in 0..2 {
            assert!((s.at(2)[j] - f.filtered()[j]).abs() < 1e-14);
        }
        assert!((s.log_likelihood - f.log_likelihood()).abs() < 1e-14);
    }

    #[test]
    fn impossible_observation_gives_neg_inf_without_nan() {
        let hmm = two_state();
        let ninf = f64::NEG_INFINITY;
        let e = [-0.1, -2.0, ninf, ninf, -0.2, -0.9];
        assert_eq!(hmm.forward(&e).unwrap(), ninf);
        assert!(hmm.viterbi(&e).unwrap().is_none());
        assert!(hmm.forward_backward(&e).unwrap().is_none());
        let mut f = ForwardFilter::new(&hmm);
        for row in e.chunks(2) {
            let c = f.step(&hmm, row).unwrap();
            assert!(!c.is_nan());
        }
        assert!(f.is_impossible());
        assert!(f.filtered().iter().all(|&p| p == 0.0));
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(Hmm::from_probabilities(&[0.5, 0.6], &[1.0, 0.0, 0.0, 1.0]).is_err());
        assert!(Hmm::from_probabilities(&[0.5, 0.5], &[1.0, 0.0, 0.0]).is_err());
        assert!(Hmm::new(vec![], vec![]).is_err());
        assert!(Hmm::new(vec![0.0, f64::NAN], vec![0.0; 4]).is_err());
        let hmm = two_state();
        assert!(hmm.forward(&[]).is_err());
        assert!(hmm.forward(&[0.0, 0.0, 0.0]).is_err());
        assert!(hmm.forward(&[0.0, f64::NAN]).is_err());
        assert!(hmm.forward(&[0.0, f64::INFINITY]).is_err());
        let mut f = ForwardFilter::new(&hmm);
        assert!(f.step(&hmm, &[0.0]).is_err());
        assert_eq!(f.steps(), 0);
        assert!(categorical_log_emissions(&[0.0, 0.0], 2, &[1]).is_err());
    }

    #[test]
    fn tiny_transition_survives_where_linear_space_would_underflow() {
        // State 1 is reachable only through a transition of probability e^-800, and only state 1
        // can emit the second symbol; the answer must be finite, near -800.
        let l = -800.0_f64;
        let stay = (-(l.exp())).ln_1p(); // log(1 - e^-800) = -0 in f64
        let hmm = Hmm::new(vec![0.0, f64::NEG_INFINITY], vec![stay, l, f64::NEG_INFINITY, 0.0]).unwrap();
        let e = [0.0, f64::NEG_INFINITY, f64::NEG_INFINITY, 0.0];
        let lp = hmm.forward(&e).unwrap();
        assert!((lp - l).abs() < 1e-12, "{lp}");
        let s = hmm.forward_backward(&e).unwrap().unwrap();
        assert_eq!(s.at(1), &[0.0, 1.0]);
        assert!((s.at(0)[0] - 1.0).abs() < 1e-15);
        assert!((hmm.viterbi(&e).unwrap().unwrap().log_prob - l).abs() < 1e-12);
    }
}

//! Linear-domain kernels with per-step scaling: the fast path of every forward pass.
//!
//! One step of the scaled forward recursion (Rabiner 1989, §V.A; the quantities of Sweeney 2011,
//! (4.10)–(4.13)) is
//!
//! ```text
//!   pred_j = Σ_i α̂_{t−1,i} A_ij                (dense rows, diagonals of a band, or CSC columns)
//!   a_j    = pred_j · e_t,j                      e_t,j = p(o_t | z_t = j), linear
//!   c_t    = Σ_j a_j = p(o_t | o_<t)
//!   α̂_t,j = a_j / c_t
//! ```
//!
//! and log p(o_1..T) = Σ_t ln c_t. No `exp` or `ln` is taken per element: the product of the c_t
//! is carried as a float and its logarithm taken only when it leaves [1e-200, 1e200] (about once
//! every hundred steps).
//!
//! ## Exactness
//! Linear arithmetic loses a state whose filtered probability falls below the floating-point range,
//! which the log-space recursion (the exact path in `hmm/mod.rs`) keeps. Here such a state is
//! flushed explicitly, as soon as its normalised probability is below [`FLOOR`], and the flushed
//! mass is accounted for: with ℓ_t the (unknown) forward mass that the flushes removed, relative to
//! the normalised α̂_t,
//!
//! ```text
//!   |ℓ_t|₁ ≤ |ℓ_{t−1}|₁ · max_j e_t,j / c_t + flushed_t          (rows of A sum to one)
//! ```
//!
//! so `bound` = this right-hand side bounds the relative error of p(o_1..t) (and the absolute
//! error of the filtered distribution) at every step. The bound is a worst case: it lets the
//! flushed mass take the best emission of every later step, so for long sequences it can grow far
//! beyond the real loss (which is zero unless a flushed path later outweighs the kept ones by 280
//! orders of magnitude). A step whose c_t is zero after a flush, below 1e-280 or not finite marks
//! the pass `collapsed`. Callers that promise the exact answer (`Hmm::forward`, `forward_linear`,
//! `forward_backward`, the batched pass) rerun the log-space recursion when the pass collapsed or
//! the bound exceeds [`BOUND_TOL`]: the bound is 0 for models whose states all stay above 1e-280
//! (dense models, most schema models), and the exact rerun covers the rest.

use super::Hmm;

/// Normalised probabilities below this are flushed to zero (and added to the error bound).
pub(crate) const FLOOR: f64 = 1e-280;
/// Non-zero transition or start probabilities below this make the linear path unsafe (a product
/// with a probability near [`FLOOR`] would be subnormal); such models always take the exact path.
pub(crate) const MIN_LINEAR_PROBABILITY: f64 = 1e-20;
/// Largest accepted bound on the relative error of the likelihood (absolute error of its log).
pub(crate) const BOUND_TOL: f64 = 1e-13;
/// c_t below this is too close to the subnormal range to trust.
const MIN_C: f64 = 1e-280;
/// The pending product of scale factors is folded into the log when it leaves this range.
const SCALE_RANGE: f64 = 1e200;

/// Columns per register block of the dense kernel.
pub(crate) const BLOCK: usize = 8;

/// How the transitions are laid out for the linear prediction step.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Kernel {
    /// Column blocks of [`BLOCK`]: `blocks[(b·n + i)·BLOCK + k]` = A_{i, b·BLOCK + k} (zero past
    /// column n). pred's block b is accumulated in registers over the rows i: one broadcast, one
    /// contiguous load and BLOCK multiply-adds per entry, no stores in the inner loop.
    Dense {
        /// The blocked matrix, ⌈n / BLOCK⌉ · n · BLOCK entries.
        blocks: Vec<f64>,
    },
    /// A band of diagonals: A_ij ≠ 0 only for j − i ∈ `offsets`. `diags[d·n + j]` = A_{j−o_d, j}
    /// (zero outside the matrix). α̂ is kept in a zero-padded buffer so that every diagonal is one
    /// contiguous multiply-add over the states (vectorises). Left-to-right schema HMMs are bands.
    Banded {
        /// j − i of each stored diagonal.
        offsets: Vec<isize>,
        /// One row of n per diagonal.
        diags: Vec<f64>,
    },
    /// Columns in CSC form (`Hmm::in_ptr`, `in_from`, `in_lin`): pred_j = Σ α̂_i A_ij over j's
    /// incoming transitions.
    Sparse,
}

impl Kernel {
    /// The layout with the least work for `trans` (n×n, linear, row-major): a band when it has at
    /// most n/4 diagonals (and fewer stored entries than the dense matrix), else dense when more than
    /// a third of the entries are non-zero, else sparse columns.
    pub(crate) fn choose(n: usize, trans: &[f64], nonzeros: usize) -> Kernel {
        let mut present = vec![false; 2 * n - 1];
        for i in 0..n {
            for j in 0..n {
                if trans[i * n + j] > 0.0 {
                    present[j + n - 1 - i] = true;
                }
            }
        }
        let offsets: Vec<isize> = present
            .iter()
            .enumerate()
            .filter(|(_, p)| **p)
            .map(|(k, _)| k as isize - (n as isize - 1))
            .collect();
        if n >= 4 && offsets.len() * 4 <= n {
            let mut diags = vec![0.0; offsets.len() * n];
            for (d, &o) in offsets.iter().enumerate() {
                for j in 0..n {
                    let i = j as isize - o;
                    if (0..n as isize).contains(&i) {
                        diags[d * n + j] = trans[i as usize * n + j];
                    }
                }
            }
            Kernel::Banded { offsets, diags }
        } else if 3 * nonzeros > n * n {
            let nb = n.div_ceil(BLOCK);
            let mut blocks = vec![0.0; nb * n * BLOCK];
            for b in 0..nb {
                for i in 0..n {
                    for k in 0..BLOCK {
                        let j = b * BLOCK + k;
                        if j < n {
                            blocks[(b * n + i) * BLOCK + k] = trans[i * n + j];
                        }
                    }
                }
            }
            Kernel::Dense { blocks }
        } else {
            Kernel::Sparse
        }
    }

    /// (left padding, total buffer length) of the α̂ buffer for n states.
    pub(crate) fn padding(&self, n: usize) -> (usize, usize) {
        match self {
            Kernel::Banded { offsets, .. } => {
                let hi = offsets.iter().copied().max().unwrap_or(0).max(0) as usize;
                let lo = (-offsets.iter().copied().min().unwrap_or(0)).max(0) as usize;
                (hi, hi + n + lo)
            }
            _ => (0, n),
        }
    }
}

impl Hmm {
    /// pred = Aᵀ α̂, where α̂ sits at `buf[pad..pad + n]` (zeros around it).
    #[inline]
    pub(crate) fn predict(&self, buf: &[f64], pad: usize, pred: &mut [f64]) {
        let n = self.n;
        match &self.kernel {
            Kernel::Dense { blocks } => {
                let alpha = &buf[pad..pad + n];
                for (b, block) in blocks.chunks_exact(n * BLOCK).enumerate() {
                    let mut acc = [0.0f64; BLOCK];
                    for (&a, row) in alpha.iter().zip(block.chunks_exact(BLOCK)) {
                        for k in 0..BLOCK {
                            acc[k] += a * row[k];
                        }
                    }
                    let j0 = b * BLOCK;
                    let len = BLOCK.min(n - j0);
                    pred[j0..j0 + len].copy_from_slice(&acc[..len]);
                }
            }
            Kernel::Banded { offsets, diags } => {
                pred.fill(0.0);
                for (&o, diag) in offsets.iter().zip(diags.chunks_exact(n)) {
                    let start = (pad as isize - o) as usize;
                    let src = &buf[start..start + n];
                    for ((p, a), d) in pred.iter_mut().zip(src).zip(diag) {
                        *p += a * d;
                    }
                }
            }
            Kernel::Sparse => {
                let alpha = &buf[pad..pad + n];
                for (j, p) in pred.iter_mut().enumerate() {
                    let r = self.in_ptr[j]..self.in_ptr[j + 1];
                    *p = self.in_from[r.clone()]
                        .iter()
                        .zip(&self.in_lin[r])
                        .map(|(&i, a)| alpha[i] * a)
                        .sum();
                }
            }
        }
    }

    /// out_i = Σ_j A_ij w_j (the backward step's transition product).
    pub(crate) fn pull_back(&self, w: &[f64], out: &mut [f64]) {
        let n = self.n;
        if matches!(self.kernel, Kernel::Dense { .. }) {
            for (o, row) in out.iter_mut().zip(self.trans.chunks_exact(n)) {
                *o = dot(row, w);
            }
        } else {
            for (i, o) in out.iter_mut().enumerate() {
                let r = self.out_ptr[i]..self.out_ptr[i + 1];
                *o = self.out_to[r.clone()]
                    .iter()
                    .zip(&self.out_lin[r])
                    .map(|(&j, a)| a * w[j])
                    .sum();
            }
        }
    }
}

/// Σ a_i b_i with four independent accumulators (the compiler vectorises them).
#[inline]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    s
}

/// The working state of one scaled forward pass.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Scaled {
    /// α̂ (normalised filtered posterior) at `buf[pad..pad + n]`, zeros around it.
    pub(crate) buf: Vec<f64>,
    pub(crate) pad: usize,
    pred: Vec<f64>,
    pub(crate) steps: usize,
    /// Σ ln c over the steps folded so far.
    log_scale: f64,
    /// Π c over the steps not yet folded into `log_scale`.
    scale: f64,
    /// Bound on the relative error of p(o_1..t) from flushed mass (see the module docs).
    pub(crate) bound: f64,
    /// An observation had probability zero under every state that carries mass.
    pub(crate) dead: bool,
    /// A step the linear path could not represent (c_t zero after a flush, below 1e-280, or not
    /// finite; or a model with probabilities below 1e-20): only the exact path can answer.
    pub(crate) collapsed: bool,
}

impl Scaled {
    pub(crate) fn new(hmm: &Hmm) -> Self {
        let (pad, len) = hmm.kernel.padding(hmm.n);
        let mut s = Scaled {
            buf: vec![0.0; len],
            pad,
            pred: vec![0.0; hmm.n],
            steps: 0,
            log_scale: 0.0,
            scale: 1.0,
            bound: 0.0,
            dead: false,
            collapsed: false,
        };
        s.reset(hmm);
        s
    }

    /// Back to t = 0: α̂ shows the start distribution; the bound is infinite for a model the
    /// linear path cannot represent.
    pub(crate) fn reset(&mut self, hmm: &Hmm) {
        self.buf.fill(0.0);
        let n = hmm.n;
        self.buf[self.pad..self.pad + n].copy_from_slice(&hmm.start_lin);
        self.steps = 0;
        self.log_scale = 0.0;
        self.scale = 1.0;
        self.bound = 0.0;
        self.dead = false;
        self.collapsed = !hmm.linear_ok;
    }

    /// Number of states.
    pub(crate) fn n(&self) -> usize {
        self.pred.len()
    }

    /// α̂_t, length n.
    pub(crate) fn alpha(&self) -> &[f64] {
        &self.buf[self.pad..self.pad + self.pred.len()]
    }

    /// log p(o_1..t) so far.
    pub(crate) fn log_likelihood(&self) -> f64 {
        if self.dead {
            f64::NEG_INFINITY
        } else {
            self.log_scale + self.scale.ln()
        }
    }

    /// Absorbs one row of linear emissions (finite, ≥ 0) and returns c_t = p(o_t | o_<t) (0 once
    /// the stream is impossible). Allocates nothing.
    #[inline]
    pub(crate) fn step(&mut self, hmm: &Hmm, e: &[f64]) -> f64 {
        let n = hmm.n;
        if self.dead {
            self.steps += 1;
            return 0.0;
        }
        if self.steps == 0 {
            self.pred.copy_from_slice(&hmm.start_lin);
        } else {
            hmm.predict(&self.buf, self.pad, &mut self.pred);
        }
        self.steps += 1;
        let alpha = &mut self.buf[self.pad..self.pad + n];
        let mut acc = [0.0f64; 4];
        {
            let (ca, cp, ce) = (alpha.chunks_exact_mut(4), self.pred.chunks_exact(4), e.chunks_exact(4));
            for ((a, p), e) in ca.zip(cp).zip(ce) {
                for k in 0..4 {
                    a[k] = p[k] * e[k];
                    acc[k] += a[k];
                }
            }
        }
        let tail = n - n % 4;
        let mut c = (acc[0] + acc[1]) + (acc[2] + acc[3]);
        for j in tail..n {
            alpha[j] = self.pred[j] * e[j];
            c += alpha[j];
        }
        if c == 0.0 && self.bound == 0.0 && !self.collapsed {
            // Every state carrying mass gives the observation probability zero, and none was
            // flushed: the sequence is impossible (the exact path agrees).
            let underflow = self.pred.iter().zip(e).any(|(&p, &e)| p > 0.0 && e > 0.0);
            if !underflow {
                self.dead = true;
                alpha.fill(0.0);
                return 0.0;
            }
        }
        if !(c >= MIN_C && c.is_finite()) {
            self.collapsed = true;
            if c == 0.0 || !c.is_finite() {
                // Nothing left to normalise: the exact path takes over (callers check the bound).
                self.dead = true;
                alpha.fill(0.0);
                return 0.0;
            }
        }
        let inv = 1.0 / c;
        let mut flushed = 0.0;
        for a in alpha.iter_mut() {
            let v = *a * inv;
            let keep = v >= FLOOR;
            flushed += if keep { 0.0 } else { v };
            *a = if keep { v } else { 0.0 };
        }
        if self.bound > 0.0 {
            let emax = e.iter().copied().fold(0.0, f64::max);
            self.bound = self.bound * emax * inv;
        }
        self.bound += flushed;
        let s = self.scale * c;
        if (1.0 / SCALE_RANGE..=SCALE_RANGE).contains(&s) {
            self.scale = s;
        } else {
            self.log_scale += self.scale.ln() + c.ln();
            self.scale = 1.0;
        }
        c
    }
}

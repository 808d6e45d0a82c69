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

use super::{ForwardFilter, Hmm};

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

/// exp(x), with arguments far below the double range answered 0 directly (glibc's underflow
/// path, which sets errno, is slow).
#[inline]
fn exp_or_zero(x: f64) -> f64 {
    if x < -746.0 { 0.0 } else { x.exp() }
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

/// What a scaled pass does with a state whose normalised probability falls below [`FLOOR`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Tiny {
    /// Flush it to zero and add its mass to the worst-case bound (hmmlearn's scaling mode loses it
    /// the same way, without the bound).
    Flush,
    /// Carry it exactly, in log space, until it rises above the floor again or becomes impossible.
    Track,
}

/// The working state of one scaled forward pass.
///
/// In [`Tiny::Track`] mode the pass is exact: states below [`FLOOR`] leave the linear vector and
/// are carried as log values (`tiny_log`), stepped by a log-sum-exp over their outgoing CSR
/// transitions, and promoted back when they rise above the floor. Their contributions to linear
/// states are added in linear arithmetic; only a contribution below the smallest normal double
/// (< 2.2e-308 of the step's normaliser) can be lost, and then it is at most a fraction r of the
/// receiving state's own probability, so by linearity of the recursion its whole future is at most
/// r of the total: r is added to `bound` (which therefore stays near 1e-300, never grows). The
/// tiny pass costs a few `exp` per transition out of a tiny state — nothing while every state is
/// above the floor (dense models, and most steps of most models).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Scaled {
    /// α̂ (normalised filtered posterior) at `buf[pad..pad + n]`, zeros around it (and at tiny
    /// states).
    pub(crate) buf: Vec<f64>,
    pub(crate) pad: usize,
    pred: Vec<f64>,
    pub(crate) steps: usize,
    /// Σ ln c over the steps folded so far.
    log_scale: f64,
    /// Π c over the steps not yet folded into `log_scale`.
    scale: f64,
    /// Bound on the relative error of p(o_1..t) from flushed or dropped mass (module docs).
    pub(crate) bound: f64,
    /// An observation had probability zero under every state that carries mass.
    pub(crate) dead: bool,
    /// A step the linear path could not represent (c_t zero after a flush, below 1e-280, or not
    /// finite; or a model with probabilities below 1e-20): only the exact path can answer.
    pub(crate) collapsed: bool,
    mode: Tiny,
    /// Some state has been tiny at some step (the scaled backward pass then defers to log space).
    pub(crate) ever_tiny: bool,
    /// log α̂_j of each tiny state (same normalisation as α̂); `-inf` for every other state.
    pub(crate) tiny_log: Vec<f64>,
    /// The tiny states, increasing. Capacity 2n, so the step never allocates.
    tiny: Vec<usize>,
    next_tiny: Vec<usize>,
    /// Per-destination online log-sum-exp (max, sum of exp(v − max)) of the tiny contributions.
    acc_max: Vec<f64>,
    acc_sum: Vec<f64>,
    touched: Vec<usize>,
    touched_mark: Vec<bool>,
    /// When more than a quarter of the states are tiny, per-state log arithmetic is cheaper than
    /// the tiny pass: the pass continues as the log-space recursion (`ForwardFilter`) and comes
    /// back to linear when no state is below the floor any more.
    log_mode: bool,
    /// The log-space recursion's state (allocated up front: switching never allocates).
    log_filter: ForwardFilter,
    /// ln of the emission row (log mode).
    log_row: Vec<f64>,
    /// ln c_t of the last step.
    pub(crate) log_c: f64,
}

impl Scaled {
    pub(crate) fn new(hmm: &Hmm, mode: Tiny) -> Self {
        let (pad, len) = hmm.kernel.padding(hmm.n);
        let n = hmm.n;
        let mut s = Scaled {
            buf: vec![0.0; len],
            pad,
            pred: vec![0.0; n],
            steps: 0,
            log_scale: 0.0,
            scale: 1.0,
            bound: 0.0,
            dead: false,
            collapsed: false,
            mode,
            ever_tiny: false,
            tiny_log: vec![f64::NEG_INFINITY; n],
            tiny: Vec::with_capacity(2 * n),
            next_tiny: Vec::with_capacity(2 * n),
            acc_max: vec![0.0; n],
            acc_sum: vec![0.0; n],
            touched: Vec::with_capacity(n),
            touched_mark: vec![false; n],
            log_mode: false,
            log_filter: ForwardFilter::new(hmm),
            log_row: vec![0.0; n],
            log_c: 0.0,
        };
        s.reset(hmm);
        s
    }

    /// Back to t = 0: α̂ shows the start distribution.
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
        self.ever_tiny = false;
        self.tiny_log.fill(f64::NEG_INFINITY);
        self.tiny.clear();
        self.log_mode = false;
        self.log_c = 0.0;
    }

    /// Number of states.
    pub(crate) fn n(&self) -> usize {
        self.pred.len()
    }

    /// α̂_t, length n (tiny states read 0 in linear mode).
    pub(crate) fn alpha(&self) -> &[f64] {
        if self.log_mode {
            self.log_filter.filtered()
        } else {
            &self.buf[self.pad..self.pad + self.pred.len()]
        }
    }

    /// log α̂_t,j for every state, into `out` (length n; exact for tiny states too).
    pub(crate) fn log_alpha_into(&self, out: &mut [f64]) {
        if self.log_mode {
            out.copy_from_slice(self.log_filter.log_filtered());
            return;
        }
        for ((o, &a), &l) in out.iter_mut().zip(self.alpha()).zip(&self.tiny_log) {
            *o = if a > 0.0 { a.ln() } else { l };
        }
    }

    /// log α̂_t,j for every state, into `out` (exact for tiny states too).
    pub(crate) fn log_alpha(&self, out: &mut Vec<f64>) {
        out.clear();
        out.resize(self.n(), 0.0);
        self.log_alpha_into(out);
    }

    /// log p(o_1..t) so far.
    pub(crate) fn log_likelihood(&self) -> f64 {
        if self.log_mode {
            return self.log_filter.log_likelihood();
        }
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
        if self.log_mode {
            return self.log_step(hmm, e);
        }
        if self.steps == 0 {
            self.pred.copy_from_slice(&hmm.start_lin);
        } else {
            hmm.predict(&self.buf, self.pad, &mut self.pred);
        }
        self.steps += 1;
        let tracking = !self.tiny.is_empty();
        if tracking {
            self.tiny_contributions(hmm);
        }
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
        // Tiny contributions (log, unnormalised) become x_j = exp(t_j); t_j is kept in acc_max.
        let mut tiny_possible = false;
        if tracking {
            for &j in &self.touched {
                let t = if e[j] > 0.0 {
                    self.acc_max[j] + self.acc_sum[j].ln() + e[j].ln()
                } else {
                    f64::NEG_INFINITY
                };
                self.acc_max[j] = t;
                tiny_possible |= t > f64::NEG_INFINITY;
                c += exp_or_zero(t);
            }
        }
        if c == 0.0 && self.bound == 0.0 && !self.collapsed && !tiny_possible {
            // Every state carrying mass gives the observation probability zero, and none was
            // flushed: the sequence is impossible (the exact path agrees).
            let underflow = self.pred.iter().zip(e).any(|(&p, &e)| p > 0.0 && e > 0.0);
            if !underflow {
                self.dead = true;
                alpha.fill(0.0);
                self.clear_tiny();
                return 0.0;
            }
        }
        if !(c >= MIN_C && c.is_finite()) {
            self.collapsed = true;
            if c == 0.0 || !c.is_finite() {
                // Nothing left to normalise: the exact path takes over (callers check).
                self.dead = true;
                alpha.fill(0.0);
                self.clear_tiny();
                return 0.0;
            }
        }
        let inv = 1.0 / c;
        self.log_c = f64::NAN;
        // Normalise; find states that fall below the floor (or whose product underflowed).
        let mut small = false;
        for ((a, &p), &e) in alpha.iter_mut().zip(&self.pred).zip(e) {
            let v = *a * inv;
            small |= (v < FLOOR) & (v > 0.0) | ((*a < 1e-290) & (p > 0.0) & (e > 0.0));
            *a = v;
        }
        if self.mode == Tiny::Flush && self.bound > 0.0 {
            // Flushed mass can grow at most by the best emission over the normaliser.
            let emax = e.iter().copied().fold(0.0, f64::max);
            self.bound = self.bound * emax * inv;
        }
        if small || tracking {
            self.below_floor(e, c, inv);
        }
        let s = self.scale * c;
        if (1.0 / SCALE_RANGE..=SCALE_RANGE).contains(&s) {
            self.scale = s;
        } else {
            self.log_scale += self.scale.ln() + c.ln();
            self.scale = 1.0;
        }
        if self.tiny.len() >= 2 && 4 * self.tiny.len() > n {
            self.enter_log_mode(hmm);
        }
        c
    }

    /// Hands the pass over to the log-space recursion from the current (exact) state.
    #[cold]
    fn enter_log_mode(&mut self, hmm: &Hmm) {
        let _ = hmm;
        let ll = self.log_likelihood();
        let pad = self.pad;
        let f = &mut self.log_filter;
        for (j, ((l, p), &t)) in f
            .log_alpha
            .iter_mut()
            .zip(f.post.iter_mut())
            .zip(&self.tiny_log)
            .enumerate()
        {
            let a = self.buf[pad + j];
            *l = if a > 0.0 { a.ln() } else { t };
            *p = if a > 0.0 { a } else { t.exp() };
        }
        f.steps = self.steps;
        f.log_likelihood = ll;
        self.log_mode = true;
    }

    /// One step of the log-space recursion; back to linear when no state is below the floor.
    fn log_step(&mut self, hmm: &Hmm, e: &[f64]) -> f64 {
        let f = &mut self.log_filter;
        for (l, &x) in self.log_row.iter_mut().zip(e) {
            *l = x.ln();
        }
        self.steps += 1;
        let log_c = f.step_unchecked(hmm, &self.log_row);
        self.log_c = log_c;
        if f.is_impossible() {
            self.dead = true;
            return 0.0;
        }
        let floor = FLOOR.ln();
        if f.log_alpha.iter().all(|&l| l == f64::NEG_INFINITY || l >= floor) {
            // Every state is representable again: back to the linear pass.
            let n = self.pred.len();
            self.buf[self.pad..self.pad + n].copy_from_slice(&f.post);
            let ll = f.log_likelihood();
            for &i in &self.tiny {
                self.tiny_log[i] = f64::NEG_INFINITY;
            }
            self.tiny.clear();
            self.log_scale = ll;
            self.scale = 1.0;
            self.log_mode = false;
        }
        log_c.exp()
    }

    /// Accumulates, per destination j, log Σ_{tiny i} α̂_i A_ij (online log-sum-exp over the CSR
    /// rows of the tiny states) into acc_max/acc_sum, listing the destinations in `touched`.
    fn tiny_contributions(&mut self, hmm: &Hmm) {
        self.touched.clear();
        for &i in &self.tiny {
            let li = self.tiny_log[i];
            for k in hmm.out_ptr[i]..hmm.out_ptr[i + 1] {
                let j = hmm.out_to[k];
                let v = li + hmm.out_log[k];
                if !self.touched_mark[j] {
                    self.touched_mark[j] = true;
                    self.touched.push(j);
                    self.acc_max[j] = v;
                    self.acc_sum[j] = 1.0;
                } else if v <= self.acc_max[j] {
                    self.acc_sum[j] += exp_or_zero(v - self.acc_max[j]);
                } else {
                    self.acc_sum[j] = self.acc_sum[j] * exp_or_zero(self.acc_max[j] - v) + 1.0;
                    self.acc_max[j] = v;
                }
            }
        }
        // The old tiny values are consumed; the new ones are written by `below_floor`.
        for &i in &self.tiny {
            self.tiny_log[i] = f64::NEG_INFINITY;
        }
    }

    /// The slow part of a step (only when some state is, or becomes, tiny): flush or track states
    /// below the floor, add the tiny contributions (already in acc_max as unnormalised logs t_j),
    /// promote tiny states that rose above the floor.
    #[cold]
    fn below_floor(&mut self, e: &[f64], c: f64, inv: f64) {
        let n = self.pred.len();
        let ln_c = c.ln();
        let pad = self.pad;
        self.next_tiny.clear();
        for (j, &ej) in e.iter().enumerate().take(n) {
            let v = self.buf[pad + j];
            let p = self.pred[j];
            let underflow = v * c < 1e-290 && p > 0.0 && ej > 0.0;
            if (v > 0.0 && v < FLOOR) || underflow {
                self.buf[pad + j] = 0.0;
                match self.mode {
                    Tiny::Flush => self.bound += if v > 0.0 { v } else { f64::MIN_POSITIVE * inv },
                    Tiny::Track => {
                        self.tiny_log[j] = p.ln() + ej.ln() - ln_c;
                        self.next_tiny.push(j);
                    }
                }
            }
        }
        for &j in &self.touched {
            self.touched_mark[j] = false;
            let t = self.acc_max[j];
            if t == f64::NEG_INFINITY {
                continue;
            }
            let a = self.buf[pad + j];
            if a > 0.0 {
                // A live state: add the tiny mass linearly; what underflows is dominated by a.
                let x = exp_or_zero(t - ln_c);
                if x > 0.0 {
                    self.buf[pad + j] = a + x;
                } else {
                    let r = exp_or_zero(t - ln_c - a.ln());
                    self.bound += if r > 0.0 { r } else { f64::MIN_POSITIVE };
                }
            } else {
                let l = self.tiny_log[j];
                let t = t - ln_c;
                let m = l.max(t);
                self.tiny_log[j] = m + (exp_or_zero(l - m) + exp_or_zero(t - m)).ln();
                self.next_tiny.push(j);
            }
        }
        self.next_tiny.sort_unstable();
        self.next_tiny.dedup();
        self.tiny.clear();
        for k in 0..self.next_tiny.len() {
            let j = self.next_tiny[k];
            let l = self.tiny_log[j];
            if l >= FLOOR.ln() {
                self.buf[pad + j] = l.exp();
                self.tiny_log[j] = f64::NEG_INFINITY;
            } else if l > f64::NEG_INFINITY {
                self.tiny.push(j);
            }
        }
        self.ever_tiny |= !self.tiny.is_empty();
    }

    fn clear_tiny(&mut self) {
        for &i in &self.tiny {
            self.tiny_log[i] = f64::NEG_INFINITY;
        }
        for &j in &self.touched {
            self.touched_mark[j] = false;
        }
        self.touched.clear();
        self.tiny.clear();
    }
}

/// A positive double as (mantissa in [0.5, 1), binary exponent): `x = m · 2^k`. Zero is (0, 0).
/// Subnormal inputs are scaled into the normal range first.
#[inline]
fn split(x: f64) -> (f64, i64) {
    if x == 0.0 {
        return (0.0, 0);
    }
    let (x, bias) = if x < f64::MIN_POSITIVE {
        (x * TWO_POW_64, -64)
    } else {
        (x, 0)
    };
    let bits = x.to_bits();
    let e = ((bits >> 52) & 0x7ff) as i64 - 1022;
    let m = f64::from_bits((bits & !(0x7ffu64 << 52)) | (1022u64 << 52));
    (m, e + bias)
}

/// 2⁶⁴.
const TWO_POW_64: f64 = 18_446_744_073_709_551_616.0;

/// 2^d for −1022 ≤ d ≤ 0; 0 below (a term that far below the largest cannot change a double sum).
#[inline]
fn pow2_down(d: i64) -> f64 {
    if d < -1022 {
        0.0
    } else {
        f64::from_bits(((1023 + d) as u64) << 52)
    }
}

impl Hmm {
    /// log p(o_1..T) over a band of diagonals in extended-range arithmetic: every α_t,j is kept as
    /// its own mantissa and binary exponent, so no state is ever lost below the floating-point
    /// range (the exactness of the log-space recursion) and no `exp` or `ln` is taken per element
    /// (the speed of the scaled pass). Each step sums a state's incoming terms aligned to the
    /// largest one's exponent by a power of two; a term more than 2¹⁰²² below it is dropped —
    /// it could not change the sum's double. Relative rounding per step is that of a double
    /// multiply-add, as in the other paths. `emissions` are linear and checked; the model is
    /// `linear_ok` (its non-zero probabilities ≥ 1e-20, so no aligned sum is subnormal) and its
    /// kernel is [`Kernel::Banded`]. Returns `-inf` for an impossible sequence.
    pub(crate) fn forward_banded_extended(&self, emissions: &[f64], scratch: &mut ExtendedScratch) -> f64 {
        let Kernel::Banded { offsets, diags } = &self.kernel else {
            unreachable!("forward_banded_extended on a kernel that is not a band")
        };
        let n = self.n;
        scratch.resize(n);
        let ExtendedScratch { m, k, top, sum } = scratch;
        for j in 0..n {
            let (me, ke) = split(emissions[j]);
            let (ms, ks) = split(self.start_lin[j]);
            let (mm, km) = split(ms * me);
            m[j] = mm;
            k[j] = if mm == 0.0 { ZERO_EXP } else { ks + ke + km };
        }
        // Each diagonal's destinations a..b (its sources are a − o..b − o).
        let range = |o: isize| {
            let a = o.max(0) as usize;
            let b = (n as isize + o.min(0)) as usize;
            (a, b, (a as isize - o) as usize)
        };
        for e in emissions.chunks_exact(n).skip(1) {
            // The largest exponent among each state's incoming terms (a zero transition or a zero
            // α is no term: its exponent reads ZERO_EXP).
            top.fill(ZERO_EXP);
            for (&o, diag) in offsets.iter().zip(diags.chunks_exact(n)) {
                let (a, b, src) = range(o);
                for ((t, &d), &ki) in top[a..b].iter_mut().zip(&diag[a..b]).zip(&k[src..src + b - a]) {
                    *t = (*t).max(if d > 0.0 { ki } else { ZERO_EXP });
                }
            }
            sum.fill(0.0);
            for (&o, diag) in offsets.iter().zip(diags.chunks_exact(n)) {
                let (a, b, src) = range(o);
                let len = b - a;
                for (((s, &d), (&mi, &ki)), &t) in sum[a..b]
                    .iter_mut()
                    .zip(&diag[a..b])
                    .zip(m[src..src + len].iter().zip(&k[src..src + len]))
                    .zip(&top[a..b])
                {
                    *s += mi * d * pow2_down(ki - t);
                }
            }
            let mut any = false;
            for (((mj, kj), (&sj, &tj)), &ej) in m.iter_mut().zip(k.iter_mut()).zip(sum.iter().zip(top.iter())).zip(e) {
                // An aligned sum is at least half the smallest non-zero transition (≥ 1e-20): times
                // an emission above 1e-250 it stays a normal double, and one split suffices.
                let (ms, ks) = if ej >= 1e-250 {
                    split(sj * ej)
                } else {
                    let (me, ke) = split(ej);
                    let (ms, ks) = split(sj * me);
                    (ms, ks + ke)
                };
                *mj = ms;
                *kj = if ms == 0.0 { ZERO_EXP } else { tj + ks };
                any |= ms != 0.0;
            }
            if !any {
                return f64::NEG_INFINITY;
            }
        }
        let Some(top) = k.iter().copied().filter(|&x| x != ZERO_EXP).max() else {
            return f64::NEG_INFINITY;
        };
        let sum: f64 = m.iter().zip(k.iter()).map(|(&m, &k)| m * pow2_down(k - top)).sum();
        sum.ln() + top as f64 * std::f64::consts::LN_2
    }
}

/// The exponent of a zero α (or of no term): far below every real one, so that it never is the
/// largest and its power of two is 0.
const ZERO_EXP: i64 = i64::MIN / 4;

/// Working vectors of [`Hmm::forward_banded_extended`] (mantissas and exponents of α, and per state the
/// largest incoming exponent and the aligned sum).
#[derive(Debug, Clone, Default)]
pub(crate) struct ExtendedScratch {
    m: Vec<f64>,
    k: Vec<i64>,
    top: Vec<i64>,
    sum: Vec<f64>,
}

impl ExtendedScratch {
    fn resize(&mut self, n: usize) {
        for v in [&mut self.m, &mut self.sum] {
            v.clear();
            v.resize(n, 0.0);
        }
        for v in [&mut self.k, &mut self.top] {
            v.clear();
            v.resize(n, 0);
        }
    }
}

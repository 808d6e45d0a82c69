//! The ranked composition C_k ◁ … ◁ C₁ as a quadratic programme with joint position and velocity limits.
//!
//! [`ControlStack::tick`] composes its levels by the pseudoinverse law (3.5–3.7),
//! Δu_ref = Σₖ N₁…ₖ₋₁ (−κₖ dt Jₖ† eₖ). Velocity limits it can only meet by scaling the whole step, and
//! position limits by clamping (stop the joint at its limit, drop its column, recompose), which bends
//! the superior task off the direction the law chose whenever the remaining joints cannot realise it.
//! [`QpComposer`] instead asks, every tick, for the step closest to Δu_ref that keeps each joint inside
//! its position and velocity limits while moving the superior task along *exactly the direction* the
//! pseudoinverse law chose — as far along it as the limits allow, and reports when that is nowhere
//! ([`QpStatus::Stuck`]). This is the task-scaling idea of Drake's `DoDifferentialInverseKinematics` (a
//! scale α ∈ [0, 1] on the commanded task velocity; statuses found / stuck), carried over to the control
//! basis. Build the stack with `clamp_position_limits = false`: the QP replaces the clamping.
//!
//! With J₁ the Jacobian of the first active level, d₁ = J₁ Δu_ref the task motion it asks for, and
//! per-joint bounds lo ≤ Δu ≤ hi (below), the step solves, lexicographically,
//!
//! 1. α* = max α   s.t.  J₁ Δu = α d₁,  lo ≤ Δu ≤ hi,  0 ≤ α ≤ 1        (an LP)
//! 2. min ½‖Δu − Δu_ref‖²   s.t.  J₁ Δu = α d₁,  lo ≤ Δu ≤ hi,  α ∈ A      (a QP)
//!
//! where A = {1} when α* ≥ 1 − 10⁻⁸ (the whole of d₁ is possible: fixed exactly, so a limit the null
//! space can absorb still reports α = 1), and A = [α* − 10⁻⁷, 1] otherwise, with a small linear pull
//! −10 α added to the objective. The 10⁻⁷ of slack absorbs the LP's tolerance and keeps stage 2's
//! feasible set from being too thin for an interior-point method; the pull makes the upper end of α's
//! interval a non-degenerate active bound. With a 10⁻⁹ slack and no pull, 17 of the 185,000 stage-2
//! solves of the random-run test hit the iteration limit; with these, none does.
//!
//! Two solves rather than Drake's single weighted objective (−100 α + a null-space cost): a linear
//! weight on α is an exact penalty only when it exceeds the multiplier of the second objective, which
//! has no bound near singular configurations, so a weighted solve can silently trade the superior task
//! for the inferior ones. The lexicographic form never does, and it needs no weight to tune.
//!
//! **Agreement.** When Δu_ref already respects every bound, it is feasible with α = 1 and makes the
//! second objective zero, so it *is* the solution: the QP reproduces the pseudoinverse law exactly.
//! [`QpSettings::skip_when_feasible`] (default on) returns Δu_ref without calling the solver in that
//! case; the tests check the solver path too, to 10⁻⁶.
//!
//! **Inferior levels** are in Δu_ref already, through their null-space projections. Among the steps
//! that realise α* d₁ the second stage keeps the one nearest Δu_ref in joint space, so they survive as
//! far as the limits allow. (A strict hierarchy over inferior levels too — one more solve per level,
//! Kanoun/Escande style — would reproduce the law in the same way; it is not needed for a
//! manipulability or joint-limit level, whose J = I makes joint-space proximity the natural metric.)
//! Since J₁ Δu = α d₁ fixes the row-space part of Δu to α times that of Δu_ref, the proximity term is
//! Drake's null-space cost plus ½(1 − α)² times the squared row-space part of Δu_ref.
//!
//! **Bounds.** With q the current joint value, `lower`/`upper` its position limits and v its velocity
//! limit, lo = max(lower − q, −v dt) and hi = min(upper − q, v dt), infinite sides dropped. If q is
//! already outside its range (a plant that overshot, a start configuration off the limits) the bound on
//! that side is relaxed to 0: the joint may stay or move back, never further out. Hence lo ≤ 0 ≤ hi
//! always, (Δu, α) = (0, 0) is always feasible, and "infeasible" can only come from numerical failure.
//! The returned step is finally clamped into [lo, hi], so interior-point tolerances cannot accumulate
//! into a limit violation over many ticks.
//!
//! **Conditioning.** The problem is solved in units of ‖Δu_ref‖∞ (so the data are O(1) whatever dt and
//! the gains), with the equality written on an orthonormal basis of J₁'s row space (equivalent to
//! J₁ Δu = α d₁ because d₁ lies in J₁'s range, and free of the dependent rows that a 6-row task on a
//! short chain or a damped singular J₁ would bring). Bounds farther than 10³ step units are capped
//! there; that only tightens them, and only against steps a thousand times larger than the one asked for.
//!
//! Clarabel allocates when a solver is built, so a tick that calls it is not allocation-free, unlike
//! [`ControlStack::tick`]; the composer's own buffers are reused, and a tick in which no limit binds
//! (Δu_ref returned as is) calls no solver and allocates nothing.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, SupportedConeT,
    ZeroConeT,
};
use nalgebra::DVector;

use crate::chain::{Chain, ChainState};
use crate::controller::ControlStack;
use crate::error::{CbError, check_finite};
use crate::linalg::RowSpaceBasis;

/// Bounds farther than this many units of ‖Δu_ref‖∞ are capped (see the module docs).
const BOUND_CAP: f64 = 1e3;
/// How far below the first stage's α* the second stage may go: absorbs the LP's tolerance, and keeps the
/// second stage's feasible set from being too thin for the interior-point method.
const ALPHA_SLACK: f64 = 1e-7;
/// Linear pull −μα in the proximity stage: makes the (implicit) upper end of α's interval a
/// non-degenerate active bound, which the interior-point method needs to converge there; its effect on α
/// is bounded by [`ALPHA_SLACK`].
const ALPHA_PULL: f64 = 10.0;
/// A first-stage α* this close to 1 means "the whole of d₁": the second stage then fixes α = 1 exactly.
const ALPHA_SNAP: f64 = 1e-8;
/// d₁ (in step units) below this is "the superior task asks for no motion".
const IDLE_TOL: f64 = 1e-12;

/// Settings of [`QpComposer`], validated once by [`QpComposer::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QpSettings {
    /// Clarabel's absolute and relative gap and feasibility tolerances (the problem is O(1), see the
    /// module docs). 10⁻¹⁰ keeps the solver path within 10⁻⁶ of the pseudoinverse law.
    pub tolerance: f64,
    /// Interior-point iteration limit per solve.
    pub max_iterations: u32,
    /// α at or below this, with a superior task that asks to move, is [`QpStatus::Stuck`]. Drake reports
    /// stuck below 0.01; the default 10⁻⁶ reserves it for "cannot move along the direction at all".
    pub stuck_alpha: f64,
    /// α at or above 1 − this is [`QpStatus::Found`]. α = 1 exactly whenever the first stage finds the
    /// whole of d₁ possible; otherwise stage 2 may end up to 10⁻⁷ below α*, hence the default 10⁻⁶.
    pub found_tolerance: f64,
    /// Return Δu_ref without solving when it already respects every bound (it is then the exact optimum).
    pub skip_when_feasible: bool,
}

impl Default for QpSettings {
    fn default() -> Self {
        QpSettings {
            tolerance: 1e-10,
            max_iterations: 100,
            stuck_alpha: 1e-6,
            found_tolerance: 1e-6,
            skip_when_feasible: true,
        }
    }
}

impl QpSettings {
    /// Checks the settings once, at construction.
    pub fn validate(&self) -> Result<(), CbError> {
        let bad = |name, value, expected| Err(CbError::InvalidParameter { name, value, expected });
        if !(self.tolerance > 0.0 && self.tolerance <= 1e-3) {
            return bad("tolerance", self.tolerance, "a positive number <= 1e-3");
        }
        if self.max_iterations == 0 {
            return bad("max_iterations", 0.0, "at least one iteration");
        }
        if !(0.0..0.5).contains(&self.stuck_alpha) {
            return bad("stuck_alpha", self.stuck_alpha, "a number in [0, 0.5)");
        }
        if !(0.0..0.5).contains(&self.found_tolerance) {
            return bad("found_tolerance", self.found_tolerance, "a number in [0, 0.5)");
        }
        Ok(())
    }
}

/// What one QP tick achieved. These are outcomes, not errors; every status comes with a step that
/// respects the limits (zero when the solver failed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum QpStatus {
    /// The superior task moves exactly as the pseudoinverse law asks (α = 1).
    Found,
    /// The superior task moves along the asked direction, scaled by α ∈ (0, 1) by the limits.
    Scaled {
        /// The achieved fraction of d₁.
        alpha: f64,
    },
    /// The superior task asks to move but the limits allow no motion along its direction (α ≈ 0);
    /// the step may still move inferior levels within the superior task's null space.
    Stuck,
    /// Clarabel reported the problem infeasible (only possible numerically: Δu = 0 is always feasible).
    Infeasible,
    /// Clarabel stopped without a solution (iteration limit, numerical error); the step is zero.
    NotConverged,
}

/// The report of one [`QpComposer::solve`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QpReport {
    /// Outcome.
    pub status: QpStatus,
    /// Achieved fraction α ∈ [0, 1] of the superior task's motion d₁ (1 when it asks for none).
    pub alpha: f64,
    /// Clarabel solves run: 0 when Δu_ref was returned as is, 1 when the superior task asks for no
    /// motion (or the first stage failed), 2 otherwise.
    pub solves: u32,
    /// Interior-point iterations, summed over the solves.
    pub iterations: u32,
    /// Clarabel's own set-up and solve time, summed over the solves (s).
    pub solver_secs: f64,
    /// The second (proximity) stage failed and the step is the first stage's: it respects the limits
    /// and realises α d₁, but ignores the inferior levels.
    pub fallback: bool,
}

impl QpReport {
    fn new() -> Self {
        QpReport {
            status: QpStatus::Found,
            alpha: 1.0,
            solves: 0,
            iterations: 0,
            solver_secs: 0.0,
            fallback: false,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Stage {
    /// Stage 1: maximise α.
    MaxAlpha,
    /// Stage 2: nearest to Δu_ref with α ≥ `alpha_lo`.
    Proximity { alpha_lo: f64 },
    /// Stage 2: nearest to Δu_ref with α = 1.
    ProximityFull,
}

/// Composes a [`ControlStack`]'s levels under joint position and velocity limits by two small
/// Clarabel programmes per tick (see the module docs). Build once per chain; reuse every tick.
#[derive(Debug, Clone)]
pub struct QpComposer {
    settings: QpSettings,
    clarabel: DefaultSettings<f64>,
    n: usize,
    /// Δu_ref: the stack's composed step before any velocity scaling.
    reference: DVector<f64>,
    /// Step bounds of the last tick (radians or metres per tick).
    lo: Vec<f64>,
    hi: Vec<f64>,
    basis: RowSpaceBasis,
    v: DVector<f64>,
    /// Orthonormal basis of J₁'s row space in its first `rank` columns.
    /// Orthonormal basis of the superior task's rows (dependent rows dropped).
    rows: RowSpaceBasis,
    rank: usize,
    /// Problem data in step units.
    y_ref: Vec<f64>,
    y_lo: Vec<f64>,
    y_hi: Vec<f64>,
    c: Vec<f64>,
    x: Vec<f64>,
    stage_one: Vec<f64>,
    p: CscMatrix<f64>,
    a: CscMatrix<f64>,
    q: Vec<f64>,
    b: Vec<f64>,
    cones: Vec<SupportedConeT<f64>>,
}

impl QpComposer {
    /// A composer for `chain` (sizes its buffers; validates `settings`).
    pub fn new(chain: &Chain, settings: QpSettings) -> Result<Self, CbError> {
        settings.validate()?;
        let clarabel = DefaultSettingsBuilder::default()
            .verbose(false)
            .max_iter(settings.max_iterations)
            .tol_gap_abs(settings.tolerance)
            .tol_gap_rel(settings.tolerance)
            .tol_feas(settings.tolerance)
            .build()
            .map_err(|e| CbError::Solver(e.to_string()))?;
        let n = chain.dof();
        let vars = n + 1;
        // Worst case: n equality rows, two bounds per joint, two on α.
        let max_rows = 3 * n + 2;
        let max_nnz = n * n + 2 * n + n + 2;
        let mut a = CscMatrix::zeros((max_rows, vars));
        a.rowval.reserve(max_nnz);
        a.nzval.reserve(max_nnz);
        let mut p = CscMatrix::zeros((vars, vars));
        p.rowval.reserve(vars);
        p.nzval.reserve(vars);
        Ok(QpComposer {
            settings,
            clarabel,
            n,
            reference: DVector::zeros(n),
            lo: vec![0.0; n],
            hi: vec![0.0; n],
            basis: RowSpaceBasis::new(n),
            v: DVector::zeros(n),
            rows: RowSpaceBasis::new(n),
            rank: 0,
            y_ref: vec![0.0; n],
            y_lo: vec![0.0; n],
            y_hi: vec![0.0; n],
            c: vec![0.0; n],
            x: vec![0.0; vars],
            stage_one: vec![0.0; n],
            p,
            a,
            q: Vec::with_capacity(vars),
            b: Vec::with_capacity(max_rows),
            cones: Vec::with_capacity(2),
        })
    }

    /// The settings.
    pub fn settings(&self) -> &QpSettings {
        &self.settings
    }

    /// Δu_ref of the last solve: the stack's pseudoinverse composition before velocity scaling.
    pub fn reference(&self) -> &DVector<f64> {
        &self.reference
    }

    /// The per-joint step bounds (lo, hi) of the last solve; lo ≤ 0 ≤ hi, ±∞ where a joint has neither a
    /// position nor a velocity limit on that side.
    pub fn bounds(&self) -> (&[f64], &[f64]) {
        (&self.lo, &self.hi)
    }

    /// One QP tick. `stack` must just have run [`ControlStack::tick`] on `state` with the same `dt_secs`,
    /// and be built with `clamp_position_limits = false` (the QP replaces that clamping; its velocity
    /// scaling is ignored, the QP starts from the unscaled law). The step Δu (joint increments for this
    /// tick) is written into `out`.
    ///
    /// `Err` only for malformed input (sizes that do not fit `chain`, non-finite q, dt ≤ 0) or a problem
    /// Clarabel refuses to set up; limits that bind, or a solver that fails, are [`QpStatus`]es.
    pub fn solve(
        &mut self,
        chain: &Chain,
        state: &ChainState,
        stack: &ControlStack,
        dt_secs: f64,
        out: &mut DVector<f64>,
    ) -> Result<QpReport, CbError> {
        self.check_inputs(chain, state, stack, dt_secs, out)?;
        let n = self.n;
        let first = self.compose_reference(stack);
        self.compute_bounds(chain, state.q().as_slice(), dt_secs);
        let mut report = QpReport::new();

        let scale = self.reference.amax();
        if scale == 0.0 {
            out.fill(0.0);
            return Ok(report);
        }
        if self.settings.skip_when_feasible && self.reference_within_bounds() {
            out.copy_from(&self.reference);
            return Ok(report);
        }

        for j in 0..n {
            self.y_ref[j] = self.reference[j] / scale;
            self.y_lo[j] = (self.lo[j] / scale).max(-BOUND_CAP);
            self.y_hi[j] = (self.hi[j] / scale).min(BOUND_CAP);
        }
        self.rank = match first {
            Some(k) => {
                let buf = &stack.buffers()[k];
                self.rows.clear();
                self.rows.add_first_rows(&buf.jacobian, buf.rows);
                self.rows.rank()
            }
            None => 0,
        };
        let mut c_norm_sq = 0.0;
        for bi in 0..self.rank {
            let cb: f64 = (0..n).map(|j| self.rows.vector(bi)[j] * self.y_ref[j]).sum();
            self.c[bi] = cb;
            c_norm_sq += cb * cb;
        }
        let primary_moves = c_norm_sq.sqrt() > IDLE_TOL;

        // Stage 1: the largest fraction of d₁ the limits allow.
        let alpha_star = if primary_moves {
            self.assemble(Stage::MaxAlpha);
            match self.run(&mut report)? {
                Ok(()) => {
                    self.stage_one.copy_from_slice(&self.x[..n]);
                    self.x[n].clamp(0.0, 1.0)
                }
                Err(status) => {
                    out.fill(0.0);
                    report.status = status;
                    report.alpha = 0.0;
                    return Ok(report);
                }
            }
        } else {
            1.0
        };

        // Stage 2: nearest to Δu_ref among the steps that keep α*.
        let stage = if !primary_moves {
            Stage::Proximity { alpha_lo: 0.0 }
        } else if alpha_star >= 1.0 - ALPHA_SNAP {
            Stage::ProximityFull
        } else {
            Stage::Proximity {
                alpha_lo: (alpha_star - ALPHA_SLACK).max(0.0),
            }
        };
        self.assemble(stage);
        let alpha = match self.run(&mut report)? {
            Ok(()) => match stage {
                Stage::Proximity { .. } if primary_moves => self.x[n].clamp(0.0, 1.0),
                _ => 1.0,
            },
            Err(_) => {
                report.fallback = true;
                if primary_moves {
                    self.x[..n].copy_from_slice(&self.stage_one);
                } else {
                    // Δu = 0 keeps the idle superior task still and respects every bound.
                    self.x[..n].fill(0.0);
                }
                alpha_star
            }
        };
        for j in 0..n {
            out[j] = (self.x[j] * scale).clamp(self.lo[j], self.hi[j]);
        }
        report.alpha = alpha;
        report.status = if !primary_moves || alpha >= 1.0 - self.settings.found_tolerance {
            QpStatus::Found
        } else if alpha <= self.settings.stuck_alpha {
            QpStatus::Stuck
        } else {
            QpStatus::Scaled { alpha }
        };
        Ok(report)
    }

    fn check_inputs(
        &self,
        chain: &Chain,
        state: &ChainState,
        stack: &ControlStack,
        dt_secs: f64,
        out: &DVector<f64>,
    ) -> Result<(), CbError> {
        let n = self.n;
        let mismatch = |what: &str, got: usize| {
            Err(CbError::DimensionMismatch {
                what: what.to_string(),
                expected: n,
                got,
            })
        };
        if chain.dof() != n {
            return mismatch("QP composer: chain degrees of freedom", chain.dof());
        }
        if state.q().len() != n {
            return mismatch("QP composer: joint values of the state", state.q().len());
        }
        if out.len() != n {
            return mismatch("QP composer: output step", out.len());
        }
        for (buf, step) in stack.buffers().iter().zip(stack.level_steps()) {
            if buf.jacobian.ncols() != n {
                return mismatch("QP composer: columns of a stack level's Jacobian", buf.jacobian.ncols());
            }
            if step.len() != n {
                return mismatch("QP composer: a stack level's step", step.len());
            }
        }
        if stack.settings().clamp_position_limits {
            // Clamping zeroes the clamped joints' Jacobian columns in the stack's buffers: the QP would
            // then neither see nor constrain what those joints do to the superior task.
            return Err(CbError::InvalidParameter {
                name: "clamp_position_limits",
                value: 1.0,
                expected: "false: the QP composer needs the unclamped pseudoinverse law and handles position limits itself",
            });
        }
        if !(dt_secs > 0.0 && dt_secs.is_finite()) {
            return Err(CbError::InvalidParameter {
                name: "dt_secs",
                value: dt_secs,
                expected: "a positive finite time step (s)",
            });
        }
        check_finite("QP composer: joint values", state.q().as_slice())
    }

    /// Δu_ref = Σₖ N₁…ₖ₋₁ (level step k), recomputed from the stack's per-level steps with the same
    /// operations in the same order as [`ControlStack::tick`] (so it is bit-identical to the tick's step
    /// when no velocity scaling happened). Returns the index of the first active level.
    fn compose_reference(&mut self, stack: &ControlStack) -> Option<usize> {
        self.reference.fill(0.0);
        self.basis.clear();
        let mut first = None;
        for (k, ((buf, step), phi)) in stack
            .buffers()
            .iter()
            .zip(stack.level_steps())
            .zip(stack.potentials())
            .enumerate()
        {
            if phi.is_none() || buf.rows == 0 {
                continue;
            }
            self.v.copy_from(step);
            self.basis.project_out(&mut self.v);
            self.reference += &self.v;
            // As the tick does: the first level's rows from its own factor when it has one.
            let from_factor = !buf.identity
                && self
                    .basis
                    .start_from_factor(&stack.dls_workspaces()[k], &buf.jacobian, buf.rows);
            if !from_factor {
                self.basis.add_first_rows(&buf.jacobian, buf.rows);
            }
            first.get_or_insert(k);
        }
        first
    }

    fn compute_bounds(&mut self, chain: &Chain, q: &[f64], dt_secs: f64) {
        for (j, dof) in chain.dofs().iter().enumerate() {
            let l = dof.limits;
            let reach = l.velocity * dt_secs;
            // NaN-free: every term is finite or ±∞, never ∞ − ∞ (q is finite).
            let lo = (l.lower - q[j]).max(-reach);
            let hi = (l.upper - q[j]).min(reach);
            // Outside the range already: may stay or move back, never further out.
            self.lo[j] = lo.min(0.0);
            self.hi[j] = hi.max(0.0);
        }
    }

    fn reference_within_bounds(&self) -> bool {
        self.reference
            .iter()
            .zip(self.lo.iter().zip(&self.hi))
            .all(|(d, (lo, hi))| *lo <= *d && *d <= *hi)
    }

    /// Writes P, q, A, b and the cones of one stage. Variables x = (y, α) with y = Δu / ‖Δu_ref‖∞.
    /// Rows: [Vᵀ  −c] x = 0 (zero cone, c = Vᵀ y_ref; with α = 1 also in the zero cone when it is fixed),
    /// then y_j ≤ hi_j, −y_j ≤ −lo_j (finite sides only), and α ≤ 1, −α ≤ −α_lo when α is free.
    fn assemble(&mut self, stage: Stage) {
        let n = self.n;
        let r = self.rank;

        // P (upper triangle): I on y for the proximity stage, nothing for the LP.
        let p = &mut self.p;
        p.colptr.clear();
        p.rowval.clear();
        p.nzval.clear();
        p.colptr.push(0);
        for j in 0..=n {
            if stage != Stage::MaxAlpha && j < n {
                p.rowval.push(j);
                p.nzval.push(1.0);
            }
            p.colptr.push(p.rowval.len());
        }

        self.q.clear();
        match stage {
            Stage::MaxAlpha => {
                self.q.extend(std::iter::repeat_n(0.0, n));
                self.q.push(-1.0);
            }
            Stage::Proximity { .. } | Stage::ProximityFull => {
                self.q.extend(self.y_ref.iter().map(|v| -v));
                self.q.push(if stage == Stage::ProximityFull {
                    0.0
                } else {
                    -ALPHA_PULL
                });
            }
        }

        // Equality rows first (the zero cone): the r task rows, and α = 1 when it is fixed.
        let fixed = stage == Stage::ProximityFull;
        let eq = r + usize::from(fixed);
        self.b.clear();
        self.b.extend(std::iter::repeat_n(0.0, r));
        if fixed {
            self.b.push(1.0);
        }
        let a = &mut self.a;
        a.colptr.clear();
        a.rowval.clear();
        a.nzval.clear();
        a.colptr.push(0);
        let mut row = eq;
        for j in 0..n {
            for bi in 0..r {
                a.rowval.push(bi);
                a.nzval.push(self.rows.vector(bi)[j]);
            }
            if self.y_hi[j].is_finite() {
                a.rowval.push(row);
                a.nzval.push(1.0);
                self.b.push(self.y_hi[j]);
                row += 1;
            }
            if self.y_lo[j].is_finite() {
                a.rowval.push(row);
                a.nzval.push(-1.0);
                self.b.push(-self.y_lo[j]);
                row += 1;
            }
            a.colptr.push(a.rowval.len());
        }
        for bi in 0..r {
            a.rowval.push(bi);
            a.nzval.push(-self.c[bi]);
        }
        if fixed {
            a.rowval.push(r);
            a.nzval.push(1.0);
        } else {
            let alpha_lo = match stage {
                Stage::Proximity { alpha_lo } => alpha_lo,
                _ => 0.0,
            };
            a.rowval.push(row);
            a.nzval.push(1.0);
            self.b.push(1.0);
            a.rowval.push(row + 1);
            a.nzval.push(-1.0);
            self.b.push(-alpha_lo);
            row += 2;
        }
        a.colptr.push(a.rowval.len());
        a.m = row;
        a.n = n + 1;

        self.cones.clear();
        if eq > 0 {
            self.cones.push(ZeroConeT(eq));
        }
        if row > eq {
            self.cones.push(NonnegativeConeT(row - eq));
        }
    }

    /// Runs Clarabel on the assembled stage; the solution lands in `self.x`. The outer `Result` is a
    /// set-up failure (a bug or malformed data), the inner one the solve's outcome.
    fn run(&mut self, report: &mut QpReport) -> Result<Result<(), QpStatus>, CbError> {
        let mut solver = DefaultSolver::new(&self.p, &self.q, &self.a, &self.b, &self.cones, self.clarabel.clone())
            .map_err(|e| CbError::Solver(e.to_string()))?;
        solver.solve();
        let sol = &solver.solution;
        report.solves += 1;
        report.iterations += sol.iterations;
        report.solver_secs += sol.solve_time;
        Ok(match sol.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => {
                self.x.copy_from_slice(&sol.x);
                Ok(())
            }
            SolverStatus::PrimalInfeasible
            | SolverStatus::AlmostPrimalInfeasible
            | SolverStatus::DualInfeasible
            | SolverStatus::AlmostDualInfeasible => Err(QpStatus::Infeasible),
            _ => Err(QpStatus::NotConverged),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::controller::StackSettings;
    use crate::controller::{Controller, FeedbackElement, MotorUnits, Operator, Potential, Reference, Sensor};
    use crate::math::Vec3;
    use crate::model::RobotModel;

    /// A planar two-link arm (links 1 m and 0.5 m) with joint limits ±1 rad and velocity limit 2 rad/s.
    fn planar() -> Chain {
        let urdf = r#"<robot name="p"><link name="a"/><link name="b"/><link name="c"/>
          <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
            <limit lower="-1" upper="1" effort="1" velocity="2"/></joint>
          <joint name="j2" type="revolute"><parent link="b"/><child link="c"/><origin xyz="1 0 0"/>
            <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="2"/></joint></robot>"#;
        let model = RobotModel::from_urdf_str(urdf).unwrap();
        Chain::new(&model, "a", "c").unwrap()
    }

    fn reach_position(chain: &Chain, gain: f64) -> Controller {
        Controller::new(
            "reach",
            FeedbackElement {
                sensor: Sensor::LinkPosition {
                    link: chain.links().len() - 1,
                },
                operator: Operator::Identity,
            },
            Potential::Quadratic {
                orientation_weight: 1.0,
            },
            MotorUnits::all(chain.dof()),
            gain,
        )
        .unwrap()
    }

    #[test]
    fn bounds_outside_the_range_allow_only_motion_back() {
        let chain = planar();
        let mut qp = QpComposer::new(&chain, QpSettings::default()).unwrap();
        // j1 0.5 rad above its upper limit, j2 inside near its lower limit.
        qp.compute_bounds(&chain, &[1.5, -0.99], 0.01);
        let (lo, hi) = qp.bounds();
        assert_eq!(hi[0], 0.0);
        assert_eq!(lo[0], -0.02);
        assert!((lo[1] + 0.01).abs() < 1e-12);
        assert_eq!(hi[1], 0.02);
    }

    #[test]
    fn non_redundant_chain_scales_the_whole_step_like_the_stack() {
        // Two joints, a planar position task of rank 2: J₁ Δu = α d₁ forces Δu = α Δu_ref, so with only
        // velocity limits binding α must equal the stack's uniform scaling factor.
        let chain = planar();
        let mut state = chain.new_state();
        state.set_q(&chain, &[0.3, 0.6]).unwrap();
        let settings = StackSettings {
            respect_velocity_limits: false,
            clamp_position_limits: false,
            ..StackSettings::default()
        };
        let mut stack = ControlStack::new(&chain, vec![reach_position(&chain, 20.0)], settings).unwrap();
        stack
            .set_reference(&chain, 0, Reference::Position(Vec3::new(0.9, 0.7, 0.0)))
            .unwrap();
        stack.tick(&chain, &mut state, &[], 0.01);
        let du_ref = stack.delta_u().clone();
        let worst = du_ref.iter().map(|d| d.abs() / 0.02).fold(0.0, f64::max);
        assert!(worst > 1.0, "the test needs a step beyond the velocity limit ({worst})");
        let mut qp = QpComposer::new(&chain, QpSettings::default()).unwrap();
        let mut du = DVector::zeros(2);
        let report = qp.solve(&chain, &state, &stack, 0.01, &mut du).unwrap();
        assert_eq!(report.solves, 2);
        assert!(
            (report.alpha - 1.0 / worst).abs() < 1e-7,
            "{} vs {}",
            report.alpha,
            1.0 / worst
        );
        assert!((du - du_ref / worst).amax() < 1e-9);
    }
}

//! Allocation-free dense kernels for the control tick: the damped least-squares pseudoinverse and an
//! orthonormal basis of the row space of stacked Jacobians (for exact null-space projection).
//!
//! Buffers are sized once at construction for the largest task dimension and number of motor units;
//! the per-tick calls never allocate.

use nalgebra::{DMatrix, DVector};

/// Settings of the damped least-squares pseudoinverse.
///
/// Damping follows Maciejewski & Klein / Chiaverini: λ² = λ²_max (1 − (σ_min/ε)²) when the smallest
/// singular value σ_min of J falls below ε, and 0 otherwise. Far from singularities the law is the exact
/// Moore–Penrose solution (3.4); near them the step stays bounded by |e| / (2λ_max).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DlsSettings {
    /// Largest damping factor λ_max (same units as J's singular values).
    pub lambda_max: f64,
    /// Singular-value threshold ε below which damping is switched on.
    pub sigma_threshold: f64,
}

impl Default for DlsSettings {
    fn default() -> Self {
        DlsSettings {
            lambda_max: 0.05,
            sigma_threshold: 0.05,
        }
    }
}

/// What one damped solve did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DlsInfo {
    /// Estimated smallest singular value of J.
    pub sigma_min: f64,
    /// Damping λ² actually applied.
    pub lambda_sq: f64,
}

/// Workspace for `x = J†_λ e` with J of size m×n (m ≤ `max_rows`).
#[derive(Debug, Clone)]
pub struct DampedLeastSquares {
    settings: DlsSettings,
    a: Vec<f64>,
    chol: Vec<f64>,
    y: Vec<f64>,
    w: Vec<f64>,
    /// Rows of the previous solve whose smallest-eigenvector estimate `y` is kept (0 = none).
    warm_rows: usize,
}

impl DampedLeastSquares {
    /// A workspace for tasks of up to `max_rows` rows.
    pub fn new(max_rows: usize, settings: DlsSettings) -> Self {
        DampedLeastSquares {
            settings,
            a: vec![0.0; max_rows * max_rows],
            chol: vec![0.0; max_rows * max_rows],
            y: vec![0.0; max_rows],
            w: vec![0.0; max_rows],
            warm_rows: 0,
        }
    }

    /// The settings.
    pub fn settings(&self) -> DlsSettings {
        self.settings
    }

    /// Largest task dimension this workspace accepts.
    pub fn max_rows(&self) -> usize {
        self.y.len()
    }

    /// `out = J†_λ e = Jᵀ (J Jᵀ + λ² I)⁻¹ e` for the whole of `jac` (m×n).
    pub fn solve(&mut self, jac: &DMatrix<f64>, e: &[f64], out: &mut [f64]) -> DlsInfo {
        self.solve_rows(jac, jac.nrows(), e, out)
    }

    /// `out = J†_λ e` using the first `m` rows of `jac` (a buffer sized for the largest task), `e` of
    /// length ≥ m (first m used), `out` of length n.
    pub fn solve_rows(&mut self, jac: &DMatrix<f64>, m: usize, e: &[f64], out: &mut [f64]) -> DlsInfo {
        let n = jac.ncols();
        debug_assert!(m <= jac.nrows());
        let e = &e[..m];
        assert!(
            m <= self.max_rows(),
            "task has {m} rows, workspace sized for {}",
            self.max_rows()
        );
        debug_assert_eq!(e.len(), m);
        debug_assert_eq!(out.len(), n);
        out.fill(0.0);
        if m == 0 {
            return DlsInfo::default();
        }
        // A = J Jᵀ (column-major m×m).
        let a = &mut self.a[..m * m];
        let rows = jac.nrows();
        let js = jac.as_slice();
        a.fill(0.0);
        for k in 0..n {
            let col = &js[k * rows..k * rows + m];
            for i in 0..m {
                let ci = col[i];
                for j in 0..=i {
                    a[i + j * m] += ci * col[j];
                }
            }
        }
        for i in 0..m {
            for j in 0..i {
                a[j + i * m] = a[i + j * m];
            }
        }
        let scale = (0..m).map(|i| a[i + i * m]).fold(0.0, f64::max);
        let trace: f64 = (0..m).map(|i| a[i + i * m]).sum();
        let chol = &mut self.chol[..m * m];
        chol.copy_from_slice(a);
        let tiny = 1e-14 * scale.max(1e-300);
        for i in 0..m {
            chol[i + i * m] += tiny;
        }
        let DlsSettings {
            lambda_max,
            sigma_threshold,
        } = self.settings;
        let threshold_sq = sigma_threshold * sigma_threshold;
        let factored = cholesky_in_place(chol, m);
        // Cheap certificate first: λ_min ≥ det(A) / (tr(A)/(m−1))^(m−1) (AM–GM on the other
        // eigenvalues); det(A) comes free with the Cholesky factor. Only when it cannot prove
        // σ_min ≥ ε do we estimate σ_min by inverse iteration with a Rayleigh quotient — an estimate that
        // never undershoots and converges in a few steps exactly where it matters, near a singularity
        // (σ_min ≪ σ₂).
        let lower_bound = if factored && m > 1 {
            let det: f64 = (0..m).map(|i| chol[i + i * m] * chol[i + i * m]).product();
            det / (trace / (m - 1) as f64).powi(m as i32 - 1)
        } else if factored {
            a[0]
        } else {
            0.0
        };
        let sigma_min_sq = if lower_bound >= threshold_sq {
            lower_bound
        } else if factored {
            let y = &mut self.y[..m];
            // Warm start: the configuration moves little between ticks, so the previous tick's
            // eigenvector estimate is nearly converged and two iterations refine it.
            let iterations = if self.warm_rows == m { 2 } else { 8 };
            if self.warm_rows != m {
                for (i, yi) in y.iter_mut().enumerate() {
                    *yi = 1.0 + 0.1 * i as f64;
                }
            }
            self.warm_rows = m;
            let mut lam = 0.0;
            for _ in 0..iterations {
                let norm = y.iter().map(|v| v * v).sum::<f64>().sqrt();
                y.iter_mut().for_each(|v| *v /= norm);
                let w = &mut self.w[..m];
                w.copy_from_slice(y);
                cholesky_solve(chol, m, w);
                let ray: f64 = y.iter().zip(w.iter()).map(|(a, b)| a * b).sum();
                lam = 1.0 / ray;
                y.copy_from_slice(w);
            }
            lam.max(0.0)
        } else {
            0.0
        };
        let sigma_min = sigma_min_sq.sqrt();
        let lambda_sq = if sigma_min < sigma_threshold {
            let r = sigma_min / sigma_threshold;
            lambda_max * lambda_max * (1.0 - r * r)
        } else {
            0.0
        };
        if lambda_sq > 0.0 || !factored {
            chol.copy_from_slice(a);
            for i in 0..m {
                chol[i + i * m] += lambda_sq + tiny;
            }
            if !cholesky_in_place(chol, m) {
                // Only reachable with λ_max = 0 at an exact singularity: fall back to full damping so
                // the step stays bounded rather than undefined.
                chol.copy_from_slice(a);
                let d = (lambda_max * lambda_max).max(1e-12 * scale.max(1.0));
                for i in 0..m {
                    chol[i + i * m] += d;
                }
                cholesky_in_place(chol, m);
            }
        }
        let w = &mut self.w[..m];
        w.copy_from_slice(e);
        cholesky_solve(chol, m, w);
        for (k, o) in out.iter_mut().enumerate() {
            let col = &js[k * rows..k * rows + m];
            *o = col.iter().zip(w.iter()).map(|(a, b)| a * b).sum();
        }
        DlsInfo { sigma_min, lambda_sq }
    }
}

/// In-place lower Cholesky factorisation of the column-major m×m matrix `a`; false if not positive definite.
pub(crate) fn cholesky_in_place(a: &mut [f64], m: usize) -> bool {
    for j in 0..m {
        let mut d = a[j + j * m];
        for k in 0..j {
            d -= a[j + k * m] * a[j + k * m];
        }
        if d <= 0.0 || !d.is_finite() {
            return false;
        }
        let d = d.sqrt();
        a[j + j * m] = d;
        for i in j + 1..m {
            let mut s = a[i + j * m];
            for k in 0..j {
                s -= a[i + k * m] * a[j + k * m];
            }
            a[i + j * m] = s / d;
        }
    }
    true
}

/// Solves `L Lᵀ x = b` in place with the factor from [`cholesky_in_place`].
pub(crate) fn cholesky_solve(l: &[f64], m: usize, b: &mut [f64]) {
    for i in 0..m {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i + k * m] * b[k];
        }
        b[i] = s / l[i + i * m];
    }
    for i in (0..m).rev() {
        let mut s = b[i];
        for k in i + 1..m {
            s -= l[k + i * m] * b[k];
        }
        b[i] = s / l[i + i * m];
    }
}

/// An orthonormal basis of the span of the rows of several stacked Jacobians [J₁; J₂; …].
///
/// `N = I − V Vᵀ` is then the exact orthogonal projector onto the null space of the stacked Jacobian,
/// the augmented `N₁…ₖ` of the recursive null-space formulation (3.6–3.7). Building it by (twice
/// re-orthogonalised) Gram–Schmidt is cheaper than `I − J†J` and, unlike a damped pseudoinverse, exact:
/// an inferior objective projected with it cannot move a superior one to first order.
#[derive(Debug, Clone)]
pub struct RowSpaceBasis {
    basis: DMatrix<f64>,
    rank: usize,
    tmp: DVector<f64>,
    /// Rows whose component outside the current span is below `tol` × their norm are dependent.
    tol: f64,
}

impl RowSpaceBasis {
    /// An empty basis in R^n.
    pub fn new(n: usize) -> Self {
        RowSpaceBasis {
            basis: DMatrix::zeros(n, n),
            rank: 0,
            tmp: DVector::zeros(n),
            tol: 1e-10,
        }
    }
    /// Forgets all rows.
    pub fn clear(&mut self) {
        self.rank = 0;
    }
    /// Dimension of the span so far.
    pub fn rank(&self) -> usize {
        self.rank
    }
    /// Ambient dimension n.
    pub fn dim(&self) -> usize {
        self.basis.nrows()
    }

    /// Adds every row of `jac` (m×n) to the span.
    pub fn add_rows(&mut self, jac: &DMatrix<f64>) {
        self.add_first_rows(jac, jac.nrows());
    }

    /// Adds the first `m` rows of `jac` to the span.
    pub fn add_first_rows(&mut self, jac: &DMatrix<f64>, m: usize) {
        let n = self.dim();
        debug_assert_eq!(jac.ncols(), n);
        for r in 0..m {
            if self.rank == n {
                return;
            }
            for k in 0..n {
                self.tmp[k] = jac[(r, k)];
            }
            let norm0 = self.tmp.norm();
            if norm0 == 0.0 || !norm0.is_finite() {
                continue;
            }
            for _ in 0..2 {
                for b in 0..self.rank {
                    let col = self.basis.column(b);
                    let d = col.dot(&self.tmp);
                    self.tmp.axpy(-d, &col, 1.0);
                }
            }
            let norm = self.tmp.norm();
            if norm > self.tol * norm0 {
                self.tmp /= norm;
                self.basis.column_mut(self.rank).copy_from(&self.tmp);
                self.rank += 1;
            }
        }
    }

    /// Basis vector `b` (< rank) of the span, unit length.
    pub fn vector(&self, b: usize) -> nalgebra::DVectorView<'_, f64> {
        debug_assert!(b < self.rank);
        self.basis.column(b)
    }

    /// `v ← (I − V Vᵀ) v`: removes from `v` every component that would move the spanned tasks.
    pub fn project_out(&self, v: &mut DVector<f64>) {
        for b in 0..self.rank {
            let col = self.basis.column(b);
            let d = col.dot(v);
            v.axpy(-d, &col, 1.0);
        }
    }

    /// Writes the projector `N = I − V Vᵀ` (n×n) into `out`.
    pub fn projector(&self, out: &mut DMatrix<f64>) {
        out.fill_with_identity();
        for b in 0..self.rank {
            let col = self.basis.column(b);
            out.ger(-1.0, &col, &col, 1.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dls_equals_pinv_when_well_conditioned() {
        let j = DMatrix::from_row_slice(2, 3, &[1.0, 0.2, 0.0, 0.0, 1.0, 0.5]);
        let e = [0.3, -0.7];
        let mut out = [0.0; 3];
        let mut dls = DampedLeastSquares::new(6, DlsSettings::default());
        let info = dls.solve(&j, &e, &mut out);
        assert_eq!(info.lambda_sq, 0.0);
        let pinv = j.clone().pseudo_inverse(1e-15).unwrap();
        let expect = pinv * DVector::from_row_slice(&e);
        for k in 0..3 {
            assert!((out[k] - expect[k]).abs() < 1e-12);
        }
        // Inverse iteration overestimates σ_min when it is not well separated, which is harmless: damping
        // only matters near singularities, where σ_min ≪ σ₂ and the iteration converges in a few steps.
        let smin = j.clone().svd(false, false).singular_values.min();
        // Far from the threshold the determinant certificate suffices: a lower bound, no iteration.
        assert!(info.sigma_min <= smin + 1e-12 && info.sigma_min >= 0.05);
        let near = DMatrix::from_row_slice(2, 3, &[1.0, 0.2, 0.0, 1.0, 0.2 + 1e-3, 1e-3]);
        let info = dls.solve(&near, &e, &mut out);
        let smin = near.svd(false, false).singular_values.min();
        assert!(
            (info.sigma_min - smin).abs() < 1e-6 * smin,
            "{} vs {}",
            info.sigma_min,
            smin
        );
        assert!(info.lambda_sq > 0.0);
    }

    #[test]
    fn dls_bounded_at_exact_singularity() {
        let j = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 1.0, 0.0]);
        let mut out = [0.0; 2];
        let mut dls = DampedLeastSquares::new(2, DlsSettings::default());
        let info = dls.solve(&j, &[1.0, -1.0], &mut out);
        assert!(info.lambda_sq > 0.0);
        assert!(
            out.iter()
                .all(|v| v.is_finite() && v.abs() <= 1.0 / (2.0 * 0.05) + 1e-9)
        );
    }

    #[test]
    fn check_nullspace_projector_idempotent() {
        let j = DMatrix::from_fn(3, 7, |i, k| {
            (((i + 1) * (k + 2)) as f64 * 0.37).sin() + 0.1 * (i * k) as f64
        });
        let mut b = RowSpaceBasis::new(7);
        b.add_rows(&j);
        b.add_rows(&j); // dependent rows add nothing
        assert_eq!(b.rank(), 3);
        let mut n = DMatrix::zeros(7, 7);
        b.projector(&mut n);
        assert!((&n * &n - &n).abs().max() < 1e-12);
        assert!((&j * &n).abs().max() < 1e-12);
    }
}

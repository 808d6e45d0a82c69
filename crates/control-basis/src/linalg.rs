//! Allocation-free dense kernels for the control tick: the damped least-squares pseudoinverse and an
//! orthonormal basis of the row space of stacked Jacobians (for exact null-space projection).
//!
//! Buffers are sized once at construction for the largest task dimension and number of motor units;
//! the per-tick calls never allocate.

use nalgebra::{DMatrix, DVector, Dim, IsContiguous, Matrix, RawStorage};

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
    /// The Cholesky factor of J Jᵀ (+ 1e-14·scale I) of the last fixed-size solve whose law was
    /// undamped (`factor[k][i]` = L(i, k)), its reciprocal pivots, and its row count (0: none kept).
    factor: [[f64; 6]; 6],
    factor_inv: [f64; 6],
    factor_rows: usize,
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
            factor: [[0.0; 6]; 6],
            factor_inv: [0.0; 6],
            factor_rows: 0,
        }
    }

    /// After a fixed-size solve, writes an orthonormal basis of the row space of the same J (its first
    /// `m` rows, n columns, column-major with `rows` rows) into `out` (m rows of n, contiguous):
    /// Q = L⁻¹ J from the solve's own undamped factor, m²n/2 multiply-adds instead of a Gram–Schmidt
    /// pass. Q Qᵀ = I − δ (A + δI)⁻¹ with δ = 1e-14·max Aᵢᵢ the factor's regularisation, so the rows
    /// are orthonormal to δ/σ_min². The factor is kept when the law was undamped (σ_min ≥ ε: error
    /// ≤ 4e-12·max Aᵢᵢ/ε²) or when the certified lower bound on σ_min² (AM–GM or 1/tr A⁻¹, see
    /// [`DampedLeastSquares::solve_rows`]) is at least 1e10·δ (error ≤ 1e-10). False (nothing
    /// written) otherwise, and after a general-size solve or one of another row count.
    pub fn row_basis_from_factor(&self, js: &[f64], rows: usize, m: usize, out: &mut [f64]) -> bool {
        if m == 0 || m != self.factor_rows || rows < m {
            return false;
        }
        let n = js.len() / rows;
        debug_assert!(out.len() >= m * n);
        match m {
            1 => self.row_basis_fixed::<1>(js, rows, n, out),
            2 => self.row_basis_fixed::<2>(js, rows, n, out),
            3 => self.row_basis_fixed::<3>(js, rows, n, out),
            4 => self.row_basis_fixed::<4>(js, rows, n, out),
            5 => self.row_basis_fixed::<5>(js, rows, n, out),
            _ => self.row_basis_fixed::<6>(js, rows, n, out),
        }
        true
    }

    /// The Cholesky factor (`l[k][i]` = L(i, k)) of J Jᵀ + 1e-14·max Aᵢᵢ I and its reciprocal pivots,
    /// when the last solve was a fixed-size one on `m` rows whose law was undamped.
    pub(crate) fn undamped_factor(&self, m: usize) -> Option<(&[[f64; 6]; 6], &[f64; 6])> {
        (m > 0 && m == self.factor_rows).then_some((&self.factor, &self.factor_inv))
    }

    /// Q = L⁻¹ J for M rows: the columns go through the forward substitution side by side (8 at a
    /// time, independent dependency chains), then out as rows.
    #[allow(clippy::needless_range_loop)] // triangular index loops over a fixed-size factor
    fn row_basis_fixed<const M: usize>(&self, js: &[f64], rows: usize, n: usize, out: &mut [f64]) {
        let mut c0 = 0;
        while c0 < n {
            let cnt = (n - c0).min(8);
            let mut b = [[0.0f64; 8]; M];
            for c in 0..cnt {
                let col = &js[(c0 + c) * rows..(c0 + c) * rows + M];
                for (r, &v) in col.iter().enumerate() {
                    b[r][c] = v;
                }
            }
            for i in 0..M {
                let mut s = b[i];
                for k in 0..i {
                    let lki = self.factor[k][i];
                    for c in 0..8 {
                        s[c] -= lki * b[k][c];
                    }
                }
                let p = self.factor_inv[i];
                for c in 0..8 {
                    b[i][c] = s[c] * p;
                }
            }
            for (r, br) in b.iter().enumerate() {
                out[r * n + c0..r * n + c0 + cnt].copy_from_slice(&br[..cnt]);
            }
            c0 += cnt;
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

    /// `out = J†_λ e = Jᵀ (J Jᵀ + λ² I)⁻¹ e` for the whole of `jac` (m×n): a [`DMatrix`], or the 6×n
    /// [`nalgebra::Matrix6xX`] that [`crate::jacobian`] writes.
    pub fn solve<R: Dim, C: Dim, S: RawStorage<f64, R, C> + IsContiguous>(
        &mut self,
        jac: &Matrix<f64, R, C, S>,
        e: &[f64],
        out: &mut [f64],
    ) -> DlsInfo {
        self.solve_rows(jac, jac.nrows(), e, out)
    }

    /// `out = J†_λ e` using the first `m` rows of `jac` (a buffer sized for the largest task), `e` of
    /// length ≥ m (first m used), `out` of length n.
    ///
    /// Tasks of up to 6 rows (every pose, position and orientation task) run a fixed-size kernel whose
    /// matrices live on the stack and whose loops the compiler unrolls; larger ones (contact tasks) the
    /// general one. Both run the same algorithm (the fixed one multiplies by the pivots' reciprocals
    /// where the general one divides, so the two agree to rounding).
    ///
    /// # Adaptive damping: the σ_min estimate
    ///
    /// Let A = J Jᵀ = L Lᵀ (the Cholesky factor needed for the solve anyway) with eigenvalues
    /// λ₁ ≥ … ≥ λ_m = σ_min². Two lower bounds on σ_min² come out of L for O(m) and O(m³/6) flops, no
    /// second decomposition:
    ///
    /// 1. AM–GM on the other eigenvalues: σ_min² ≥ det A / (tr A / (m−1))^(m−1), det A = Π Lᵢᵢ².
    /// 2. The trace of the inverse: tr A⁻¹ = Σ 1/λᵢ = ‖L⁻¹‖²_F (L⁻¹ is a triangular inverse, 56 products
    ///    for m = 6), and 1/tr A⁻¹ ≤ σ_min² ≤ m / tr A⁻¹. The lower end is exact to first order near a
    ///    singularity: 1/tr A⁻¹ = σ_min² / (1 + Σ_{i<m} σ_min²/λᵢ).
    ///
    /// When either bound proves σ_min ≥ ε the law is the exact pseudoinverse (no damping) and the bound is
    /// reported as `sigma_min` (so `sigma_min` ≤ the true σ_min there). Only inside the damping band,
    /// where neither certifies, is σ_min² refined by inverse iteration on the same factor with a
    /// Rayleigh quotient (warm-started from the previous tick's vector: 2 steps, 8 from cold), which
    /// approaches σ_min² from above and converges fast exactly there (σ_min ≪ σ₂).
    pub fn solve_rows<R: Dim, C: Dim, S: RawStorage<f64, R, C> + IsContiguous>(
        &mut self,
        jac: &Matrix<f64, R, C, S>,
        m: usize,
        e: &[f64],
        out: &mut [f64],
    ) -> DlsInfo {
        let n = jac.ncols();
        let rows = jac.nrows();
        debug_assert!(m <= rows);
        let e = &e[..m];
        assert!(
            m <= self.max_rows(),
            "task has {m} rows, workspace sized for {}",
            self.max_rows()
        );
        debug_assert_eq!(out.len(), n);
        let js = jac.as_slice();
        match m {
            0 => {
                out.fill(0.0);
                DlsInfo::default()
            }
            1 => self.solve_fixed::<1>(js, rows, e, out),
            2 => self.solve_fixed::<2>(js, rows, e, out),
            3 => self.solve_fixed::<3>(js, rows, e, out),
            4 => self.solve_fixed::<4>(js, rows, e, out),
            5 => self.solve_fixed::<5>(js, rows, e, out),
            6 => self.solve_fixed::<6>(js, rows, e, out),
            _ => self.solve_general(js, rows, m, e, out),
        }
    }

    /// The fixed-size kernel for M ≤ 6 rows; `js` column-major with `rows` rows (≥ M), n = len / rows.
    #[allow(clippy::needless_range_loop)] // triangular index loops over fixed-size factors
    fn solve_fixed<const M: usize>(&mut self, js: &[f64], rows: usize, e: &[f64], out: &mut [f64]) -> DlsInfo {
        let n = out.len();
        debug_assert!(js.len() >= rows * n);
        let a = gram_fixed::<M>(js, rows, n);
        let mut scale = 0.0f64;
        let mut trace = 0.0;
        for (i, ai) in a.iter().enumerate() {
            scale = scale.max(ai[i]);
            trace += ai[i];
        }
        let tiny = 1e-14 * scale.max(1e-300);
        let mut chol = a;
        for (i, ci) in chol.iter_mut().enumerate() {
            ci[i] += tiny;
        }
        let DlsSettings {
            lambda_max,
            sigma_threshold,
        } = self.settings;
        let threshold_sq = sigma_threshold * sigma_threshold;
        let mut inv = [0.0f64; M];
        let factored = cholesky_fixed(&mut chol, &mut inv);
        let lower_bound = if !factored {
            0.0
        } else if M == 1 {
            a[0][0]
        } else {
            let det: f64 = (0..M).map(|i| chol[i][i] * chol[i][i]).product();
            let amgm = det / (trace / (M - 1) as f64).powi(M as i32 - 1);
            if amgm >= threshold_sq {
                amgm
            } else {
                // 1 / tr (A + tiny I)⁻¹ − tiny ≤ λ_min(A).
                (1.0 / inverse_trace_fixed(&chol, &inv) - tiny).max(amgm)
            }
        };
        let sigma_min_sq = if lower_bound >= threshold_sq {
            lower_bound
        } else if factored {
            let y = &mut self.y[..M];
            let iterations = if self.warm_rows == M { 2 } else { 8 };
            if self.warm_rows != M {
                for (i, yi) in y.iter_mut().enumerate() {
                    *yi = 1.0 + 0.1 * i as f64;
                }
            }
            self.warm_rows = M;
            let mut v = [0.0f64; M];
            v.copy_from_slice(y);
            let mut lam = 0.0;
            for _ in 0..iterations {
                let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                v.iter_mut().for_each(|x| *x /= norm);
                let mut w = v;
                cholesky_solve_fixed(&chol, &inv, &mut w);
                let ray: f64 = v.iter().zip(w.iter()).map(|(a, b)| a * b).sum();
                lam = 1.0 / ray;
                v = w;
            }
            y.copy_from_slice(&v);
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
        self.factor_rows = 0;
        // The undamped factor is kept for the row basis (and a manipulability level) when the law
        // used it, or — inside the damping band — when the certified bound λ_min ≥ `lower_bound`
        // keeps Q = L⁻¹J orthonormal to tiny / λ_min ≤ 1e-10 (see `row_basis_from_factor`).
        if factored && (lambda_sq == 0.0 || lower_bound >= 1e10 * tiny) {
            for (f, c) in self.factor.iter_mut().zip(&chol) {
                f[..M].copy_from_slice(c);
            }
            self.factor_inv[..M].copy_from_slice(&inv);
            self.factor_rows = M;
        }
        if lambda_sq > 0.0 || !factored {
            chol = a;
            for (i, ci) in chol.iter_mut().enumerate() {
                ci[i] += lambda_sq + tiny;
            }
            if !cholesky_fixed(&mut chol, &mut inv) {
                // Only reachable with λ_max = 0 at an exact singularity: fall back to full damping so
                // the step stays bounded rather than undefined.
                chol = a;
                let d = (lambda_max * lambda_max).max(1e-12 * scale.max(1.0));
                for (i, ci) in chol.iter_mut().enumerate() {
                    ci[i] += d;
                }
                cholesky_fixed(&mut chol, &mut inv);
            }
        }
        let mut w: [f64; M] = e.try_into().expect("M rows");
        cholesky_solve_fixed(&chol, &inv, &mut w);
        for (k, o) in out.iter_mut().enumerate() {
            let col: &[f64; M] = js[k * rows..k * rows + M].try_into().expect("M rows");
            *o = col.iter().zip(w.iter()).map(|(a, b)| a * b).sum();
        }
        DlsInfo { sigma_min, lambda_sq }
    }

    /// The general kernel (any m ≤ `max_rows`), buffers on the heap (sized at construction).
    fn solve_general(&mut self, js: &[f64], rows: usize, m: usize, e: &[f64], out: &mut [f64]) -> DlsInfo {
        self.factor_rows = 0;
        let n = out.len();
        // A = J Jᵀ (column-major m×m).
        let a = &mut self.a[..m * m];
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
        // The AM–GM certificate (see `solve_rows`); inverse iteration when it cannot prove σ_min ≥ ε.
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

/// In-place lower Cholesky factorisation of a fixed-size matrix stored by columns (`a[j][i]` = A(i, j);
/// lower triangle read and written), with the reciprocals of the diagonal of L into `inv`; false if not
/// positive definite. The algorithm of [`cholesky_in_place`], with one division per column: the
/// divisions by the pivot become products with its reciprocal (results agree to rounding).
#[inline]
#[allow(clippy::needless_range_loop)] // triangular index loops over fixed-size factors
pub(crate) fn cholesky_fixed<const M: usize>(a: &mut [[f64; M]; M], inv: &mut [f64; M]) -> bool {
    for j in 0..M {
        let mut d = a[j][j];
        for k in 0..j {
            d -= a[k][j] * a[k][j];
        }
        if d <= 0.0 || !d.is_finite() {
            return false;
        }
        let d = d.sqrt();
        a[j][j] = d;
        let r = 1.0 / d;
        inv[j] = r;
        for i in j + 1..M {
            let mut s = a[j][i];
            for k in 0..j {
                s -= a[k][i] * a[k][j];
            }
            a[j][i] = s * r;
        }
    }
    true
}

/// Solves `L Lᵀ x = b` in place with the factor and reciprocal diagonal from [`cholesky_fixed`].
#[inline]
#[allow(clippy::needless_range_loop)] // triangular index loops over fixed-size factors
pub(crate) fn cholesky_solve_fixed<const M: usize>(l: &[[f64; M]; M], inv: &[f64; M], b: &mut [f64; M]) {
    cholesky_solve_many_fixed(l, inv, std::slice::from_mut(b));
}

/// A = J Jᵀ for the first M rows of J (column-major with `rows` rows, n columns): `a[j][i]` = A(i, j),
/// the lower triangle computed and mirrored.
#[inline]
#[allow(clippy::needless_range_loop)] // triangular index loops over fixed-size matrices
pub(crate) fn gram_fixed<const M: usize>(js: &[f64], rows: usize, n: usize) -> [[f64; M]; M] {
    let mut a = [[0.0f64; M]; M];
    for k in 0..n {
        let col: &[f64; M] = js[k * rows..k * rows + M].try_into().expect("M rows");
        for i in 0..M {
            let ci = col[i];
            for j in 0..=i {
                a[j][i] += ci * col[j];
            }
        }
    }
    for i in 0..M {
        for j in 0..i {
            a[i][j] = a[j][i];
        }
    }
    a
}

/// Solves `L Lᵀ X = B` in place for every column of `cols` (each an M-vector) at once: the columns are
/// independent, so the substitution runs row by row across all of them (no dependency chain through
/// one column's divisions).
#[inline]
#[allow(clippy::needless_range_loop)] // triangular index loops over fixed-size factors
pub(crate) fn cholesky_solve_many_fixed<const M: usize>(l: &[[f64; M]; M], inv: &[f64; M], cols: &mut [[f64; M]]) {
    for i in 0..M {
        for b in cols.iter_mut() {
            let mut s = b[i];
            for k in 0..i {
                s -= l[k][i] * b[k];
            }
            b[i] = s * inv[i];
        }
    }
    for i in (0..M).rev() {
        for b in cols.iter_mut() {
            let mut s = b[i];
            for k in i + 1..M {
                s -= l[i][k] * b[k];
            }
            b[i] = s * inv[i];
        }
    }
}

/// tr (L Lᵀ)⁻¹ = ‖L⁻¹‖²_F for a factor from [`cholesky_fixed`]: L⁻¹ column by column by forward
/// substitution (M(M+1)(M+2)/6 products), no second decomposition.
#[inline]
#[allow(clippy::needless_range_loop)] // triangular index loops over fixed-size factors
fn inverse_trace_fixed<const M: usize>(l: &[[f64; M]; M], inv_diag: &[f64; M]) -> f64 {
    let mut total = 0.0;
    for c in 0..M {
        // x = L⁻¹ e_c: zero above c.
        let mut x = [0.0f64; M];
        x[c] = inv_diag[c];
        let mut sum = x[c] * x[c];
        for i in c + 1..M {
            let mut s = 0.0;
            for k in c..i {
                s -= l[k][i] * x[k];
            }
            x[i] = s * inv_diag[i];
            sum += x[i] * x[i];
        }
        total += sum;
    }
    total
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
    /// The orthonormal rows so far (`rank` rows of n, contiguous).
    pub(crate) fn rows(&self) -> &[f64] {
        &self.basis.as_slice()[..self.rank * self.dim()]
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

    /// Starts the span with the first `m` rows of `jac` using the factor of the damped least-squares
    /// solve that just ran on the same rows ([`DampedLeastSquares::row_basis_from_factor`]). Only on
    /// an empty basis; false (basis unchanged) when that is not possible — use
    /// [`RowSpaceBasis::add_first_rows`] then.
    pub fn start_from_factor(&mut self, dls: &DampedLeastSquares, jac: &DMatrix<f64>, m: usize) -> bool {
        let n = self.dim();
        if self.rank != 0 || m > n || jac.ncols() != n {
            return false;
        }
        let rows = jac.nrows();
        if dls.row_basis_from_factor(jac.as_slice(), rows, m, &mut self.basis.as_mut_slice()[..m * n]) {
            self.rank = m;
            true
        } else {
            false
        }
    }

    /// Adds the first `m` rows of `jac` to the span.
    pub fn add_first_rows(&mut self, jac: &DMatrix<f64>, m: usize) {
        let n = self.dim();
        debug_assert_eq!(jac.ncols(), n);
        let rows = jac.nrows();
        let js = jac.as_slice();
        let basis = self.basis.as_mut_slice();
        let tmp = self.tmp.as_mut_slice();
        for r in 0..m {
            if self.rank == n {
                return;
            }
            for (k, t) in tmp.iter_mut().enumerate() {
                *t = js[r + k * rows];
            }
            let norm0 = dot(tmp, tmp).sqrt();
            if norm0 == 0.0 || !norm0.is_finite() {
                continue;
            }
            // Classical Gram–Schmidt, twice ("twice is enough": orthogonal to working precision): the
            // rank dot products of one pass are independent of each other, unlike modified
            // Gram–Schmidt's chain of dot → update → dot.
            for _ in 0..2 {
                let mut d = [0.0f64; MAX_DOTS];
                if self.rank <= MAX_DOTS {
                    for (db, col) in d.iter_mut().zip(basis[..self.rank * n].chunks_exact(n)) {
                        *db = dot(col, tmp);
                    }
                    for (db, col) in d.iter().zip(basis[..self.rank * n].chunks_exact(n)) {
                        tmp.iter_mut().zip(col).for_each(|(t, c)| *t -= db * c);
                    }
                } else {
                    for col in basis[..self.rank * n].chunks_exact(n) {
                        let d = dot(col, tmp);
                        tmp.iter_mut().zip(col).for_each(|(t, c)| *t -= d * c);
                    }
                }
            }
            let norm = dot(tmp, tmp).sqrt();
            if norm > self.tol * norm0 {
                let inv = 1.0 / norm;
                basis[self.rank * n..(self.rank + 1) * n]
                    .iter_mut()
                    .zip(tmp.iter())
                    .for_each(|(b, t)| *b = t * inv);
                self.rank += 1;
            }
        }
    }

    /// Basis vector `b` (< rank) of the span, unit length.
    pub fn vector(&self, b: usize) -> nalgebra::DVectorView<'_, f64> {
        debug_assert!(b < self.rank);
        self.basis.column(b)
    }

    /// `v ← (I − V Vᵀ) v`: removes from `v` every component that would move the spanned tasks
    /// (O(rank · n); the n×n projector is never formed).
    pub fn project_out(&self, v: &mut DVector<f64>) {
        let n = self.dim();
        let v = v.as_mut_slice();
        for col in self.basis.as_slice()[..self.rank * n].chunks_exact(n) {
            let d = dot(col, v);
            v.iter_mut().zip(col).for_each(|(x, c)| *x -= d * c);
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

/// Basis size up to which [`RowSpaceBasis`] orthogonalises by classical Gram–Schmidt (dot products on
/// the stack); beyond it, modified Gram–Schmidt.
const MAX_DOTS: usize = 16;

/// Plain dot product of two equal-length slices.
#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
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
    fn fixed_kernel_matches_general_kernel_and_bounds_sigma_min() {
        // 6×7 Jacobian-like matrices from far from singular to nearly singular: the fixed-size kernel
        // equals the general one to rounding, and a certified σ_min never exceeds the true one.
        for t in 0..40usize {
            let eps = 10f64.powi(-((t % 8) as i32));
            let mut j = DMatrix::from_fn(6, 7, |i, k| ((1 + i * 7 + k + t) as f64 * 0.7).sin());
            for k in 0..7 {
                j[(5, k)] = j[(4, k)] * (1.0 - eps) + eps * j[(5, k)];
            }
            let e = [0.01, -0.02, 0.005, 0.0, 0.03, -0.01];
            let (mut fixed, mut general) = ([0.0; 7], [0.0; 7]);
            let mut a = DampedLeastSquares::new(6, DlsSettings::default());
            let mut b = DampedLeastSquares::new(6, DlsSettings::default());
            let fi = a.solve(&j, &e, &mut fixed);
            let gi = b.solve_general(j.as_slice(), 6, 6, &e, &mut general);
            let smin = j.clone().svd(false, false).singular_values.min();
            assert!(
                (fi.lambda_sq - gi.lambda_sq).abs() <= 1e-9 * gi.lambda_sq.max(1e-12),
                "{fi:?} {gi:?}"
            );
            let scale = general.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for k in 0..7 {
                assert!(
                    (fixed[k] - general[k]).abs() <= 1e-9 * scale,
                    "{fixed:?} vs {general:?}"
                );
            }
            if fi.lambda_sq == 0.0 {
                assert!(
                    fi.sigma_min <= smin * (1.0 + 1e-12) && fi.sigma_min >= 0.05,
                    "{fi:?} vs {smin}"
                );
            }
        }
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

    #[test]
    fn basis_from_the_factor_equals_gram_schmidt() {
        for (m, seed) in [(1usize, 0.3), (3, 0.7), (6, 1.1), (6, 2.9)] {
            let j = DMatrix::from_fn(m, 7, |i, k| {
                (((i + 2) * (k + 1)) as f64 * seed).sin() + 0.2 * (i == k) as u8 as f64
            });
            let mut dls = DampedLeastSquares::new(6, DlsSettings::default());
            let mut out = vec![0.0; 7];
            let info = dls.solve(&j, &vec![0.1; m], &mut out);
            assert_eq!(info.lambda_sq, 0.0, "test matrices are well conditioned");
            let mut fast = RowSpaceBasis::new(7);
            assert!(fast.start_from_factor(&dls, &j, m));
            assert_eq!(fast.rank(), m);
            assert!(!fast.start_from_factor(&dls, &j, m), "only on an empty basis");
            let mut slow = RowSpaceBasis::new(7);
            slow.add_rows(&j);
            let (mut pf, mut ps) = (DMatrix::zeros(7, 7), DMatrix::zeros(7, 7));
            fast.projector(&mut pf);
            slow.projector(&mut ps);
            assert!((&pf - &ps).abs().max() < 1e-10, "m = {m}");
            assert!((&j * &pf).abs().max() < 1e-10);
            // Another row count than the last solve: refused.
            let mut other = RowSpaceBasis::new(7);
            if m > 1 {
                assert!(!other.start_from_factor(&dls, &j, m - 1));
            }
        }
        // A damped solve keeps no factor.
        let singular = DMatrix::from_fn(2, 7, |_, k| k as f64);
        let mut dls = DampedLeastSquares::new(6, DlsSettings::default());
        let mut out = vec![0.0; 7];
        assert!(dls.solve(&singular, &[1.0, 1.0], &mut out).lambda_sq > 0.0);
        assert!(!RowSpaceBasis::new(7).start_from_factor(&dls, &singular, 2));
    }
}

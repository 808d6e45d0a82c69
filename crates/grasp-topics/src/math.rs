//! Small fixed-size linear algebra and random variates used by the sampler and the generator.
//!
//! Everything here works on stack matrices (`nalgebra::SMatrix`), so the sampler's hot path never
//! allocates (`bayes::multivariate` works on heap matrices, so it serves as the reference in tests
//! rather than in the hot path). Special functions come from `bayes::special`.

use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector3};
use rand::{Rng, RngExt};
use rand_distr::{Distribution, Gamma, StandardNormal};

/// Position vectors are 3-D (6.7).
pub(crate) const DX: usize = 3;

/// ln Γ(x) (from `bayes::special`).
#[inline]
pub(crate) fn ln_gamma(x: f64) -> f64 {
    bayes::special::ln_gamma(x)
}

/// Multivariate log-gamma ln Γ_p(a) (from `bayes::special`).
#[inline]
pub(crate) fn ln_multigamma(a: f64, p: usize) -> f64 {
    bayes::special::ln_multigamma(p, a)
}

/// Lower Cholesky factor of a symmetric matrix, or `None` if it is not (numerically) positive
/// definite. Fixed size, no allocation.
pub(crate) fn cholesky<const D: usize>(a: &SMatrix<f64, D, D>) -> Option<SMatrix<f64, D, D>> {
    let mut l = SMatrix::<f64, D, D>::zeros();
    for j in 0..D {
        let mut d = a[(j, j)];
        for k in 0..j {
            d -= l[(j, k)] * l[(j, k)];
        }
        if d.is_nan() || d <= 0.0 || !d.is_finite() {
            return None;
        }
        let djj = d.sqrt();
        l[(j, j)] = djj;
        for i in (j + 1)..D {
            let mut s = a[(i, j)];
            for k in 0..j {
                s -= l[(i, k)] * l[(j, k)];
            }
            l[(i, j)] = s / djj;
        }
    }
    Some(l)
}

/// ln |A| from A's lower Cholesky factor.
pub(crate) fn ln_det_from_chol<const D: usize>(l: &SMatrix<f64, D, D>) -> f64 {
    let mut s = 0.0;
    for i in 0..D {
        s += l[(i, i)].ln();
    }
    2.0 * s
}

/// |L⁻¹ v|² for lower-triangular L (forward substitution), i.e. vᵀ (L Lᵀ)⁻¹ v.
#[inline]
pub(crate) fn mahalanobis_sq<const D: usize>(l: &SMatrix<f64, D, D>, v: &SVector<f64, D>) -> f64 {
    let mut y = [0.0; D];
    let mut q = 0.0;
    for i in 0..D {
        let mut s = v[i];
        for (k, yk) in y.iter().enumerate().take(i) {
            s -= l[(i, k)] * yk;
        }
        let yi = s / l[(i, i)];
        y[i] = yi;
        q += yi * yi;
    }
    q
}

/// Symmetric part (A + Aᵀ)/2, to keep accumulated matrices exactly symmetric.
pub(crate) fn symmetrize<const D: usize>(a: &SMatrix<f64, D, D>) -> SMatrix<f64, D, D> {
    (a + a.transpose()) * 0.5
}

/// Inverse of an SPD 2×2 matrix (closed form).
#[inline]
pub(crate) fn inv2(a: &Matrix2<f64>) -> Matrix2<f64> {
    let det = a[(0, 0)] * a[(1, 1)] - a[(0, 1)] * a[(1, 0)];
    Matrix2::new(a[(1, 1)], -a[(0, 1)], -a[(1, 0)], a[(0, 0)]) / det
}

/// Determinant of a 2×2 matrix.
#[inline]
pub(crate) fn det2(a: &Matrix2<f64>) -> f64 {
    a[(0, 0)] * a[(1, 1)] - a[(0, 1)] * a[(1, 0)]
}

/// A standard normal variate.
#[inline]
pub(crate) fn std_normal<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    StandardNormal.sample(rng)
}

/// A Gamma(shape, 1) variate; `shape` > 0.
pub(crate) fn gamma<R: Rng + ?Sized>(shape: f64, rng: &mut R) -> f64 {
    match Gamma::new(shape, 1.0) {
        Ok(g) => g.sample(rng),
        // Only reachable with a non-positive shape, which validation excludes.
        Err(_) => f64::NAN,
    }
}

/// Fills `out` with a Dirichlet(`alpha`…) draw (symmetric if all equal). No allocation.
pub(crate) fn dirichlet_into<R: Rng + ?Sized>(alpha: &[f64], out: &mut [f64], rng: &mut R) {
    let mut s = 0.0;
    for (o, &a) in out.iter_mut().zip(alpha) {
        // Tiny shapes underflow to 0; floor them so the draw stays on the simplex.
        let g = gamma(a, rng).max(1e-300);
        *o = g;
        s += g;
    }
    for o in out.iter_mut() {
        *o /= s;
    }
}

/// Fills `out` with a symmetric Dirichlet(β, …, β) draw. No allocation.
pub(crate) fn dirichlet_symmetric_into<R: Rng + ?Sized>(beta: f64, out: &mut [f64], rng: &mut R) {
    let mut s = 0.0;
    for o in out.iter_mut() {
        let g = gamma(beta, rng).max(1e-300);
        *o = g;
        s += g;
    }
    for o in out.iter_mut() {
        *o /= s;
    }
}

/// A Wishart(ν, S) draw given the lower Cholesky factor of S (Bartlett decomposition).
pub(crate) fn sample_wishart<const D: usize, R: Rng + ?Sized>(
    dof: f64,
    scale_chol: &SMatrix<f64, D, D>,
    rng: &mut R,
) -> SMatrix<f64, D, D> {
    let mut a = SMatrix::<f64, D, D>::zeros();
    for i in 0..D {
        // χ²_{ν−i} = 2·Gamma((ν−i)/2) with i 0-based.
        a[(i, i)] = (2.0 * gamma((dof - i as f64) / 2.0, rng)).sqrt();
        for j in 0..i {
            a[(i, j)] = std_normal(rng);
        }
    }
    let la = scale_chol * a;
    symmetrize(&(la * la.transpose()))
}

/// An inverse-Wishart(ν, Ψ) draw: the inverse of a Wishart(ν, Ψ⁻¹) draw.
pub(crate) fn sample_inv_wishart<const D: usize, R: Rng + ?Sized>(
    dof: f64,
    scale: &SMatrix<f64, D, D>,
    rng: &mut R,
) -> SMatrix<f64, D, D> {
    let inv = scale.try_inverse().unwrap_or_else(SMatrix::identity);
    let l = cholesky(&symmetrize(&inv)).unwrap_or_else(SMatrix::identity);
    let w = sample_wishart(dof, &l, rng);
    symmetrize(&w.try_inverse().unwrap_or_else(SMatrix::identity))
}

/// A multivariate normal draw N(μ, L Lᵀ).
pub(crate) fn sample_mvn<const D: usize, R: Rng + ?Sized>(
    mean: &SVector<f64, D>,
    chol: &SMatrix<f64, D, D>,
    rng: &mut R,
) -> SVector<f64, D> {
    let z = SVector::<f64, D>::from_fn(|_, _| std_normal(rng));
    mean + chol * z
}

/// Index drawn from unnormalised log-weights `logw` (max-subtracted exp, then inverse CDF). The
/// slice is overwritten with the unnormalised weights. No allocation.
pub(crate) fn sample_log_weights<R: Rng + ?Sized>(logw: &mut [f64], rng: &mut R) -> usize {
    let mut m = f64::NEG_INFINITY;
    for &v in logw.iter() {
        if v > m {
            m = v;
        }
    }
    let mut total = 0.0;
    for v in logw.iter_mut() {
        *v = (*v - m).exp();
        total += *v;
    }
    let mut u = rng.random::<f64>() * total;
    for (i, &v) in logw.iter().enumerate() {
        u -= v;
        if u < 0.0 {
            return i;
        }
    }
    // Rounding left a sliver of mass: take the last index with positive weight.
    logw.iter().rposition(|&v| v > 0.0).unwrap_or(0)
}

/// Index drawn from non-negative weights.
pub(crate) fn sample_weights<R: Rng + ?Sized>(w: &[f64], rng: &mut R) -> usize {
    let total: f64 = w.iter().sum();
    let mut u = rng.random::<f64>() * total;
    for (i, &v) in w.iter().enumerate() {
        u -= v;
        if u < 0.0 {
            return i;
        }
    }
    w.iter().rposition(|&v| v > 0.0).unwrap_or(0)
}

/// 3×3 from row-major nested arrays.
pub(crate) fn m3(a: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| a[i][j])
}

/// 2×2 from row-major nested arrays.
pub(crate) fn m2(a: &[[f64; 2]; 2]) -> Matrix2<f64> {
    Matrix2::from_fn(|i, j| a[i][j])
}

/// Row-major nested arrays from a 3×3.
pub(crate) fn a3(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    [
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
    ]
}

/// Row-major nested arrays from a 2×2.
pub(crate) fn a2(m: &Matrix2<f64>) -> [[f64; 2]; 2] {
    [[m[(0, 0)], m[(0, 1)]], [m[(1, 0)], m[(1, 1)]]]
}

/// Array from a 3-vector.
pub(crate) fn v3a(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wishart_mean_is_dof_times_scale() {
        let mut rng = bayes::rng::seeded(3);
        let s = Matrix2::new(0.5, 0.1, 0.1, 0.2);
        let l = cholesky(&s).unwrap();
        let n = 20_000;
        let mut acc = Matrix2::zeros();
        for _ in 0..n {
            acc += sample_wishart(5.0, &l, &mut rng);
        }
        let mean = acc / n as f64;
        assert!((mean - s * 5.0).abs().max() < 0.05, "{mean}");
    }
}

//! Artificial potentials φ (seed §3.1): scalar fields over a feedback signal whose descent achieves a
//! reference. Each evaluation yields φ, the gradient `e = ∂φ/∂f` in the feedback space and, with the
//! feedback Jacobian `J_τ = ∂f/∂u_τ` (3.1), everything the control law (3.4) needs.
//!
//! - [`quadratic`]: φ_U = ½ (y − r)ᵀ(y − r) (3.10) with gradient (y − r) (3.11), on positions, on
//!   configurations and — with the SO(3) logarithm as the difference — on orientations.
//! - [`manipulability`]: φ_M = −√det(J Jᵀ) (3.14) with its analytic gradient ∂φ_M/∂q (3.16).
//! - [`joint_limit`]: a quadratic pull towards the middle of each joint's range, normalised by the range.
//! - [`force_residual`]: ½‖F‖² + ½w²‖M‖² of the net contact wrench, the grasp potential of §3.1.3.3.

use nalgebra::{DVector, Matrix6xX};

use crate::chain::{Chain, ChainState};
use crate::math::{Rot3, Vec3};
use crate::model::JointKind;

/// φ_U (3.10) and its gradient (3.11): `e = y − r`, φ = ½ eᵀe. Returns φ.
pub fn quadratic(y: &[f64], r: &[f64], e: &mut [f64]) -> f64 {
    let mut phi = 0.0;
    for ((ei, yi), ri) in e.iter_mut().zip(y).zip(r) {
        *ei = yi - ri;
        phi += 0.5 * *ei * *ei;
    }
    phi
}

/// Orientation error on SO(3): `e = log(R Rᵣᵀ)` (a rotation vector in base axes, |e| = geodesic angle
/// from the reference to the current orientation, ≤ π). Its time derivative is ω to first order, so the
/// angular rows of the geometric Jacobian serve as the feedback Jacobian.
pub fn orientation_error(current: &Rot3, reference: &Rot3) -> Vec3 {
    (current * reference.inverse()).scaled_axis()
}

/// Which rows of the chain Jacobian enter the manipulability measure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ManipulabilityRows {
    /// All six rows (translation and rotation).
    Full,
    /// The three translational rows (positioning dexterity).
    Position,
}

impl ManipulabilityRows {
    /// Number of Jacobian rows used.
    pub fn count(self) -> usize {
        match self {
            ManipulabilityRows::Full => 6,
            ManipulabilityRows::Position => 3,
        }
    }
}

/// Scratch space for [`manipulability`] (allocated once).
#[derive(Debug, Clone)]
pub struct ManipulabilityWorkspace {
    b: Matrix6xX<f64>,
    axes: Vec<Vec3>,
    /// z_e × (p − p_e) of each joint (the revolute fast path).
    lin: Vec<Vec3>,
}

impl ManipulabilityWorkspace {
    /// Scratch for a chain.
    pub fn new(chain: &Chain) -> Self {
        ManipulabilityWorkspace {
            b: Matrix6xX::zeros(chain.dof()),
            axes: vec![Vec3::zeros(); chain.joints().len()],
            lin: vec![Vec3::zeros(); chain.joints().len()],
        }
    }
}

/// Yoshikawa's measure w = √det(J Jᵀ) of the tip Jacobian in `state` (after [`crate::jacobian`]) and,
/// into `grad`, its gradient ∂w/∂q (n). φ_M = −w (3.14), so ∇φ_M = −grad.
///
/// ∂w/∂q_k = w · tr(A⁻¹ J ∂Jᵀ/∂q_k) with A = J Jᵀ, and ∂J/∂q_k in closed form from the geometric
/// Jacobian (for revolute joints f and columns e: z_f × (z_e × (p − p_e)) when f < e, z_e × (z_f × (p − p_f))
/// when f ≥ e, z_f × z_e on the angular rows when f < e; prismatic joints analogously), so the gradient
/// is exact and costs O(n²). At an exact singularity a tiny Tikhonov term keeps A⁻¹ finite.
pub fn manipulability(
    chain: &Chain,
    state: &ChainState,
    rows: ManipulabilityRows,
    ws: &mut ManipulabilityWorkspace,
    grad: &mut [f64],
) -> f64 {
    match rows {
        ManipulabilityRows::Full => manipulability_fixed::<6>(chain, state, ws, grad),
        ManipulabilityRows::Position => manipulability_fixed::<3>(chain, state, ws, grad),
    }
}

/// [`manipulability`] for the first M rows of the tip Jacobian (M = 6 or 3), A on the stack.
#[allow(clippy::needless_range_loop)] // triangular index loops over fixed-size factors
fn manipulability_fixed<const M: usize>(
    chain: &Chain,
    state: &ChainState,
    ws: &mut ManipulabilityWorkspace,
    grad: &mut [f64],
) -> f64 {
    let jac = state.jacobian();
    let n = chain.dof();
    let js = jac.as_slice();
    // A = J Jᵀ (M×M, a[j][i] = A(i, j)), factored by Cholesky: det A = Π Lᵢᵢ², and B = A⁻¹ J by M×M
    // solves.
    let a = crate::linalg::gram_fixed::<M>(js, 6, n);
    let scale = (0..M).map(|i| a[i][i]).fold(0.0, f64::max).max(1e-300);
    let mut l = a;
    let mut inv = [0.0f64; M];
    let factored = crate::linalg::cholesky_fixed(&mut l, &mut inv);
    let w = if factored {
        (0..M).map(|i| l[i][i]).product::<f64>()
    } else {
        0.0
    };
    // The exact factor where A is positive definite; only at a singularity (where w → 0 anyway) a
    // tiny Tikhonov term keeps A⁻¹ finite. Damping always would bias the gradient wherever one
    // singular value of J is small but not zero.
    let ok = factored && w > 0.0 || {
        l = a;
        for (i, li) in l.iter_mut().enumerate() {
            li[i] += 1e-12 * scale;
        }
        crate::linalg::cholesky_fixed(&mut l, &mut inv)
    };
    let bs = ws.b.as_mut_slice();
    bs.fill(0.0);
    if ok {
        // All n columns solved together (up to 16 at a time, on the stack).
        for (jk, bk) in js.chunks(6 * 16).zip(bs.chunks_mut(6 * 16)) {
            let mut cols = [[0.0f64; M]; 16];
            let cnt = jk.len() / 6;
            for (c, j) in cols.iter_mut().zip(jk.chunks_exact(6)) {
                c.copy_from_slice(&j[..M]);
            }
            crate::linalg::cholesky_solve_many_fixed(&l, &inv, &mut cols[..cnt]);
            for (c, b) in cols.iter().zip(bk.chunks_exact_mut(6)) {
                b[..M].copy_from_slice(c);
            }
        }
    }
    manipulability_gradient::<M>(chain, state, w, ws, grad);
    w
}

/// [`manipulability`] from a damped least-squares solve that ran on the weighted rows J₀ = D J (first M
/// rows of the tip Jacobian, D = diag(`d`) > 0) and was undamped: its Cholesky factor L₀ = D L of
/// J₀J₀ᵀ = D A D (`l[k][i]` = L₀(i, k), `inv` its reciprocal pivots) and the rows Q = L₀⁻¹J₀ = L⁻¹J
/// (M rows of n, contiguous). Then w = √det A = Π L₀ᵢᵢ / Π dᵢ and B = A⁻¹J = L⁻ᵀQ = D L₀⁻ᵀ Q (one
/// back-substitution per column): no Gram matrix, no second factorisation.
#[allow(clippy::needless_range_loop, clippy::too_many_arguments)] // triangular index loops
pub(crate) fn manipulability_from_factor<const M: usize>(
    chain: &Chain,
    state: &ChainState,
    l: &[[f64; 6]; 6],
    inv: &[f64; 6],
    d: &[f64; 6],
    q_rows: &[f64],
    ws: &mut ManipulabilityWorkspace,
    grad: &mut [f64],
) -> f64 {
    let n = chain.dof();
    debug_assert!(q_rows.len() >= M * n);
    let w: f64 = (0..M).map(|i| l[i][i] / d[i]).product();
    let bs = ws.b.as_mut_slice();
    for c in 0..n {
        let mut b = [0.0f64; M];
        for (r, br) in b.iter_mut().enumerate() {
            *br = q_rows[r * n + c];
        }
        // L₀ᵀ b = q: row i of L₀ᵀ is column i of L₀, i.e. l[i][k] for k ≥ i.
        for i in (0..M).rev() {
            let mut s = b[i];
            for k in i + 1..M {
                s -= l[i][k] * b[k];
            }
            b[i] = s * inv[i];
        }
        let col = &mut bs[6 * c..6 * c + 6];
        for r in 0..M {
            col[r] = d[r] * b[r];
        }
        col[M..].fill(0.0);
    }
    manipulability_gradient::<M>(chain, state, w, ws, grad);
    w
}

/// ∂w/∂q_k = w · Σ_e b_e · ∂J_e/∂q_k (3.16) from B = A⁻¹ J in `ws.b` (first M rows of each column).
#[allow(clippy::needless_range_loop)] // fixed-size row loops
fn manipulability_gradient<const M: usize>(
    chain: &Chain,
    state: &ChainState,
    w: f64,
    ws: &mut ManipulabilityWorkspace,
    grad: &mut [f64],
) {
    let ManipulabilityWorkspace { b, axes, lin } = ws;
    let bs = b.as_slice();
    grad.fill(0.0);
    let joints = chain.joints();
    let frames = state.joint_frames();
    let p = state.tip_pose().translation.vector;
    let mut revolute = true;
    for (e, (je, fe)) in joints.iter().zip(frames).enumerate() {
        axes[e] = (fe.rotation * je.axis.into_inner()) * (je.sign * je.multiplier);
        revolute &= je.kind != JointKind::Prismatic;
    }
    if revolute {
        // All joints revolute: with c_e = z_e × (p − p_e) (the linear Jacobian column of joint e) and
        // B's column b_e = (b_v, b_ω), the triple products of the general loop below regroup as
        //   f < e: b_v·(z_f × c_e) + b_ω·(z_f × z_e) = z_f · (c_e × b_v + z_e × b_ω) = z_f · g_e,
        //   f ≥ e: b_v·(z_e × c_f) = c_f · (b_v × z_e) = c_f · h_e,
        // so each pair costs one 3-vector dot product instead of two nested cross products — and the
        // sum over e splits into a suffix sum of g and a prefix sum of h:
        //   ∂w/∂q_f = w (z_f · Σ_{e>f} g_e + c_f · Σ_{e≤f} h_e),
        // O(n) instead of O(n²).
        let count = joints.len();
        for (e, fe) in frames.iter().enumerate().take(count) {
            lin[e] = axes[e].cross(&(p - fe.translation.vector));
        }
        let mut suffix = Vec3::zeros(); // Σ_{e>f} g_e
        for f in (0..count).rev() {
            // grad gets z_f · Σ_{e>f} g_e first, then g_f joins the sum.
            grad[joints[f].dof] += w * axes[f].dot(&suffix);
            let be = &bs[6 * joints[f].dof..6 * joints[f].dof + 6];
            let bv = Vec3::new(be[0], be[1], be[2]);
            let mut g = lin[f].cross(&bv);
            if M == 6 {
                g += axes[f].cross(&Vec3::new(be[3], be[4], be[5]));
            }
            suffix += g;
        }
        let mut prefix = Vec3::zeros(); // Σ_{e≤f} h_e
        for f in 0..count {
            let be = &bs[6 * joints[f].dof..6 * joints[f].dof + 3];
            prefix += Vec3::new(be[0], be[1], be[2]).cross(&axes[f]);
            grad[joints[f].dof] += w * lin[f].dot(&prefix);
        }
        return;
    }
    for (e, je) in joints.iter().enumerate() {
        let ze = axes[e];
        let pe = frames[e].translation.vector;
        let be = b.column(je.dof);
        for (f, jf) in joints.iter().enumerate() {
            let zf = axes[f];
            let pf = frames[f].translation.vector;
            let (dv, dw) = match (je.kind == JointKind::Prismatic, jf.kind == JointKind::Prismatic) {
                (false, false) => {
                    if f < e {
                        (zf.cross(&ze.cross(&(p - pe))), zf.cross(&ze))
                    } else {
                        (ze.cross(&zf.cross(&(p - pf))), Vec3::zeros())
                    }
                }
                (false, true) => {
                    if f < e {
                        (Vec3::zeros(), Vec3::zeros())
                    } else {
                        (ze.cross(&zf), Vec3::zeros())
                    }
                }
                (true, false) => {
                    if f < e {
                        (zf.cross(&ze), Vec3::zeros())
                    } else {
                        (Vec3::zeros(), Vec3::zeros())
                    }
                }
                (true, true) => (Vec3::zeros(), Vec3::zeros()),
            };
            let mut s = 0.0;
            for r in 0..M.min(3) {
                s += be[r] * dv[r];
            }
            if M == 6 {
                for r in 0..3 {
                    s += be[r + 3] * dw[r];
                }
            }
            grad[jf.dof] += w * s;
        }
    }
}

/// Joint-limit potential φ_L = ½ Σ ((q_i − mid_i) / range_i)² over joints with finite limits; gradient
/// into `e`. Its descent keeps joints away from their stops; its value is 0 at mid-range and ⅛ for each
/// joint sitting at a stop.
pub fn joint_limit(chain: &Chain, q: &[f64], e: &mut [f64]) -> f64 {
    let mut phi = 0.0;
    for ((ei, qi), d) in e.iter_mut().zip(q).zip(chain.dofs()) {
        let (lo, hi) = (d.limits.lower, d.limits.upper);
        if lo.is_finite() && hi.is_finite() && hi > lo {
            let range = hi - lo;
            let x = (qi - 0.5 * (lo + hi)) / range;
            phi += 0.5 * x * x;
            *ei = x / range;
        } else {
            *ei = 0.0;
        }
    }
    phi
}

/// A contact between a fingertip (or any chain link) and a grasped object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Chain link carrying the contact (index into [`Chain::links`]).
    pub link: usize,
    /// Contact point in the chain's base frame (m).
    pub point: Vec3,
    /// Force the link applies to the object at the point, base axes (N).
    pub force: Vec3,
}

/// Net wrench of contact forces about `center` (base frame): (F, M) = (Σ fᵢ, Σ (pᵢ − c) × fᵢ).
pub fn net_wrench(contacts: &[Contact], center: &Vec3) -> (Vec3, Vec3) {
    let mut f = Vec3::zeros();
    let mut m = Vec3::zeros();
    for c in contacts {
        f += c.force;
        m += (c.point - center).cross(&c.force);
    }
    (f, m)
}

/// Force-residual potential of the grasp controller (§3.1.3.3, Coelho & Grupen):
/// φ = ½‖F‖² + ½ w² ‖M‖² for the net wrench about `center`. A force-closure grasp with balanced
/// contact forces has φ = 0.
///
/// Writes into `e` (3 per contact) the gradient of φ with respect to each contact *position* for fixed
/// contact forces, ∂φ/∂pᵢ = w² fᵢ × M (the net force does not depend on where forces are applied):
/// moving contacts along it balances the moments. With the contact-point Jacobians as feedback Jacobian
/// this drives the hand's joints. Returns φ.
pub fn force_residual(contacts: &[Contact], center: &Vec3, moment_weight: f64, e: &mut [f64]) -> f64 {
    let (f, m) = net_wrench(contacts, center);
    let w2 = moment_weight * moment_weight;
    for (i, c) in contacts.iter().enumerate() {
        let g = c.force.cross(&m) * w2;
        e[3 * i] = g.x;
        e[3 * i + 1] = g.y;
        e[3 * i + 2] = g.z;
    }
    0.5 * f.norm_squared() + 0.5 * w2 * m.norm_squared()
}

/// Gradient of the force residual with respect to each contact *force* (3 per contact) for fixed
/// positions: ∂φ/∂fᵢ = F − w² (pᵢ − c) × M. The force-domain half of the grasp controller (squeeze
/// harder on the finger that balances the wrench).
pub fn force_residual_force_gradient(contacts: &[Contact], center: &Vec3, moment_weight: f64, out: &mut DVector<f64>) {
    let (f, m) = net_wrench(contacts, center);
    let w2 = moment_weight * moment_weight;
    for (i, c) in contacts.iter().enumerate() {
        let g = f - (c.point - center).cross(&m) * w2;
        out[3 * i] = g.x;
        out[3 * i + 1] = g.y;
        out[3 * i + 2] = g.z;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn force_residual_zero_for_opposed_pinch_and_gradient_matches_fd() {
        let c = |p: [f64; 3], f: [f64; 3]| Contact {
            link: 0,
            point: Vec3::from(p),
            force: Vec3::from(f),
        };
        let pinch = [
            c([0.05, 0.0, 0.0], [-2.0, 0.0, 0.0]),
            c([-0.05, 0.0, 0.0], [2.0, 0.0, 0.0]),
        ];
        let mut e = [0.0; 6];
        assert!(force_residual(&pinch, &Vec3::zeros(), 10.0, &mut e) < 1e-20);
        // Offset contact: a couple. Check the position gradient by finite differences.
        let skew = [
            c([0.05, 0.01, 0.0], [-2.0, 0.0, 0.0]),
            c([-0.05, -0.02, 0.01], [2.0, 0.3, 0.0]),
        ];
        let mut g = [0.0; 6];
        let phi = force_residual(&skew, &Vec3::zeros(), 10.0, &mut g);
        assert!(phi > 0.0);
        let h = 1e-7;
        for i in 0..2 {
            for a in 0..3 {
                let mut plus = skew;
                let mut minus = skew;
                plus[i].point[a] += h;
                minus[i].point[a] -= h;
                let mut tmp = [0.0; 6];
                let fd = (force_residual(&plus, &Vec3::zeros(), 10.0, &mut tmp)
                    - force_residual(&minus, &Vec3::zeros(), 10.0, &mut tmp))
                    / (2.0 * h);
                assert!((fd - g[3 * i + a]).abs() < 1e-6, "{fd} vs {}", g[3 * i + a]);
            }
        }
    }
}

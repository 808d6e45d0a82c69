//! Force closure of a grasp with frictional point contacts, decided by a second-order cone program.
//!
//! The Grasp controller of the seed (§3.1.3.3) converges when the contact forces balance; whether the
//! resulting grasp can resist *any* disturbance is force closure. For point contacts with Coulomb
//! friction a grasp is force closure iff the grasp map G has full rank 6 and an internal force exists
//! strictly inside every friction cone (Murray, Li & Sastry 1994, Prop. 5.2). The second condition is
//! the SOCP
//!
//! ```text
//! maximise t  over  f_i ∈ ℝ³, t
//! subject to  Σ f_i = 0,  Σ (p_i − c) × f_i = 0          (an internal force: zero net wrench)
//!             n_i · f_i ≥ t                               (every finger pushes at least t)
//!             ‖f_i − (n_i·f_i) n_i‖ ≤ μ_i (n_i · f_i)     (inside the friction cone)
//!             Σ n_i · f_i ≤ 1                             (scale)
//! ```
//!
//! solved by Clarabel; t > 0 (the *margin*) says how deep inside the cones the best internal force
//! sits, per unit of total squeeze.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SecondOrderConeT, SolverStatus, SupportedConeT,
    ZeroConeT,
};

use crate::error::{CbError, check_finite};
use crate::math::Vec3;

/// A frictional point contact on the grasped object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactPoint {
    /// Contact position (any frame, the same for all contacts and the centre).
    pub position: Vec3,
    /// Unit normal pointing *into* the object (the direction the finger pushes).
    pub normal: Vec3,
    /// Coulomb friction coefficient (> 0).
    pub friction: f64,
}

/// The verdict on a grasp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceClosure {
    /// Rank of the 6 × 3k grasp map.
    pub rank: usize,
    /// The largest t of the SOCP (0 if infeasible): the least normal force of the best internal force,
    /// per unit of total normal force.
    pub margin: f64,
    /// Force closure: rank 6 and margin > 1e-6.
    pub closure: bool,
}

/// Decides force closure of `contacts` about `center` (the object's centre of mass).
pub fn force_closure(contacts: &[ContactPoint], center: &Vec3) -> Result<ForceClosure, CbError> {
    for (i, c) in contacts.iter().enumerate() {
        check_finite(&format!("contact {i} position"), c.position.as_slice())?;
        check_finite(&format!("contact {i} normal"), c.normal.as_slice())?;
        if !(c.friction.is_finite() && c.friction > 0.0) {
            return Err(CbError::InvalidParameter {
                name: "contact friction",
                value: c.friction,
                expected: "a positive number",
            });
        }
        if c.normal.norm() < 1e-9 {
            return Err(CbError::InvalidParameter {
                name: "contact normal length",
                value: c.normal.norm(),
                expected: "a non-zero normal",
            });
        }
    }
    let k = contacts.len();
    if k == 0 {
        return Ok(ForceClosure {
            rank: 0,
            margin: 0.0,
            closure: false,
        });
    }
    // Grasp map G (6 × 3k): force rows, then torque rows about `center`.
    let mut g = nalgebra::DMatrix::<f64>::zeros(6, 3 * k);
    for (i, c) in contacts.iter().enumerate() {
        let r = c.position - center;
        for a in 0..3 {
            g[(a, 3 * i + a)] = 1.0;
        }
        let rx = crate::math::skew(&r);
        g.view_mut((3, 3 * i), (3, 3)).copy_from(&rx);
    }
    let rank = g.clone().svd(false, false).rank(1e-9 * g.norm().max(1.0));
    // Variables x = [f_1 … f_k, t]; minimise −t.
    let vars = 3 * k + 1;
    let mut rows: Vec<Vec<(usize, f64)>> = Vec::new();
    let mut b: Vec<f64> = Vec::new();
    // Zero cone: G f = 0.
    for r in 0..6 {
        rows.push(
            (0..3 * k)
                .filter(|&j| g[(r, j)] != 0.0)
                .map(|j| (j, g[(r, j)]))
                .collect(),
        );
        b.push(0.0);
    }
    // Nonnegative: t − n_i·f_i ≤ 0, Σ n_i·f_i ≤ 1.
    let mut units = Vec::with_capacity(k);
    for c in contacts {
        units.push(c.normal.normalize());
    }
    for (i, n) in units.iter().enumerate() {
        let mut row: Vec<(usize, f64)> = (0..3).map(|a| (3 * i + a, -n[a])).collect();
        row.push((3 * k, 1.0));
        rows.push(row);
        b.push(0.0);
    }
    rows.push(
        units
            .iter()
            .enumerate()
            .flat_map(|(i, n)| (0..3).map(move |a| (3 * i + a, n[a])))
            .collect(),
    );
    b.push(1.0);
    // Second-order cones: s = (μ n·f, t1·f, t2·f), written as −A f + s = 0.
    for (i, (n, c)) in units.iter().zip(contacts).enumerate() {
        let t1 = if n.x.abs() < 0.9 {
            Vec3::x().cross(n)
        } else {
            Vec3::y().cross(n)
        }
        .normalize();
        let t2 = n.cross(&t1);
        for v in [n * c.friction, t1, t2] {
            rows.push((0..3).map(|a| (3 * i + a, -v[a])).collect());
            b.push(0.0);
        }
    }
    let m = rows.len();
    let mut triplets_i = Vec::new();
    let mut triplets_j = Vec::new();
    let mut triplets_v = Vec::new();
    for (r, row) in rows.iter().enumerate() {
        for &(j, v) in row {
            triplets_i.push(r);
            triplets_j.push(j);
            triplets_v.push(v);
        }
    }
    let a = CscMatrix::new_from_triplets(m, vars, triplets_i, triplets_j, triplets_v);
    let p = CscMatrix::zeros((vars, vars));
    let mut q = vec![0.0; vars];
    q[3 * k] = -1.0;
    let mut cones: Vec<SupportedConeT<f64>> = vec![ZeroConeT(6), NonnegativeConeT(k + 1)];
    cones.extend((0..k).map(|_| SecondOrderConeT(3)));
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .build()
        .map_err(|e| CbError::Solver(e.to_string()))?;
    let mut solver =
        DefaultSolver::new(&p, &q, &a, &b, &cones, settings).map_err(|e| CbError::Solver(e.to_string()))?;
    solver.solve();
    let margin = match solver.solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => solver.solution.x[3 * k].max(0.0),
        _ => 0.0,
    };
    Ok(ForceClosure {
        rank,
        margin,
        closure: rank == 6 && margin > 1e-6,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(p: [f64; 3], n: [f64; 3], mu: f64) -> ContactPoint {
        ContactPoint {
            position: Vec3::from(p),
            normal: Vec3::from(n),
            friction: mu,
        }
    }

    #[test]
    fn three_finger_grasp_of_a_box_is_force_closure() {
        // F1, F2 on −y, F3 on +y, as a BarrettHand closes on a 6 cm box.
        let g = [
            c([-0.025, -0.03, 0.0], [0.0, 1.0, 0.0], 0.8),
            c([0.025, -0.03, 0.0], [0.0, 1.0, 0.0], 0.8),
            c([0.0, 0.03, 0.0], [0.0, -1.0, 0.0], 0.8),
        ];
        let r = force_closure(&g, &Vec3::zeros()).unwrap();
        assert_eq!(r.rank, 6);
        assert!(r.closure && r.margin > 0.1, "{r:?}");
    }

    #[test]
    fn fingers_on_one_side_or_a_frictionless_pinch_are_not() {
        let same_side = [
            c([-0.025, -0.03, 0.0], [0.0, 1.0, 0.0], 0.8),
            c([0.025, -0.03, 0.0], [0.0, 1.0, 0.0], 0.8),
            c([0.0, -0.03, 0.01], [0.0, 1.0, 0.0], 0.8),
        ];
        assert!(!force_closure(&same_side, &Vec3::zeros()).unwrap().closure);
        // Two opposed point contacts: the rotation about their common line cannot be resisted.
        let pinch = [
            c([0.0, -0.03, 0.0], [0.0, 1.0, 0.0], 0.8),
            c([0.0, 0.03, 0.0], [0.0, -1.0, 0.0], 0.8),
        ];
        let r = force_closure(&pinch, &Vec3::zeros()).unwrap();
        assert!(r.rank < 6 && !r.closure, "{r:?}");
        // Contacts pushing at 60° from the normal with µ = 0.5 (cone half-angle 26.6°): no internal force.
        let s = (60f64).to_radians();
        let slanted = [
            c([-0.025, -0.03, 0.0], [0.0, s.cos(), s.sin()], 0.5),
            c([0.025, -0.03, 0.0], [0.0, s.cos(), s.sin()], 0.5),
            c([0.0, 0.03, 0.0], [0.0, -s.cos(), s.sin()], 0.5),
        ];
        assert!(!force_closure(&slanted, &Vec3::zeros()).unwrap().closure);
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(force_closure(&[c([f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0], 0.5)], &Vec3::zeros()).is_err());
        assert!(force_closure(&[c([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], -1.0)], &Vec3::zeros()).is_err());
        assert!(force_closure(&[c([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 0.5)], &Vec3::zeros()).is_err());
        assert!(!force_closure(&[], &Vec3::zeros()).unwrap().closure);
    }
}

//! `pbd robot fk [URDF] --base LINK --tip LINK [--q V1,…,VN] [--degrees] [--json]`.
//!
//! Forward kinematics and the geometric Jacobian of one serial chain at one configuration: the numbers a
//! user checks a URDF with, and the ones the tests compare against Pinocchio. The pose is `base_from_tip`
//! (the tip frame expressed in the base frame); the Jacobian is 6×n with rows (vx, vy, vz, ωx, ωy, ωz) in
//! base axes and one column per chain variable, in the order `--q` takes them.
//!
//! `--q` is validated here, before anything is computed: every entry must be a finite number, and there
//! must be exactly as many as the chain has variables — the error lists them, so the user can copy the
//! order.

use std::f64::consts::PI;
use std::fmt;
use std::path::PathBuf;

use anyhow::bail;
use control_basis::{Chain, ChainState, JointKind, forward_kinematics, jacobian};
use serde::{Deserialize, Serialize};

use super::{ModelSource, load_model};
use crate::table::{DECIMALS, Table, num};

/// Options of [`fk`].
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FkOptions {
    /// URDF file (default: the built-in Dexter model).
    pub urdf: Option<PathBuf>,
    /// Base link of the chain: the frame the pose and the Jacobian are expressed in.
    pub base: String,
    /// Tip link of the chain.
    pub tip: String,
    /// Joint values, one per chain variable in base-to-tip order (radians, metres for prismatic
    /// joints). `None`: all zero.
    pub q: Option<Vec<f64>>,
    /// Read the revolute and continuous entries of `q` in degrees (prismatic ones stay in metres).
    pub degrees: bool,
}

/// Forward kinematics and the Jacobian of `base → tip` at `q` (checked against the chain: the error
/// lists the chain's variables in order).
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn fk(args: &FkOptions) -> crate::Result<FkReport> {
    fk_impl(args).map_err(crate::Error::from)
}

fn fk_impl(args: &FkOptions) -> anyhow::Result<FkReport> {
    let loaded = load_model(args.urdf.as_deref())?;
    let chain = Chain::new(&loaded.model, &args.base, &args.tip)?;
    let n = chain.dof();
    let mut q = args.q.clone().unwrap_or_else(|| vec![0.0; n]);
    if q.len() != n {
        let names: Vec<&str> = chain.dofs().iter().map(|d| d.name.as_str()).collect();
        bail!(
            "q has {} value{}, but the chain {} -> {} has {n} joint variable{}; expected {n} values, in this \
             order: {}",
            q.len(),
            if q.len() == 1 { "" } else { "s" },
            chain.base(),
            chain.tip(),
            if n == 1 { "" } else { "s" },
            names.join(", ")
        );
    }
    if let Some((i, v)) = q.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        bail!("q entry {} ({v}) is not a finite number", i + 1);
    }
    if args.degrees {
        for (v, d) in q.iter_mut().zip(chain.dofs()) {
            if d.kind != JointKind::Prismatic {
                *v *= PI / 180.0;
            }
        }
    }
    chain.check_q(&q)?;
    let mut warnings = Vec::new();
    for (i, (v, d)) in q.iter().zip(chain.dofs()).enumerate() {
        if *v < d.limits.lower || *v > d.limits.upper {
            warnings.push(format!(
                "q[{}] = {v} for {} is outside its limits [{}, {}]; computing anyway",
                i + 1,
                d.name,
                d.limits.lower,
                d.limits.upper
            ));
        }
    }
    let mut state = chain.new_state();
    state.set_q(&chain, &q)?;
    forward_kinematics(&chain, &mut state);
    jacobian(&chain, &mut state);
    let mut report = FkReport::new(&loaded.source, &chain, &q, &state);
    report.warnings = warnings;
    Ok(report)
}

/// Row labels of the Jacobian.
const ROWS: [&str; 6] = ["vx", "vy", "vz", "wx", "wy", "wz"];

/// The JSON object of `pbd robot fk --json`. Field names are a public interface (README).
#[derive(Debug, Clone, Serialize)]
pub struct FkReport {
    /// `built-in:dexter` or the URDF path as given.
    pub model: String,
    /// Base link.
    pub base: String,
    /// Tip link.
    pub tip: String,
    /// The chain variables: the Jacobian's columns and the entries of `q`.
    pub joint_names: Vec<String>,
    /// Radians / metres (after the degrees conversion).
    pub q: Vec<f64>,
    /// Tip origin in the base frame (m).
    pub position: [f64; 3],
    /// `base_from_tip` rotation, row-major.
    pub rotation_rowmajor: [f64; 9],
    /// The same rotation as a unit quaternion with w ≥ 0.
    pub quaternion_xyzw: [f64; 4],
    /// Fixed-axis roll, pitch, yaw (URDF convention, R = Rz(yaw)·Ry(pitch)·Rx(roll)), radians.
    pub rpy: [f64; 3],
    /// 6×n, row-major: `jacobian_rowmajor[r * n + c]`.
    pub jacobian_rowmajor: Vec<f64>,
    /// Row labels of the Jacobian.
    pub rows: [&'static str; 6],
    /// Joint values outside their limits (computed anyway).
    #[serde(skip)]
    pub warnings: Vec<String>,
}

impl FkReport {
    fn new(source: &ModelSource, chain: &Chain, q: &[f64], state: &ChainState) -> Self {
        let pose = state.tip_pose();
        let p = pose.translation.vector;
        let r = pose.rotation.to_rotation_matrix();
        let mut rotation_rowmajor = [0.0; 9];
        for i in 0..3 {
            for j in 0..3 {
                rotation_rowmajor[3 * i + j] = r[(i, j)];
            }
        }
        // q and −q are the same rotation; pick w ≥ 0 so the output is unique.
        let c = pose.rotation.coords;
        let s = if c.w < 0.0 { -1.0 } else { 1.0 };
        let (roll, pitch, yaw) = pose.rotation.euler_angles();
        let jac = state.jacobian();
        let n = chain.dof();
        let mut jacobian_rowmajor = Vec::with_capacity(6 * n);
        for row in 0..6 {
            for col in 0..n {
                jacobian_rowmajor.push(jac[(row, col)]);
            }
        }
        FkReport {
            model: source.label(),
            base: chain.base().to_string(),
            tip: chain.tip().to_string(),
            joint_names: chain.dofs().iter().map(|d| d.name.clone()).collect(),
            q: q.to_vec(),
            position: [p.x, p.y, p.z],
            rotation_rowmajor,
            quaternion_xyzw: [s * c.x, s * c.y, s * c.z, s * c.w],
            rpy: [roll, pitch, yaw],
            jacobian_rowmajor,
            rows: ROWS,
            warnings: Vec::new(),
        }
    }
}

impl fmt::Display for FkReport {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = self;
        let n = r.joint_names.len();
        let d = DECIMALS;
        writeln!(
            out,
            "chain   {} -> {}   ({n} joint variables, model {})",
            r.base, r.tip, r.model
        )?;
        writeln!(out)?;
        writeln!(out, "joint values (rad, or m for prismatic joints)")?;
        let mut t = Table::new(["", "joint", "q"]);
        for (i, (name, q)) in r.joint_names.iter().zip(&r.q).enumerate() {
            t.row([format!("j{}", i + 1), name.clone(), num(*q, d)]);
        }
        write!(out, "{}", t.render(2))?;
        writeln!(out)?;
        writeln!(out, "tip pose in the base frame (base_from_tip)")?;
        let mut t = Table::new(Vec::<String>::new());
        t.row([
            "position (m)".to_string(),
            num(r.position[0], d),
            num(r.position[1], d),
            num(r.position[2], d),
        ]);
        for i in 0..3 {
            let label = if i == 0 { "rotation" } else { "" };
            let m = &r.rotation_rowmajor[3 * i..3 * i + 3];
            t.row([label.to_string(), num(m[0], d), num(m[1], d), num(m[2], d)]);
        }
        let qt = r.quaternion_xyzw;
        t.row([
            "quaternion (x y z w)".to_string(),
            num(qt[0], d),
            num(qt[1], d),
            num(qt[2], d),
            num(qt[3], d),
        ]);
        t.row([
            "rpy (rad)".to_string(),
            num(r.rpy[0], d),
            num(r.rpy[1], d),
            num(r.rpy[2], d),
        ]);
        write!(out, "{}", t.render(2))?;
        writeln!(out)?;
        writeln!(
            out,
            "Jacobian (6x{n}; rows: tip origin velocity and angular velocity in base axes; columns: j1..j{n} above)"
        )?;
        let mut t = Table::new(std::iter::once(String::new()).chain((1..=n).map(|c| format!("j{c}"))));
        for (row, label) in ROWS.iter().enumerate() {
            t.row(std::iter::once(label.to_string()).chain((0..n).map(|c| num(r.jacobian_rowmajor[row * n + c], d))));
        }
        write!(out, "{}", t.render(2))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternion_is_unique_and_matches_rotation() {
        let r = fk(&FkOptions {
            urdf: None,
            base: "left/base_link".into(),
            tip: "left/wrist_palm_link".into(),
            q: Some(vec![0.3, -0.4, 1.2, 2.0, -1.0, 0.7, 2.9]),
            degrees: false,
        })
        .unwrap();
        assert!(r.quaternion_xyzw[3] >= 0.0);
        let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            r.quaternion_xyzw[3],
            r.quaternion_xyzw[0],
            r.quaternion_xyzw[1],
            r.quaternion_xyzw[2],
        ));
        let m = q.to_rotation_matrix();
        for i in 0..3 {
            for j in 0..3 {
                assert!((m[(i, j)] - r.rotation_rowmajor[3 * i + j]).abs() < 1e-12);
            }
        }
        let rpy = nalgebra::UnitQuaternion::from_euler_angles(r.rpy[0], r.rpy[1], r.rpy[2]);
        assert!(rpy.angle_to(&q) < 1e-12);
        assert_eq!(r.jacobian_rowmajor.len(), 42);
    }

    #[test]
    fn wrong_length_lists_the_chain_variables() {
        let e = fk(&FkOptions {
            base: "left/base_link".into(),
            tip: "left/wrist_palm_link".into(),
            q: Some(vec![0.0]),
            ..FkOptions::default()
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("expected 7 values") && e.contains("left/"), "{e}");
    }
}

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
use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, ensure};
use clap::Args;
use control_basis::{Chain, ChainState, JointKind, forward_kinematics, jacobian};
use serde::Serialize;

use super::{ModelSource, load_model};
use crate::output::{DECIMALS, Table, num};

/// Arguments of `pbd robot fk`.
#[derive(Debug, Args)]
pub struct FkArgs {
    /// URDF file [default: the built-in Dexter model]
    urdf: Option<PathBuf>,
    /// Base link of the chain: the frame the pose and the Jacobian are expressed in.
    #[arg(long, value_name = "LINK")]
    base: String,
    /// Tip link of the chain.
    #[arg(long, value_name = "LINK")]
    tip: String,
    /// Joint values, comma-separated, one per chain variable in base-to-tip order (radians, metres for
    /// prismatic joints). `pbd robot info` lists them. Omitted: all zero.
    #[arg(long, value_name = "V1,...,VN", allow_hyphen_values = true)]
    q: Option<String>,
    /// Read the revolute and continuous entries of --q in degrees (prismatic ones stay in metres).
    #[arg(long)]
    degrees: bool,
    /// Print one JSON object with full-precision numbers instead of tables.
    #[arg(long)]
    json: bool,
}

/// A validated request: the chain cut from the model and a joint vector that fits it.
#[derive(Debug)]
pub struct FkConfig {
    source: ModelSource,
    chain: Chain,
    /// Radians / metres, one per chain variable.
    q: Vec<f64>,
    json: bool,
}

impl FkConfig {
    /// Loads the model, cuts the chain and checks `--q` against it.
    pub fn new(args: FkArgs) -> anyhow::Result<Self> {
        let loaded = load_model(args.urdf.as_deref())?;
        let chain = Chain::new(&loaded.model, &args.base, &args.tip)?;
        let n = chain.dof();
        let mut q = match &args.q {
            Some(text) => parse_q(text)?,
            None => vec![0.0; n],
        };
        if q.len() != n {
            let names: Vec<&str> = chain.dofs().iter().map(|d| d.name.as_str()).collect();
            bail!(
                "--q has {} value{}, but the chain {} -> {} has {n} joint variable{}; expected {n} values, in this \
                 order: {}",
                q.len(),
                if q.len() == 1 { "" } else { "s" },
                chain.base(),
                chain.tip(),
                if n == 1 { "" } else { "s" },
                names.join(", ")
            );
        }
        if args.degrees {
            for (v, d) in q.iter_mut().zip(chain.dofs()) {
                if d.kind != JointKind::Prismatic {
                    *v *= PI / 180.0;
                }
            }
        }
        // Already checked above with better messages; kept so the library's own rule is the final word.
        chain.check_q(&q)?;
        Ok(FkConfig {
            source: loaded.source,
            chain,
            q,
            json: args.json,
        })
    }
}

/// Parses `--q`: comma-separated finite numbers; the error names the offending entry.
fn parse_q(text: &str) -> anyhow::Result<Vec<f64>> {
    ensure!(
        !text.trim().is_empty(),
        "--q is empty; give comma-separated joint values such as --q 0.1,-0.2,0.3 (or omit --q for all zeros)"
    );
    let entries: Vec<&str> = text.split(',').collect();
    let count = entries.len();
    entries
        .iter()
        .enumerate()
        .map(|(i, raw)| {
            let entry = raw.trim();
            let pos = i + 1;
            ensure!(!entry.is_empty(), "--q entry {pos} of {count} is empty (in '{text}')");
            let v: f64 = entry
                .parse()
                .map_err(|_| anyhow::anyhow!("--q entry {pos} of {count} ('{entry}') is not a number"))?;
            ensure!(
                v.is_finite(),
                "--q entry {pos} of {count} ('{entry}') is not a finite number"
            );
            Ok(v)
        })
        .collect()
}

/// Computes FK and the Jacobian and prints them.
pub fn run(config: &FkConfig, out: &mut dyn Write) -> anyhow::Result<()> {
    let chain = &config.chain;
    for (i, (v, d)) in config.q.iter().zip(chain.dofs()).enumerate() {
        if *v < d.limits.lower || *v > d.limits.upper {
            eprintln!(
                "warning: q[{}] = {v} for {} is outside its limits [{}, {}]; computing anyway",
                i + 1,
                d.name,
                d.limits.lower,
                d.limits.upper
            );
        }
    }
    let mut state = chain.new_state();
    state.set_q(chain, &config.q)?;
    forward_kinematics(chain, &mut state);
    jacobian(chain, &mut state);
    let report = FkReport::new(config, &state);
    if config.json {
        // Serialise first: an I/O error (a closed pipe) then stays an io::Error main recognises.
        writeln!(out, "{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        write_tables(&report, out)?;
    }
    Ok(())
}

/// Row labels of the Jacobian.
const ROWS: [&str; 6] = ["vx", "vy", "vz", "wx", "wy", "wz"];

/// The JSON object of `pbd robot fk --json`. Field names are a public interface (README).
#[derive(Debug, Serialize)]
struct FkReport {
    /// `built-in:dexter` or the URDF path as given.
    model: String,
    base: String,
    tip: String,
    /// The chain variables: the Jacobian's columns and the entries of `q`.
    joint_names: Vec<String>,
    /// Radians / metres (after `--degrees` conversion).
    q: Vec<f64>,
    /// Tip origin in the base frame (m).
    position: [f64; 3],
    /// `base_from_tip` rotation, row-major.
    rotation_rowmajor: [f64; 9],
    /// The same rotation as a unit quaternion with w ≥ 0.
    quaternion_xyzw: [f64; 4],
    /// Fixed-axis roll, pitch, yaw (URDF convention, R = Rz(yaw)·Ry(pitch)·Rx(roll)), radians.
    rpy: [f64; 3],
    /// 6×n, row-major: `jacobian_rowmajor[r * n + c]`.
    jacobian_rowmajor: Vec<f64>,
    rows: [&'static str; 6],
}

impl FkReport {
    fn new(config: &FkConfig, state: &ChainState) -> Self {
        let chain = &config.chain;
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
            model: config.source.label(),
            base: chain.base().to_string(),
            tip: chain.tip().to_string(),
            joint_names: chain.dofs().iter().map(|d| d.name.clone()).collect(),
            q: config.q.clone(),
            position: [p.x, p.y, p.z],
            rotation_rowmajor,
            quaternion_xyzw: [s * c.x, s * c.y, s * c.z, s * c.w],
            rpy: [roll, pitch, yaw],
            jacobian_rowmajor,
            rows: ROWS,
        }
    }
}

fn write_tables(r: &FkReport, out: &mut dyn Write) -> anyhow::Result<()> {
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
    t.write(out, 2)?;
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
    t.write(out, 2)?;
    writeln!(out)?;
    writeln!(
        out,
        "Jacobian (6x{n}; rows: tip origin velocity and angular velocity in base axes; columns: j1..j{n} above)"
    )?;
    let mut t = Table::new(std::iter::once(String::new()).chain((1..=n).map(|c| format!("j{c}"))));
    for (row, label) in ROWS.iter().enumerate() {
        t.row(std::iter::once(label.to_string()).chain((0..n).map(|c| num(r.jacobian_rowmajor[row * n + c], d))));
    }
    t.write(out, 2)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_q_accepts_spaces_signs_and_exponents() {
        assert_eq!(parse_q("0.5, -1,+2e-1 ,3").unwrap(), vec![0.5, -1.0, 0.2, 3.0]);
    }

    #[test]
    fn parse_q_names_the_bad_entry() {
        let e = parse_q("0.1,NaN,0.3").unwrap_err().to_string();
        assert!(
            e.contains("entry 2") && e.contains("NaN") && e.contains("finite"),
            "{e}"
        );
        let e = parse_q("0.1,,0.3").unwrap_err().to_string();
        assert!(e.contains("entry 2") && e.contains("empty"), "{e}");
        let e = parse_q("0.1,inf").unwrap_err().to_string();
        assert!(e.contains("entry 2") && e.contains("inf"), "{e}");
        let e = parse_q("0.1,abc").unwrap_err().to_string();
        assert!(e.contains("'abc'") && e.contains("not a number"), "{e}");
        assert!(parse_q("  ").unwrap_err().to_string().contains("empty"));
    }

    #[test]
    fn quaternion_is_unique_and_matches_rotation() {
        let args = FkArgs {
            urdf: None,
            base: "left/base_link".into(),
            tip: "left/wrist_palm_link".into(),
            q: Some("0.3,-0.4,1.2,2.0,-1.0,0.7,2.9".into()),
            degrees: false,
            json: true,
        };
        let config = FkConfig::new(args).unwrap();
        let mut state = config.chain.new_state();
        state.set_q(&config.chain, &config.q).unwrap();
        forward_kinematics(&config.chain, &mut state);
        jacobian(&config.chain, &mut state);
        let r = FkReport::new(&config, &state);
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
}

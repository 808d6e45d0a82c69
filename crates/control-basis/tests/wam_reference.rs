//! FK and Jacobian of the WAM against Pinocchio (tests/data/wam7_kinematics.json, see PROVENANCE.md).

use control_basis::{Chain, RobotModel, forward_kinematics, jacobian};
use serde_json::Value;
use std::path::PathBuf;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn cases() -> Vec<Value> {
    let text = std::fs::read_to_string(repo().join("tests/data/wam7_kinematics.json")).unwrap();
    let v: Value = serde_json::from_str(&text).unwrap();
    v["cases"].as_array().unwrap().clone()
}

fn f64s(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

/// Largest deviation of `chain` (7 DOF, base frame = the WAM base) from every reference case.
pub fn worst_deviation(chain: &Chain) -> f64 {
    let mut s = chain.new_state();
    let mut worst: f64 = 0.0;
    for case in cases() {
        s.set_q(chain, &f64s(&case["q"])).unwrap();
        forward_kinematics(chain, &mut s);
        jacobian(chain, &mut s);
        let pos = f64s(&case["tip_position"]);
        let rot = f64s(&case["tip_rotation_rowmajor"]);
        let jac = f64s(&case["jacobian_world_aligned_6x7_rowmajor"]);
        let t = s.tip_pose();
        let r = t.rotation.to_rotation_matrix();
        for i in 0..3 {
            worst = worst.max((t.translation.vector[i] - pos[i]).abs());
            for j in 0..3 {
                worst = worst.max((r[(i, j)] - rot[3 * i + j]).abs());
            }
        }
        for i in 0..6 {
            for j in 0..7 {
                worst = worst.max((s.jacobian()[(i, j)] - jac[7 * i + j]).abs());
            }
        }
    }
    worst
}

#[test]
fn wam_urdf_matches_pinocchio_to_1e_9() {
    let urdf = repo().join("../shared/reference/wam7/wam7.urdf");
    if !urdf.exists() {
        eprintln!(
            "SKIPPED: {} not found (the GPL WAM URDF lives in ../shared beside the repository)",
            urdf.display()
        );
        return;
    }
    let model = RobotModel::from_urdf_file(&urdf).unwrap();
    let chain = Chain::new(&model, "wam/base_link", "wam/wrist_palm_link").unwrap();
    assert_eq!(chain.dof(), 7);
    let worst = worst_deviation(&chain);
    assert!(worst < 1e-9, "worst deviation {worst:e}");
}

#[test]
fn dexter_arms_match_pinocchio_wam_in_their_base_frames_to_1e_9() {
    let model = RobotModel::from_urdf_file(repo().join("assets/dexter.urdf")).unwrap();
    for side in ["left", "right"] {
        let chain = Chain::new(&model, &format!("{side}/base_link"), &format!("{side}/wrist_palm_link")).unwrap();
        assert_eq!(chain.dof(), 7);
        let worst = worst_deviation(&chain);
        assert!(worst < 1e-9, "{side} arm: worst deviation {worst:e}");
    }
}

#[test]
fn dexter_hands_match_pinocchio_bhand_fingertips() {
    // tests/data/bhand_kinematics.json: fingertips in the palm frame for 8 hand joints (independent).
    let text = std::fs::read_to_string(repo().join("tests/data/bhand_kinematics.json")).unwrap();
    let v: Value = serde_json::from_str(&text).unwrap();
    let model = RobotModel::from_urdf_file(repo().join("assets/dexter.urdf")).unwrap();
    let mut worst: f64 = 0.0;
    let mut checked = 0;
    for side in ["left", "right"] {
        for (f, prox, med, key) in [(1, Some(0), 1, "f1"), (2, Some(3), 4, "f2"), (3, None, 6, "f3")] {
            let chain = Chain::new(
                &model,
                &format!("{side}/bhand/palm_link"),
                &format!("{side}/bhand/finger_{f}/tip_link"),
            )
            .unwrap();
            let mut s = chain.new_state();
            for case in v["cases"].as_array().unwrap() {
                let hq = f64s(&case["hand_q"]);
                // Only cases that respect the coupling (dist = med/3; F2 spread = F1 spread) are
                // reproducible by Dexter's 4-DOF hand.
                let coupled = (hq[2] - hq[1] / 3.0).abs() < 1e-12
                    && (hq[5] - hq[4] / 3.0).abs() < 1e-12
                    && (hq[7] - hq[6] / 3.0).abs() < 1e-12
                    && (hq[0] - hq[3]).abs() < 1e-12;
                if !coupled {
                    continue;
                }
                let q: Vec<f64> = match prox {
                    Some(p) => vec![hq[p], hq[med]],
                    None => vec![hq[med]],
                };
                s.set_q(&chain, &q).unwrap();
                forward_kinematics(&chain, &mut s);
                let pos = f64s(&case[format!("{key}_tip_position")]);
                for (i, p) in pos.iter().enumerate() {
                    worst = worst.max((s.tip_pose().translation.vector[i] - p).abs());
                }
                checked += 1;
            }
        }
    }
    assert!(checked >= 6 * 10, "checked {checked}");
    assert!(worst < 1e-9, "worst fingertip deviation {worst:e}");
}

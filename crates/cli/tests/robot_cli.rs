//! End-to-end runs of the built `pbd` binary: `pbd robot info` and `pbd robot fk`, on the built-in
//! Dexter model and on the Barrett WAM URDF against Pinocchio's numbers (tests/data/wam7_kinematics.json,
//! see tests/data/PROVENANCE.md), plus every kind of bad input a user can give.

use crate::common;

use common::{pbd, repo, stderr, stdout};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use serde_json::Value;

/// Runs `pbd` expecting success and returns stdout.
fn ok(args: &[&str]) -> String {
    let o = pbd(args);
    assert!(o.status.success(), "pbd {args:?} failed: {}", stderr(&o));
    stdout(&o)
}

/// Runs `pbd` expecting success with `--json` and parses stdout.
fn ok_json(args: &[&str]) -> Value {
    let text = ok(args);
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("pbd {args:?} printed invalid JSON ({e}):\n{text}"))
}

/// Runs `pbd` expecting a clean failure (exit code 1, `error: …` on stderr, nothing on stdout, no panic)
/// and returns stderr.
fn fails(args: &[&str]) -> String {
    let o = pbd(args);
    let err = stderr(&o);
    assert_eq!(
        o.status.code(),
        Some(1),
        "pbd {args:?}: expected exit code 1, stderr: {err}"
    );
    assert!(
        err.starts_with("error: "),
        "pbd {args:?}: stderr should start with 'error: ': {err}"
    );
    assert!(!err.contains("panicked"), "pbd {args:?} panicked: {err}");
    assert!(o.stdout.is_empty(), "pbd {args:?} printed to stdout: {}", stdout(&o));
    err
}

/// A file under the temp dir with a name unique to this process and call.
struct TempFile(PathBuf);

impl TempFile {
    fn new(tag: &str, contents: &str) -> Self {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let path = std::env::temp_dir().join(format!("pbd-robot-cli-{}-{n}-{tag}.urdf", std::process::id()));
        std::fs::write(&path, contents).unwrap();
        TempFile(path)
    }
    fn path(&self) -> &str {
        self.0.to_str().unwrap()
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

fn f64s(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn q_arg(q: &[f64]) -> String {
    q.iter().map(f64::to_string).collect::<Vec<_>>().join(",")
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

const LEFT_ARM: [&str; 4] = ["--base", "left/base_link", "--tip", "left/wrist_palm_link"];

// ---------------------------------------------------------------------------------------------------
// pbd robot info

#[test]
fn info_on_builtin_dexter_lists_dofs_mimics_and_chains() {
    let text = ok(&["robot", "info"]);
    for needle in [
        "dexter",
        "left/base_yaw_joint",
        "revolute",
        "mimic couplings",
        "left/bhand/finger_1/dist_joint",
        "left arm",
        "right arm",
        "head left camera",
        "left/bhand/finger_3/tip_link",
    ] {
        assert!(text.contains(needle), "'{needle}' missing from:\n{text}");
    }
}

#[test]
fn info_json_parses_with_documented_fields() {
    let v = ok_json(&["robot", "info", "--json"]);
    assert_eq!(v["name"], "dexter");
    assert_eq!(v["source"], "built-in:dexter");
    assert_eq!(v["root"], "world");
    for key in ["link_count", "joint_count", "dof_count"] {
        assert!(v[key].as_u64().unwrap() > 0, "{key}");
    }
    let dofs = v["dofs"].as_array().unwrap();
    assert_eq!(dofs.len() as u64, v["dof_count"].as_u64().unwrap());
    // 2 arms × 7 + 2 hands × 4 + head 4.
    assert_eq!(dofs.len(), 26);
    for d in dofs {
        for key in [
            "name", "kind", "parent", "child", "lower", "upper", "velocity", "effort",
        ] {
            assert!(d.get(key).is_some(), "dof field {key} missing: {d}");
        }
    }
    let mimic = v["mimic"].as_array().unwrap();
    assert!(!mimic.is_empty(), "the BarrettHand fingers have <mimic> joints");
    assert!(
        mimic
            .iter()
            .all(|m| m["follows"].is_string() && m["multiplier"].is_f64())
    );
    let named = v["named_chains"].as_array().unwrap();
    let left = named.iter().find(|c| c["name"] == "left arm").expect("left arm");
    assert_eq!(left["base"], "left/base_link");
    assert_eq!(left["tip"], "left/wrist_palm_link");
    assert_eq!(left["dof"], 7);
    assert_eq!(left["dof_names"].as_array().unwrap().len(), 7);
    let head = named
        .iter()
        .find(|c| c["tip"] == "head/left_camera_optical_frame")
        .expect("head camera");
    assert_eq!(head["base"], "head/base_link");
    let leaves = v["leaf_chains"].as_array().unwrap();
    assert!(leaves.iter().any(|c| c["link"] == "right/bhand/finger_2/tip_link"));
}

#[test]
fn info_on_wam_urdf_finds_the_arm() {
    let Some(urdf) = wam_urdf() else { return };
    let v = ok_json(&["robot", "info", urdf.to_str().unwrap(), "--json"]);
    assert_eq!(v["dof_count"], 7);
    let arm = &v["named_chains"][0];
    assert_eq!(arm["base"], "wam/base_link");
    assert_eq!(arm["tip"], "wam/wrist_palm_link");
    assert_eq!(arm["dof"], 7);
}

// ---------------------------------------------------------------------------------------------------
// pbd robot fk

#[test]
fn fk_on_dexter_arm_prints_pose_and_jacobian() {
    let q = "0.1,0.2,0.3,0.4,0.5,0.6,0.7";
    let text = ok(&[
        "robot",
        "fk",
        LEFT_ARM[0],
        LEFT_ARM[1],
        LEFT_ARM[2],
        LEFT_ARM[3],
        "--q",
        q,
    ]);
    for needle in [
        "position (m)",
        "rotation",
        "quaternion",
        "rpy",
        "Jacobian",
        "left/palm_yaw_joint",
        "wz",
    ] {
        assert!(text.contains(needle), "'{needle}' missing from:\n{text}");
    }
    let v = ok_json(&[
        "robot",
        "fk",
        LEFT_ARM[0],
        LEFT_ARM[1],
        LEFT_ARM[2],
        LEFT_ARM[3],
        "--q",
        q,
        "--json",
    ]);
    assert_eq!(v["base"], "left/base_link");
    assert_eq!(v["tip"], "left/wrist_palm_link");
    assert_eq!(v["joint_names"].as_array().unwrap().len(), 7);
    assert_eq!(f64s(&v["q"]), vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]);
    assert_eq!(f64s(&v["position"]).len(), 3);
    assert_eq!(f64s(&v["rotation_rowmajor"]).len(), 9);
    assert_eq!(f64s(&v["quaternion_xyzw"]).len(), 4);
    assert_eq!(f64s(&v["jacobian_rowmajor"]).len(), 42);
    assert_eq!(v["rows"], serde_json::json!(["vx", "vy", "vz", "wx", "wy", "wz"]));
    // The rotation is orthonormal.
    let r = f64s(&v["rotation_rowmajor"]);
    for i in 0..3 {
        for j in 0..3 {
            let dot: f64 = (0..3).map(|k| r[3 * i + k] * r[3 * j + k]).sum();
            assert!((dot - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
        }
    }
}

#[test]
fn fk_jacobian_position_rows_match_finite_differences_of_printed_positions() {
    let q = [0.3, -0.4, 0.5, 1.1, -0.6, 0.4, 0.2];
    let fk = |q: &[f64]| {
        let qs = q_arg(q);
        ok_json(&[
            "robot",
            "fk",
            LEFT_ARM[0],
            LEFT_ARM[1],
            LEFT_ARM[2],
            LEFT_ARM[3],
            "--q",
            &qs,
            "--json",
        ])
    };
    let jac = f64s(&fk(&q)["jacobian_rowmajor"]);
    let h = 1e-6;
    for c in 0..7 {
        let (mut qp, mut qm) = (q, q);
        qp[c] += h;
        qm[c] -= h;
        let (pp, pm) = (f64s(&fk(&qp)["position"]), f64s(&fk(&qm)["position"]));
        for r in 0..3 {
            let fd = (pp[r] - pm[r]) / (2.0 * h);
            assert!(
                (fd - jac[7 * r + c]).abs() < 1e-7,
                "J[{r},{c}] = {} vs finite difference {fd}",
                jac[7 * r + c]
            );
        }
    }
}

#[test]
fn fk_without_q_uses_zeros_and_degrees_convert() {
    let zeros = ok_json(&[
        "robot",
        "fk",
        LEFT_ARM[0],
        LEFT_ARM[1],
        LEFT_ARM[2],
        LEFT_ARM[3],
        "--json",
    ]);
    assert_eq!(f64s(&zeros["q"]), vec![0.0; 7]);
    let rad = ok_json(&[
        "robot",
        "fk",
        LEFT_ARM[0],
        LEFT_ARM[1],
        LEFT_ARM[2],
        LEFT_ARM[3],
        "--q",
        &q_arg(&[90f64.to_radians(), -0.5, 0.0, 1.0, 0.0, 0.0, 0.25]),
        "--json",
    ]);
    let deg = ok_json(&[
        "robot",
        "fk",
        LEFT_ARM[0],
        LEFT_ARM[1],
        LEFT_ARM[2],
        LEFT_ARM[3],
        "--degrees",
        "--q",
        &q_arg(&[
            90.0,
            (-0.5f64).to_degrees(),
            0.0,
            1f64.to_degrees(),
            0.0,
            0.0,
            0.25f64.to_degrees(),
        ]),
        "--json",
    ]);
    assert!(max_abs_diff(&f64s(&rad["q"]), &f64s(&deg["q"])) < 1e-12);
    assert!(max_abs_diff(&f64s(&rad["position"]), &f64s(&deg["position"])) < 1e-12);
}

#[test]
fn fk_accepts_negative_first_value_with_or_without_equals() {
    let a = ok_json(&[
        "robot",
        "fk",
        LEFT_ARM[0],
        LEFT_ARM[1],
        LEFT_ARM[2],
        LEFT_ARM[3],
        "--q",
        "-0.5,0,0,0,0,0,0",
        "--json",
    ]);
    let b = ok_json(&[
        "robot",
        "fk",
        LEFT_ARM[0],
        LEFT_ARM[1],
        LEFT_ARM[2],
        LEFT_ARM[3],
        "--q=-0.5,0,0,0,0,0,0",
        "--json",
    ]);
    assert_eq!(f64s(&a["q"])[0], -0.5);
    assert_eq!(a["position"], b["position"]);
}

fn wam_urdf() -> Option<PathBuf> {
    let urdf = repo().join("../shared/reference/wam7/wam7.urdf");
    if urdf.exists() {
        Some(urdf)
    } else {
        eprintln!(
            "SKIPPED: {} not found (the GPL WAM URDF lives in ../shared beside the repository)",
            urdf.display()
        );
        None
    }
}

/// Acceptance: `pbd robot fk` prints the same numbers as Pinocchio for every reference case, both for
/// the wrist palm link and the flange (`wrist_palm_stump_link`).
#[test]
fn fk_on_wam_prints_pinocchio_numbers_to_1e_9() {
    let Some(urdf) = wam_urdf() else { return };
    let urdf = urdf.to_str().unwrap();
    let text = std::fs::read_to_string(repo().join("tests/data/wam7_kinematics.json")).unwrap();
    let reference: Value = serde_json::from_str(&text).unwrap();
    let base = reference["base_frame"].as_str().unwrap();
    let tip = reference["tip_frame"].as_str().unwrap();
    let flange = reference["flange_frame"].as_str().unwrap();
    let joint_names = &reference["joint_names"];
    let cases = reference["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 31);
    let mut worst: f64 = 0.0;
    for (i, case) in cases.iter().enumerate() {
        let q = q_arg(&f64s(&case["q"]));
        let out = ok_json(&["robot", "fk", urdf, "--base", base, "--tip", tip, "--q", &q, "--json"]);
        assert_eq!(&out["joint_names"], joint_names, "case {i}");
        // The printed q round-trips exactly.
        assert_eq!(f64s(&out["q"]), f64s(&case["q"]), "case {i}");
        for (got, want) in [
            ("position", "tip_position"),
            ("rotation_rowmajor", "tip_rotation_rowmajor"),
            ("jacobian_rowmajor", "jacobian_world_aligned_6x7_rowmajor"),
        ] {
            let d = max_abs_diff(&f64s(&out[got]), &f64s(&case[want]));
            assert!(d < 1e-9, "case {i}: {got} differs from Pinocchio's {want} by {d:e}");
            worst = worst.max(d);
        }
        let out = ok_json(&[
            "robot", "fk", urdf, "--base", base, "--tip", flange, "--q", &q, "--json",
        ]);
        for (got, want) in [
            ("position", "flange_position"),
            ("jacobian_rowmajor", "flange_jacobian_world_aligned_6x7_rowmajor"),
        ] {
            let d = max_abs_diff(&f64s(&out[got]), &f64s(&case[want]));
            assert!(
                d < 1e-9,
                "case {i}: flange {got} differs from Pinocchio's {want} by {d:e}"
            );
            worst = worst.max(d);
        }
    }
    eprintln!("worst deviation from Pinocchio over {} cases: {worst:e}", cases.len());
}

// ---------------------------------------------------------------------------------------------------
// Bad input: exit code 1, a clear message, no panic.

#[test]
fn missing_urdf_file_is_reported_with_its_path() {
    let missing = std::env::temp_dir().join(format!("pbd-robot-cli-{}-does-not-exist.urdf", std::process::id()));
    let missing = missing.to_str().unwrap();
    let err = fails(&["robot", "info", missing]);
    assert!(err.contains(missing) && err.contains("cannot read"), "{err}");
    let err = fails(&["robot", "fk", missing, "--base", "a", "--tip", "b"]);
    assert!(err.contains(missing), "{err}");
}

#[test]
fn urdf_that_is_not_xml_is_malformed() {
    let f = TempFile::new("not-xml", "this is not xml at all {");
    let err = fails(&["robot", "info", f.path()]);
    assert!(err.contains("malformed URDF") && err.contains(f.path()), "{err}");
}

#[test]
fn urdf_with_missing_attributes_is_malformed() {
    // A link without its name attribute.
    let f = TempFile::new("no-name", r#"<robot name="r"><link/></robot>"#);
    let err = fails(&["robot", "info", f.path()]);
    assert!(err.contains("malformed URDF") && err.contains("name"), "{err}");
    // A joint without its parent element.
    let f = TempFile::new(
        "no-parent",
        r#"<robot name="r"><link name="a"/><link name="b"/>
           <joint name="j" type="revolute"><child link="b"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"#,
    );
    let err = fails(&["robot", "fk", f.path(), "--base", "a", "--tip", "b"]);
    assert!(err.contains("malformed URDF") && err.contains("parent"), "{err}");
}

#[test]
fn unsupported_joint_type_is_rejected() {
    let f = TempFile::new(
        "planar",
        r#"<robot name="r"><link name="a"/><link name="b"/>
           <joint name="slide" type="planar"><parent link="a"/><child link="b"/></joint></robot>"#,
    );
    let err = fails(&["robot", "info", f.path()]);
    assert!(err.contains("slide") && err.contains("not supported"), "{err}");
}

#[test]
fn unknown_link_is_named_with_suggestions() {
    let err = fails(&["robot", "fk", "--base", "left/base_link", "--tip", "wrist_palm_link"]);
    assert!(err.contains("unknown link 'wrist_palm_link'"), "{err}");
    assert!(
        err.contains("left/wrist_palm_link") && err.contains("right/wrist_palm_link"),
        "{err}"
    );
}

#[test]
fn wrong_number_of_joint_values_says_how_many_and_which() {
    let err = fails(&[
        "robot",
        "fk",
        LEFT_ARM[0],
        LEFT_ARM[1],
        LEFT_ARM[2],
        LEFT_ARM[3],
        "--q",
        "0.1,0.2",
    ]);
    assert!(err.contains("expected 7 values"), "{err}");
    assert!(err.contains("has 2 values"), "{err}");
    assert!(
        err.contains("left/base_yaw_joint") && err.contains("left/palm_yaw_joint"),
        "{err}"
    );
}

#[test]
fn nan_in_q_is_rejected_naming_the_entry() {
    let err = fails(&[
        "robot",
        "fk",
        LEFT_ARM[0],
        LEFT_ARM[1],
        LEFT_ARM[2],
        LEFT_ARM[3],
        "--q",
        "0,0,NaN,0,0,0,0",
    ]);
    assert!(
        err.contains("entry 3") && err.contains("NaN") && err.contains("not a finite number"),
        "{err}"
    );
    let err = fails(&[
        "robot",
        "fk",
        LEFT_ARM[0],
        LEFT_ARM[1],
        LEFT_ARM[2],
        LEFT_ARM[3],
        "--q",
        "0,0,0,inf,0,0,0",
    ]);
    assert!(err.contains("entry 4") && err.contains("inf"), "{err}");
}

#[test]
fn empty_and_non_numeric_q_entries_are_rejected() {
    let err = fails(&[
        "robot",
        "fk",
        LEFT_ARM[0],
        LEFT_ARM[1],
        LEFT_ARM[2],
        LEFT_ARM[3],
        "--q",
        "0,,0,0,0,0,0",
    ]);
    assert!(err.contains("entry 2") && err.contains("empty"), "{err}");
    let err = fails(&[
        "robot",
        "fk",
        LEFT_ARM[0],
        LEFT_ARM[1],
        LEFT_ARM[2],
        LEFT_ARM[3],
        "--q",
        "0,0,0,0,0,0,x",
    ]);
    assert!(err.contains("entry 7") && err.contains("'x'"), "{err}");
    let err = fails(&[
        "robot",
        "fk",
        LEFT_ARM[0],
        LEFT_ARM[1],
        LEFT_ARM[2],
        LEFT_ARM[3],
        "--q",
        "",
    ]);
    assert!(err.contains("--q is empty"), "{err}");
}

#[test]
fn base_equal_to_tip_is_rejected() {
    let err = fails(&["robot", "fk", "--base", "left/base_link", "--tip", "left/base_link"]);
    assert!(err.contains("same link"), "{err}");
}

#[test]
fn chain_without_moving_joint_is_rejected() {
    let err = fails(&["robot", "fk", "--base", "world", "--tip", "chassis/left_camera_link"]);
    assert!(err.contains("no moving joint"), "{err}");
}

#[test]
fn usage_errors_exit_with_2() {
    let o = pbd(&["robot", "fk", "--tip", "left/wrist_palm_link"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--base"), "{}", stderr(&o));
    let o = pbd(&["robot", "frobnicate"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn help_exits_with_0() {
    let o = pbd(&["robot", "fk", "--help"]);
    assert_eq!(o.status.code(), Some(0));
    assert!(stdout(&o).contains("--degrees"));
}

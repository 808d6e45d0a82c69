//! `pbd calibrate` then `pbd execute --calibration FILE`: the file the command writes for a
//! workcell gives the same run as the calibration `pbd execute` computes by itself (same placed
//! count, same per-object outcomes); bad calibration files and outputs are refused with exit code 1
//! and a message naming them.

use crate::common;

use std::path::{Path, PathBuf};

use common::{pbd, refused, repo, stderr};
use serde_json::Value;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pbd-calibrate-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

fn ok_json(args: &[&str]) -> Value {
    let o = pbd(args);
    assert!(o.status.success(), "pbd {args:?} failed: {}", stderr(&o));
    serde_json::from_slice(&o.stdout).expect("valid JSON")
}

/// The report without what depends on the machine's speed.
fn outcome(mut v: Value) -> Value {
    let o = v.as_object_mut().expect("object");
    o.remove("wall_time");
    v
}

#[test]
fn execute_with_the_calibration_file_equals_execute_without() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: simulation end-to-end tests run in release mode");
        return;
    }
    let d = dir("same");
    let cal = d.join("workcell.cal");
    let report = ok_json(&["calibrate", "--scene", "pick-place", "-o", &s(&cal), "--json"]);
    assert_eq!(report["file"], s(&cal), "{report:#}");
    assert_eq!(report["bytes"].as_u64(), Some(std::fs::metadata(&cal).unwrap().len()));
    assert!(report["views"].as_u64().unwrap() > 4, "{report:#}");
    let cameras = report["cameras"].as_array().unwrap();
    assert!(cameras.iter().any(|c| c["name"] == "head/left"), "{report:#}");
    // No temporary file is left beside it.
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);

    let model = s(&repo().join("crates/py/tests/data/sorting-model.json"));
    let base = ["execute", "--scene", "pick-place", "--model", &model, "--json"];
    let without = ok_json(&base);
    let mut args = base.to_vec();
    let cal_s = s(&cal);
    args.extend(["--calibration", &cal_s]);
    let with = ok_json(&args);
    assert_eq!(with["placed"], without["placed"]);
    assert_eq!(
        with["objects"].as_array().map(Vec::len),
        without["objects"].as_array().map(Vec::len)
    );
    assert_eq!(outcome(with), outcome(without), "the run with the file differs");

    // The text report names the file and how to use it.
    let o = pbd(&["calibrate", "--scene", "pick-place", "-o", &cal_s]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = common::stdout(&o);
    assert!(text.contains("head/left") && text.contains("--calibration"), "{text}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_calibration_files_and_outputs_are_refused() {
    let d = dir("bad");
    let model = s(&repo().join("crates/py/tests/data/sorting-model.json"));
    let garbage = d.join("garbage.cal");
    std::fs::write(&garbage, b"\xa2\x66format\x63pbd\x67version\x01").unwrap();
    refused(
        &[
            "execute",
            "--scene",
            "pick-place",
            "--model",
            &model,
            "--calibration",
            &s(&garbage),
        ],
        &[&s(&garbage), "not a pbd calibration file", "\"pbd\""],
    );
    let v2 = d.join("v2.cal");
    // {"format": "pbd-calibration", "version": 2}
    let mut bytes = vec![0xa2, 0x66];
    bytes.extend(b"format");
    bytes.push(0x6f);
    bytes.extend(b"pbd-calibration");
    bytes.push(0x67);
    bytes.extend(b"version");
    bytes.push(0x02);
    std::fs::write(&v2, &bytes).unwrap();
    refused(
        &[
            "execute",
            "--scene",
            "pick-place",
            "--model",
            &model,
            "--calibration",
            &s(&v2),
        ],
        &[&s(&v2), "version 2 is not supported"],
    );
    refused(
        &[
            "execute",
            "--scene",
            "pick-place",
            "--model",
            &model,
            "--calibration",
            &s(&d.join("none.cal")),
        ],
        &["none.cal"],
    );
    // Outputs: a directory that does not exist, the model (an input of nothing here, but a
    // directory), checked before the calibration runs.
    refused(
        &["calibrate", "--scene", "pick-place", "-o", &s(&d.join("no/such/w.cal"))],
        &["does not exist"],
    );
    refused(&["calibrate", "--scene", "pick-place", "-o", &s(&d)], &["directory"]);
    refused(&["calibrate", "--scene", "no-such-scene"], &["no-such-scene"]);
    let _ = std::fs::remove_dir_all(&d);
}

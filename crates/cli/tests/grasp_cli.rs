//! End-to-end tests of `pbd grasp`: bad input is a clear error with a non-zero exit; learning works on
//! a small corpus; in release mode, record, generate and a reduced eval run in the simulator.

use crate::common;

use std::path::{Path, PathBuf};

use common::{pbd, stderr, stdout};
use serde_json::{Value, json};

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pbd-grasp-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

fn fails_with(args: &[&str], needles: &[&str]) {
    let o = pbd(args);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
    let e = stderr(&o);
    assert!(e.starts_with("error: "), "{e}");
    for n in needles {
        assert!(e.contains(n), "{args:?}: expected {n:?} in {e}");
    }
    assert!(!e.contains("panicked"), "{e}");
}

fn ok_json(args: &[&str]) -> Value {
    let o = pbd(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    serde_json::from_str(&stdout(&o)).expect("JSON on stdout")
}

/// A small corpus: two kinds of grasp (top-down on round-looking objects, side on tall-looking
/// ones), three objects each.
fn small_corpus() -> Value {
    let top = [0.0, 1.0, 0.0, 0.0]; // palm down: 180° about x
    let side = [0.5, -0.5, 0.5, -0.5];
    let mut objects = Vec::new();
    for m in 0..6 {
        let tall = m >= 3;
        let s = 1.0 + 0.1 * m as f64;
        let b = if tall {
            [[10.0 * s, 0.5], [0.5, 60.0 * s]]
        } else {
            [[12.0 * s, 0.2], [0.2, 14.0 * s]]
        };
        let grasps: Vec<Value> = (0..4)
            .map(|i| {
                let e = 0.003 * (i as f64 - 1.5);
                if tall {
                    json!({ "position": [-0.08 + e, e, 0.0], "orientation": side })
                } else {
                    json!({ "position": [e, -e, 0.07 + e], "orientation": top })
                }
            })
            .collect();
        objects.push(json!({ "name": format!("obj-{m}"), "appearance": b, "grasps": grasps }));
    }
    json!({ "format": "pbd-grasp-corpus", "version": 1, "objects": objects })
}

fn write(dir: &Path, name: &str, v: &Value) -> String {
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_string_pretty(v).expect("json")).expect("write");
    p.display().to_string()
}

#[test]
fn learn_rejects_bad_corpora() {
    let d = tmp("bad");
    let out = d.join("m.json").display().to_string();
    let mut c = small_corpus();
    // No grasps.
    c["objects"][0]["grasps"] = json!([]);
    let p = write(&d, "empty.json", &c);
    fails_with(&["grasp", "learn", &p, "-o", &out], &["empty corpus", "no grasps"]);
    // No objects.
    let p = write(
        &d,
        "none.json",
        &json!({ "format": "pbd-grasp-corpus", "version": 1, "objects": [] }),
    );
    fails_with(&["grasp", "learn", &p, "-o", &out], &["empty corpus"]);
    // Wrong dimensions.
    let mut c = small_corpus();
    c["objects"][1]["grasps"][2]["position"] = json!([0.0, 0.1]);
    let p = write(&d, "dims.json", &c);
    fails_with(
        &["grasp", "learn", &p, "-o", &out],
        &["objects[1].grasps[2].position", "expected 3 numbers, got 2"],
    );
    let mut c = small_corpus();
    c["objects"][0]["appearance"] = json!([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let p = write(&d, "dims2.json", &c);
    fails_with(
        &["grasp", "learn", &p, "-o", &out],
        &["objects[0].appearance[0]", "expected 2"],
    );
    // Not positive definite.
    let mut c = small_corpus();
    c["objects"][2]["appearance"] = json!([[1.0, 2.0], [2.0, 1.0]]);
    let p = write(&d, "npd.json", &c);
    fails_with(
        &["grasp", "learn", &p, "-o", &out],
        &["objects[2].appearance", "not symmetric positive definite"],
    );
    // Not JSON, missing file, wrong format.
    let p = d.join("junk.json");
    std::fs::write(&p, "{ not json").expect("write");
    fails_with(
        &["grasp", "learn", &p.display().to_string(), "-o", &out],
        &["grasp corpus"],
    );
    fails_with(
        &[
            "grasp",
            "learn",
            &d.join("missing.json").display().to_string(),
            "-o",
            &out,
        ],
        &["missing.json"],
    );
    let p = write(
        &d,
        "fmt.json",
        &json!({ "format": "something", "version": 1, "objects": [] }),
    );
    fails_with(&["grasp", "learn", &p, "-o", &out], &["unsupported format"]);
    // Bad config.
    let p = write(&d, "ok.json", &small_corpus());
    fails_with(
        &["grasp", "learn", &p, "-o", &out, "--prototypes", "0"],
        &["config.prototypes"],
    );
    assert!(!Path::new(&out).exists(), "no model is written on bad input");
}

#[test]
fn learn_writes_a_model_with_shared_prototypes() {
    let d = tmp("learn");
    let p = write(&d, "corpus.json", &small_corpus());
    let out = d.join("m.json").display().to_string();
    let args = [
        "grasp",
        "learn",
        &p,
        "-o",
        &out,
        "--prototypes",
        "4",
        "--orientations",
        "2",
        "--burn-in",
        "30",
        "--chains",
        "2",
        "--seed",
        "3",
        "--json",
    ];
    let s = ok_json(&args);
    assert_eq!(s["objects"], 6);
    assert_eq!(s["grasps"], 24);
    let k = s["prototypes"].as_u64().expect("prototypes");
    assert!((1..=4).contains(&k), "{s}");
    // The two kinds of grasp are each shared by three objects.
    assert!(s["shared_fraction"].as_f64().expect("fraction") >= 0.5, "{s}");
    let model: Value = serde_json::from_str(&std::fs::read_to_string(&out).expect("model")).expect("json");
    assert_eq!(model["format"], "pbd-grasp-model");
    // Same seed, same model.
    let first = std::fs::read_to_string(&out).expect("model");
    ok_json(&args);
    assert_eq!(first, std::fs::read_to_string(&out).expect("model"));
    // The nonparametric variant and the human output.
    let out2 = d.join("dp.json").display().to_string();
    let o = pbd(&[
        "grasp",
        "learn",
        &p,
        "-o",
        &out2,
        "--nonparametric",
        "--burn-in",
        "30",
        "--chains",
        "2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("learned"), "{}", stdout(&o));
    assert!(stdout(&o).contains("obj-5"), "sharing table printed: {}", stdout(&o));
}

#[test]
fn generate_and_record_reject_bad_input() {
    let d = tmp("gen-bad");
    let p = write(&d, "corpus.json", &small_corpus());
    let model = d.join("m.json").display().to_string();
    let o = pbd(&["grasp", "learn", &p, "-o", &model, "--burn-in", "10", "--chains", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    fails_with(
        &["grasp", "generate", "--model", &model, "--object", "no_such_thing"],
        &["unknown object", "no_such_thing"],
    );
    fails_with(
        &[
            "grasp",
            "generate",
            "--model",
            &d.join("nope.json").display().to_string(),
            "--object",
            "jif",
        ],
        &["nope.json"],
    );
    // A corpus is not a model.
    fails_with(
        &["grasp", "generate", "--model", &p, "--object", "jif"],
        &["grasp model"],
    );
    fails_with(
        &[
            "grasp", "generate", "--model", &model, "--object", "jif", "--xy", "5", "0",
        ],
        &["not on the table"],
    );
    let out = d.join("c.json").display().to_string();
    fails_with(
        &["grasp", "record", "--objects", "jif,bogus", "-o", &out],
        &["unknown object", "bogus"],
    );
    fails_with(
        &["grasp", "record", "--objects", "jif,jif-1", "--teleop", &p, "-o", &out],
        &["exactly one"],
    );
    fails_with(
        &["grasp", "record", "--objects", "jif", "--demos", "0", "-o", &out],
        &["--demos"],
    );
    fails_with(
        &[
            "grasp",
            "eval",
            "--objects",
            "bogus",
            "-o",
            &d.join("e").display().to_string(),
        ],
        &["unknown object"],
    );
    fails_with(
        &["grasp", "eval", "--model", &p, "-o", &d.join("e").display().to_string()],
        &["grasp model"],
    );
}

#[test]
fn record_generate_and_a_reduced_eval_in_the_sim() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: simulation end-to-end tests run in release mode");
        return;
    }
    let d = tmp("sim");
    // Record: two demonstrations on each of two presentations (a top and a side grasp).
    let corpus = d.join("corpus.json").display().to_string();
    let s = ok_json(&[
        "grasp",
        "record",
        "--objects",
        "jif,black_thermos",
        "--demos",
        "2",
        "--seed",
        "1",
        "-o",
        &corpus,
        "--json",
    ]);
    assert_eq!(s["attempts"], 4, "{s}");
    assert!(
        s["grasps"].as_u64().expect("grasps") >= 3,
        "the teacher's grasps hold: {s}"
    );
    let c: Value = serde_json::from_str(&std::fs::read_to_string(&corpus).expect("corpus")).expect("json");
    let kinds: Vec<&str> = s["demos"]
        .as_array()
        .expect("demos")
        .iter()
        .map(|d| d["kind"].as_str().unwrap_or(""))
        .collect();
    assert!(kinds.contains(&"top") && kinds.contains(&"side"), "{kinds:?}");
    // Positions are relative to the seen centroid: within 15 cm of it.
    for o in c["objects"].as_array().expect("objects") {
        for g in o["grasps"].as_array().expect("grasps") {
            let p: Vec<f64> = serde_json::from_value(g["position"].clone()).expect("position");
            assert!(p.iter().map(|v| v * v).sum::<f64>().sqrt() < 0.15, "{p:?}");
        }
    }
    // Learn and generate for a new presentation.
    let model = d.join("m.json").display().to_string();
    let o = pbd(&[
        "grasp",
        "learn",
        &corpus,
        "-o",
        &model,
        "--prototypes",
        "3",
        "--burn-in",
        "30",
        "--chains",
        "2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let g = ok_json(&[
        "grasp",
        "generate",
        "--model",
        &model,
        "--object",
        "tomato_soup",
        "--n",
        "3",
        "--json",
    ]);
    let pre = g["pre_grasps"].as_array().expect("pre-grasps");
    assert!(!pre.is_empty() && pre.len() <= 3, "{g}");
    let r: Vec<f64> = pre
        .iter()
        .map(|p| p["reach_distance"].as_f64().expect("reach"))
        .collect();
    assert!(r.windows(2).all(|w| w[0] <= w[1]), "ranked by reach: {r:?}");
    // A reduced eval from the learned model: one test object, one candidate per method.
    let dir = d.join("eval");
    let e = ok_json(&[
        "grasp",
        "eval",
        "--model",
        &model,
        "--objects",
        "tomato_soup",
        "--candidates",
        "1",
        "--seed",
        "2",
        "-o",
        &dir.display().to_string(),
        "--json",
    ]);
    assert_eq!(e["model_total"][1], 1);
    assert_eq!(e["naive_total"][1], 1);
    for f in [
        "trials.csv",
        "objects.csv",
        "sharing.csv",
        "fig6_7.svg",
        "summary.md",
        "summary.json",
    ] {
        assert!(dir.join(f).exists(), "{f}");
    }
    let svg = std::fs::read_to_string(dir.join("fig6_7.svg")).expect("svg");
    assert!(
        svg.starts_with("<svg") && svg.contains("tomato_soup"),
        "{}",
        &svg[..svg.len().min(200)]
    );
    // The executed candidates drawn for Foxglove, one entity per method's candidate.
    let rec = pbd::mcap_log::read_recording(dir.join("candidates/tomato_soup.mcap"), &[]).expect("candidates mcap");
    let drawn: Vec<Value> = rec
        .topic(pbd::mcap_log::TOPIC_GRASP_CANDIDATES)
        .map(|(_, b)| pbd::mcap_log::message_json("foxglove.SceneUpdate", "protobuf", b).expect("a scene update"))
        .collect();
    assert_eq!(drawn.len(), 1);
    let ids: Vec<&str> = drawn[0]["entities"]
        .as_array()
        .expect("entities")
        .iter()
        .map(|e| e["id"].as_str().expect("id"))
        .collect();
    assert!(
        !ids.is_empty()
            && ids
                .iter()
                .all(|id| *id == "pre-grasp/model/1" || *id == "pre-grasp/naive/1"),
        "{ids:?}"
    );
}

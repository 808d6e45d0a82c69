//! The bad-input sweep of issue 18 (fuzzed readers): every reader behind a `pbd` command is handed
//! malformed, truncated, garbage, empty, missing and wrong-kind files, and flags get non-numbers,
//! negatives, huge values and unknown names. Each case fails at input validation with exit code ≠ 0
//! and one `error:` line, never a panic. The cases are distinct (checked) and there are at least 50.

use crate::common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use common::{pbd, repo, stderr};

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("pbd-bad-input-sweep-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// Writes `bytes` to `dir/name` and returns the path as a string.
fn put(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> String {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    s(&p)
}

fn text(path: &str) -> String {
    std::fs::read_to_string(repo().join(path)).unwrap()
}

/// Checks one refused run: exit code ≠ 0, no panic; a usage error (clap, exit 2) starts with
/// `error:`; any other error is exactly one `error:` line (warnings aside).
fn check(args: &[String]) -> Result<(), String> {
    let o = pbd(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let e = stderr(&o);
    let code = o.status.code();
    if o.status.success() || code.is_none() {
        return Err(format!("{args:?}: exit {code:?}\n{e}"));
    }
    if e.contains("panicked") || e.contains("RUST_BACKTRACE") {
        return Err(format!("{args:?}: panicked\n{e}"));
    }
    let lines: Vec<&str> = e.lines().filter(|l| !l.trim().is_empty()).collect();
    if code == Some(2) {
        if !lines.first().is_some_and(|l| l.starts_with("error:")) {
            return Err(format!("{args:?}: usage error without `error:` first\n{e}"));
        }
        return Ok(());
    }
    let errors: Vec<&&str> = lines.iter().filter(|l| !l.starts_with("warning:")).collect();
    if errors.len() != 1 || !errors[0].starts_with("error:") {
        return Err(format!("{args:?}: exit {code:?}, not one `error:` line\n{e}"));
    }
    Ok(())
}

#[test]
fn bad_inputs_through_the_cli_fail_with_one_error_line_and_never_panic() {
    let d = dir();
    let out = s(&d.join("out"));
    let missing = s(&d.join("no-such-file"));
    let a_dir = s(&d);
    let empty = |name: &str| put(&d, name, "");
    let garbage = |name: &str| put(&d, name, b"\x00\xff\xfe garbage \x89\x01\n{[<");

    let mut cases: Vec<Vec<String>> = Vec::new();
    let mut case = |args: &[&str]| cases.push(args.iter().map(|a| a.to_string()).collect());

    // MCAP recordings: doctor, infer, learn from a recording.
    let magic_only = put(&d, "magic.mcap", b"\x89MCAP0\r\n");
    let mut huge_len = b"\x89MCAP0\r\n\x01\x08\x00\x00\x00\x00\x00\x00\x00".to_vec();
    huge_len.extend_from_slice(&[0, 0, 0, 0xF3, 0, 0, 0, 0]);
    let huge_len = put(&d, "huge-length.mcap", huge_len);
    let json_as_mcap = put(&d, "json.mcap", "{\"format\": \"pbd-inference\"}");
    for f in [
        empty("empty.mcap"),
        garbage("garbage.mcap"),
        magic_only.clone(),
        huge_len.clone(),
        json_as_mcap.clone(),
        missing.clone(),
        a_dir.clone(),
    ] {
        case(&["doctor", &f]);
    }
    for f in [
        &empty("empty2.mcap"),
        &garbage("garbage2.mcap"),
        &magic_only,
        &huge_len,
        &missing,
    ] {
        case(&["infer", f, "-o", &s(&d.join("x.infer.json"))]);
    }
    case(&["learn", &garbage("garbage3.mcap"), "-o", &out]);
    case(&["doctor", &magic_only, "--repair", &magic_only]);

    // Inference JSON: learn and execute --demo.
    let infer = text("fuzz/corpus/inference_json/pick-place-left.infer.json");
    let infer_cases = [
        ("empty.infer.json", String::new()),
        ("garbage.infer.json", "not json at all".to_owned()),
        ("object.infer.json", "{}".to_owned()),
        ("array.infer.json", "[1, 2, 3]".to_owned()),
        ("cut.infer.json", infer[..infer.len() / 2].to_owned()),
        (
            "format.infer.json",
            infer.replacen("\"pbd-inference\"", "\"pbd-procedural-model\"", 1),
        ),
        (
            "version.infer.json",
            infer.replacen("\"version\": 1", "\"version\": 99", 1),
        ),
        (
            "nan.infer.json",
            infer
                .replacen("\"posterior\": 1", "\"posterior\": NaN", 1)
                .replacen("\"steps\": ", "\"steps\": -", 1),
        ),
        (
            "type.infer.json",
            infer.replacen("\"instances\": [", "\"instances\": \"x\", \"was\": [", 1),
        ),
    ];
    for (name, body) in &infer_cases {
        case(&["learn", &put(&d, name, body), "-o", &out]);
    }
    case(&["learn", &missing, "-o", &out]);
    case(&["learn", &a_dir, "-o", &out]);
    case(&[
        "execute",
        "--scene",
        "pick-place",
        "--demo",
        &put(&d, "demo-garbage.infer.json", "{\"format\": 7}"),
    ]);
    case(&[
        "execute",
        "--scene",
        "pick-place",
        "--demo",
        &put(&d, "demo-cut.infer.json", &infer[..infer.len() / 3]),
    ]);

    // Procedural models: learn --explain, learn --update, execute --model.
    let model = text("crates/py/tests/data/sorting-model.json");
    let model_cases = [
        ("empty-model.json", String::new()),
        ("garbage-model.json", "\u{1}\u{2} garbage".to_owned()),
        ("object-model.json", "{}".to_owned()),
        ("cut-model.json", model[..model.len() / 2].to_owned()),
        ("v1-model.json", model.replacen("\"version\": 4", "\"version\": 1", 1)),
        (
            "negative-model.json",
            model.replacen("\"version\": 4", "\"version\": -4", 1),
        ),
        (
            "huge-model.json",
            model.replacen("\"version\": 4", "\"version\": 99999999999999999999", 1),
        ),
        (
            "kind-model.json",
            model.replacen("\"kind\": \"uniform\"", "\"kind\": \"gaussian\"", 1),
        ),
    ];
    for (name, body) in &model_cases {
        case(&["learn", "--explain", &put(&d, name, body)]);
    }
    case(&["learn", "--explain", &missing]);
    case(&[
        "learn",
        &put(&d, "for-update.infer.json", &infer),
        "--update",
        &put(&d, "update-garbage.json", "[]"),
        "-o",
        &out,
    ]);
    case(&[
        "execute",
        "--scene",
        "pick-place",
        "--model",
        &put(&d, "exec-model.json", &model[..model.len() / 3]),
    ]);

    // Scene and catalog TOML.
    let scene = text("assets/scenes/pick-place.toml").replace(
        "\"../objects/household.toml\"",
        &format!("{:?}", s(&repo().join("assets/objects/household.toml"))),
    );
    for f in std::fs::read_dir(repo().join("crates/dexter-sim/tests/data")).unwrap() {
        let p = f.unwrap().path();
        if p.extension().is_some_and(|e| e == "toml") {
            case(&["sim", "pick-place", "--scene", &s(&p)]);
        }
    }
    let scene_cases = [
        ("empty.toml", String::new()),
        ("garbage.toml", "[[[ = = ]]]".to_owned()),
        ("cut.toml", scene[..scene.len() / 2].to_owned()),
        ("nan.toml", scene.replacen("seed = ", "seed = nan #", 1)),
        (
            "catalog-missing.toml",
            scene.replacen("household.toml", "nowhere.toml", 1),
        ),
    ];
    for (name, body) in &scene_cases {
        case(&["sim", "pick-place", "--scene", &put(&d, name, body)]);
    }
    case(&["sim", "pick-place", "--scene", "no-such-scene"]);
    case(&["sim", "pick-place", "--scene", &a_dir]);
    case(&["sim", "pick-place", "--object", "no-such-object"]);
    case(&["sim", "pick-place", "--place", "no-such-place"]);
    case(&["sim", "pick-place", "--seed", "-1"]);
    case(&["sim", "pick-place", "--arm", "middle"]);
    let catalog = text("assets/objects/household.toml");
    case(&[
        "experiment",
        "sorting",
        "--feature",
        "color",
        "--catalog",
        &put(&d, "cut-catalog.toml", &catalog[..catalog.len() / 2]),
        "-o",
        &out,
    ]);
    case(&[
        "experiment",
        "sorting",
        "--feature",
        "color",
        "--catalog",
        &empty("empty-catalog.toml"),
        "-o",
        &out,
    ]);

    // Teleop streams: record --teleop.
    let header = "t,hand,x,y,z,qx,qy,qz,qw,flexion\n";
    let row = "0.0,right,0.42,-0.32,1.07,1,0,0,0,0.3\n";
    let teleop_cases = [
        ("empty.csv", String::new()),
        ("header.csv", "t,hand,x\n0,right,1\n".to_owned()),
        ("columns.csv", format!("{header}0.0,right,0.42\n")),
        ("nan.csv", format!("{header}{}", row.replacen("0.42", "NaN", 1))),
        ("inf.csv", format!("{header}{}", row.replacen("1.07", "inf", 1))),
        (
            "quat.csv",
            format!("{header}{}", row.replacen(",1,0,0,0,", ",2,0,0,0,", 1)),
        ),
        ("flexion.csv", format!("{header}{}", row.replacen("0.3\n", "9.0\n", 1))),
        ("hand.csv", format!("{header}{}", row.replacen("right", "tentacle", 1))),
        (
            "backwards.csv",
            format!("{header}{}{}", row.replacen("0.0,", "1.0,", 1), row),
        ),
        ("garbage.jsonl", "{\"t\": \"soon\"}\n".to_owned()),
        ("empty.jsonl", String::new()),
    ];
    for (name, body) in &teleop_cases {
        case(&["record", "--teleop", &put(&d, name, body), "-o", &s(&d.join("t.mcap"))]);
    }
    case(&["record", "--teleop", &missing, "-o", &s(&d.join("t.mcap"))]);

    // URDF: robot info and fk.
    let urdf = text("assets/dexter.urdf");
    let urdf_cases = [
        ("empty.urdf", String::new()),
        ("garbage.urdf", "<robot <<< ".to_owned()),
        ("cut.urdf", urdf[..urdf.len() / 2].to_owned()),
        ("nolinks.urdf", "<robot name=\"r\"></robot>".to_owned()),
        ("planar.urdf", urdf.replacen("type=\"revolute\"", "type=\"planar\"", 1)),
        (
            "axis.urdf",
            urdf.replacen("<axis xyz=\"", "<axis xyz=\"0 0 0\" was=\"", 1),
        ),
        ("nan.urdf", urdf.replacen("<origin xyz=\"", "<origin xyz=\"nan ", 1)),
    ];
    for (name, body) in &urdf_cases {
        case(&["robot", "info", &put(&d, name, body)]);
    }
    case(&["robot", "info", &missing]);
    case(&["robot", "info", &a_dir]);
    case(&["robot", "fk", "--base", "no-such-link", "--tip", "also-not"]);
    case(&["robot", "fk", "--base", "world", "--tip", "world", "--q", "nan,1"]);

    // Grasp corpora.
    case(&["grasp", "learn", &garbage("garbage-corpus.json"), "-o", &out]);
    case(&["grasp", "learn", &empty("empty-corpus.json"), "-o", &out]);

    let distinct: BTreeSet<&Vec<String>> = cases.iter().collect();
    assert_eq!(distinct.len(), cases.len(), "a case is listed twice");
    assert!(cases.len() >= 50, "{} cases", cases.len());
    let failures: Vec<String> = cases.iter().filter_map(|c| check(c).err()).collect();
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n---\n")
    );
    let _ = std::fs::remove_dir_all(&d);
}

//! Regression tests for hostile files (issue 38): a JSON key given twice is refused in every JSON
//! input, `record --teleop … --save-teleop …` never writes an empty copy silently, and a scene (or
//! catalog) with more objects than the limit is refused before any work.

use crate::common;

use std::path::{Path, PathBuf};

use common::{pbd, repo, stderr, stdout};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pbd-hostile-files-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// Runs `pbd args`: exit code 1 (never a panic's 101 or an abort), stderr naming every needle, and
/// none of `unwritten` exists afterwards.
fn refused(args: &[&str], needles: &[&str], unwritten: &[&Path]) {
    common::refused(args, needles);
    for f in unwritten {
        assert!(!f.exists(), "{args:?}: {} was written", f.display());
    }
}

/// `text` with `new` put in place of the one occurrence of `old`.
fn edit(text: &str, old: &str, new: &str) -> String {
    assert_eq!(text.matches(old).count(), 1, "{old:?}");
    text.replacen(old, new, 1)
}

/// A key given twice in a JSON object once silently won (a model with two `"places"` keys loaded
/// the second, a map kept the last value). Every JSON input is now refused, naming the file and the
/// key's path, before anything is written. TOML inputs (scenes, catalogs, libraries) were already
/// refused by the parser, naming the file and line.
#[test]
fn a_json_key_given_twice_is_refused_in_every_json_input() {
    let d = dir("dup");

    // Procedural model, top level: an empty `places` before the real one.
    let model = std::fs::read_to_string(repo().join("crates/py/tests/data/sorting-model.json")).unwrap();
    let m1 = d.join("m1.json");
    std::fs::write(
        &m1,
        edit(&model, "{\n  \"format\"", "{\n  \"places\": [],\n  \"format\""),
    )
    .unwrap();
    let run = d.join("run.mcap");
    refused(
        &["execute", "--scene", "pick-place", "--model", &s(&m1), "-o", &s(&run)],
        &[&s(&m1), "places", "duplicate key `places`"],
        &[&run],
    );
    // … and nested: a place prior of two kinds.
    let m2 = d.join("m2.json");
    let nested = edit(
        &model,
        "\"kind\": \"uniform\"",
        "\"kind\": \"dirichlet\", \"kind\": \"uniform\"",
    );
    std::fs::write(&m2, nested).unwrap();
    refused(
        &["learn", "--explain", &s(&m2)],
        &[&s(&m2), "duplicate key `hyper.place_prior.kind`"],
        &[],
    );

    // Teleop stream (JSON lines): the line and the key.
    let teleop = d.join("t.jsonl");
    std::fs::write(
        &teleop,
        "{\"t\":0.0,\"hand\":\"right\",\"position\":[0.42,-0.32,1.07],\"orientation\":[1,0,0,0],\"flexion\":0.3}\n\
         {\"t\":0.5,\"hand\":\"right\",\"position\":[0.42,-0.32,1.07],\"orientation\":[1,0,0,0],\"flexion\":0.3,\"flexion\":2.0}\n",
    )
    .unwrap();
    let rec = d.join("rec.mcap");
    refused(
        &["record", "--teleop", &s(&teleop), "-o", &s(&rec)],
        &[&s(&teleop), "line 2", "duplicate key `flexion`"],
        &[&rec],
    );

    // Grasp prototype model and grasp corpus.
    let protos = std::fs::read_to_string(repo().join("crates/py/tests/data/grasp-prototypes.json")).unwrap();
    let p = d.join("p.json");
    std::fs::write(&p, edit(&protos, "\"seed\": 0,", "\"seed\": 0, \"seed\": 1,")).unwrap();
    refused(
        &["grasp", "generate", "--model", &s(&p), "--object", "jif"],
        &[&s(&p), "duplicate key `config.seed`"],
        &[],
    );
    let corpus = d.join("c.json");
    std::fs::write(
        &corpus,
        r#"{"format": "pbd-grasp-corpus", "version": 1, "objects": [
            {"name": "jif", "appearance": [[1, 0], [0, 1]], "grasps": []},
            {"name": "mug", "appearance": [[1, 0], [0, 1]], "grasps": [], "name": "jif"}]}"#,
    )
    .unwrap();
    let learned = d.join("learned.json");
    refused(
        &["grasp", "learn", &s(&corpus), "-o", &s(&learned)],
        &[&s(&corpus), "duplicate key `objects[1].name`"],
        &[&learned],
    );

    // Feature bank (`experiment sorting --features`).
    let bank = std::fs::read_to_string(repo().join("crates/pbd/tests/data/household_features.json")).unwrap();
    let b = d.join("bank.json");
    std::fs::write(&b, edit(&bank, "{\"catalog\"", "{\"seed\":7,\"catalog\"")).unwrap();
    let out = d.join("sorting");
    refused(
        &[
            "experiment",
            "sorting",
            "--feature",
            "color",
            "--features",
            &s(&b),
            "--trials",
            "1",
            "-o",
            &s(&out),
        ],
        &[&s(&b), "duplicate key `seed`"],
        &[&out.join("summary.md")],
    );

    // Inference file (`learn` and `execute --demo` read it): a key twice in its metadata map.
    let demo = d.join("demo.mcap");
    let o = pbd(&["record", "--scene", "pick-place", "-o", &s(&demo)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let inferred = d.join("demo.infer.json");
    let o = pbd(&["infer", &s(&demo), "-o", &s(&inferred)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&inferred).unwrap();
    let inf = d.join("dup.infer.json");
    std::fs::write(&inf, edit(&text, "\"metadata\": {", "\"metadata\": {\"seed\": \"99\",")).unwrap();
    let learned = d.join("model.json");
    refused(
        &["learn", &s(&inf), "-o", &s(&learned)],
        &[&s(&inf), "duplicate key `metadata.seed`"],
        &[&learned],
    );
    refused(
        &["execute", "--scene", "pick-place", "--demo", &s(&inf), "-o", &s(&run)],
        &[&s(&inf), "duplicate key `metadata.seed`"],
        &[&run],
    );
    // The same file without the duplicate is read (the check refuses only the duplicate).
    let o = pbd(&["learn", &s(&inferred), "-o", &s(&learned)]);
    assert!(o.status.success(), "{}", stderr(&o));

    // TOML inputs: the parser refuses a key given twice, naming the file and line.
    let scene_text = std::fs::read_to_string(repo().join("assets/scenes/pick-place.toml")).unwrap();
    let scene = d.join("s.toml");
    let scene_text = edit(&scene_text, "\"../objects/household.toml\"", "\"builtin:household\"");
    std::fs::write(&scene, edit(&scene_text, "seed = 2", "seed = 2\nseed = 3")).unwrap();
    let mcap = d.join("pp.mcap");
    refused(
        &["sim", "pick-place", "--scene", &s(&scene), "--mcap", &s(&mcap)],
        &[&s(&scene), "duplicate key"],
        &[&mcap],
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// `record --teleop STREAM --save-teleop OUT` writes the hand commands that drove the run (a stream
/// that replays as the same run); a stream that would replay nothing (its first sample after the
/// end of the recording) once wrote an empty OUT and exited 0: it is refused before any work.
#[test]
fn save_teleop_with_teleop_writes_the_commands_replayed() {
    let d = dir("save-teleop");
    let sample = |t: f64, flexion: f64| {
        format!(
            "{{\"t\":{t},\"hand\":\"right\",\"position\":[0.42,-0.32,1.07],\"orientation\":[1,0,0,0],\"flexion\":{flexion}}}\n"
        )
    };
    let stream = d.join("in.jsonl");
    std::fs::write(&stream, [sample(0.0, 0.3), sample(0.5, 0.6), sample(1.0, 0.9)].concat()).unwrap();
    let rec = d.join("rec.mcap");
    let copy = d.join("copy.csv");
    let o = pbd(&[
        "record",
        "--teleop",
        &s(&stream),
        "--save-teleop",
        &s(&copy),
        "-o",
        &s(&rec),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains(&s(&copy)),
        "the report names the copy: {}",
        stdout(&o)
    );
    let csv = std::fs::read_to_string(&copy).expect("the copy is written");
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows[0], "t,hand,x,y,z,qx,qy,qz,qw,flexion", "{csv}");
    assert_eq!(rows.len(), 4, "the three samples replayed: {csv}");
    for (row, flexion) in rows[1..].iter().zip(["0.3", "0.6", "0.9"]) {
        assert!(row.ends_with(flexion), "{row} (expected flexion {flexion})");
    }
    // The copy replays: read back as a teleop stream.
    let again = d.join("again.mcap");
    let o = pbd(&["record", "--teleop", &s(&copy), "-o", &s(&again)]);
    assert!(o.status.success(), "{}", stderr(&o));

    // A stream that begins after the end of the recording: refused before anything is written.
    let late = d.join("late.jsonl");
    std::fs::write(&late, [sample(100.0, 0.3), sample(101.0, 0.6)].concat()).unwrap();
    let (rec2, copy2) = (d.join("late.mcap"), d.join("late-copy.jsonl"));
    refused(
        &[
            "record",
            "--teleop",
            &s(&late),
            "--save-teleop",
            &s(&copy2),
            "--max-seconds",
            "5",
            "-o",
            &s(&rec2),
        ],
        &[
            &s(&late),
            "first sample is at t = 100 s",
            "--max-seconds 5",
            "nothing would be replayed",
        ],
        &[&rec2, &copy2],
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// A scene of `n` upright jars in rows of 16, 15 cm apart, on a table grown to hold them.
fn scene_of(n: usize, catalog: &str, presentation: &str) -> String {
    let rows = n.div_ceil(16);
    let length = 0.6 + rows as f64 * 0.15;
    let mut text = format!(
        "version = 1\nname = \"many\"\ncatalog = {catalog:?}\nseed = 2\n\n[table]\nheight = 0.75\n\
         center = [{}, 0.0]\nsize = [{length}, 2.6]\n\n[[places]]\nname = \"bin-left\"\ncenter = [0.55, 0.45]\n\
         size = [0.2, 0.25]\nwall_height = 0.06\n",
        0.3 + length / 2.0
    );
    for k in 0..n {
        let (r, c) = (k / 16, k % 16);
        text += &format!(
            "\n[[objects]]\npresentation = {presentation:?}\nxy = [{:.3}, {:.3}]\n",
            0.85 + r as f64 * 0.15,
            -1.2 + c as f64 * 0.15
        );
    }
    text
}

/// A scene of 10⁴ objects ran past 30 s: a scene holds at most 64 objects and a catalog 1,000,
/// refused on load naming the file and the field, before any output is written.
#[test]
fn scenes_and_catalogs_past_the_object_limit_are_refused_before_any_work() {
    let d = dir("many");
    // At the limit: accepted (one pick takes about a second).
    let at = d.join("at.toml");
    std::fs::write(&at, scene_of(64, "builtin:household", "jif")).unwrap();
    let o = pbd(&["sim", "pick-place", "--scene", &s(&at)]);
    let e = stderr(&o);
    assert!(!e.contains("objects"), "64 objects are accepted: {e}");
    assert!(!e.contains("panicked"), "{e}");

    // One past it: refused by every command that reads a scene, naming the limit, nothing written
    // (the refusal comes on load, before any work).
    let over = d.join("over.toml");
    std::fs::write(&over, scene_of(65, "builtin:household", "jif")).unwrap();
    let (mcap, run) = (d.join("pp.mcap"), d.join("run.mcap"));
    let needles = [s(&over), "objects".into(), "65 entries".into(), "at most 64".into()];
    let needles: Vec<&str> = needles.iter().map(String::as_str).collect();
    refused(
        &["sim", "pick-place", "--scene", &s(&over), "--mcap", &s(&mcap)],
        &needles,
        &[&mcap],
    );
    let model = s(&repo().join("crates/py/tests/data/sorting-model.json"));
    refused(
        &["execute", "--scene", &s(&over), "--model", &model, "-o", &s(&run)],
        &needles,
        &[&run],
    );
    refused(&["record", "--scene", &s(&over), "-o", &s(&run)], &needles, &[&run]);

    // A catalog of 1,001 objects.
    let catalog = d.join("big.toml");
    let mut text = String::from("version = 1\n");
    for i in 0..1001 {
        text += &format!(
            "\n[[objects]]\nname = \"o{i}\"\nshape = {{ kind = \"cylinder\", radius = 0.0375, height = 0.1 }}\n\
             mass = 0.38\nfriction = 0.8\ncolor_class = \"red\"\nsize_class = \"medium\"\n\
             colors = [{{ hsv = [2, 0.85, 0.80], fraction = 1.0 }}]\n"
        );
    }
    std::fs::write(&catalog, text).unwrap();
    let scene = d.join("big-catalog.toml");
    std::fs::write(&scene, scene_of(1, &s(&catalog), "o1")).unwrap();
    refused(
        &["sim", "pick-place", "--scene", &s(&scene), "--mcap", &s(&mcap)],
        &[&s(&catalog), "objects", "1001 entries", "at most 1000"],
        &[&mcap],
    );
    let _ = std::fs::remove_dir_all(&d);
}

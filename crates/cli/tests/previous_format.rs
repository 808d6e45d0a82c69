//! Recordings of the previous format (every topic JSON, before Foxglove's topics became Protobuf)
//! still read: `pbd infer` on one gives the inference it gave then, and a recording of the same
//! demonstration in today's format gives the same inference (issue 40). The fixture
//! `tests/data/touch-json-v1.mcap` is `pbd record --script touch --seed 3` written by pbd at commit
//! 356f02b (JSON schemas); `touch-json-v1.expected.json` is what `pbd infer` said of it then.

use crate::common;

use common::{pbd, stderr, stdout};
use serde_json::Value;

fn data(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn infer(path: &std::path::Path) -> Value {
    let o = pbd(&["infer", path.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "infer {}: {}", path.display(), stderr(&o));
    serde_json::from_str(&stdout(&o)).unwrap()
}

/// `a` and `b` have the same structure, strings and booleans, and numbers within 1e-6 (relative
/// above 1).
fn same_within(a: &Value, b: &Value, path: &str) {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-6 * x.abs().max(y.abs()).max(1.0),
                "{path}: {x} vs {y}"
            );
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{path}: lengths");
            for (k, (x, y)) in x.iter().zip(y).enumerate() {
                same_within(x, y, &format!("{path}[{k}]"));
            }
        }
        (Value::Object(x), Value::Object(y)) => {
            assert_eq!(
                x.keys().collect::<Vec<_>>(),
                y.keys().collect::<Vec<_>>(),
                "{path}: keys"
            );
            for (k, v) in x {
                same_within(v, &y[k], &format!("{path}.{k}"));
            }
        }
        _ => assert_eq!(a, b, "{path}"),
    }
}

#[test]
fn a_json_recording_of_the_previous_format_infers_as_it_did_and_as_todays_format_does() {
    // Inferred in a temporary directory: `pbd infer` writes its files beside the recording.
    let dir = std::env::temp_dir().join(format!("pbd-previous-format-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let old = dir.join("touch-json-v1.mcap");
    std::fs::copy(data("touch-json-v1.mcap"), &old).unwrap();
    let expected: Value =
        serde_json::from_str(&std::fs::read_to_string(data("touch-json-v1.expected.json")).unwrap()).unwrap();
    let then = infer(&old);
    for key in ["inference", "warnings", "metadata"] {
        assert_eq!(then[key], expected[key], "{key} of the previous format's recording");
    }
    let best = &then["inference"]["instances"][0];
    assert_eq!(best["schema"], "reach_and_touch", "{best}");

    // Today's format: Foxglove's topics are Protobuf; pbd's own (read by infer) are JSON as before.
    let new = dir.join("touch.mcap");
    let o = pbd(&[
        "record",
        "--script",
        "touch",
        "--seed",
        "3",
        "-o",
        new.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&new).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
    let encoding = |topic: &str| {
        let c = summary.channels.values().find(|c| c.topic == topic).unwrap();
        (c.message_encoding.clone(), c.schema.as_ref().unwrap().encoding.clone())
    };
    assert_eq!(encoding("/tf"), ("protobuf".to_owned(), "protobuf".to_owned()));
    assert_eq!(encoding("/pbd/percept"), ("json".to_owned(), "jsonschema".to_owned()));
    let old_summary = mcap::Summary::read(&std::fs::read(&old).unwrap()).unwrap().unwrap();
    let old_tf = old_summary.channels.values().find(|c| c.topic == "/tf").unwrap();
    assert_eq!(old_tf.message_encoding, "json", "the fixture is of the previous format");
    let now = infer(&new);
    // Today's JSON carries its numbers to 6 decimals (6 significant digits below 1): the same
    // schemas, states, steps and facts, every number within a millionth of what the full doubles
    // of the previous format gave.
    same_within(&now["inference"], &then["inference"], "inference");
    let _ = std::fs::remove_dir_all(&dir);
}

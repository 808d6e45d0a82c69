//! Every reader driven with generated bad input (proptest, on stable): valid files of each format
//! mutated — bytes flipped, the file cut, bytes inserted or deleted, numbers replaced by extremes,
//! NaN, infinities, wrong types, lines (keys, rows) dropped or repeated — and arbitrary bytes. Each read ends in `Ok` or a typed error, never a panic; a read never
//! changes its input; `learn` leaves either a complete model file or none.
//!
//! 48 cases per reader run in `cargo test`; `PBD_FUZZ_CASES=5000 cargo test --release -p pbd --test
//! fuzz_readers` hunts longer.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use pbd::dexter_sim::physics::DEXTER_URDF;
use pbd::dexter_sim::scene::{Catalog, Scene};
use pbd::dexter_sim::teleop::TeleopStream;
use pbd::progress::Quiet;
use proptest::prelude::*;

/// Replacements for a number in a text format: extremes, non-numbers, wrong types.
const WEIRD: [&str; 14] = [
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "-inf",
    "-0",
    "0",
    "99999999999999999999",
    "-1",
    "1e-320",
    "\"x\"",
    "[]",
    "{}",
    "true",
];

#[derive(Debug, Clone)]
enum Edit {
    /// XOR a byte at a position (taken modulo the length).
    Flip(usize, u8),
    /// Cut the file at a position.
    Truncate(usize),
    /// Insert bytes.
    Insert(usize, Vec<u8>),
    /// Delete up to n bytes.
    Delete(usize, usize),
    /// Replace the k-th number (digit run) by a weird token.
    Number(usize, usize),
    /// Drop the k-th line (a key of a TOML table or of pretty-printed JSON, a CSV row).
    DropLine(usize),
    /// Duplicate the k-th line (a key given twice, a repeated row).
    DuplicateLine(usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), 1u8..=255).prop_map(|(p, x)| Edit::Flip(p, x)),
        any::<usize>().prop_map(Edit::Truncate),
        (any::<usize>(), proptest::collection::vec(any::<u8>(), 1..16)).prop_map(|(p, b)| Edit::Insert(p, b)),
        (any::<usize>(), 1usize..64).prop_map(|(p, n)| Edit::Delete(p, n)),
        (any::<usize>(), 0..WEIRD.len()).prop_map(|(k, w)| Edit::Number(k, w)),
        any::<usize>().prop_map(Edit::DropLine),
        any::<usize>().prop_map(Edit::DuplicateLine),
    ]
}

fn apply(base: &[u8], edits: &[Edit]) -> Vec<u8> {
    let mut v = base.to_vec();
    for e in edits {
        let n = v.len().max(1);
        match e {
            Edit::Flip(p, x) => {
                if !v.is_empty() {
                    v[p % n] ^= x;
                }
            }
            Edit::Truncate(p) => v.truncate(p % n),
            Edit::Insert(p, b) => {
                let at = p % (v.len() + 1);
                v.splice(at..at, b.iter().copied());
            }
            Edit::Delete(p, k) => {
                let at = p % n;
                let end = (at + k).min(v.len());
                if at < end {
                    v.drain(at..end);
                }
            }
            Edit::Number(k, w) => {
                let runs: Vec<(usize, usize)> = digit_runs(&v);
                if !runs.is_empty() {
                    let (a, b) = runs[k % runs.len()];
                    v.splice(a..b, WEIRD[*w].bytes());
                }
            }
            Edit::DropLine(k) | Edit::DuplicateLine(k) => {
                let lines = line_spans(&v);
                let (a, b) = lines[k % lines.len()];
                if matches!(e, Edit::DropLine(_)) {
                    v.drain(a..b);
                } else {
                    let line = v[a..b].to_vec();
                    v.splice(b..b, line);
                }
            }
        }
    }
    v
}

/// Byte ranges of the lines, each with its newline (at least one, maybe empty).
fn line_spans(v: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut a = 0;
    for (i, &b) in v.iter().enumerate() {
        if b == b'\n' {
            spans.push((a, i + 1));
            a = i + 1;
        }
    }
    if a < v.len() || spans.is_empty() {
        spans.push((a, v.len()));
    }
    spans
}

fn digit_runs(v: &[u8]) -> Vec<(usize, usize)> {
    let mut runs = Vec::new();
    let mut i = 0;
    while i < v.len() {
        if v[i].is_ascii_digit() {
            let a = i;
            while i < v.len() && (v[i].is_ascii_digit() || v[i] == b'.') {
                i += 1;
            }
            runs.push((a, i));
        } else {
            i += 1;
        }
    }
    runs
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn work_dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("pbd-fuzz-readers-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A short recorded demonstration and its inference file (made once).
fn recorded() -> &'static (Vec<u8>, Vec<u8>) {
    static R: OnceLock<(Vec<u8>, Vec<u8>)> = OnceLock::new();
    R.get_or_init(|| {
        let d = work_dir().join("seed");
        std::fs::create_dir_all(&d).unwrap();
        let mcap = d.join("touch.mcap");
        let options = pbd::record::RecordOptions {
            script: pbd::record::Script::Touch,
            output: mcap.clone(),
            ..Default::default()
        };
        pbd::record::record(&options, &Quiet).unwrap();
        let run = pbd::infer::infer(
            &pbd::infer::InferOptions {
                demo: mcap.clone(),
                output: Some(d.join("touch.infer.json")),
                library: None,
            },
            &Quiet,
        )
        .unwrap();
        (std::fs::read(&mcap).unwrap(), std::fs::read(&run.json_path).unwrap())
    })
}

/// Writes `bytes` to a fresh file named `name` and returns its path.
fn file(name: &str, bytes: &[u8]) -> PathBuf {
    static N: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let k = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let d = work_dir().join(format!("case-{k}"));
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// Runs `read`; the input must be unchanged afterwards. Panics propagate (and fail the case).
fn read_unchanged<T>(path: &Path, read: impl FnOnce(&Path) -> T) -> T {
    let before = std::fs::read(path).unwrap();
    let r = read(path);
    assert_eq!(
        std::fs::read(path).unwrap(),
        before,
        "{} was changed by a read",
        path.display()
    );
    r
}

fn text(path: &str) -> Vec<u8> {
    std::fs::read(repo().join(path)).unwrap()
}

proptest! {
    // 48 cases per reader in `cargo test`; PBD_FUZZ_CASES=N for a longer hunt.
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PBD_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(48),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// MCAP: summary, recording, percepts (what `doctor` and `infer` read).
    #[test]
    fn mcap_readers_never_panic(edits in proptest::collection::vec(edit(), 1..4)) {
        let bytes = apply(&recorded().0, &edits);
        let p = file("demo.mcap", &bytes);
        let _ = read_unchanged(&p, |p| pbd::mcap_log::read_summary(p).map(|s| s.message_count));
        let _ = read_unchanged(&p, |p| pbd::mcap_log::read_recording(p, &[]).map(|r| r.messages.len()));
        let _ = read_unchanged(&p, |p| pbd::infer::read_percepts(p).map(|d| d.percepts.len()));
    }

    /// Inference JSON through `learn`: refused or learned; the output is a complete model or absent.
    #[test]
    fn inference_files_never_panic_and_learn_writes_whole_files(edits in proptest::collection::vec(edit(), 1..4)) {
        let bytes = apply(&recorded().1, &edits);
        let p = file("demo.infer.json", &bytes);
        let out = p.with_file_name("model.json");
        let options = pbd::learn::LearnOptions { demos: vec![p.clone()], output: out.clone(), ..Default::default() };
        let r = read_unchanged(&p, |_| pbd::learn::learn(&options, &Quiet));
        if out.exists() {
            prop_assert!(r.is_ok());
            prop_assert!(pbd::schema::procedural::ProceduralModel::load(&out).is_ok());
        }
        let leftovers: Vec<_> = std::fs::read_dir(p.parent().unwrap()).unwrap()
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().to_string())
            .filter(|n| n != "demo.infer.json" && n != "model.json")
            .collect();
        prop_assert!(leftovers.is_empty(), "temporary files left: {:?}", leftovers);
    }

    /// Scene and catalog TOML.
    #[test]
    fn scene_and_catalog_toml_never_panic(edits in proptest::collection::vec(edit(), 1..4), which in 0usize..4) {
        let scenes = ["pick-place", "sorting", "sorting-new", "sorting-demo"];
        let base = String::from_utf8(text(&format!("assets/scenes/{}.toml", scenes[which]))).unwrap();
        let catalog = repo().join("assets/objects/household.toml");
        let base = base.replace("\"../objects/household.toml\"", &format!("{:?}", catalog.display().to_string()));
        let bytes = apply(base.as_bytes(), &edits);
        let _ = Scene::from_toml_str(&String::from_utf8_lossy(&bytes), "fuzz.toml");
        let bytes = apply(&text("assets/objects/household.toml"), &edits);
        let _ = Catalog::from_toml_str(&String::from_utf8_lossy(&bytes), Path::new("fuzz-catalog.toml"));
    }

    /// Procedural model JSON, grasp model and corpus JSON.
    #[test]
    fn model_files_never_panic(edits in proptest::collection::vec(edit(), 1..4)) {
        let m = apply(&text("crates/py/tests/data/sorting-model.json"), &edits);
        if let Ok(model) = pbd::schema::procedural::ProceduralModel::from_json(&String::from_utf8_lossy(&m), "fuzz.json") {
            // A model that loads can be used.
            let _ = model.explain();
        }
        let g = apply(&text("crates/py/tests/data/grasp-prototypes.json"), &edits);
        let _ = pbd::grasp_topics::GraspModel::from_json_str(&String::from_utf8_lossy(&g));
        let _ = pbd::grasp_topics::Corpus::from_json_str(&String::from_utf8_lossy(&g));
    }

    /// Teleop CSV and JSON lines.
    #[test]
    fn teleop_streams_never_panic(edits in proptest::collection::vec(edit(), 1..4), rows in 1usize..6) {
        let mut csv = String::from(pbd::dexter_sim::teleop::CSV_HEADER);
        csv.push('\n');
        for i in 0..rows {
            csv.push_str(&format!("{}.0,right,0.5,-0.2,1.0,0,0,0,1,0.{i}\n", i));
        }
        let bytes = apply(csv.as_bytes(), &edits);
        let p = file("t.csv", &bytes);
        let _ = read_unchanged(&p, |p| TeleopStream::load(p).map(|s| s.samples.len()));
        let jsonl = TeleopStream::load(file("ok.csv", csv.as_bytes())).unwrap().to_jsonl();
        let p = file("t.jsonl", &apply(jsonl.as_bytes(), &edits));
        let _ = read_unchanged(&p, |p| TeleopStream::load(p).map(|s| s.samples.len()));
    }

    /// URDF robot models.
    #[test]
    fn urdf_never_panics(edits in proptest::collection::vec(edit(), 1..3)) {
        let bytes = apply(DEXTER_URDF.as_bytes(), &edits);
        let _ = pbd::control_basis::RobotModel::from_urdf_str(&String::from_utf8_lossy(&bytes));
    }

    /// The in-memory readers the fuzz targets drive (`fuzz/`), on mutated files: MCAP read from
    /// bytes, then the demonstration in it; inference JSON parsed and checked.
    #[test]
    fn in_memory_readers_never_panic(edits in proptest::collection::vec(edit(), 1..4)) {
        let bytes = apply(&recorded().0, &edits);
        let _ = pbd::mcap_log::read_summary_bytes(&bytes);
        if let Ok(rec) = pbd::mcap_log::read_recording_bytes(&bytes, &[]) {
            let _ = pbd::infer::demonstration_from(&rec, Path::new("fuzz.mcap"));
        }
        let json = apply(&recorded().1, &edits);
        let _ = pbd::infer::InferFile::from_json(&String::from_utf8_lossy(&json), "fuzz.infer.json");
    }

    /// `doctor --repair` of a damaged recording: a complete copy or an error, and no file left
    /// behind on an error.
    #[test]
    fn repair_never_panics(edits in proptest::collection::vec(edit(), 1..3)) {
        let p = file("demo.mcap", &apply(&recorded().0, &edits));
        let out = p.with_file_name("repaired.mcap");
        match read_unchanged(&p, |p| pbd::mcap_log::repair(p, &out)) {
            Ok(_) => prop_assert!(pbd::mcap_log::read_summary(&out).is_ok()),
            Err(_) => prop_assert!(!out.exists()),
        }
    }
}

/// Valid seeds of every text format, for the arbitrary-bytes tests to splice from.
fn text_seeds() -> Vec<Vec<u8>> {
    vec![
        text("assets/scenes/pick-place.toml"),
        text("assets/objects/household.toml"),
        text("crates/py/tests/data/sorting-model.json"),
        recorded().1.clone(),
        format!(
            "{}\n0.0,right,0.5,-0.2,1.0,0,0,0,1,0.3\n",
            pbd::dexter_sim::teleop::CSV_HEADER
        )
        .into_bytes(),
    ]
}

/// Every in-memory reader on `bytes`.
fn read_all(bytes: &[u8]) {
    let _ = pbd::mcap_log::read_summary_bytes(bytes);
    if let Ok(rec) = pbd::mcap_log::read_recording_bytes(bytes, &[]) {
        let _ = pbd::infer::demonstration_from(&rec, Path::new("fuzz.mcap"));
    }
    let text = String::from_utf8_lossy(bytes);
    let _ = Scene::from_toml_str(&text, repo().join("assets/scenes/fuzz.toml"));
    let _ = Catalog::from_toml_str(&text, Path::new("fuzz-catalog.toml"));
    if let Ok(model) = pbd::schema::procedural::ProceduralModel::from_json(&text, "fuzz.json") {
        let _ = model.explain();
    }
    let _ = pbd::grasp_topics::GraspModel::from_json_str(&text);
    let _ = pbd::grasp_topics::Corpus::from_json_str(&text);
    let _ = pbd::infer::InferFile::from_json(&text, "fuzz.infer.json");
    let _ = TeleopStream::parse(&text, "fuzz.csv");
    let _ = TeleopStream::parse(&text, "fuzz.jsonl");
    let _ = pbd::control_basis::RobotModel::from_urdf_str(&text);
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PBD_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(128),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// Arbitrary bytes through every reader.
    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        read_all(&bytes);
    }

    /// Arbitrary bytes after the start of a valid file of each format (the reader gets past the
    /// header or first keys), and the MCAP magic followed by garbage.
    #[test]
    fn valid_prefix_then_garbage_never_panics(
        which in 0usize..6,
        cut in any::<usize>(),
        tail in proptest::collection::vec(any::<u8>(), 0..256),
    ) {
        let mut seeds = text_seeds();
        seeds.push(recorded().0[..recorded().0.len().min(4096)].to_vec());
        let seed = &seeds[which];
        let mut bytes = seed[..cut % (seed.len() + 1)].to_vec();
        bytes.extend_from_slice(&tail);
        read_all(&bytes);
    }
}

//! Every crate's integration-test file runs (with `autotests = false` a file
//! under `tests/` that is neither a module of `tests/integration.rs` nor a `[[test]]` of its
//! `Cargo.toml` would be skipped without a word; docs/src/testing.md, "Layout of the test suite").

use std::collections::BTreeSet;
use std::path::Path;

/// The test files of `crate_dir` that nothing compiles.
fn orphans(crate_dir: &Path) -> Vec<String> {
    let tests = crate_dir.join("tests");
    let Ok(entries) = std::fs::read_dir(&tests) else {
        return Vec::new();
    };
    let files: BTreeSet<String> = entries
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter_map(|n| n.strip_suffix(".rs").map(str::to_string))
        .collect();
    let manifest = std::fs::read_to_string(crate_dir.join("Cargo.toml")).expect("Cargo.toml reads");
    if !manifest.contains("autotests = false") {
        // Cargo discovers every file itself.
        return Vec::new();
    }
    let modules = std::fs::read_to_string(tests.join("integration.rs")).unwrap_or_default();
    files
        .into_iter()
        .filter(|f| {
            let as_module = modules.lines().any(|l| l.trim() == format!("mod {f};"));
            let as_target = manifest.contains(&format!("path = \"tests/{f}.rs\""));
            !as_module && !as_target
        })
        .map(|f| format!("{}/tests/{f}.rs", crate_dir.display()))
        .collect()
}

#[test]
fn every_test_file_of_every_crate_is_compiled() {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut checked = 0;
    let mut missing = Vec::new();
    for e in std::fs::read_dir(&crates).expect("crates/ lists") {
        let dir = e.expect("an entry").path();
        if dir.join("Cargo.toml").is_file() {
            checked += 1;
            missing.extend(orphans(&dir));
        }
    }
    assert!(checked >= 8, "only {checked} crates found under {}", crates.display());
    assert!(missing.is_empty(), "test files no target compiles: {missing:?}");
}

#[test]
fn a_file_left_out_of_the_integration_binary_is_found() {
    let dir = std::env::temp_dir().join(format!("pbd-test-layout-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("tests")).expect("temp dir");
    std::fs::write(dir.join("Cargo.toml"), "[package]\nautotests = false\n\n[[test]]\nname = \"integration\"\npath = \"tests/integration.rs\"\n\n[[test]]\nname = \"alone\"\npath = \"tests/alone.rs\"\n").expect("write");
    std::fs::write(dir.join("tests/integration.rs"), "mod listed;\n").expect("write");
    for f in ["listed", "alone", "forgotten"] {
        std::fs::write(dir.join(format!("tests/{f}.rs")), "").expect("write");
    }
    let found = orphans(&dir);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].ends_with("tests/forgotten.rs"), "{found:?}");
}

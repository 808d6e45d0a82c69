//! Scene TOML. The scene is named as if it were in `assets/scenes/`, so the shipped scenes'
//! `catalog = "../objects/household.toml"` resolves to the real catalog.
#![no_main]

use std::path::PathBuf;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    // A catalog path may name any file; devices (`/dev/stdin`, `/dev/zero`) would block or stream,
    // which tests the fuzzer's machine, not the reader.
    if ["/dev", "/proc", "/sys"].iter().any(|d| text.contains(d)) {
        return;
    }
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/fuzz.toml");
    let _ = pbd::dexter_sim::scene::Scene::from_toml_str(&text, &path);
});

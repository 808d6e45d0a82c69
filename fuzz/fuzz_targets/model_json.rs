//! Model JSON: the procedural model (`pbd learn`'s output, read by `learn --update`, `--explain`,
//! `execute --model`), the grasp prototype model and the grasp corpus. `explain` is left to the
//! property tests (`crates/pbd/tests/fuzz_readers.rs`): on the shipped seed model it takes seconds
//! under the sanitizer, which libFuzzer reports as a timeout.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let _ = pbd::schema::procedural::ProceduralModel::from_json(&text, "fuzz.json");
    let _ = pbd::grasp_topics::GraspModel::from_json_str(&text);
    let _ = pbd::grasp_topics::Corpus::from_json_str(&text);
});

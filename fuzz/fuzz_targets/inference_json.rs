//! Inference JSON (`pbd infer`'s output, read by `pbd learn` and `pbd execute --demo`).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let _ = pbd::infer::InferFile::from_json(&text, "fuzz.infer.json");
});

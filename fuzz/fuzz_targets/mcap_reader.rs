//! MCAP bytes through the readers `pbd doctor`, `pbd infer` and `pbd learn` use: the summary, the
//! recording (all topics) and the demonstration (percepts, truth, metadata) read from it.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = pbd::mcap_log::read_summary_bytes(data);
    if let Ok(recording) = pbd::mcap_log::read_recording_bytes(data, &[]) {
        let _ = pbd::infer::demonstration_from(&recording, Path::new("fuzz.mcap"));
    }
});

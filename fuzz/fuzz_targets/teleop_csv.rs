//! Teleop streams: the same bytes read as CSV and as JSON lines.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pbd::dexter_sim::teleop::TeleopStream;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let _ = TeleopStream::parse(&text, "fuzz.csv");
    let _ = TeleopStream::parse(&text, "fuzz.jsonl");
});

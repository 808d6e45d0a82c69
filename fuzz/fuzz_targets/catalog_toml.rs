//! Object catalog TOML.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let _ = pbd::dexter_sim::scene::Catalog::from_toml_str(&text, Path::new("fuzz-catalog.toml"));
});

//! No code: see `Cargo.toml` — the features shared by the workspace's tests and the Python
//! module's build, so that pip reuses what `cargo test` compiled.

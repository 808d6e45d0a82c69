//! Every integration test of this crate that needs no process of its own, in one binary: one link
//! and one set of generic instantiations instead of one per file (rebuilding the workspace's test
//! binaries took 50 s with one per file, 33 s so, on 2 idle cores). Each file is a module; run one
//! with `cargo test --release -p <crate> --test integration <file>::`. A test that installs a counting
//! global allocator keeps a binary of its own (`Cargo.toml`); docs/src/testing.md has the layout.

mod any_schema;
mod calibration_file;
mod determinism;
mod foxglove_layout;
mod fuzz_readers;
mod grasp_candidates;
mod live_view;
mod skills;
mod sorting_acceptance;
mod sorting_trials;

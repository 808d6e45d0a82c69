//! Every integration test of this crate that needs no process of its own, in one binary: one link
//! and one set of generic instantiations instead of one per file (rebuilding the workspace's test
//! binaries took 50 s with one per file, 33 s so, on 2 idle cores). Each file is a module; run one
//! with `cargo test --release -p <crate> --test integration <file>::`. A test that installs a counting
//! global allocator keeps a binary of its own (`Cargo.toml`); docs/src/testing.md has the layout.

mod bench_scene;
mod capture_pair;
mod faults;
mod grasp_grid;
mod honest_eyes;
mod physics;
mod pick_place_catalog;
mod scene_input;
mod surface_colours;

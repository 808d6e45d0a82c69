//! One injected-fault scene, for debugging: `cargo run --release -p dexter-sim --example fault_probe
//! -- <kind> <index> [seed]` (set `PBD_DEBUG_EXEC=1` to see the monitors after every action,
//! `PBD_DEBUG_BLOBS=1` for every stereo blob and forgotten track, `PBD_DEBUG_TRUTH=1` for the
//! object's true position, both palms and the six fingertip heights every half second, or
//! `PBD_DEBUG_TRUTH=50` every 50 ms). Rebuild it after a change: a stale probe disagrees with the
//! experiment, which is deterministic (one thread or two give the same rows).

use dexter_sim::fault::{FaultKind, fault_trial};
use dexter_sim::scene::Scene;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let kind = args.get(1).and_then(|s| FaultKind::parse(s)).unwrap_or(FaultKind::Bump);
    let i: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(0);
    let seed: u64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1);
    let base = Scene::builtin("pick-place").expect("built-in scene");
    let library = schema::Library::builtin();
    match fault_trial(&base, "pick-place", &library, kind, seed, i) {
        Ok(t) => println!("{}", serde_json::to_string_pretty(&t).unwrap_or_default()),
        Err(e) => eprintln!("error: {e}"),
    }
}

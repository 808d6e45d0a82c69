//! One injected-fault scene, for debugging: `cargo run --release -p dexter-sim --example fault_probe
//! -- <kind> <index> [seed]` (set `RUST_LOG=schema=info,dexter::exec=debug` to see each action and
//! the monitors after it, `dexter::watch=trace` for every stereo blob and forgotten track,
//! `dexter_sim::truth=trace` for the object's true position, both palms and the six fingertip
//! heights every half second). Rebuild it after a change: a stale probe disagrees with the
//! experiment, which is deterministic (one thread or two give the same rows).

use dexter_sim::fault::{FaultKind, fault_trial};
use dexter_sim::scene::Scene;

fn main() {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .with_writer(std::io::stderr)
        .without_time()
        .init();
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

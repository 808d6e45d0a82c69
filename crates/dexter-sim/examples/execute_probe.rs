//! One scene of the execute experiment, for debugging: `cargo run --release -p dexter-sim --example
//! execute_probe -- <model.json> <index> [seed]` runs scene `index` of `pbd experiment execute
//! --seed seed` on `sorting-demo` and prints the true objects and the report (`PBD_DEBUG_BLOBS=1`,
//! `PBD_DEBUG_EXEC=1` print the robot's reasoning).

use std::collections::BTreeMap;

use dexter_sim::experiment::{ExperimentConfig, run_scene};
use dexter_sim::scene::Scene;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let model = args.get(1).cloned().unwrap_or("pbd-demo/model.json".into());
    let i: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(0);
    let seed: u64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1);
    let base = Scene::builtin("sorting-demo")?;
    let library = schema::Library::builtin();
    let task: BTreeMap<String, String> = [("red", "bin-right"), ("blue", "bin-left")]
        .into_iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    let config = ExperimentConfig {
        model: model.into(),
        scenes: i + 1,
        objects: 3,
        task,
        seed,
    };
    let (scene, report) = run_scene(&base, "sorting-demo", &library, &config, i)?;
    for r in &scene.resolved {
        println!("object {} at {:?}", r.label, r.pose.translation.vector);
    }
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}

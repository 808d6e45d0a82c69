//! Same seed, same files: two runs of the whole pipeline give byte-identical inference and model
//! files, and the execute experiment gives a byte-identical `objects.csv` on one thread and on two.

use std::path::Path;

use pbd::demo::{DemoOptions, demo};
use pbd::experiment::execute::{ExecuteExperimentOptions, run};
use pbd::progress::Quiet;

fn read(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn same_seed_gives_identical_files_on_two_runs_and_any_number_of_threads() {
    let dir = std::env::temp_dir().join(format!("pbd-determinism-{}", std::process::id()));
    let out = dir.join("demo");
    let options = DemoOptions {
        out: out.clone(),
        seed: 3,
        ..DemoOptions::default()
    };
    let first = demo(&options, &Quiet).unwrap();
    let (infer_1, model_1) = (read(&out.join("demo.infer.json")), read(&out.join("model.json")));
    let second = demo(&options, &Quiet).unwrap();
    assert_eq!(
        read(&out.join("demo.infer.json")),
        infer_1,
        "demo.infer.json differs between two runs"
    );
    assert_eq!(
        read(&out.join("model.json")),
        model_1,
        "model.json differs between two runs"
    );
    assert_eq!(first.execute.placed, second.execute.placed);

    let csv_with = |threads: usize| {
        let options = ExecuteExperimentOptions {
            model: out.join("model.json"),
            scenes: 3,
            objects: 2,
            seed: 5,
            output: dir.join(format!("experiment-{threads}")),
            ..ExecuteExperimentOptions::default()
        };
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| run(&options, &Quiet)).unwrap();
        read(&options.output.join("objects.csv"))
    };
    let one = csv_with(1);
    assert_eq!(one, csv_with(2), "objects.csv differs between 1 and 2 threads");
    assert!(one.len() > 100, "{}", String::from_utf8_lossy(&one));
    let _ = std::fs::remove_dir_all(&dir);
}

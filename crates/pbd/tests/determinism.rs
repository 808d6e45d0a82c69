//! Same seed, same files: two runs of the whole pipeline, at once on two threads, give
//! byte-identical inference and model files, and the execute experiment gives a byte-identical `objects.csv` on one thread and on two.

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
    // The two runs at once, on two threads of one process: same files, and nothing shared between
    // runs that could make them differ (and half the wall time of running them one after the other).
    let demo_run = |name: &str| {
        let out = dir.join(name);
        let options = DemoOptions {
            out: out.clone(),
            seed: 3,
            ..DemoOptions::default()
        };
        let report = demo(&options, &Quiet).unwrap();
        // The inference file names its recording by path: the same text in both runs.
        let infer = String::from_utf8(read(&out.join("demo.infer.json")))
            .unwrap()
            .replace(&out.display().to_string(), "OUT");
        (report, infer, read(&out.join("model.json")), out)
    };
    let (first, second) = std::thread::scope(|s| {
        let a = s.spawn(|| demo_run("demo-1"));
        let b = s.spawn(|| demo_run("demo-2"));
        (a.join().unwrap(), b.join().unwrap())
    });
    assert_eq!(first.1, second.1, "demo.infer.json differs between two runs");
    assert_eq!(first.2, second.2, "model.json differs between two runs");
    assert_eq!(first.0.execute.placed, second.0.execute.placed);
    let out = first.3;

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

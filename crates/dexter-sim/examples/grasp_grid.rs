//! The grasp grid of `../shared/NOTES-grasp-physics.md` (96 trials) on Dexter's right WAM + hand,
//! scored with the NOTES' criterion (`dexter_sim::grasp_grid`): a physics regression check for
//! changes to the simulator (issue 17).
//!
//! ```text
//! cargo run --release -p dexter-sim --example grasp_grid -- [--iterations N] [--every-substep]
//!     [--trials A..B] [--threads N] [--json FILE]
//! ```
//! `--iterations` sets the solver substeps per 1 ms step (default 4); `--every-substep` rebuilds the
//! arms' mass matrices at every substep (rapier's schedule) instead of once per step. Prints the
//! failures, the score over the grid and its subset, and the deepest penetration; `--json` writes
//! every row.

use std::time::Instant;

use dexter_sim::grasp_grid::{self, GridRow};
use dexter_sim::physics::SimSettings;
use rayon::prelude::*;

fn main() {
    if let Err(e) = run() {
        eprintln!("grasp_grid: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut settings = SimSettings {
        placement_jitter: (0.0, 0.0),
        allow_sleep: false,
        ..SimSettings::default()
    };
    let mut trials = 0..96;
    let mut threads = 2;
    let mut json = None;
    let mut i = 0;
    while i < args.len() {
        let value = |i: usize| args.get(i + 1).cloned().ok_or(format!("{} needs a value", args[i]));
        match args[i].as_str() {
            "--iterations" => {
                settings.solver_iterations = value(i)?.parse()?;
                i += 1;
            }
            "--every-substep" => settings.mass_matrix_once_per_step = false,
            "--trials" => {
                let v = value(i)?;
                let (a, b) = v.split_once("..").ok_or("--trials A..B")?;
                trials = a.parse()?..b.parse()?;
                i += 1;
            }
            "--threads" => {
                threads = value(i)?.parse()?;
                i += 1;
            }
            "--json" => {
                json = Some(value(i)?);
                i += 1;
            }
            other => return Err(format!("unknown argument {other}").into()),
        }
        i += 1;
    }
    let wall = Instant::now();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
    let rows: Vec<GridRow> = pool.install(|| {
        trials
            .clone()
            .into_par_iter()
            .map(|t| grasp_grid::run_trial(t, &settings))
            .collect::<Result<_, _>>()
    })?;
    for r in rows.iter().filter(|r| !r.success) {
        println!(
            "FAIL {:3} {:20} {:15} rose {:6.3} sank {:6.3} parts {} pen {:4.1} mm  {}",
            r.trial,
            r.object,
            r.offset,
            r.rose,
            r.sank,
            r.parts,
            r.max_penetration * 1000.0,
            r.outcome
        );
    }
    let s = grasp_grid::summarize(&rows);
    let pct = |(a, b): (usize, usize)| 100.0 * a as f64 / b.max(1) as f64;
    println!(
        "grid {}/{} = {:.1} %, subset {}/{} = {:.1} %, max penetration {:.1} mm (successes) / {:.1} mm (all); \
         {} substeps, mass matrix {}; {:.0} s wall on {threads} threads",
        s.grid.0,
        s.grid.1,
        pct(s.grid),
        s.subset.0,
        s.subset.1,
        pct(s.subset),
        s.max_penetration_success * 1000.0,
        s.max_penetration * 1000.0,
        settings.solver_iterations,
        if settings.mass_matrix_once_per_step {
            "once per step"
        } else {
            "every substep"
        },
        wall.elapsed().as_secs_f64()
    );
    if let Some(path) = json {
        let text = serde_json::to_string_pretty(&serde_json::json!({ "summary": s, "rows": rows }))?;
        std::fs::write(&path, text)?;
    }
    Ok(())
}

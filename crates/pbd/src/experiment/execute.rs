//! `pbd experiment execute`: a learned procedural model executed by the robot, from its own senses,
//! on N random new scenes drawn from a catalog (objects, poses, which bins; seeded) — the seed's
//! claim that what was learned from a few demonstrations transfers to new situations (§4.3.2, §5.3).
//!
//! Per scene: K presentations drawn from the catalog at random poses on the table (clear of the bins
//! and of each other), the robot looks over the table, decides per seen segment (relevance by B10,
//! place by MAP) and runs Pick-And-Place with ψ on each relevant one. The evaluator matches segments to
//! objects by the truth at the start and judges each outcome by the truth at the end. The task's
//! intended decision per object comes from the catalog's colour and size labels (`--task
//! red=bin-right,…`, `--task small=bin-left,large=bin-right`, `--task red+large=bin-right`).
//! One scene is a pure function of (config, index) in [`dexter_sim::experiment`]; this module runs the
//! scenes on the thread pool and writes per-object decisions and outcomes (`objects.csv`), the placed
//! fraction with a 95 % Wilson interval, decision accuracy and failure causes by phase (`summary.md`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use dexter_sim::experiment::{ExperimentConfig, ObjectRow, Summary, run_scene_logged, summarize};
use dexter_sim::scene::Scene;
use schema::Library;
use serde::{Deserialize, Serialize};

use crate::progress::Progress;

/// Options of the execute experiment ([`run`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ExecuteExperimentOptions {
    /// The learned procedural model (from `pbd learn`, e.g. `pbd-demo/model.json`).
    pub model: PathBuf,
    /// Base scene: its table, bins and catalog (built-in name or TOML file).
    pub scene: String,
    /// Number of random scenes.
    pub scenes: usize,
    /// Objects per scene.
    pub objects: usize,
    /// The intended task: `class=place` entries (objects of other classes are not part of the task);
    /// a class is a colour class, a size class (`small`, `medium`, `large`) or `colour+size`.
    pub task: Vec<String>,
    /// Random seed (scenes and every run).
    pub seed: u64,
    /// Output directory (objects.csv, summary.md).
    pub output: PathBuf,
    /// Run only scene K (0-based; the same scene as in the full run), to trace it.
    pub only: Option<usize>,
}

impl Default for ExecuteExperimentOptions {
    fn default() -> Self {
        ExecuteExperimentOptions {
            model: PathBuf::from("pbd-demo/model.json"),
            scene: "sorting-demo".into(),
            scenes: 50,
            objects: 3,
            task: vec!["red=bin-right".into(), "blue=bin-left".into()],
            seed: 1,
            output: PathBuf::from("experiment-execute"),
            only: None,
        }
    }
}

/// The experiment's result: per-object rows, the summary and its Markdown.
#[derive(Debug, Clone, Serialize)]
pub struct ExecuteExperimentRun {
    /// The summary (placed fraction, intervals, failures by phase).
    pub summary: Summary,
    /// One row per seen segment or unseen object.
    #[serde(skip)]
    pub rows: Vec<ObjectRow>,
    /// `summary.md`.
    #[serde(skip)]
    pub markdown: String,
    /// The output directory.
    pub output: PathBuf,
}

fn parse_task(task: &[String]) -> Result<BTreeMap<String, String>> {
    task.iter()
        .map(|t| {
            let (c, p) = t
                .split_once('=')
                .with_context(|| format!("--task: `{t}` is not class=place"))?;
            let c = c.trim();
            let parts: Vec<&str> = c.split('+').map(str::trim).collect();
            if parts.iter().any(|p| p.is_empty()) || p.trim().is_empty() {
                bail!("--task: `{t}` is not class=place (a class is a colour class, a size class or colour+size)");
            }
            let sizes = parts
                .iter()
                .filter(|p| dexter_sim::scene::SIZE_CLASSES.contains(p))
                .count();
            if parts.len() > 2 || sizes > 1 || (parts.len() == 2 && sizes != 1) {
                bail!(
                    "--task: `{c}` must be one colour class, one size class ({}) or colour+size",
                    dexter_sim::scene::SIZE_CLASSES.join(", ")
                );
            }
            Ok((parts.join("+"), p.trim().to_string()))
        })
        .collect()
}

/// The files `experiment execute` writes in its output directory.
pub const OUTPUT_FILES: &[&str] = &["objects.csv", "summary.md"];

/// Runs the experiment: the scenes in parallel on the thread pool, then `objects.csv` and `summary.md`
/// in the output directory. The same seed gives the same files, whatever the number of threads.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn run(args: &ExecuteExperimentOptions, progress: &dyn Progress) -> crate::Result<ExecuteExperimentRun> {
    run_impl(args, progress).map_err(crate::Error::from)
}

fn run_impl(args: &ExecuteExperimentOptions, progress: &dyn Progress) -> anyhow::Result<ExecuteExperimentRun> {
    crate::limits::check_count("scenes", args.scenes, crate::limits::MAX_SCENES)?;
    crate::limits::check_count("objects", args.objects, crate::limits::MAX_OBJECTS)?;
    if let Some(k) = args.only.filter(|&k| k >= args.scenes) {
        anyhow::bail!(
            "--only {k}: there are {} scenes (0-based, so at most {})",
            args.scenes,
            args.scenes.saturating_sub(1)
        );
    }
    let base = Scene::open(&args.scene)?;
    let task = parse_task(&args.task)?;
    for p in task.values() {
        base.place(p)?;
    }
    // Check the model before minutes of simulation.
    schema::procedural::ProceduralModel::load(&args.model)?;
    crate::files::IoPlan::new()
        .read("--model", &args.model)
        .read("--scene", &base.path)
        .read("the scene's catalog", &base.catalog.path)
        .write_in("-o", &args.output, OUTPUT_FILES)
        .check()?;
    std::fs::create_dir_all(&args.output).with_context(|| format!("cannot create {}", args.output.display()))?;
    let config = ExperimentConfig {
        model: args.model.clone(),
        scenes: args.scenes,
        objects: args.objects,
        task,
        seed: args.seed,
    };
    let library = Library::builtin();
    let wall = std::time::Instant::now();
    let indices: Vec<usize> = match args.only {
        Some(k) => vec![k],
        None => (0..args.scenes).collect(),
    };
    progress.phase("execute", Some(indices.len() as u64));
    // On Ctrl-C, scenes not yet started are skipped; the finished ones are written, marked partial.
    // A scene under way when the signal comes stops within a control period (and is not counted).
    struct Stop<'a>(&'a dyn Progress);
    impl dexter_sim::execute::RunLog for Stop<'_> {
        fn should_stop(&mut self) -> bool {
            self.0.should_stop()
        }
    }
    let runs = crate::parallel::map_until_stopped(&indices, progress, |&i| {
        match run_scene_logged(&base, &args.scene, &library, &config, i, &mut Stop(progress)) {
            Ok(run) => Ok(Some(run)),
            Err(_) if progress.should_stop() => Ok(None),
            Err(e) => Err(e.into()),
        }
    })?;
    let runs: Vec<Option<_>> = runs.into_iter().map(Option::flatten).collect();
    progress.finish();
    let done: Vec<usize> = runs
        .iter()
        .enumerate()
        .filter(|(_, r)| r.is_some())
        .map(|(i, _)| indices[i])
        .collect();
    let completed: Vec<_> = runs.into_iter().flatten().collect();
    let (mut rows, summary) = summarize(&config, &completed);
    for r in &mut rows {
        r.scene = done[r.scene];
    }
    let wall_time = wall.elapsed().as_secs_f64();
    write_csv(&args.output.join("objects.csv"), &rows)?;
    let mut md = markdown(args, &summary, wall_time);
    let partial = completed.len() < indices.len();
    if partial {
        md = format!(
            "**PARTIAL: interrupted after {} of {} scenes** (scenes {:?}); the figures below are over those.\n\n{md}",
            completed.len(),
            indices.len(),
            done
        );
    }
    crate::files::write_atomic(&args.output.join("summary.md"), md.as_bytes())?;
    if partial {
        anyhow::bail!(
            "interrupted after {} of {} scenes; the partial results are in {} (marked PARTIAL)",
            completed.len(),
            indices.len(),
            args.output.display()
        );
    }
    Ok(ExecuteExperimentRun {
        summary,
        rows,
        markdown: md,
        output: args.output.clone(),
    })
}

fn write_csv(path: &Path, rows: &[ObjectRow]) -> Result<()> {
    let mut s = String::from(
        "scene,object,color_class,size_class,intended,decision,place,log_b10,size_cm,arms,transfer,placed,decision_correct,failure\n",
    );
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},\"{}\"\n",
            r.scene,
            r.object,
            r.color_class,
            r.size_class,
            r.intended,
            r.decision,
            r.place,
            r.log_b10.map(|v| format!("{v:.3}")).unwrap_or_default(),
            r.size_cm.map(|v| format!("{v:.2}")).unwrap_or_default(),
            r.arms,
            r.transfer,
            r.placed,
            r.decision_correct,
            r.failure.replace('"', "'")
        ));
    }
    crate::files::write_atomic(path, s.as_bytes())
}

fn markdown(args: &ExecuteExperimentOptions, s: &Summary, wall_time: f64) -> String {
    let mut m = format!(
        "# Execution in new scenes\n\nModel `{}` on {} random scenes of {} objects drawn from the catalog of `{}` (seed {}); task {}.\n\n",
        args.model.display(),
        s.scenes,
        args.objects,
        args.scene,
        args.seed,
        args.task.join(", ")
    );
    m.push_str("| figure | value |\n|---|---|\n");
    m.push_str(&format!(
        "| objects presented | {} ({} report rows: seen segments and unseen objects) |\n",
        s.objects, s.rows
    ));
    m.push_str(&format!(
        "| decided relevant and executed | {} |\n| placed / executed | {}/{} = {:.3} (95 % CI {:.3}–{:.3}) |\n",
        s.executed, s.placed, s.executed, s.placed_fraction, s.placed_interval.0, s.placed_interval.1
    ));
    m.push_str(&format!(
        "| task objects in their intended place | {:.3} (95 % CI {:.3}–{:.3}) |\n| decisions matching the task | {:.3} (95 % CI {:.3}–{:.3}) |\n",
        s.task_success,
        s.task_interval.0,
        s.task_interval.1,
        s.decision_accuracy,
        s.decision_interval.0,
        s.decision_interval.1
    ));
    m.push_str(&format!(
        "| simulated / wall time | {:.0} s / {wall_time:.0} s |\n\n",
        s.sim_time
    ));
    m.push_str("Failures by phase:\n\n| phase | count |\n|---|---|\n");
    for (p, n) in &s.failures {
        m.push_str(&format!("| {p} | {n} |\n"));
    }
    m.push_str(&format!("\nHand-to-hand transfers: {}.\n", s.transfers));
    m
}

//! `pbd experiment execute`: a learned procedural model executed by the robot, from its own senses,
//! on N random new scenes drawn from a catalog (objects, poses, which bins; seeded) — the seed's
//! claim that what was learned from a few demonstrations transfers to new situations (§4.3.2, §5.3).
//!
//! Per scene: K presentations drawn from the catalog at random poses on the table (clear of the bins
//! and of each other), the robot looks over the table, decides per seen segment (relevance by B10,
//! place by MAP) and runs Pick-And-Place with ψ on each relevant one. The evaluator matches segments to
//! objects by the truth at the start and judges each outcome by the truth at the end. The task's
//! intended decision per object comes from the catalog's colour labels (`--task red=bin-right,…`).
//! The experiment itself is the library's [`dexter_sim::experiment`]; this file parses the arguments,
//! runs the scenes on worker threads and writes per-object decisions and outcomes (CSV), the placed
//! fraction with a 95 % Wilson interval, decision accuracy and failure causes by phase (Markdown,
//! SVG).

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use dexter_sim::experiment::{ExperimentConfig, ObjectRow, Summary, run_scene, summarize};
use dexter_sim::scene::Scene;
use plotters::prelude::*;
use schema::Library;

/// `pbd experiment execute` arguments.
#[derive(Debug, Args)]
pub struct ExecuteExperimentArgs {
    /// The learned procedural model (from `pbd learn`, e.g. `pbd-demo/model.json`).
    #[arg(long)]
    pub model: PathBuf,
    /// Base scene: its table, bins and catalog (built-in name or TOML file).
    #[arg(long, default_value = "sorting-demo")]
    pub scene: String,
    /// Number of random scenes.
    #[arg(long, default_value_t = 50)]
    pub scenes: usize,
    /// Objects per scene.
    #[arg(long, default_value_t = 3)]
    pub objects: usize,
    /// The intended task: colour class = place, comma-separated (objects of other classes are not
    /// part of the task).
    #[arg(long, value_delimiter = ',', default_value = "red=bin-right,blue=bin-left")]
    pub task: Vec<String>,
    /// Random seed (scenes and every run).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output directory (objects.csv, summary.md, outcomes.svg).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

fn parse_task(task: &[String]) -> Result<BTreeMap<String, String>> {
    task.iter()
        .map(|t| {
            let (c, p) = t
                .split_once('=')
                .with_context(|| format!("--task: `{t}` is not class=place"))?;
            Ok((c.trim().to_string(), p.trim().to_string()))
        })
        .collect()
}

/// Runs the experiment.
pub fn run(args: &ExecuteExperimentArgs, out: &mut dyn Write) -> Result<()> {
    if args.scenes == 0 || args.objects == 0 {
        bail!("--scenes and --objects must be at least 1");
    }
    let base = Scene::open(&args.scene)?;
    let task = parse_task(&args.task)?;
    for p in task.values() {
        base.place(p)?;
    }
    // Check the model before minutes of simulation.
    schema::procedural::ProceduralModel::load(&args.model)?;
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
    let bar = crate::progress::bar(args.json, args.scenes as u64, "execute");
    let indices: Vec<usize> = (0..args.scenes).collect();
    let runs = crate::grasp::common::parallel_map(&indices, |_, &i| {
        let r = run_scene(&base, &args.scene, &library, &config, i);
        bar.inc(1);
        Ok(r?)
    })?;
    bar.finish_and_clear();
    let (rows, summary) = summarize(&config, &runs);
    let wall_time = wall.elapsed().as_secs_f64();
    write_csv(&args.output.join("objects.csv"), &rows)?;
    let md = markdown(args, &summary, wall_time);
    std::fs::write(args.output.join("summary.md"), &md)
        .with_context(|| format!("cannot write {}", args.output.join("summary.md").display()))?;
    outcome_chart(&args.output.join("outcomes.svg"), &summary)?;
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&summary)?)?;
    } else {
        write!(out, "{md}")?;
        writeln!(
            out,
            "files: objects.csv, summary.md, outcomes.svg in {}",
            args.output.display()
        )?;
    }
    Ok(())
}

fn write_csv(path: &Path, rows: &[ObjectRow]) -> Result<()> {
    let mut s = String::from(
        "scene,object,color_class,intended,decision,place,log_b10,arms,transfer,placed,decision_correct,failure\n",
    );
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},\"{}\"\n",
            r.scene,
            r.object,
            r.color_class,
            r.intended,
            r.decision,
            r.place,
            r.log_b10.map(|v| format!("{v:.3}")).unwrap_or_default(),
            r.arms,
            r.transfer,
            r.placed,
            r.decision_correct,
            r.failure.replace('"', "'")
        ));
    }
    std::fs::write(path, s).with_context(|| format!("cannot write {}", path.display()))
}

fn markdown(args: &ExecuteExperimentArgs, s: &Summary, wall_time: f64) -> String {
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
        "| task objects in their intended place | {:.3} (95 % CI {:.3}–{:.3}) |\n| decisions matching the task | {:.3} |\n",
        s.task_success, s.task_interval.0, s.task_interval.1, s.decision_accuracy
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

fn outcome_chart(path: &Path, s: &Summary) -> Result<()> {
    let root = SVGBackend::new(path, (720, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut bars: Vec<(String, usize)> = vec![("placed".into(), s.placed)];
    for (p, n) in &s.failures {
        bars.push((p.clone(), *n));
    }
    let top = bars.iter().map(|b| b.1).max().unwrap_or(1).max(1) as f64 * 1.15;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "placed {}/{} = {:.2} (95 % CI {:.2}-{:.2})",
                s.placed, s.executed, s.placed_fraction, s.placed_interval.0, s.placed_interval.1
            ),
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..bars.len() as f64, 0.0..top)?;
    let labels: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(bars.len())
        .x_label_formatter(&|x| {
            let i = x.floor() as usize;
            if (x - x.floor() - 0.5).abs() < 0.26 {
                labels.get(i).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .y_desc("objects")
        .draw()?;
    chart.draw_series(bars.iter().enumerate().map(|(i, b)| {
        let color = if i == 0 {
            RGBColor(44, 160, 44)
        } else {
            RGBColor(214, 39, 40)
        };
        Rectangle::new([(i as f64 + 0.15, 0.0), (i as f64 + 0.85, b.1 as f64)], color.filled())
    }))?;
    root.present()?;
    Ok(())
}

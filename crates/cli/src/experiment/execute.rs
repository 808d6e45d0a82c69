//! `pbd experiment execute`: a learned procedural model executed by the robot, from its own senses,
//! on N random new scenes drawn from a catalog (objects, poses, which bins; seeded) — the seed's
//! claim that what was learned from a few demonstrations transfers to new situations (§4.3.2, §5.3).
//!
//! Per scene: K presentations drawn from the catalog at random poses on the table (clear of the bins
//! and of each other), the robot looks over the table, decides per seen segment (relevance by B10,
//! place by MAP) and runs Pick-And-Place with ψ on each relevant one. The evaluator matches segments to
//! objects by the truth at the start and judges each outcome by the truth at the end. The task's
//! intended decision per object comes from the catalog's colour labels (`--task red=bin-right,…`).
//! Reports per-object decisions and outcomes (CSV), the placed fraction with a 95 % Wilson interval,
//! decision accuracy, and failure causes by phase (Markdown, SVG).

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use dexter_sim::rng::SplitMix64;
use dexter_sim::scene::{ObjectPlacement, Scene};
use plotters::prelude::*;
use schema::Library;
use serde::Serialize;

use crate::execute::{Decider, ExecuteReport, execute_scene};

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

/// One object of one scene.
#[derive(Debug, Clone, Serialize)]
pub struct ObjectRow {
    /// Scene index.
    pub scene: usize,
    /// Scene label (the evaluator's).
    pub object: String,
    /// Its catalog colour class.
    pub color_class: String,
    /// The place the task intends, or `-`.
    pub intended: String,
    /// The robot's decision: `execute`, `ignore`, `skip`, `unseen`.
    pub decision: String,
    /// The place it chose.
    pub place: String,
    /// ln B10.
    pub log_b10: Option<f64>,
    /// Arms used.
    pub arms: String,
    /// Hand-to-hand transfer.
    pub transfer: bool,
    /// At rest inside the chosen place.
    pub placed: bool,
    /// The decision matches the task (ignore a distractor, or execute to the intended place).
    pub decision_correct: bool,
    /// Failure cause by phase.
    pub failure: String,
}

/// The experiment's figures.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Scenes run.
    pub scenes: usize,
    /// Objects presented.
    pub objects: usize,
    /// Report rows: one per seen segment, plus one per unseen object.
    pub rows: usize,
    /// Objects the robot decided to execute.
    pub executed: usize,
    /// Of those, placed in the chosen place.
    pub placed: usize,
    /// placed / executed.
    pub placed_fraction: f64,
    /// 95 % Wilson interval of the placed fraction.
    pub placed_interval: (f64, f64),
    /// Objects of the task placed in their intended place / objects of the task.
    pub task_success: f64,
    /// 95 % Wilson interval of the task success.
    pub task_interval: (f64, f64),
    /// Decisions that match the task / objects.
    pub decision_accuracy: f64,
    /// Failure causes by phase (count).
    pub failures: BTreeMap<String, usize>,
    /// Simulated seconds.
    pub sim_time: f64,
    /// Wall seconds.
    pub wall_time: f64,
}

/// The 95 % Wilson score interval of `k` successes in `n`.
pub fn wilson(k: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let (k, n, z) = (k as f64, n as f64, 1.959_963_984_540_054);
    let p = k / n;
    let d = 1.0 + z * z / n;
    let c = (p + z * z / (2.0 * n)) / d;
    let h = z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt() / d;
    ((c - h).max(0.0), (c + h).min(1.0))
}

/// Draws `k` presentations of `base`'s catalog at random poses on its table, clear of the places
/// (8 cm) and of each other (14 cm between centres); `None` after 200 failed draws.
pub fn random_scene(base: &Scene, k: usize, rng: &mut SplitMix64) -> Result<Scene> {
    let names: Vec<String> = base
        .catalog
        .presentation_names()
        .iter()
        .map(|s| s.to_string())
        .collect();
    if names.is_empty() {
        bail!("the catalog of {} has no presentations", base.spec.name);
    }
    let t = &base.spec.table;
    for _attempt in 0..200 {
        let mut objects: Vec<ObjectPlacement> = Vec::new();
        let mut tries = 0;
        while objects.len() < k && tries < 500 {
            tries += 1;
            let x = t.center[0] - t.size[0] / 2.0 + 0.12 + rng.next_f64() * (t.size[0] - 0.24);
            let y = t.center[1] - 0.4 + rng.next_f64() * 0.8;
            let clear_of_places = base.spec.places.iter().all(|p| {
                (x - p.center[0]).abs() > p.size[0] / 2.0 + p.wall_thickness + 0.08
                    || (y - p.center[1]).abs() > p.size[1] / 2.0 + p.wall_thickness + 0.08
            });
            let clear_of_others = objects.iter().all(|o| (o.xy[0] - x).hypot(o.xy[1] - y) >= 0.14);
            if !(clear_of_places && clear_of_others) {
                continue;
            }
            let name = &names[(rng.next_u64() % names.len() as u64) as usize];
            objects.push(ObjectPlacement {
                presentation: name.clone(),
                xy: [x, y],
                yaw_deg: 360.0 * rng.next_f64(),
                z: None,
            });
        }
        if objects.len() < k {
            continue;
        }
        if let Ok(s) = base.with_objects(objects) {
            return Ok(s);
        }
    }
    bail!(
        "could not place {k} objects on the table of {} in 200 draws",
        base.spec.name
    )
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
    // Check the model before hours of simulation.
    schema::procedural::ProceduralModel::load(&args.model)?;
    std::fs::create_dir_all(&args.output).with_context(|| format!("cannot create {}", args.output.display()))?;
    let library = Library::builtin();
    let mut scenes = Vec::with_capacity(args.scenes);
    for i in 0..args.scenes {
        let mut rng = SplitMix64::stream(args.seed, i as u64);
        scenes.push(random_scene(&base, args.objects, &mut rng)?);
    }
    let wall = std::time::Instant::now();
    let bar = crate::progress::bar(args.json, scenes.len() as u64, "execute");
    let reports: Vec<ExecuteReport> = crate::grasp::common::parallel_map(&scenes, |i, scene| {
        let r = execute_scene(
            scene,
            &format!("{}#{i}", args.scene),
            &library,
            &Decider::Model(&args.model),
            crate::grasp::common::mix(args.seed, i as u64),
            None,
            None,
            indicatif::ProgressBar::hidden(),
        );
        bar.inc(1);
        r
    })?;
    bar.finish_and_clear();
    let mut rows = Vec::new();
    for (i, (scene, r)) in scenes.iter().zip(&reports).enumerate() {
        for o in &r.objects {
            let class = scene
                .object_index(&o.object)
                .ok()
                .and_then(|k| scene.catalog.objects[scene.resolved[k].object].color_class.clone())
                .unwrap_or_else(|| "-".into());
            let intended = task.get(&class).cloned();
            let decision_correct = match (&intended, o.decision.as_str()) {
                (None, "ignore") => true,
                (Some(p), "execute" | "skip") => o.place.as_deref() == Some(p.as_str()),
                _ => false,
            };
            rows.push(ObjectRow {
                scene: i,
                object: o.object.clone(),
                color_class: class,
                intended: intended.unwrap_or_else(|| "-".into()),
                decision: o.decision.clone(),
                place: o.place.clone().unwrap_or_else(|| "-".into()),
                log_b10: o.log_bayes_factor,
                arms: o.arms.join(">"),
                transfer: o.transfer,
                placed: o.success,
                decision_correct,
                failure: o.failure.clone().unwrap_or_default(),
            });
        }
    }
    let executed = rows.iter().filter(|r| r.decision == "execute").count();
    let placed = rows.iter().filter(|r| r.decision == "execute" && r.placed).count();
    // Task objects, once each (an object seen as two segments has two rows): done if any row placed
    // it in its intended place.
    let mut task_objects: BTreeMap<(usize, String), bool> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.intended != "-" && r.object != "-") {
        *task_objects.entry((r.scene, r.object.clone())).or_insert(false) |= r.placed && r.place == r.intended;
    }
    let task_total = task_objects.len();
    let task_ok = task_objects.values().filter(|&&v| v).count();
    let presented: usize = scenes.iter().map(|s| s.resolved.len()).sum();
    let mut failures = BTreeMap::new();
    for r in rows.iter().filter(|r| !r.failure.is_empty()) {
        let phase = r.failure.split(':').next().unwrap_or("?").trim().to_string();
        *failures.entry(phase).or_insert(0) += 1;
    }
    let summary = Summary {
        scenes: args.scenes,
        objects: presented,
        rows: rows.len(),
        executed,
        placed,
        placed_fraction: if executed > 0 {
            placed as f64 / executed as f64
        } else {
            0.0
        },
        placed_interval: wilson(placed, executed),
        task_success: if task_total == 0 {
            0.0
        } else {
            task_ok as f64 / task_total as f64
        },
        task_interval: wilson(task_ok, task_total),
        decision_accuracy: rows.iter().filter(|r| r.decision_correct).count() as f64 / rows.len().max(1) as f64,
        failures,
        sim_time: reports.iter().map(|r| r.sim_time).sum(),
        wall_time: wall.elapsed().as_secs_f64(),
    };
    write_csv(&args.output.join("objects.csv"), &rows)?;
    std::fs::write(args.output.join("summary.md"), markdown(args, &summary, &rows))
        .with_context(|| format!("cannot write {}", args.output.join("summary.md").display()))?;
    outcome_chart(&args.output.join("outcomes.svg"), &summary)?;
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&summary)?)?;
    } else {
        write!(out, "{}", markdown(args, &summary, &rows))?;
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

fn markdown(args: &ExecuteExperimentArgs, s: &Summary, rows: &[ObjectRow]) -> String {
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
        "| simulated / wall time | {:.0} s / {:.0} s |\n\n",
        s.sim_time, s.wall_time
    ));
    m.push_str("Failures by phase:\n\n| phase | count |\n|---|---|\n");
    for (p, n) in &s.failures {
        m.push_str(&format!("| {p} | {n} |\n"));
    }
    let transfers = rows.iter().filter(|r| r.transfer).count();
    m.push_str(&format!("\nHand-to-hand transfers: {transfers}.\n"));
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_matches_the_textbook_values() {
        // 45/50: (0.786, 0.957) (Wilson 1927; e.g. Newcombe 1998, method 3).
        let (lo, hi) = wilson(45, 50);
        assert!((lo - 0.7864).abs() < 1e-3 && (hi - 0.9565).abs() < 1e-3, "{lo} {hi}");
        assert_eq!(wilson(0, 0), (0.0, 1.0));
        let (lo, hi) = wilson(10, 10);
        assert!((hi - 1.0).abs() < 1e-12 && (lo - 0.7225).abs() < 1e-3, "{lo} {hi}");
    }

    #[test]
    fn random_scenes_are_seeded_and_clear_of_each_other() {
        let base = Scene::builtin("sorting-demo").unwrap();
        let a = random_scene(&base, 3, &mut SplitMix64::stream(1, 0)).unwrap();
        let b = random_scene(&base, 3, &mut SplitMix64::stream(1, 0)).unwrap();
        assert_eq!(a.spec.objects, b.spec.objects);
        for (i, p) in a.spec.objects.iter().enumerate() {
            for q in &a.spec.objects[..i] {
                assert!((p.xy[0] - q.xy[0]).hypot(p.xy[1] - q.xy[1]) >= 0.14);
            }
        }
    }
}

//! `pbd experiment perception`: what the robot's eyes make of N random scenes, against the truth —
//! the scenes of `pbd experiment execute` with the same seed (catalog objects at random poses on the
//! table). Per scene the robot looks over the table as it does before a task, and its tracked
//! segments are compared with the objects ([`dexter_sim::perception`]): objects missed, duplicate and
//! phantom segments, centroid, height and footprint errors. Writes `objects.csv` (one row per
//! object), `summary.md` and `errors.svg` (median and maximum errors).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use dexter_sim::perception::{MedianMax, PerceptionSummary, ScanReport, scan_trial, summarize};
use dexter_sim::scene::Scene;
use serde::{Deserialize, Serialize};

use crate::figure::Figure;
use crate::progress::Progress;

/// Options of the perception experiment ([`run`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PerceptionOptions {
    /// Base scene: its table, bins and catalog (built-in name or TOML file).
    pub scene: String,
    /// Number of random scenes.
    pub scenes: usize,
    /// Objects per scene.
    pub objects: usize,
    /// Random seed (scenes and every run; the same scenes as `pbd experiment execute --seed`).
    pub seed: u64,
    /// Output directory (objects.csv, summary.md, errors.svg).
    pub output: PathBuf,
}

impl Default for PerceptionOptions {
    fn default() -> Self {
        PerceptionOptions {
            scene: "sorting-demo".into(),
            scenes: 50,
            objects: 3,
            seed: 1,
            output: PathBuf::from("experiment-perception"),
        }
    }
}

/// The experiment's result.
#[derive(Debug, Clone, Serialize)]
pub struct PerceptionRun {
    /// The figures.
    pub summary: PerceptionSummary,
    /// Per scene (in order), what the robot saw.
    #[serde(skip)]
    pub scenes: Vec<ScanReport>,
    /// `summary.md`.
    #[serde(skip)]
    pub markdown: String,
    /// The figure to draw to `errors.svg`.
    #[serde(skip)]
    pub figure: Figure,
    /// The output directory.
    pub output: PathBuf,
}

impl std::fmt::Display for PerceptionRun {
    /// `summary.md`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.markdown)
    }
}

/// Runs the experiment: the scenes in parallel on the thread pool, then `objects.csv` and
/// `summary.md` in the output directory (the caller draws [`PerceptionRun::figure`]). The same seed
/// gives the same files, whatever the number of threads.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn run(args: &PerceptionOptions, progress: &dyn Progress) -> crate::Result<PerceptionRun> {
    run_impl(args, progress).map_err(crate::Error::from)
}

fn run_impl(args: &PerceptionOptions, progress: &dyn Progress) -> anyhow::Result<PerceptionRun> {
    crate::limits::check_count("scenes", args.scenes, crate::limits::MAX_SCENES)?;
    crate::limits::check_count("objects", args.objects, crate::limits::MAX_OBJECTS)?;
    let base = Scene::open(&args.scene)?;
    std::fs::create_dir_all(&args.output).with_context(|| format!("cannot create {}", args.output.display()))?;
    let wall = std::time::Instant::now();
    progress.phase("perceive", Some(args.scenes as u64));
    let indices: Vec<usize> = (0..args.scenes).collect();
    let runs = crate::parallel::map_until_stopped(&indices, progress, |&i| {
        Ok(scan_trial(&base, args.objects, args.seed, i)?)
    })?;
    progress.finish();
    let done: Vec<usize> = runs
        .iter()
        .enumerate()
        .filter(|(_, r)| r.is_some())
        .map(|(i, _)| i)
        .collect();
    let scenes: Vec<ScanReport> = runs.into_iter().flatten().collect();
    let summary = summarize(&scenes);
    write_csv(&args.output.join("objects.csv"), &done, &scenes)?;
    let mut md = markdown(args, &summary, wall.elapsed().as_secs_f64());
    let partial = scenes.len() < args.scenes;
    if partial {
        md = format!(
            "**PARTIAL: interrupted after {} of {} scenes** (scenes {done:?}); the figures below are over those.\n\n{md}",
            scenes.len(),
            args.scenes
        );
    }
    crate::files::write_atomic(&args.output.join("summary.md"), md.as_bytes())?;
    if partial {
        anyhow::bail!(
            "interrupted after {} of {} scenes; the partial results are in {} (marked PARTIAL)",
            scenes.len(),
            args.scenes,
            args.output.display()
        );
    }
    let figure = figure(&summary);
    Ok(PerceptionRun {
        summary,
        scenes,
        markdown: md,
        figure,
        output: args.output.clone(),
    })
}

fn write_csv(path: &Path, indices: &[usize], scenes: &[ScanReport]) -> Result<()> {
    let mut s = String::from(
        "scene,object,segments,centroid_error_xy_m,centroid_error_z_m,height_error_m,footprint_error_m,phantoms_in_scene\n",
    );
    let num = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.4}"));
    for (i, r) in indices.iter().zip(scenes) {
        for o in &r.objects {
            let _ = writeln!(
                s,
                "{i},{},{},{},{},{},{},{}",
                o.object,
                o.segments,
                num(o.centroid_error_xy),
                num(o.centroid_error_z),
                num(o.height_error),
                num(o.footprint_error),
                r.phantoms
            );
        }
    }
    crate::files::write_atomic(path, s.as_bytes())
}

fn cm(m: Option<MedianMax>) -> String {
    m.map_or("-".into(), |m| {
        format!("{:.1} / {:.1}", 100.0 * m.median, 100.0 * m.max)
    })
}

fn markdown(args: &PerceptionOptions, s: &PerceptionSummary, wall_time: f64) -> String {
    let mut md = format!(
        "# Perception\n\n{} random scenes of `{}` with {} objects each (seed {}; the scenes of `pbd experiment \
         execute` with that seed). The robot looks over the table as before a task; its tracked segments are \
         compared with the objects (a segment within 8 cm of an object's centre in the table plane is a view \
         of it).\n\n| figure | value |\n|---|---|\n",
        args.scenes, args.scene, args.objects, args.seed
    );
    let _ = writeln!(md, "| objects presented | {} |", s.objects);
    let _ = writeln!(md, "| missed (no segment within 8 cm) | {} |", s.missed);
    let _ = writeln!(
        md,
        "| duplicate segments (a second one of an object) | {} |",
        s.duplicates
    );
    let _ = writeln!(md, "| phantom segments (no object within 8 cm) | {} |", s.phantoms);
    let _ = writeln!(
        md,
        "| centroid error in the table plane, median / max (cm) | {} |",
        cm(s.centroid_xy)
    );
    let _ = writeln!(
        md,
        "| centroid height error, median / max (cm) | {} |",
        cm(s.centroid_z)
    );
    let _ = writeln!(md, "| object height error, median / max (cm) | {} |", cm(s.height));
    let _ = writeln!(
        md,
        "| footprint half-extent error, median / max (cm) | {} |",
        cm(s.footprint)
    );
    let _ = writeln!(md, "\nWall time: {wall_time:.0} s.");
    md
}

fn figure(s: &PerceptionSummary) -> Figure {
    let all = [s.centroid_xy, s.centroid_z, s.height, s.footprint];
    let median: Vec<f64> = all.iter().map(|m| m.map_or(0.0, |m| 100.0 * m.median)).collect();
    let max: Vec<f64> = all.iter().map(|m| m.map_or(0.0, |m| 100.0 * m.max)).collect();
    Figure::GroupedBars {
        title: format!(
            "{} objects: {} missed, {} duplicate and {} phantom segments",
            s.objects, s.missed, s.duplicates, s.phantoms
        ),
        y_label: "error (cm)".into(),
        y_max: (max.iter().copied().fold(0.0, f64::max) * 1.15).max(1.0),
        categories: vec![
            "centroid (table plane)".into(),
            "centroid height".into(),
            "object height".into(),
            "footprint".into(),
        ],
        groups: vec![("median".into(), median), ("max".into(), max)],
        intervals: vec![],
    }
}

//! `pbd experiment execute` as a library: a learned procedural model executed by the robot, from
//! its own senses, on N random new scenes drawn from a catalog — the seed's claim that what was
//! learned from a few demonstrations transfers to new situations (§4.3.2, §5.3).
//!
//! Each scene is a pure function of the configuration and its index ([`run_scene`]: K presentations
//! drawn from the base scene's catalog at random poses on its table, clear of the places and of
//! each other, then [`crate::execute::execute_scene`]), so scenes run in any order, on any number
//! of threads or machines, with the same result. [`summarize`] turns the reports into per-object
//! rows and the figures: placed fraction with a 95 % Wilson interval, task success, decision
//! accuracy against the task's colour classes, failures by phase.

use std::collections::BTreeMap;
use std::path::PathBuf;

use schema::Library;
use serde::{Deserialize, Serialize};

use crate::error::SimError;
use crate::execute::{Decider, ExecuteReport, MAX_ACTIONS, NoLog, RunLog, Task, Verdict, execute_scene};
use crate::scene::{ObjectPlacement, SIZE_CLASSES, Scene};
use bayes::rng::{Draw, Generator};
use rand::Rng as _;

/// What to run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExperimentConfig {
    /// The learned procedural model (`model.json`).
    pub model: PathBuf,
    /// Number of random scenes.
    pub scenes: usize,
    /// Objects per scene.
    pub objects: usize,
    /// The intended task: class → place (objects of other classes are not part of it). A class is
    /// a colour class (`red`), a size class (`small`, `medium`, `large`: [`SIZE_CLASSES`]) or both
    /// joined by `+` (`red+large`); an object belongs to the most specific class it matches
    /// ([`intended_place`]).
    pub task: BTreeMap<String, String>,
    /// Seed of every random choice.
    pub seed: u64,
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
    /// Its catalog size class.
    pub size_class: String,
    /// The place the task intends, or `-`.
    pub intended: String,
    /// The robot's decision.
    pub decision: Verdict,
    /// The place it chose.
    pub place: String,
    /// ln B10.
    pub log_b10: Option<f64>,
    /// The object's size as the robot measured it (cm), when it did.
    pub size_cm: Option<f64>,
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
    /// Rows whose decision matches the task / rows.
    pub decision_accuracy: f64,
    /// 95 % Wilson interval of the decision accuracy.
    pub decision_interval: (f64, f64),
    /// Failure causes by phase (count).
    pub failures: BTreeMap<String, usize>,
    /// Hand-to-hand transfers.
    pub transfers: usize,
    /// Simulated seconds.
    pub sim_time: f64,
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

/// The place `task` intends for an object of colour class `color` and size class `size` (`-`:
/// unlabelled): of the task's classes the object matches — each `+`-joined part equal to its size
/// class when the part is one of [`SIZE_CLASSES`], else to its colour class — the one with the most
/// parts (ties: the first by name). `None`: not part of the task.
pub fn intended_place(task: &BTreeMap<String, String>, color: &str, size: &str) -> Option<String> {
    task.iter()
        .filter_map(|(class, place)| {
            let parts: Vec<&str> = class.split('+').map(str::trim).collect();
            let matches = parts.iter().all(|p| {
                if SIZE_CLASSES.contains(p) {
                    *p == size
                } else {
                    *p == color
                }
            });
            matches.then_some((parts.len(), place))
        })
        .fold(None::<(usize, &String)>, |best, (n, p)| match best {
            Some((m, _)) if m >= n => best,
            _ => Some((n, p)),
        })
        .map(|(_, p)| p.clone())
}

/// Draws `k` presentations of `base`'s catalog at random poses on its table, clear of the places
/// (8 cm) and of each other (14 cm between centres).
pub fn random_scene(base: &Scene, k: usize, rng: &mut Generator) -> Result<Scene, SimError> {
    let names: Vec<String> = base
        .catalog
        .presentation_names()
        .iter()
        .map(|s| s.to_string())
        .collect();
    let invalid = |message: String| SimError::Invalid {
        path: base.path.clone(),
        field: "objects".into(),
        message,
    };
    if names.is_empty() {
        return Err(invalid("the catalog has no presentations".into()));
    }
    let t = &base.spec.table;
    for _attempt in 0..200 {
        let mut objects: Vec<ObjectPlacement> = Vec::new();
        let mut tries = 0;
        while objects.len() < k && tries < 500 {
            tries += 1;
            let x = t.center[0] - t.size[0] / 2.0 + 0.12 + rng.uniform() * (t.size[0] - 0.24);
            let y = t.center[1] - 0.4 + rng.uniform() * 0.8;
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
                yaw_deg: 360.0 * rng.uniform(),
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
    Err(invalid(format!(
        "could not place {k} objects on the table in 200 draws"
    )))
}

/// Scene `i` of the experiment and the robot's execution in it (a pure function of `base`,
/// `config` and `i`).
pub fn run_scene(
    base: &Scene,
    base_name: &str,
    library: &Library,
    config: &ExperimentConfig,
    i: usize,
) -> Result<(Scene, ExecuteReport), SimError> {
    run_scene_logged(base, base_name, library, config, i, &mut NoLog)
}

/// [`run_scene`] telling `log` what happens (its [`RunLog::should_stop`] stops the scene: a
/// signal stops a long experiment within a control period, not at the end of the scene).
pub fn run_scene_logged(
    base: &Scene,
    base_name: &str,
    library: &Library,
    config: &ExperimentConfig,
    i: usize,
    log: &mut dyn RunLog,
) -> Result<(Scene, ExecuteReport), SimError> {
    let scene = random_scene(base, config.objects, &mut bayes::rng::stream(config.seed, i as u64))?;
    for o in &scene.spec.objects {
        // The world's truth, for tracing one scene (`--only K`, `RUST_LOG=dexter_sim::experiment=debug`).
        tracing::debug!(
            "scene {i}: {} at ({:.3}, {:.3}), yaw {:.0}°",
            o.presentation,
            o.xy[0],
            o.xy[1],
            o.yaw_deg
        );
    }
    let seed = bayes::rng::stream(config.seed ^ 0x5EED_0F5C_E4E5, i as u64).next_u64();
    let model = schema::procedural::ProceduralModel::load(&config.model)?;
    let task = Task {
        library,
        schema: model.schema_in(library)?,
        decider: Decider::Model(&model),
        only_near: None,
        max_actions: MAX_ACTIONS,
    };
    let report = execute_scene(&scene, &format!("{base_name}#{i}"), &task, seed, log)?;
    Ok((scene, report))
}

/// The rows and figures of the executed scenes.
pub fn summarize(config: &ExperimentConfig, runs: &[(Scene, ExecuteReport)]) -> (Vec<ObjectRow>, Summary) {
    let mut rows = Vec::new();
    for (i, (scene, r)) in runs.iter().enumerate() {
        for o in &r.objects {
            let spec = scene
                .object_index(&o.object)
                .ok()
                .map(|k| &scene.catalog.objects[scene.resolved[k].object]);
            let class = spec.and_then(|o| o.color_class.clone()).unwrap_or_else(|| "-".into());
            let size_class = spec.and_then(|o| o.size_class.clone()).unwrap_or_else(|| "-".into());
            let intended = intended_place(&config.task, &class, &size_class);
            let decision_correct = match (&intended, o.decision) {
                (None, Verdict::Ignore) => true,
                (Some(p), Verdict::Execute | Verdict::Skip) => o.place.as_deref() == Some(p.as_str()),
                _ => false,
            };
            rows.push(ObjectRow {
                scene: i,
                object: o.object.clone(),
                color_class: class,
                size_class,
                intended: intended.unwrap_or_else(|| "-".into()),
                decision: o.decision,
                place: o.place.clone().unwrap_or_else(|| "-".into()),
                log_b10: o.log_bayes_factor,
                size_cm: o.size_cm,
                arms: o.arms.join(">"),
                transfer: o.transfer,
                placed: o.success,
                decision_correct,
                failure: o.failure.clone().unwrap_or_default(),
            });
        }
    }
    let executed = rows.iter().filter(|r| r.decision == Verdict::Execute).count();
    let placed = rows
        .iter()
        .filter(|r| r.decision == Verdict::Execute && r.placed)
        .count();
    // Task objects, once each (an object seen as two segments has two rows): done if any row placed
    // it in its intended place.
    let mut task_objects: BTreeMap<(usize, String), bool> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.intended != "-" && r.object != "-") {
        *task_objects.entry((r.scene, r.object.clone())).or_insert(false) |= r.placed && r.place == r.intended;
    }
    let task_total = task_objects.len();
    let task_ok = task_objects.values().filter(|&&v| v).count();
    let mut failures = BTreeMap::new();
    for r in rows.iter().filter(|r| !r.failure.is_empty()) {
        let phase = r.failure.split(':').next().unwrap_or("?").trim().to_string();
        *failures.entry(phase).or_insert(0) += 1;
    }
    let summary = Summary {
        scenes: runs.len(),
        objects: runs.iter().map(|(s, _)| s.resolved.len()).sum(),
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
        decision_interval: wilson(rows.iter().filter(|r| r.decision_correct).count(), rows.len()),
        failures,
        transfers: rows.iter().filter(|r| r.transfer).count(),
        sim_time: runs.iter().map(|(_, r)| r.sim_time).sum(),
    };
    (rows, summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_matches_the_textbook_values() {
        // 45/50: (0.786, 0.957) (Wilson 1927; Newcombe 1998, method 3).
        let (lo, hi) = wilson(45, 50);
        assert!((lo - 0.7864).abs() < 1e-3 && (hi - 0.9565).abs() < 1e-3, "{lo} {hi}");
        assert_eq!(wilson(0, 0), (0.0, 1.0));
        let (lo, hi) = wilson(10, 10);
        assert!((hi - 1.0).abs() < 1e-12 && (lo - 0.7225).abs() < 1e-3, "{lo} {hi}");
    }

    #[test]
    fn task_classes_are_colours_sizes_or_both_the_most_specific_winning() {
        let task: BTreeMap<String, String> = [("red", "a"), ("large", "b"), ("blue+small", "c")]
            .map(|(c, p)| (c.to_string(), p.to_string()))
            .into_iter()
            .collect();
        let at = |c: &str, s: &str| intended_place(&task, c, s);
        assert_eq!(at("red", "small").as_deref(), Some("a"));
        assert_eq!(at("green", "large").as_deref(), Some("b"));
        assert_eq!(at("blue", "small").as_deref(), Some("c"));
        assert_eq!(at("blue", "medium"), None);
        assert_eq!(at("-", "-"), None);
        // Red and large: two one-part classes, the first by name.
        assert_eq!(at("red", "large").as_deref(), Some("b"));
    }

    #[test]
    fn random_scenes_are_seeded_and_clear_of_each_other() {
        let base = Scene::builtin("sorting-demo").unwrap();
        let a = random_scene(&base, 3, &mut bayes::rng::stream(1, 0)).unwrap();
        let b = random_scene(&base, 3, &mut bayes::rng::stream(1, 0)).unwrap();
        assert_eq!(a.spec.objects, b.spec.objects);
        for (i, p) in a.spec.objects.iter().enumerate() {
            for q in &a.spec.objects[..i] {
                assert!((p.xy[0] - q.xy[0]).hypot(p.xy[1] - q.xy[1]) >= 0.14);
            }
        }
    }
}

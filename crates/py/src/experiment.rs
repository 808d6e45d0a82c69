//! `pbd.experiment` (compiled part): one trial of an experiment as a pure function of its config and
//! its index, so that any scheduler (a loop, a process pool, Ray) can run trials and get the same
//! results trial by trial. The Python package adds `pbd.experiment.run(config, trials, backend=...)`.

use std::collections::BTreeMap;
use std::path::PathBuf;

use pbd::dexter_sim::experiment::{ExperimentConfig, run_scene, summarize};
use pbd::dexter_sim::scene::Scene;
use pbd::grasp::eval::EvalOptions;
use pbd::grasp_topics::GraspModel;
use pbd::schema::Library;
use pyo3::prelude::*;
use serde::{Deserialize, Serialize};

use crate::errors::{IntoPy, value_error};
use crate::json::{from_python, to_python};
use crate::runner;

/// The config of an execute experiment (as `pbd experiment execute`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ExecuteConfig {
    /// The procedural model (`model.json`).
    model: PathBuf,
    /// The base scene (a built-in name or a TOML file) whose catalog and places the scenes use.
    #[serde(default = "default_scene")]
    scene: String,
    /// Objects per random scene.
    #[serde(default = "default_objects")]
    objects: usize,
    /// The intended task: colour class → place (for scoring decisions).
    #[serde(default)]
    task: BTreeMap<String, String>,
    /// The experiment's seed.
    #[serde(default)]
    seed: u64,
}

fn default_scene() -> String {
    "sorting-new".into()
}

fn default_objects() -> usize {
    4
}

/// One execute trial's result.
#[derive(Debug, Serialize)]
struct ExecuteTrial {
    trial: usize,
    seed: u64,
    rows: Vec<pbd::dexter_sim::experiment::ObjectRow>,
    summary: pbd::dexter_sim::experiment::Summary,
    report: pbd::dexter_sim::execute::ExecuteReport,
    /// Wall time of the trial (s): the one field that is not a function of (config, trial).
    wall_time: f64,
}

/// One trial of the execute experiment: random scene `trial` of the config (objects drawn from the
/// base scene's catalog by the seeded stream `(seed, trial)`) and the robot's execution in it — a
/// pure function of `(config, trial)`. Returns a dict: `trial`, `seed`, `rows` (one per object, as
/// `objects.csv`), `summary`, `report` (the execute report with its `wall_time` set to 0) and
/// `wall_time`.
#[pyfunction]
#[pyo3(signature = (config, trial))]
fn execute_trial(py: Python<'_>, config: &Bound<'_, PyAny>, trial: usize) -> PyResult<Py<PyAny>> {
    let c: ExecuteConfig = from_python(config, "execute experiment config")?;
    if c.objects == 0 {
        return Err(value_error("objects must be at least 1"));
    }
    let base = Scene::open(&c.scene).py_err()?;
    for p in c.task.values() {
        base.place(p).py_err()?;
    }
    pbd::schema::procedural::ProceduralModel::load(&c.model).py_err()?;
    let config = ExperimentConfig {
        model: c.model.clone(),
        scenes: trial + 1,
        objects: c.objects,
        task: c.task.clone(),
        seed: c.seed,
    };
    let (result, _) = runner::run(py, None, |_| {
        let start = std::time::Instant::now();
        let library = Library::builtin();
        let (scene, mut report) = run_scene(&base, &c.scene, &library, &config, trial)?;
        let wall_time = start.elapsed().as_secs_f64();
        report.wall_time = 0.0;
        let run = [(scene, report)];
        let (mut rows, summary) = summarize(&config, &run);
        for r in &mut rows {
            r.scene = trial;
        }
        let [(_, report)] = run;
        Ok(ExecuteTrial {
            trial,
            seed: c.seed,
            rows,
            summary,
            report,
            wall_time,
        })
    })?;
    to_python(py, &result)
}

/// The config of a perception trial (as `pbd experiment perception`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct PerceptionConfig {
    /// The base scene (a built-in name or a TOML file) whose catalog and places the scenes use.
    #[serde(default = "default_perception_scene")]
    scene: String,
    /// Objects per random scene.
    #[serde(default = "default_perception_objects")]
    objects: usize,
    /// The experiment's seed (the same scenes as the execute experiment's with this seed).
    #[serde(default = "default_perception_seed")]
    seed: u64,
}

fn default_perception_scene() -> String {
    "sorting-demo".into()
}

fn default_perception_objects() -> usize {
    3
}

fn default_perception_seed() -> u64 {
    1
}

/// One perception trial's result.
#[derive(Debug, Serialize)]
struct PerceptionTrial {
    trial: usize,
    seed: u64,
    /// Per object: segments matched, centroid, height and footprint errors.
    objects: Vec<pbd::dexter_sim::perception::ObjectPerception>,
    /// Segments on the table that match no object.
    phantoms: usize,
}

/// One trial of the perception experiment: random scene `trial` of the config (the execute
/// experiment's scene with the same seed) looked over by the robot and compared with the truth — a
/// pure function of `(config, trial)`. Returns a dict: `trial`, `seed`, `objects` (per object:
/// `object`, `segments`, `centroid_error_xy`, `centroid_error_z`, `height_error`,
/// `footprint_error`, m) and `phantoms`.
#[pyfunction]
#[pyo3(signature = (config, trial))]
fn perception_trial(py: Python<'_>, config: &Bound<'_, PyAny>, trial: usize) -> PyResult<Py<PyAny>> {
    let c: PerceptionConfig = from_python(config, "perception experiment config")?;
    if c.objects == 0 {
        return Err(value_error("objects must be at least 1"));
    }
    let base = Scene::open(&c.scene).py_err()?;
    let (result, _) = runner::run(py, None, |_| {
        let report = pbd::dexter_sim::perception::scan_trial(&base, c.objects, c.seed, trial)?;
        Ok(PerceptionTrial {
            trial,
            seed: c.seed,
            objects: report.objects,
            phantoms: report.phantoms,
        })
    })?;
    to_python(py, &result)
}

/// The grasp experiment's config: `pbd grasp eval`'s options (`present`, `seed`, `candidates`,
/// `objects` or `test`) with a required `model` (prototypes JSON).
fn grasp_options(config: &Bound<'_, PyAny>) -> PyResult<(EvalOptions, GraspModel)> {
    let options: EvalOptions = from_python(config, "grasp experiment config")?;
    let Some(path) = &options.model else {
        return Err(value_error(
            "the grasp experiment config needs `model` (a prototype model from pbd.grasp.learn)",
        ));
    };
    let model = GraspModel::load(path).py_err()?;
    Ok((options, model))
}

/// The test presentations of the grasp experiment, in trial order (`objects`, or the first `test`
/// of the catalog presentations in the seed's order that the model was not trained on).
#[pyfunction]
fn grasp_objects(config: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
    let (options, model) = grasp_options(config)?;
    pbd::grasp::eval::test_presentations(&options, &model.objects).py_err()
}

/// One trial of the grasp experiment (§6.5): test presentation `trial` of [`grasp_objects`],
/// perceived, with `candidates` pre-grasps from the model and from the naive baseline, each executed
/// in the sim (reach, close, lift 10 cm, held?). Returns `{trial, object, result: {object row, trials}}`:
/// the same rows `pbd grasp eval` gives that object.
#[pyfunction]
fn grasp_trial(py: Python<'_>, config: &Bound<'_, PyAny>, trial: usize) -> PyResult<Py<PyAny>> {
    let (options, model) = grasp_options(config)?;
    let objects = pbd::grasp::eval::test_presentations(&options, &model.objects).py_err()?;
    let Some(object) = objects.get(trial).cloned() else {
        return Err(value_error(format!(
            "trial {trial} is out of range: the experiment has {} test presentations",
            objects.len()
        )));
    };
    let (result, _) = runner::run(py, None, |_| {
        pbd::grasp::eval::object_trial(&options, &model, trial, &object)
    })?;
    let d = pyo3::types::PyDict::new(py);
    d.set_item("trial", trial)?;
    d.set_item("object", object)?;
    d.set_item("result", to_python(py, &result)?)?;
    Ok(d.into_any().unbind())
}

/// The config of a sorting / relevance trial: the options of `pbd experiment sorting` for one number
/// of examples per class, and where the features come from.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct SortingConfig {
    #[serde(default)]
    feature: pbd::experiment::Feature,
    /// Catalog TOML (default: the built-in household catalog); rendered once per process.
    #[serde(default)]
    catalog: Option<PathBuf>,
    /// Or features already rendered (`pbd experiment sorting --dump-features FILE`).
    #[serde(default)]
    features: Option<PathBuf>,
    /// A held-out catalog to test on (rendered once per process), or its feature bank.
    #[serde(default)]
    test_catalog: Option<PathBuf>,
    #[serde(default)]
    test_features: Option<PathBuf>,
    #[serde(default)]
    classes: Vec<String>,
    #[serde(default)]
    structure: Option<String>,
    #[serde(default = "default_views")]
    views: usize,
    #[serde(default = "default_sorting_seed")]
    seed: u64,
    /// Examples per class.
    #[serde(default = "default_examples")]
    examples: usize,
    /// Relevance: objects left alone in the demonstration scenes that fit the background model M₀.
    #[serde(default)]
    background: usize,
    /// The colour base measure uniform over the colour terms (default: the household shares).
    #[serde(default)]
    uniform_base: bool,
    /// The share of an object's colour term given to each neighbouring term.
    #[serde(default = "default_neighbour_share")]
    neighbour_share: f64,
    /// The chromatic rule's share (an object's achromatic pixels are left out when its chromatic
    /// terms cover at least this share).
    #[serde(default = "default_chromatic_share")]
    chromatic_share: f64,
}

fn default_chromatic_share() -> f64 {
    pbd::schema::procedural::DEFAULT_CHROMATIC_SHARE
}

fn default_neighbour_share() -> f64 {
    pbd::schema::procedural::DEFAULT_COLOR_NEIGHBOUR_SHARE
}

fn default_views() -> usize {
    4
}
fn default_sorting_seed() -> u64 {
    1
}
fn default_examples() -> usize {
    1
}

type BankKey = (Option<PathBuf>, Option<PathBuf>, usize, u64);

/// Feature banks rendered or loaded in this process, by (catalog, features file, views, seed): a
/// trial is a pure function of its config, the bank is only computed once.
static BANKS: std::sync::Mutex<BTreeMap<BankKey, std::sync::Arc<pbd::experiment::features::FeatureBank>>> =
    std::sync::Mutex::new(BTreeMap::new());

/// One trial of the sorting (colour / size) or relevance experiment (§5.1–5.3): `examples` examples
/// per class drawn by the seeded stream of trial `trial`, a procedural model learned from them, the
/// held-out objects sorted (success rate, χ² against a random sorter — `None` with the reason when it
/// cannot be computed) or scored for relevance (AUC of ln B10 (5.19), accuracy at the threshold).
/// The same record as that trial's row of `pbd experiment sorting`'s CSV.
#[pyfunction]
#[pyo3(signature = (config, trial))]
fn sorting_trial(py: Python<'_>, config: &Bound<'_, PyAny>, trial: usize) -> PyResult<Py<PyAny>> {
    let c: SortingConfig = from_python(config, "sorting experiment config")?;
    let options = pbd::experiment::SortingOptions {
        feature: c.feature,
        catalog: c.catalog.clone(),
        trials: trial + 1,
        max_examples: c.examples,
        classes: c.classes.clone(),
        structure: c.structure.clone(),
        views: c.views,
        seed: c.seed,
        test_catalog: c.test_catalog.clone(),
        test_features: c.test_features.clone(),
        background: c.background,
        uniform_base: c.uniform_base,
        neighbour_share: c.neighbour_share,
        chromatic_share: c.chromatic_share,
        ..Default::default()
    };
    let (result, _) = runner::run(py, None, |progress| {
        pbd::limits::check_count("views", c.views, pbd::limits::MAX_VIEWS)?;
        let key: BankKey = (c.catalog.clone(), c.features.clone(), c.views, c.seed);
        let cached = BANKS.lock().ok().and_then(|b| b.get(&key).cloned());
        let bank = match cached {
            Some(b) => b,
            None => {
                let bank = match &c.features {
                    Some(path) => pbd::experiment::features::load_bank(path)?,
                    None => {
                        let catalog = match &c.catalog {
                            Some(p) => pbd::dexter_sim::scene::Catalog::load(p)?,
                            None => pbd::dexter_sim::scene::Catalog::builtin_household()?,
                        };
                        progress.phase("rendering", None);
                        pbd::experiment::features::render_bank(&catalog, c.views, c.seed, || {})?
                    }
                };
                let bank = std::sync::Arc::new(bank);
                if let Ok(mut b) = BANKS.lock() {
                    b.insert(key, bank.clone());
                }
                bank
            }
        };
        let test = if c.test_catalog.is_some() || c.test_features.is_some() {
            let key: BankKey = (
                c.test_catalog.clone(),
                c.test_features.clone(),
                c.views,
                c.seed ^ 0x7E57,
            );
            let cached = BANKS.lock().ok().and_then(|b| b.get(&key).cloned());
            Some(match cached {
                Some(b) => b,
                None => {
                    let b = std::sync::Arc::new(
                        pbd::experiment::sorting::test_bank(&options, progress)?
                            .ok_or_else(|| anyhow::anyhow!("no test catalog or bank"))?,
                    );
                    if let Ok(mut m) = BANKS.lock() {
                        m.insert(key, b.clone());
                    }
                    b
                }
            })
        } else {
            None
        };
        pbd::experiment::sorting::trial_held_out(&options, &bank, test.as_deref(), c.examples, trial)
    })?;
    to_python(py, &result)
}

/// Adds the functions to the `pbd._pbd.experiment` module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(execute_trial, m)?)?;
    m.add_function(wrap_pyfunction!(grasp_trial, m)?)?;
    m.add_function(wrap_pyfunction!(grasp_objects, m)?)?;
    m.add_function(wrap_pyfunction!(sorting_trial, m)?)?;
    m.add_function(wrap_pyfunction!(perception_trial, m)?)?;
    Ok(())
}

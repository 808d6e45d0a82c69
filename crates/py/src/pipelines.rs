//! record → infer → learn → execute (and `demo`) over the facade, the procedural model and reading
//! recorded demonstrations.
//!
//! The pipelines take the facade's serde options as a dict (the Python wrappers in `pbd/__init__.py`
//! build it from keyword arguments; unknown keys are errors) and return `(report, text, warnings)`:
//! the report as Python objects (what `--json` prints), its human summary (what the command prints)
//! and the warnings reported on the way.

use std::path::PathBuf;

use pbd::schema::procedural::{Example, Features, Hyper, ProceduralModel as Model};
use pyo3::prelude::*;
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::errors::{IntoPy, Kind, error, value_error};
use crate::json::{from_python, to_python};
use crate::runner;

/// `(report, text, warnings)` of a pipeline.
type Outcome = (Py<PyAny>, String, Vec<String>);

fn pipeline<O, R, E>(
    py: Python<'_>,
    options: &Bound<'_, PyAny>,
    progress: Option<Py<PyAny>>,
    what: &str,
    f: fn(&O, &dyn pbd::Progress) -> Result<R, E>,
) -> PyResult<Outcome>
where
    O: DeserializeOwned + Send + Sync,
    R: Serialize + std::fmt::Display + Send,
    E: Into<anyhow::Error>,
{
    let options: O = from_python(options, what)?;
    let (report, warnings) = runner::run(py, progress, |p| f(&options, p).map_err(Into::into))?;
    Ok((to_python(py, &report)?, report.to_string(), warnings))
}

/// `pbd record`: a teleoperated demonstration in the simulator, written to an MCAP file.
#[pyfunction]
#[pyo3(signature = (options, progress=None))]
pub fn record(py: Python<'_>, options: &Bound<'_, PyAny>, progress: Option<Py<PyAny>>) -> PyResult<Outcome> {
    pipeline(py, options, progress, "record options", pbd::record::record)
}

/// `pbd infer`: which schema explains a demonstration (§4.2).
#[pyfunction]
#[pyo3(signature = (options, progress=None))]
pub fn infer(py: Python<'_>, options: &Bound<'_, PyAny>, progress: Option<Py<PyAny>>) -> PyResult<Outcome> {
    pipeline(py, options, progress, "infer options", pbd::infer::infer)
}

/// `pbd learn`: the procedural model from demonstrations (ch. 5), saved to `output`.
#[pyfunction]
#[pyo3(signature = (options, progress=None))]
pub fn learn(py: Python<'_>, options: &Bound<'_, PyAny>, progress: Option<Py<PyAny>>) -> PyResult<Outcome> {
    pipeline(py, options, progress, "learn options", pbd::learn::learn)
}

/// `pbd execute`: the robot does the task in a scene.
#[pyfunction]
#[pyo3(signature = (options, progress=None))]
pub fn execute(py: Python<'_>, options: &Bound<'_, PyAny>, progress: Option<Py<PyAny>>) -> PyResult<Outcome> {
    pipeline(py, options, progress, "execute options", pbd::execute::execute)
}

/// `pbd demo`: record, infer, learn, execute on the built-in scenes.
#[pyfunction]
#[pyo3(signature = (options, progress=None))]
pub fn demo(py: Python<'_>, options: &Bound<'_, PyAny>, progress: Option<Py<PyAny>>) -> PyResult<Outcome> {
    pipeline(py, options, progress, "demo options", pbd::demo::demo)
}

/// `pbd sim pick-place`: one autonomous pick-and-place in the simulator.
#[pyfunction]
#[pyo3(signature = (options, progress=None))]
pub fn pick_place(py: Python<'_>, options: &Bound<'_, PyAny>, progress: Option<Py<PyAny>>) -> PyResult<Outcome> {
    pipeline(py, options, progress, "pick-place options", pbd::sim::pick_place)
}

/// `pbd grasp record`: scripted grasp demonstrations on training presentations → a corpus (ch. 6).
#[pyfunction]
#[pyo3(signature = (options, progress=None))]
pub fn grasp_record(py: Python<'_>, options: &Bound<'_, PyAny>, progress: Option<Py<PyAny>>) -> PyResult<Outcome> {
    pipeline(py, options, progress, "grasp record options", pbd::grasp::record)
}

/// `pbd grasp learn`: grasp prototypes from a corpus (topic model, finite or Dirichlet process).
#[pyfunction]
#[pyo3(signature = (options, progress=None))]
pub fn grasp_learn(py: Python<'_>, options: &Bound<'_, PyAny>, progress: Option<Py<PyAny>>) -> PyResult<Outcome> {
    pipeline(py, options, progress, "grasp learn options", pbd::grasp::learn)
}

/// `pbd grasp generate`: pre-grasp candidates for an object from a prototype model.
#[pyfunction]
#[pyo3(signature = (options, progress=None))]
pub fn grasp_generate(py: Python<'_>, options: &Bound<'_, PyAny>, progress: Option<Py<PyAny>>) -> PyResult<Outcome> {
    pipeline(py, options, progress, "grasp generate options", |o, _| {
        pbd::grasp::generate(o)
    })
}

/// `pbd grasp eval`: the grasp experiment of §6.5 (model against the naive baseline).
#[pyfunction]
#[pyo3(signature = (options, progress=None))]
pub fn grasp_eval(py: Python<'_>, options: &Bound<'_, PyAny>, progress: Option<Py<PyAny>>) -> PyResult<Outcome> {
    pipeline(
        py,
        options,
        progress,
        "grasp eval options",
        |o: &pbd::grasp::eval::EvalOptions, p| {
            let summary = pbd::grasp::eval::run(o, p)?;
            // Fig. 6.7, as `pbd grasp eval` draws it.
            pbd::figure::draw(&o.output.join("fig6_7.svg"), &pbd::grasp::report::figure(&summary))?;
            Ok::<_, anyhow::Error>(summary)
        },
    )
}

/// `pbd experiment sorting`: the sorting / relevance / incremental / selection experiments of
/// §5.1–5.3 on features rendered from a catalog (or read from a feature bank); writes the CSVs,
/// `summary.md` and the SVG figures into `output`.
#[pyfunction]
#[pyo3(signature = (options, progress=None))]
pub fn experiment_sorting(
    py: Python<'_>,
    options: &Bound<'_, PyAny>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Outcome> {
    pipeline(py, options, progress, "sorting experiment options", |o, p| {
        let summary = pbd::experiment::sorting::run(o, p)?;
        for (path, figure) in &summary.figures {
            pbd::figure::draw(path, figure)?;
        }
        Ok::<_, anyhow::Error>(summary)
    })
}

/// `pbd experiment perception`: the robot's look over the execute experiment's scenes against the
/// truth (missed, duplicate and phantom segments; centroid, height and footprint errors); writes
/// `objects.csv`, `summary.md` and `errors.svg` into `output`.
#[pyfunction]
#[pyo3(signature = (options, progress=None))]
pub fn experiment_perception(
    py: Python<'_>,
    options: &Bound<'_, PyAny>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Outcome> {
    pipeline(py, options, progress, "perception experiment options", |o, p| {
        let run = pbd::experiment::perception::run(o, p)?;
        pbd::figure::draw(&run.output.join("errors.svg"), &run.figure)?;
        Ok::<_, anyhow::Error>(run)
    })
}

/// A recorded demonstration (an MCAP file of `pbd record`): percepts, ground truth, metadata, topics.
#[pyclass(module = "pbd", frozen)]
#[derive(Debug)]
pub struct Demonstration {
    path: PathBuf,
    percepts: Vec<pbd::schema::Percept>,
    truth: pbd::infer::TruthTrack,
    metadata: std::collections::BTreeMap<String, String>,
    warnings: Vec<String>,
}

#[pymethods]
impl Demonstration {
    /// Opens a recording (a file cut short is read up to its last complete chunk, with a warning).
    #[staticmethod]
    fn open(py: Python<'_>, path: PathBuf) -> PyResult<Demonstration> {
        let pbd::infer::Demonstration {
            percepts,
            truth,
            metadata,
            warnings,
        } = py.detach(|| pbd::infer::read_percepts(&path)).py_err()?;
        Ok(Demonstration {
            path,
            percepts,
            truth,
            metadata,
            warnings,
        })
    }

    /// The file.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// The recording's metadata (scene, seed, tasks, …).
    #[getter]
    fn metadata(&self) -> std::collections::BTreeMap<String, String> {
        self.metadata.clone()
    }

    /// Warnings from reading (a recovered file).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    /// Percept times (s), an array (T,).
    #[getter]
    fn times<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray1<f64>> {
        use numpy::IntoPyArray;
        numpy::ndarray::Array1::from_iter(self.percepts.iter().map(|p| p.t)).into_pyarray(py)
    }

    /// The percepts (`/pbd/percept`: hands, segments with features, places, fovea) as dicts.
    #[getter]
    fn percepts(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        to_python(py, &self.percepts)
    }

    /// Object truth over time (evaluation only): a list of `(t, [(label, [x, y, z])])`.
    #[getter]
    fn truth(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        to_python(py, &self.truth)
    }

    /// Topics of the file: `{topic: message count}`.
    #[getter]
    fn topics(&self, py: Python<'_>) -> PyResult<std::collections::BTreeMap<String, u64>> {
        let path = self.path.clone();
        let summary = py.detach(|| pbd::mcap_log::read_summary(&path)).py_err()?;
        Ok(summary
            .channels
            .iter()
            .map(|c| (c.topic.clone(), c.message_count))
            .collect())
    }

    /// The messages of a JSON topic: `(times (N,) in s, [message dicts])`.
    fn messages(&self, py: Python<'_>, topic: &str) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
        use numpy::IntoPyArray;
        let path = self.path.clone();
        let rec = py.detach(|| pbd::mcap_log::read_recording(&path, &[topic])).py_err()?;
        let mut times = Vec::new();
        let mut values = Vec::new();
        for (i, (t, data)) in rec.topic(topic).enumerate() {
            let v: serde_json::Value = serde_json::from_slice(data).map_err(|e| {
                error(
                    Kind::Format,
                    format!("{}: {topic} message {i} is not JSON: {e}", self.path.display()),
                )
            })?;
            times.push(t as f64 * 1e-9);
            values.push(v);
        }
        Ok((
            numpy::ndarray::Array1::from_vec(times)
                .into_pyarray(py)
                .into_any()
                .unbind(),
            to_python(py, &values)?,
        ))
    }

    fn __len__(&self) -> usize {
        self.percepts.len()
    }

    fn __repr__(&self) -> String {
        let span = match (self.percepts.first(), self.percepts.last()) {
            (Some(a), Some(b)) => b.t - a.t,
            _ => 0.0,
        };
        format!(
            "Demonstration({:?}, percepts={}, duration={span:.1} s, scene={:?})",
            self.path.display().to_string(),
            self.percepts.len(),
            self.metadata.get("scene").map(String::as_str).unwrap_or("?")
        )
    }
}

/// The Bayesian procedural model (ch. 5): which object features decide a task's reference (the
/// place), learned from a few demonstrations and updated one at a time.
///
/// Per place, a Dirichlet–multinomial colour model (5.12)–(5.18) and a Normal–Inverse-Gamma size
/// model (A.5)–(A.6); a posterior over which features matter; predictions by the posterior predictive
/// place weights ψ (5.14) and task relevance as a Bayes factor ln B₁₀ (5.19)–(5.23).
#[pyclass(module = "pbd")]
#[derive(Debug)]
pub struct ProceduralModel {
    model: Model,
    report: Option<Py<PyAny>>,
}

/// The examples of one input (a demonstration path or an example dict) and the features of the
/// objects the teacher left alone in it (none for a dict).
fn examples_from_input(py: Python<'_>, item: &Bound<'_, PyAny>) -> PyResult<(Vec<Example>, Vec<Features>)> {
    if item.is_instance_of::<pyo3::types::PyDict>() {
        return Ok((vec![from_python::<Example>(item, "example")?], Vec::new()));
    }
    let path: PathBuf = item.extract().map_err(|_| {
        value_error("expected a path to a demo (.mcap or .infer.json) or an example dict {features, reference}")
    })?;
    let ((examples, untouched), _) = runner::run(py, None, |p| {
        let library = pbd::schema::Library::builtin();
        let file = pbd::learn::read_demonstration(&path, &library, p)?;
        let examples = pbd::learn::examples_of(&file, &path, &library, p)?;
        Ok((examples, pbd::learn::untouched_from(&file)))
    })?;
    // One task: the instances of the schema most of them are of.
    let main = pbd::learn::main_schema(&examples);
    let examples: Vec<Example> = examples
        .into_iter()
        .filter(|(s, _)| Some(s) == main.as_ref())
        .map(|(_, e)| e)
        .collect();
    Ok((examples, untouched))
}

#[pymethods]
impl ProceduralModel {
    /// An empty model with the default hyper-parameters (or `relevance_threshold`, ln B₁₀).
    #[new]
    #[pyo3(signature = (*, relevance_threshold=None))]
    fn new(relevance_threshold: Option<f64>) -> PyResult<Self> {
        let mut hyper = Hyper::default();
        if let Some(t) = relevance_threshold {
            hyper.relevance_log_threshold = t;
        }
        Ok(ProceduralModel {
            model: Model::new(hyper).py_err()?,
            report: None,
        })
    }

    /// Loads `model.json` (as written by `pbd learn`).
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        Ok(ProceduralModel {
            model: Model::load(&path).py_err()?,
            report: None,
        })
    }

    /// The model from its JSON text.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        Ok(ProceduralModel {
            model: Model::from_json(text, "json").py_err()?,
            report: None,
        })
    }

    /// Learns a model from demonstrations: paths of `*.infer.json` / `*.mcap` files or example dicts
    /// `{"features": {...}, "reference": "bin_left"}`.
    ///
    /// With `distractors` (the default) the relevance background model M₀ (§5.1.3) is fitted to the
    /// objects the teacher left alone in the demonstration files (`untouched` in `pbd infer`'s file).
    #[staticmethod]
    #[pyo3(signature = (demos, *, relevance_threshold=None, distractors=true))]
    fn learn(
        py: Python<'_>,
        demos: Vec<Bound<'_, PyAny>>,
        relevance_threshold: Option<f64>,
        distractors: bool,
    ) -> PyResult<Self> {
        let mut examples = Vec::new();
        let mut untouched = Vec::new();
        for d in &demos {
            let (e, u) = examples_from_input(py, d)?;
            examples.extend(e);
            untouched.extend(u);
        }
        let mut hyper = Hyper::default();
        if let Some(t) = relevance_threshold {
            hyper.relevance_log_threshold = t;
        }
        let mut model = Model::learn(hyper, &examples).py_err()?;
        if distractors {
            for f in &untouched {
                // An untouched object without colour or pixels is no evidence; `pbd learn` warns.
                let _ = model.observe_background(f);
            }
        }
        Ok(ProceduralModel { model, report: None })
    }

    /// Adds the examples of one more demonstration (a path or an example dict), and the objects the
    /// teacher left alone in it to M₀ (unless `distractors=False`); the posterior does not depend on
    /// the order of the demonstrations (exchangeability, §5.2). Returns the number of examples.
    #[pyo3(signature = (demo, *, distractors=true))]
    fn update(&mut self, py: Python<'_>, demo: &Bound<'_, PyAny>, distractors: bool) -> PyResult<usize> {
        let (examples, untouched) = examples_from_input(py, demo)?;
        let mut model = self.model.clone();
        for e in &examples {
            model.update(e).py_err()?;
        }
        if distractors {
            for f in &untouched {
                let _ = model.observe_background(f);
            }
        }
        self.model = model;
        Ok(examples.len())
    }

    /// Adds an object the teacher left alone (its features, a dict as in the percepts) to the
    /// relevance background model M₀ (§5.1.3).
    fn observe_background(&mut self, features: &Bound<'_, PyAny>) -> PyResult<()> {
        let f: Features = from_python(features, "features")?;
        self.model.observe_background(&f).py_err()
    }

    /// Objects of the background model M₀ ([`observe_background`]).
    #[getter]
    fn background_objects(&self) -> usize {
        self.model.background_objects()
    }

    /// The place posterior for an object's features (a dict as in the percepts: `histogram`,
    /// `pixels`, `colors`): `places` [(name, p)], `map_place`, `map_probability`, `relevance`
    /// (ln B₁₀ (5.19) against the threshold).
    fn predict(&self, py: Python<'_>, features: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        let f: Features = from_python(features, "features")?;
        let p = self.model.predict(&f).py_err()?;
        to_python(py, &p)
    }

    /// The model in plain words (which features decide which place, how sure).
    fn explain(&self) -> PyResult<String> {
        Ok(self.model.explain().py_err()?.text)
    }

    /// The explanation as data (structure posterior, per-place summaries, text).
    fn explanation(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        to_python(py, &self.model.explain().py_err()?)
    }

    /// Writes `model.json`.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        self.model.save(&path).py_err()
    }

    /// The model as JSON text (the content of `model.json`).
    fn to_json(&self) -> String {
        self.model.to_json()
    }

    /// Places learned, in order.
    #[getter]
    fn places(&self) -> Vec<String> {
        self.model.place_names().into_iter().map(String::from).collect()
    }

    /// Number of demonstrations seen.
    #[getter]
    fn num_demonstrations(&self) -> u64 {
        self.model.num_demonstrations()
    }

    /// The report of `pbd.learn` that made this model (None otherwise).
    #[getter]
    fn report(&self, py: Python<'_>) -> Option<Py<PyAny>> {
        self.report.as_ref().map(|r| r.clone_ref(py))
    }

    #[setter]
    fn set_report(&mut self, report: Option<Py<PyAny>>) {
        self.report = report;
    }

    fn __reduce__(slf: &Bound<'_, Self>) -> PyResult<(Py<PyAny>, (String,))> {
        let py = slf.py();
        let ctor = py.get_type::<ProceduralModel>().getattr("from_json")?.unbind();
        Ok((ctor, (slf.borrow().model.to_json(),)))
    }

    fn __repr__(&self) -> String {
        format!(
            "ProceduralModel(places=[{}], demonstrations={})",
            self.model.place_names().join(", "),
            self.model.num_demonstrations()
        )
    }
}

//! `import pbd`: the pbd library from Python (the extension module `pbd._pbd`; the Python package
//! `pbd` around it adds keyword-argument wrappers, the Ray backend and type stubs).
//!
//! Built with maturin (`pip install ./crates/py`), abi3 for CPython ≥ 3.9. Depends on the library
//! crates only (the facade `pbd` and below), never on the CLI.

mod arrays;
mod bayes;
mod control;
mod errors;
mod experiment;
mod json;
mod pipelines;
mod robot;
mod runner;
mod sim;

use pyo3::prelude::*;

/// The compiled core of the `pbd` Python package.
#[pymodule]
fn _pbd(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<robot::Robot>()?;
    m.add_class::<robot::Chain>()?;
    m.add_class::<sim::Sim>()?;
    m.add_class::<control::ControlStack>()?;
    m.add_class::<pipelines::Demonstration>()?;
    m.add_class::<pipelines::ProceduralModel>()?;
    m.add_function(wrap_pyfunction!(pipelines::record, m)?)?;
    m.add_function(wrap_pyfunction!(pipelines::infer, m)?)?;
    m.add_function(wrap_pyfunction!(pipelines::learn, m)?)?;
    m.add_function(wrap_pyfunction!(pipelines::execute, m)?)?;
    m.add_function(wrap_pyfunction!(pipelines::demo, m)?)?;
    m.add_function(wrap_pyfunction!(pipelines::pick_place, m)?)?;
    m.add_function(wrap_pyfunction!(pipelines::grasp_record, m)?)?;
    m.add_function(wrap_pyfunction!(pipelines::grasp_learn, m)?)?;
    m.add_function(wrap_pyfunction!(pipelines::grasp_generate, m)?)?;
    m.add_function(wrap_pyfunction!(pipelines::grasp_eval, m)?)?;
    m.add_function(wrap_pyfunction!(pipelines::experiment_sorting, m)?)?;
    m.add_function(wrap_pyfunction!(pipelines::experiment_perception, m)?)?;
    m.add_function(wrap_pyfunction!(set_threads, m)?)?;
    let b = PyModule::new(m.py(), "bayes")?;
    bayes::register(&b)?;
    m.add_submodule(&b)?;
    let e = PyModule::new(m.py(), "experiment")?;
    experiment::register(&e)?;
    m.add_submodule(&e)?;
    Ok(())
}

/// Sizes the worker pool experiments run on (call before the first parallel run; the same seed
/// gives the same results whatever the number of threads).
#[pyfunction]
fn set_threads(n: usize) -> PyResult<()> {
    pbd::parallel::set_threads(n).map_err(errors::to_py)
}

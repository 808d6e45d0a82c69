//! The `pbd.PbdError` exception hierarchy and the mapping from the Rust errors onto it.
//!
//! ```text
//! PbdError(Exception)
//! ├── PbdValueError(PbdError, ValueError)    wrong sizes, NaN, parameters out of range
//! │   └── PbdFormatError(PbdValueError)      malformed URDF / MCAP / JSON / TOML
//! ├── PbdLookupError(PbdError, LookupError)  unknown link, joint, scene, object, place, schema
//! ├── PbdFileError(PbdError, OSError)        a file that cannot be read or written
//! └── PbdSimError(PbdError, RuntimeError)    the simulation or a skill failed
//! ```
//!
//! The classes are made with `type(name, bases, ns)` at import so that each one is also the builtin
//! exception a Python user expects (`except ValueError` catches a wrong-sized `q`). The message is the
//! Rust error and its causes joined by ": ", as the `pbd` command prints it.

use pyo3::exceptions::{PyException, PyLookupError, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};

/// The kinds of error, one exception class each.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `PbdError`.
    Base,
    /// `PbdValueError`.
    Value,
    /// `PbdFormatError`.
    Format,
    /// `PbdLookupError`.
    Lookup,
    /// `PbdFileError`.
    File,
    /// `PbdSimError`.
    Sim,
}

struct Classes {
    base: Py<PyType>,
    value: Py<PyType>,
    format: Py<PyType>,
    lookup: Py<PyType>,
    file: Py<PyType>,
    sim: Py<PyType>,
}

static CLASSES: PyOnceLock<Classes> = PyOnceLock::new();

fn make(py: Python<'_>, name: &str, bases: Bound<'_, PyTuple>, doc: &str) -> PyResult<Py<PyType>> {
    let ns = PyDict::new(py);
    ns.set_item("__doc__", doc)?;
    ns.set_item("__module__", "pbd")?;
    let cls = py
        .get_type::<PyType>()
        .call1((name, bases, ns))?
        .cast_into::<PyType>()?;
    Ok(cls.unbind())
}

fn classes(py: Python<'_>) -> PyResult<&Classes> {
    CLASSES.get_or_try_init(py, || {
        let base = make(
            py,
            "PbdError",
            PyTuple::new(py, [py.get_type::<PyException>()])?,
            "Every error raised by pbd; the message is the Rust error and its causes joined by ': '.",
        )?;
        let b = base.bind(py).clone();
        let value = make(
            py,
            "PbdValueError",
            PyTuple::new(py, [b.clone(), py.get_type::<PyValueError>()])?,
            "A value pbd cannot use: a wrong size, NaN or infinity, a parameter out of range.",
        )?;
        let format = make(
            py,
            "PbdFormatError",
            PyTuple::new(py, [value.bind(py).clone()])?,
            "A malformed input file or document (URDF, MCAP, JSON, TOML).",
        )?;
        let lookup = make(
            py,
            "PbdLookupError",
            PyTuple::new(py, [b.clone(), py.get_type::<PyLookupError>()])?,
            "A name that is not there: a link, joint, scene, object, place or schema.",
        )?;
        let file = make(
            py,
            "PbdFileError",
            PyTuple::new(py, [b.clone(), py.get_type::<PyOSError>()])?,
            "A file that cannot be read or written.",
        )?;
        let sim = make(
            py,
            "PbdSimError",
            PyTuple::new(py, [b, py.get_type::<PyRuntimeError>()])?,
            "The simulation, a skill or an experiment failed.",
        )?;
        Ok(Classes {
            base,
            value,
            format,
            lookup,
            file,
            sim,
        })
    })
}

/// Adds the classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    let c = classes(py)?;
    m.add("PbdError", c.base.bind(py))?;
    m.add("PbdValueError", c.value.bind(py))?;
    m.add("PbdFormatError", c.format.bind(py))?;
    m.add("PbdLookupError", c.lookup.bind(py))?;
    m.add("PbdFileError", c.file.bind(py))?;
    m.add("PbdSimError", c.sim.bind(py))?;
    Ok(())
}

/// A Python exception of `kind` with `message`.
pub fn error(kind: Kind, message: impl Into<String>) -> PyErr {
    let message = message.into();
    Python::attach(|py| match classes(py) {
        Ok(c) => {
            let cls = match kind {
                Kind::Base => &c.base,
                Kind::Value => &c.value,
                Kind::Format => &c.format,
                Kind::Lookup => &c.lookup,
                Kind::File => &c.file,
                Kind::Sim => &c.sim,
            };
            PyErr::from_type(cls.bind(py).clone(), message)
        }
        Err(e) => e,
    })
}

/// `PbdValueError(message)`.
pub fn value_error(message: impl Into<String>) -> PyErr {
    error(Kind::Value, message)
}

/// The class of a facade error's kind (decided by `pbd::Error`, not here).
fn kind_of(kind: pbd::ErrorKind) -> Kind {
    match kind {
        pbd::ErrorKind::Value => Kind::Value,
        pbd::ErrorKind::Format => Kind::Format,
        pbd::ErrorKind::Lookup => Kind::Lookup,
        pbd::ErrorKind::File => Kind::File,
        pbd::ErrorKind::Failed => Kind::Sim,
        pbd::ErrorKind::Other => Kind::Base,
    }
}

/// A facade error as a `PbdError` subclass carrying its message and causes.
pub fn from_pbd(err: &pbd::Error) -> PyErr {
    error(kind_of(err.kind()), err.chain_message())
}

/// A Rust error as a `PbdError` subclass carrying its message and causes (its kind as
/// `pbd::Error` decides it).
pub fn to_py(err: anyhow::Error) -> PyErr {
    from_pbd(&pbd::Error::from(err))
}

/// `?` for the errors of pbd's crates.
pub trait IntoPy<T> {
    /// Converts the error into a `PbdError` subclass.
    fn py_err(self) -> PyResult<T>;
}

impl<T, E: Into<anyhow::Error>> IntoPy<T> for Result<T, E> {
    fn py_err(self) -> PyResult<T> {
        self.map_err(|e| to_py(e.into()))
    }
}

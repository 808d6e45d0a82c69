//! serde values to and from Python objects through JSON (`json.loads` / `json.dumps`): numbers keep
//! full precision, and every report of the facade crosses the boundary the way `--json` prints it.

use pyo3::prelude::*;
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::errors::{Kind, error};

/// A serde value as Python objects (dicts, lists, floats, …).
pub fn to_python<T: Serialize>(py: Python<'_>, value: &T) -> PyResult<Py<PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| error(Kind::Base, format!("cannot encode the result: {e}")))?;
    let loads = py.import("json")?.getattr("loads")?;
    Ok(loads.call1((text,))?.unbind())
}

/// Python objects (a dict of options, …) as a serde value; `what` names it in the error.
pub fn from_python<T: DeserializeOwned>(value: &Bound<'_, PyAny>, what: &str) -> PyResult<T> {
    let py = value.py();
    let dumps = py.import("json")?.getattr("dumps")?;
    let kwargs = pyo3::types::PyDict::new(py);
    // Paths and other objects become strings (os.fspath for paths).
    kwargs.set_item("default", py.import("os")?.getattr("fspath")?)?;
    let text: String = dumps
        .call((value,), Some(&kwargs))
        .map_err(|e| error(Kind::Value, format!("{what}: {e}")))?
        .extract()?;
    serde_json::from_str(&text).map_err(|e| error(Kind::Value, format!("{what}: {e}")))
}

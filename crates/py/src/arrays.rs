//! Arrays in from Python: 1-D vectors, 2-D matrices and 4×4 homogeneous transforms read from numpy
//! arrays (fast path) or sequences, checked (sizes, finite entries, a proper rotation) with a
//! `PbdValueError` naming what was wrong — shared by `pbd.Robot`, `pbd.ControlStack`, `pbd.Sim` and
//! `pbd.bayes`.

use nalgebra::{Matrix3, Rotation3, Translation3, UnitQuaternion};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pbd::control_basis as cb;
use pyo3::prelude::*;

use crate::errors::value_error;

/// Reads a 1-D float vector from a numpy array (fast path) or any sequence of numbers.
pub fn vector(q: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
    if let Ok(a) = q.cast::<PyArray1<f64>>() {
        let r = a.readonly();
        if let Ok(s) = r.as_slice() {
            return Ok(s.to_vec());
        }
        return Ok(r.as_array().to_vec());
    }
    if let Ok(a) = q.cast::<numpy::PyUntypedArray>() {
        if a.ndim() != 1 {
            return Err(value_error(format!(
                "{what}: expected a 1-D array, got shape {:?}",
                a.shape()
            )));
        }
        let np = q.py().import("numpy")?;
        let f = np
            .call_method1("asarray", (q, np.getattr("float64")?))
            .map_err(|e| value_error(format!("{what}: {e}")))?;
        return vector(&f, what);
    }
    q.extract::<Vec<f64>>()
        .map_err(|_| value_error(format!("{what}: expected a 1-D array or a sequence of numbers")))
}

/// Reads a 2-D float matrix `(rows, cols, row-major values)` from a numpy array (fast path) or any
/// nested sequence numpy can convert.
pub fn matrix(m: &Bound<'_, PyAny>, what: &str) -> PyResult<(usize, usize, Vec<f64>)> {
    if let Ok(a) = m.cast::<PyArray2<f64>>() {
        let r = a.readonly();
        let v = r.as_array();
        return Ok((v.nrows(), v.ncols(), v.iter().copied().collect()));
    }
    let np = m.py().import("numpy")?;
    let a = np
        .call_method1("asarray", (m, np.getattr("float64")?))
        .map_err(|e| value_error(format!("{what}: expected a 2-D array of numbers ({e})")))?;
    match a.cast::<PyArray2<f64>>() {
        Ok(_) => matrix(&a, what),
        Err(_) => {
            let shape: Vec<usize> = a.getattr("shape")?.extract()?;
            Err(value_error(format!(
                "{what}: expected a 2-D array, got shape {shape:?}"
            )))
        }
    }
}

/// Refuses a non-finite entry, naming it.
pub fn check_finite(q: &[f64], what: &str) -> PyResult<()> {
    match q.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(value_error(format!(
            "{what}: entry {i} ({}) is not a finite number",
            q[i]
        ))),
        None => Ok(()),
    }
}

/// A 4×4 homogeneous transform as an isometry (rotation checked to be orthonormal).
pub fn isometry(target: &Bound<'_, PyAny>) -> PyResult<cb::math::Iso3> {
    let (rows, cols, flat) = matrix(target, "target")?;
    if (rows, cols) != (4, 4) {
        return Err(value_error(format!(
            "target: expected a 4x4 homogeneous matrix, got shape [{rows}, {cols}]"
        )));
    }
    check_finite(&flat, "target")?;
    let a = |i: usize, j: usize| flat[4 * i + j];
    let bottom = [a(3, 0), a(3, 1), a(3, 2), a(3, 3)];
    if bottom
        .iter()
        .zip([0.0, 0.0, 0.0, 1.0])
        .any(|(x, y)| (x - y).abs() > 1e-9)
    {
        return Err(value_error(format!(
            "target: the last row must be [0, 0, 0, 1], got {bottom:?}"
        )));
    }
    let r = Matrix3::from_fn(a);
    let err = (r.transpose() * r - Matrix3::identity()).abs().max();
    if err > 1e-6 || r.determinant() < 0.0 {
        return Err(value_error(format!(
            "target: the upper-left 3x3 block is not a rotation (|RᵀR − I| = {err:.2e}, det = {:.6})",
            r.determinant()
        )));
    }
    let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    Ok(cb::math::Iso3::from_parts(
        Translation3::new(a(0, 3), a(1, 3), a(2, 3)),
        rot,
    ))
}

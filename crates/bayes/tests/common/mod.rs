//! Shared helpers for the reference-vector tests: JSON loading with the reference files'
//! non-finite encoding ("-inf", "inf", "nan" strings) and the README's scaled-difference rule.
#![allow(dead_code)]

use serde_json::Value;

/// Parses `tests/data/<name>`.
pub fn load(name: &str) -> Value {
    let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// A float field: a JSON number or one of the strings "-inf", "inf", "nan".
pub fn f(v: &Value) -> f64 {
    match v {
        Value::Number(n) => n.as_f64().unwrap(),
        Value::String(s) => match s.as_str() {
            "-inf" => f64::NEG_INFINITY,
            "inf" => f64::INFINITY,
            "nan" => f64::NAN,
            other => panic!("not a float: {other}"),
        },
        other => panic!("not a float: {other}"),
    }
}

/// A vector of floats.
pub fn fv(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(f).collect()
}

/// A matrix (list of rows) flattened row-major, with its row count.
pub fn fm(v: &Value) -> (usize, Vec<f64>) {
    let rows = v.as_array().unwrap();
    (rows.len(), rows.iter().flat_map(fv).collect())
}

/// A vector of indices.
pub fn uv(v: &Value) -> Vec<usize> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap() as usize)
        .collect()
}

/// |a − b| / max(1, |b|); 0 when both are the same infinity, +inf when only one is infinite or
/// either is NaN.
pub fn scaled_diff(a: f64, b: f64) -> f64 {
    if a == b {
        return 0.0;
    }
    if !a.is_finite() || !b.is_finite() {
        return f64::INFINITY;
    }
    (a - b).abs() / b.abs().max(1.0)
}

/// The README's tolerance: 1e-12 + 10·cond·2.2e-16.
pub fn tol(cond: f64) -> f64 {
    1e-12 + 10.0 * cond * 2.2e-16
}

/// Tracks the worst error seen and prints it (visible with `--nocapture`).
#[derive(Debug, Default)]
pub struct Worst {
    pub value: f64,
    pub label: String,
}

impl Worst {
    pub fn see(&mut self, value: f64, label: impl FnOnce() -> String) {
        if value > self.value || self.label.is_empty() {
            self.value = value.max(self.value);
            self.label = label();
        }
    }
    pub fn report(&self, what: &str) {
        println!("worst {what}: {:.3e} ({})", self.value, self.label);
    }
}

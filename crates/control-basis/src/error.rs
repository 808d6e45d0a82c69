//! Errors of the control-basis crate: invalid input only. Outcomes of a control step (converged, no
//! reference, limited by a constraint) are statuses, not errors.

use std::path::PathBuf;

/// Everything that can be wrong with a robot model, a chain request or a controller's inputs.
#[derive(Debug, thiserror::Error)]
pub enum CbError {
    /// The URDF file could not be read.
    #[error("cannot read URDF file {path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The URDF text is not a valid URDF document.
    #[error("malformed URDF{}: {message}", origin.as_ref().map(|p| format!(" {}", p.display())).unwrap_or_default())]
    MalformedUrdf {
        /// The file, when the model came from one.
        origin: Option<PathBuf>,
        /// What the parser said.
        message: String,
    },
    /// The URDF parses but describes an invalid model.
    #[error("invalid URDF model: {element} '{name}': {problem}")]
    InvalidModel {
        /// `link` or `joint`.
        element: &'static str,
        /// The element's name.
        name: String,
        /// What is wrong.
        problem: String,
    },
    /// A link name that is not in the model.
    #[error("unknown link '{name}'{}", suggestion(candidates))]
    UnknownLink {
        /// The requested name.
        name: String,
        /// Close matches among the model's links.
        candidates: Vec<String>,
    },
    /// A joint name that is not in the model.
    #[error("unknown joint '{name}'")]
    UnknownJoint {
        /// The requested name.
        name: String,
    },
    /// Base and tip do not form a usable chain.
    #[error("no chain from '{base}' to '{tip}': {reason}")]
    NoChain {
        /// Base link.
        base: String,
        /// Tip link.
        tip: String,
        /// Why.
        reason: String,
    },
    /// A vector or matrix had the wrong size.
    #[error("{what}: expected {expected} values, got {got}")]
    DimensionMismatch {
        /// What was being given.
        what: String,
        /// Expected length.
        expected: usize,
        /// Given length.
        got: usize,
    },
    /// A value that must be finite was NaN or infinite.
    #[error("{what}: value {index} is not finite ({value})")]
    NotFinite {
        /// What was being given.
        what: String,
        /// Position of the bad value.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A parameter outside its valid range.
    #[error("invalid parameter {name} = {value}: {expected}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What is allowed.
        expected: &'static str,
    },
    /// The QP solver could not be set up (not an infeasible outcome: a malformed problem).
    #[error("QP solver set-up failed: {0}")]
    Solver(String),
}

fn suggestion(candidates: &[String]) -> String {
    if candidates.is_empty() {
        String::new()
    } else {
        format!(" (did you mean: {}?)", candidates.join(", "))
    }
}

/// Checks that every value of `values` is finite.
pub fn check_finite(what: &str, values: &[f64]) -> Result<(), CbError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(CbError::NotFinite {
            what: what.to_string(),
            index,
            value: values[index],
        }),
        None => Ok(()),
    }
}

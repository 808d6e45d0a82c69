//! The crate's one error type. `Result` is for invalid input only; how a sampler run went is
//! reported in [`crate::Diagnostics`], not as an error.

/// Everything that can be wrong with the input of this crate.
#[derive(Debug, thiserror::Error)]
pub enum GraspError {
    /// A field of a corpus, model or configuration is missing or has a bad value. `field` is a path
    /// such as `objects[3].grasps[2].position`.
    #[error("{field}: {reason}")]
    Invalid {
        /// Where the bad value is.
        field: String,
        /// What is wrong with it.
        reason: String,
    },
    /// An array has the wrong number of entries.
    #[error("{field}: expected {expected} numbers, got {got}")]
    DimensionMismatch {
        /// Where the array is.
        field: String,
        /// How many entries it must have.
        expected: usize,
        /// How many it has.
        got: usize,
    },
    /// A number is NaN or infinite.
    #[error("{field}: non-finite value {value}")]
    NonFinite {
        /// Where the number is.
        field: String,
        /// The value.
        value: f64,
    },
    /// A matrix that must be a covariance (symmetric positive definite) is not.
    #[error("{field}: not symmetric positive definite ({reason})")]
    NotPositiveDefinite {
        /// Where the matrix is.
        field: String,
        /// Why (asymmetric, a non-positive eigenvalue, …).
        reason: String,
    },
    /// The corpus holds nothing to learn from.
    #[error("empty corpus: {reason}")]
    EmptyCorpus {
        /// What is missing.
        reason: String,
    },
    /// A file declares a format or version this build does not read.
    #[error("{what}: unsupported format {found:?} (expected {expected:?})")]
    UnsupportedFormat {
        /// The kind of file.
        what: &'static str,
        /// The format/version tag found.
        found: String,
        /// The tag this build reads.
        expected: String,
    },
    /// An object name that the corpus or model does not know.
    #[error("unknown object {name:?}")]
    UnknownObject {
        /// The name asked for.
        name: String,
    },
    /// A file's content is wrong (the error says what and where in it).
    #[error("{path}: {error}")]
    InFile {
        /// The file.
        path: String,
        /// What is wrong in it.
        error: Box<GraspError>,
    },
    /// The file could not be read or written.
    #[error("cannot read or write {path}")]
    Io {
        /// The file.
        path: String,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not well-formed JSON of the expected shape.
    #[error("{what} is not valid JSON of the expected shape")]
    Json {
        /// The kind of file.
        what: &'static str,
        /// The parser's message (with line and column).
        #[source]
        source: serde_json::Error,
    },
}

/// Result with [`GraspError`].
pub type Result<T, E = GraspError> = std::result::Result<T, E>;

/// Checks that every entry is finite; names the first bad one.
pub(crate) fn check_finite(field: impl Fn() -> String, values: &[f64]) -> Result<()> {
    for (i, &v) in values.iter().enumerate() {
        if !v.is_finite() {
            let f = field();
            let field = if values.len() > 1 { format!("{f}[{i}]") } else { f };
            return Err(GraspError::NonFinite { field, value: v });
        }
    }
    Ok(())
}

/// An [`GraspError::Invalid`] for a field.
pub(crate) fn invalid(field: impl Into<String>, reason: impl Into<String>) -> GraspError {
    GraspError::Invalid {
        field: field.into(),
        reason: reason.into(),
    }
}

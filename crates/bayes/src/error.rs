//! The crate's one error type. Every variant is invalid *input*; outcomes such as "this
//! observation sequence is impossible" are values (`-inf`, `None`), never errors.

/// Invalid input to a `bayes` function or constructor.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BayesError {
    /// A vector, matrix or slice has the wrong length or shape.
    #[error("{what}: expected {expected} elements, got {got}")]
    DimensionMismatch {
        /// What was measured (e.g. "log emission row").
        what: &'static str,
        /// The size required.
        expected: usize,
        /// The size given.
        got: usize,
    },
    /// A matrix that must be square is not.
    #[error("{what}: matrix must be square, got {rows}x{cols}")]
    NotSquare {
        /// Which matrix.
        what: &'static str,
        /// Rows given.
        rows: usize,
        /// Columns given.
        cols: usize,
    },
    /// A value that must be finite (or at least not NaN / +inf) is not.
    #[error("{what}: value {value} at index {index} is not allowed ({requirement})")]
    NonFinite {
        /// Which input.
        what: &'static str,
        /// Position of the offending element (0 for scalars).
        index: usize,
        /// The offending value.
        value: f64,
        /// What was required, e.g. "finite" or "not NaN and not +inf".
        requirement: &'static str,
    },
    /// A scalar parameter is outside its domain.
    #[error("parameter {name} = {value} is invalid: must be {requirement}")]
    InvalidParameter {
        /// Parameter name as in the docs (ASCII, e.g. "kappa0").
        name: &'static str,
        /// The value given.
        value: f64,
        /// The domain, e.g. "> 0".
        requirement: &'static str,
    },
    /// A probability vector (or matrix row) does not sum to one.
    #[error("{what} (row {row}) is not normalised: log of its sum is {log_sum}")]
    NotNormalised {
        /// Which distribution.
        what: &'static str,
        /// Row index (0 for a vector).
        row: usize,
        /// log Σ p (0 when normalised).
        log_sum: f64,
    },
    /// A matrix that must be symmetric positive definite is not (Cholesky failed).
    #[error("{what}: matrix is not symmetric positive definite")]
    NotPositiveDefinite {
        /// Which matrix.
        what: &'static str,
    },
    /// A matrix that must be symmetric is not.
    #[error("{what}: matrix is not symmetric (|A - Aᵀ| = {asymmetry} at ({row}, {col}))")]
    NotSymmetric {
        /// Which matrix.
        what: &'static str,
        /// Row of the worst asymmetry.
        row: usize,
        /// Column of the worst asymmetry.
        col: usize,
        /// Its size.
        asymmetry: f64,
    },
    /// An input that must hold at least one element is empty.
    #[error("{what} is empty")]
    Empty {
        /// Which input.
        what: &'static str,
    },
    /// A category, symbol or state index is out of range.
    #[error("{what}: index {index} out of range 0..{len}")]
    IndexOutOfRange {
        /// Which index.
        what: &'static str,
        /// The index given.
        index: usize,
        /// The number of valid values.
        len: usize,
    },
    /// Two models or statistics that must agree in shape or hyper-parameters do not.
    #[error("incompatible {what}: {detail}")]
    Incompatible {
        /// What was combined.
        what: &'static str,
        /// How they differ.
        detail: String,
    },
    /// A χ² table whose expected frequencies contain a zero (a zero row or column sum).
    #[error("{what}: expected frequency is zero at ({row}, {col}); every row and column needs a positive sum")]
    ZeroExpected {
        /// Which test.
        what: &'static str,
        /// Row of the zero.
        row: usize,
        /// Column of the zero.
        col: usize,
    },
}

/// `Result` with [`BayesError`].
pub type Result<T, E = BayesError> = std::result::Result<T, E>;

/// Err unless `v` is finite.
pub(crate) fn check_finite(what: &'static str, index: usize, v: f64) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(BayesError::NonFinite {
            what,
            index,
            value: v,
            requirement: "finite",
        })
    }
}

/// Err unless `v` is finite and > 0.
pub(crate) fn check_positive(name: &'static str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(BayesError::InvalidParameter {
            name,
            value: v,
            requirement: "finite and > 0",
        })
    }
}

/// Err unless `got == expected`.
pub(crate) fn check_len(what: &'static str, expected: usize, got: usize) -> Result<()> {
    if expected == got {
        Ok(())
    } else {
        Err(BayesError::DimensionMismatch { what, expected, got })
    }
}

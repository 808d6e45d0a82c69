//! The one error type of `dexter-sim`.

use std::path::PathBuf;

/// Everything that can go wrong building or running the simulator.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A file could not be read.
    #[error("cannot read {path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A TOML file did not parse (syntax or types); the message names the line and key.
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message.
        message: String,
    },
    /// A value parsed but is not valid (negative size, unknown name, overlap, …).
    #[error("{path}: {field}: {message}")]
    Invalid {
        /// The file (or `<builtin>`).
        path: PathBuf,
        /// The field, as a TOML path such as `objects[3].shape.radius`.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A name that does not exist (object, place, presentation, arm, link).
    #[error("unknown {kind} `{name}`{}", if .candidates.is_empty() { String::new() } else { format!("; known: {}", .candidates.join(", ")) })]
    Unknown {
        /// What kind of name.
        kind: &'static str,
        /// The name asked for.
        name: String,
        /// Names that exist.
        candidates: Vec<String>,
    },
    /// The robot model is unusable for the simulator.
    #[error(transparent)]
    Model(#[from] control_basis::CbError),
    /// A schema library, procedural model or executive error.
    #[error(transparent)]
    Schema(#[from] schema::SchemaError),
    /// The robot side failed (invalid binding, hardware error).
    #[error(transparent)]
    Robot(Box<dexter::RobotError>),
    /// The robot cannot reach what a task needs (no arm reaches the object and the place, an arm
    /// cannot be parked).
    #[error("{what}: {reason}")]
    Unreachable {
        /// What was asked.
        what: String,
        /// Why not, and what to try.
        reason: String,
    },
    /// A vector of the wrong length (a configuration, a command).
    #[error("{what}: expected {expected} values, got {got}")]
    Size {
        /// What it is.
        what: &'static str,
        /// Its right length.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// The robot model uses a feature the physics engine cannot build (e.g. a mimic joint coupled
    /// across two multibodies).
    #[error("physics model: {0}")]
    Unsupported(&'static str),
    /// The simulated hardware failed (the robot's side of the world hook).
    #[error(transparent)]
    Hardware(#[from] control_basis::hardware::HardwareError),
}

/// A robot-side error met while the world ran the robot (its skills, its vision).
pub fn from_robot(e: dexter::RobotError) -> SimError {
    match e {
        dexter::RobotError::Model(m) => SimError::Model(m),
        dexter::RobotError::Schema(s) => SimError::Schema(s),
        other => SimError::Robot(Box::new(other)),
    }
}

impl From<dexter::RobotError> for SimError {
    fn from(e: dexter::RobotError) -> Self {
        from_robot(e)
    }
}

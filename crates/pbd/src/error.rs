//! The facade's error: [`Error`], what went wrong as a message with its causes (the lower crates'
//! errors — [`control_basis::CbError`], [`dexter_sim::SimError`], [`schema::SchemaError`],
//! [`bayes::BayesError`], I/O and JSON errors — are its sources) and its [`ErrorKind`], the class a
//! caller acts on: a wrong value, a malformed file, an unknown name, a file that cannot be read or
//! written, or a run that failed. The pipelines at the crate root ([`crate::record()`],
//! [`crate::infer()`], …) return it; the Python module raises one exception class per kind from
//! [`Error::kind`].
//!
//! The kind is decided once, where the error leaves the facade, by the first cause pbd knows (a
//! malformed URDF named in a model error is a format error even when a pipeline added context).

use std::fmt;

use serde::Serialize;

/// What kind of thing went wrong.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorKind {
    /// A value out of range, of the wrong size or not finite; an empty demonstration.
    Value,
    /// A malformed file (URDF, MCAP, JSON, TOML).
    Format,
    /// An unknown name (link, joint, scene, object, place, schema).
    Lookup,
    /// A file that cannot be read or written.
    File,
    /// The simulation, a solver or a skill failed.
    Failed,
    /// None of the above.
    Other,
}

/// An error of the facade. `Display` is the top message; [`std::error::Error::source`] walks the
/// causes (`{:#}` with `anyhow`, or [`Error::chain_message`], prints them joined by ": ").
pub struct Error {
    kind: ErrorKind,
    inner: anyhow::Error,
}

/// `Result` with the facade's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// What kind of error this is.
    pub fn kind(&self) -> ErrorKind {
        self.kind
    }

    /// The message and every cause, joined by ": " (what the `pbd` command prints).
    pub fn chain_message(&self) -> String {
        format!("{:#}", self.inner)
    }

    /// An error of `kind` with `message`.
    pub fn new(kind: ErrorKind, message: impl fmt::Display + Send + Sync + 'static) -> Self {
        Error {
            kind,
            inner: anyhow::Error::msg(message.to_string()),
        }
    }
}

impl fmt::Debug for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Error")
            .field("kind", &self.kind)
            .field("message", &self.chain_message())
            .finish()
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if f.alternate() {
            write!(f, "{:#}", self.inner)
        } else {
            write!(f, "{}", self.inner)
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.inner.source()
    }
}

impl From<anyhow::Error> for Error {
    fn from(inner: anyhow::Error) -> Self {
        Error {
            kind: kind_of(&inner),
            inner,
        }
    }
}

macro_rules! from_lower {
    ($($t:ty),*) => {$(
        impl From<$t> for Error {
            fn from(e: $t) -> Self {
                Error::from(anyhow::Error::from(e))
            }
        }
    )*};
}
from_lower!(
    control_basis::CbError,
    dexter_sim::SimError,
    schema::SchemaError,
    bayes::BayesError,
    dexter::RobotError,
    dexter::calibration::CalibrationFileError,
    std::io::Error,
    serde_json::Error
);

fn kind_of_cb(e: &control_basis::CbError) -> ErrorKind {
    use control_basis::CbError as E;
    match e {
        E::Io { .. } => ErrorKind::File,
        E::MalformedUrdf { .. } | E::InvalidModel { .. } => ErrorKind::Format,
        E::UnknownLink { .. } | E::UnknownJoint { .. } | E::NoChain { .. } => ErrorKind::Lookup,
        E::DimensionMismatch { .. } | E::NotFinite { .. } | E::InvalidParameter { .. } => ErrorKind::Value,
        E::Solver(_) => ErrorKind::Failed,
    }
}

fn kind_of_schema(e: &schema::SchemaError) -> ErrorKind {
    use schema::SchemaError as E;
    match e {
        E::Io { .. } => ErrorKind::File,
        E::Parse { .. } => ErrorKind::Format,
        E::Invalid { .. } | E::Empty(_) | E::Bayes(_) => ErrorKind::Value,
        E::Unknown { .. } => ErrorKind::Lookup,
        E::Plant(_) => ErrorKind::Failed,
    }
}

fn kind_of_sim(e: &dexter_sim::SimError) -> ErrorKind {
    use dexter_sim::SimError as E;
    match e {
        E::Io { .. } => ErrorKind::File,
        E::Parse { .. } => ErrorKind::Format,
        E::Invalid { .. } | E::Size { .. } => ErrorKind::Value,
        E::Unknown { .. } => ErrorKind::Lookup,
        E::Model(m) => kind_of_cb(m),
        E::Schema(s) => kind_of_schema(s),
        _ => ErrorKind::Failed,
    }
}

/// The kind of an error chain: the first cause pbd knows decides.
fn kind_of(err: &anyhow::Error) -> ErrorKind {
    for cause in err.chain() {
        if let Some(e) = cause.downcast_ref::<Error>() {
            return e.kind;
        }
        if let Some(e) = cause.downcast_ref::<control_basis::CbError>() {
            return kind_of_cb(e);
        }
        if let Some(e) = cause.downcast_ref::<dexter_sim::SimError>() {
            return kind_of_sim(e);
        }
        if let Some(e) = cause.downcast_ref::<schema::SchemaError>() {
            return kind_of_schema(e);
        }
        if let Some(e) = cause.downcast_ref::<dexter::calibration::CalibrationFileError>() {
            use dexter::calibration::CalibrationFileError as E;
            return match e {
                E::Read { .. } | E::Write { .. } => ErrorKind::File,
                E::Decode { .. } | E::Format { .. } | E::Version { .. } => ErrorKind::Format,
                E::Invalid { .. } => ErrorKind::Value,
            };
        }
        if let Some(dexter::RobotError::Invalid { .. }) = cause.downcast_ref::<dexter::RobotError>() {
            return ErrorKind::Value;
        }
        if cause.downcast_ref::<bayes::BayesError>().is_some() {
            return ErrorKind::Value;
        }
        if cause.downcast_ref::<serde_json::Error>().is_some() {
            return ErrorKind::Format;
        }
        if cause.downcast_ref::<std::io::Error>().is_some() {
            return ErrorKind::File;
        }
    }
    ErrorKind::Other
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_known_cause_decides_the_kind_and_the_message_keeps_every_cause() {
        let urdf = control_basis::CbError::MalformedUrdf {
            origin: Some("x.urdf".into()),
            message: "no <robot>".into(),
        };
        let e = Error::from(anyhow::Error::from(urdf).context("loading the robot"));
        assert_eq!(e.kind(), ErrorKind::Format);
        assert_eq!(e.to_string(), "loading the robot");
        assert!(
            e.chain_message().starts_with("loading the robot: "),
            "{}",
            e.chain_message()
        );
        assert!(std::error::Error::source(&e).is_some());
        // Through anyhow and back (a pipeline calling another): the kind is kept.
        let again = Error::from(anyhow::Error::from(e).context("in the demo"));
        assert_eq!(again.kind(), ErrorKind::Format);
        let io = Error::from(std::io::Error::new(std::io::ErrorKind::NotFound, "gone"));
        assert_eq!(io.kind(), ErrorKind::File);
        assert_eq!(Error::from(anyhow::anyhow!("plain")).kind(), ErrorKind::Other);
        assert_eq!(Error::new(ErrorKind::Lookup, "no scene `x`").kind(), ErrorKind::Lookup);
    }
}

//! The schema crate's one error type.

/// Invalid input to the schema crate: a malformed library, a bad percept stream, an empty demonstration.
#[derive(Debug, thiserror::Error)]
pub enum SchemaError {
    /// A file could not be read.
    #[error("cannot read {path}")]
    Io {
        /// The file.
        path: String,
        /// What the OS said.
        source: std::io::Error,
    },
    /// A file is not valid TOML/JSON.
    #[error("{path}: {message}")]
    Parse {
        /// The file (or `"<builtin>"`).
        path: String,
        /// The parser's message.
        message: String,
    },
    /// A field has an invalid value.
    #[error("{path}: {field}: {message}")]
    Invalid {
        /// The file (or `"<builtin>"`, or the stream).
        path: String,
        /// Where in the file, as a TOML/JSON path.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A name that does not exist (schema, action, state, arm, object, place).
    #[error("unknown {what} `{name}`{hint}")]
    Unknown {
        /// What kind of name.
        what: &'static str,
        /// The name.
        name: String,
        /// ", known: …" or empty.
        hint: String,
    },
    /// A demonstration with nothing to explain.
    #[error("empty demonstration: {0}")]
    Empty(String),
    /// The plant failed (not an action's failure: a broken simulator or robot link).
    #[error("the plant failed")]
    Plant(#[source] Box<dyn std::error::Error + Send + Sync>),
    /// An error from the statistics crate.
    #[error(transparent)]
    Bayes(#[from] bayes::BayesError),
}

impl SchemaError {
    pub(crate) fn invalid(path: &str, field: impl Into<String>, message: impl Into<String>) -> Self {
        SchemaError::Invalid {
            path: path.to_string(),
            field: field.into(),
            message: message.into(),
        }
    }

    pub(crate) fn unknown<'a>(what: &'static str, name: &str, known: impl IntoIterator<Item = &'a str>) -> Self {
        let known: Vec<&str> = known.into_iter().collect();
        let hint = if known.is_empty() {
            String::new()
        } else {
            format!(" (known: {})", known.join(", "))
        };
        SchemaError::Unknown {
            what,
            name: name.to_string(),
            hint,
        }
    }
}

//! Reading and checking catalog and scene files: the format version, TOML parsing with one-line
//! errors, the bounds on numbers (lengths, counts, [`SCENE_RANGES`]) and on names, and the
//! messages that name the file and the field.

use std::path::Path;

use serde::Deserialize;

use crate::error::SimError;

/// Current version of the catalog and scene formats.
pub const FORMAT_VERSION: u32 = 1;

/// Largest accepted camera image side (px).
pub const MAX_IMAGE_SIDE: u32 = 4096;

/// Largest length or coordinate a scene may hold (m): a room, not a planet.
pub const MAX_LENGTH: f64 = 100.0;

/// Most objects a scene may place. A tabletop within Dexter's reach holds a few dozen at most (the
/// shipped scenes 1 to 7), while cost grows with the count: with 64, `pbd sim pick-place` takes
/// about 1 s and `pbd execute` about 10 s; 1,000 took 11 s for one pick and 10,000 ran past 30 s.
/// Checked on load, before the catalog is read ([`Scene::load`](super::Scene::load), [`Scene::new`](super::Scene::new)).
pub const MAX_SCENE_OBJECTS: usize = 64;

/// Most objects a catalog may hold (the shipped ones hold 43 and 70): names are checked for
/// duplicates pairwise, and 10,000 objects already took a second to load.
pub const MAX_CATALOG_OBJECTS: usize = 1_000;

/// The physically meaningful range of each number of a scene that is not a plain length or
/// coordinate (checked on load, [`Check::within`]; documented in `assets/README-scenes.md`):
/// (field, least, most, unit).
pub const SCENE_RANGES: [(&str, f64, f64, &str); 6] = [
    ("table.height", 0.1, 2.0, "m"),
    ("places[].wall_height", 0.0, 0.5, "m"),
    ("places[].wall_thickness", 0.001, 0.2, "m"),
    ("camera.rate_hz", 0.1, 1000.0, "Hz"),
    ("objects[].yaw_deg", -360.0, 360.0, "°"),
    ("objects[].z above the table", 0.0, 2.0, "m"),
];

/// The range of `field` in [`SCENE_RANGES`].
pub(super) fn scene_range(field: &str) -> (f64, f64, &'static str) {
    SCENE_RANGES
        .iter()
        .find(|r| r.0 == field)
        .map(|r| (r.1, r.2, r.3))
        .unwrap_or((f64::NEG_INFINITY, f64::INFINITY, ""))
}

pub(super) fn read_file(path: &Path) -> Result<String, SimError> {
    bayes::input::read_text(path).map_err(|source| SimError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Parses TOML into `T`; a `version` other than [`FORMAT_VERSION`] is reported before any other
/// problem (a newer file may have fields this build does not know).
pub(super) fn parse_toml<T: serde::de::DeserializeOwned>(text: &str, path: &Path) -> Result<T, SimError> {
    #[derive(Deserialize)]
    struct Versioned {
        version: Option<toml::Value>,
    }
    let parse_error = |e: toml::de::Error| SimError::Parse {
        path: path.to_path_buf(),
        message: toml_error_line(&e, text),
    };
    let head: Versioned = toml::from_str(text).map_err(parse_error)?;
    if let Some(toml::Value::Integer(v)) = head.version
        && v != i64::from(FORMAT_VERSION)
    {
        return Err(Check { path }.version_error(v));
    }
    toml::from_str(text).map_err(parse_error)
}

/// A TOML error on one line, `line L, column C: message (at `the source line`)`: toml's own text
/// quotes the source over several lines, which a one-line `error:` cannot hold.
fn toml_error_line(e: &toml::de::Error, text: &str) -> String {
    let message = e.message().split_whitespace().collect::<Vec<_>>().join(" ");
    match e.span().and_then(|span| text.get(..span.start)) {
        Some(before) => {
            let line = before.matches('\n').count() + 1;
            let column = before.rsplit('\n').next().unwrap_or("").chars().count() + 1;
            let source: String = text
                .lines()
                .nth(line - 1)
                .unwrap_or("")
                .trim()
                .chars()
                .take(80)
                .collect();
            if source.is_empty() {
                format!("line {line}, column {column}: {message}")
            } else {
                format!("line {line}, column {column}: {message} (at `{source}`)")
            }
        }
        None => message,
    }
}

/// Appends "(in `name`)" to an [`SimError::Invalid`] message.
pub(super) fn in_context(e: SimError, name: &str) -> SimError {
    match e {
        SimError::Invalid { path, field, message } => SimError::Invalid {
            path,
            field,
            message: format!("{message} (in `{name}`)"),
        },
        other => other,
    }
}

/// `names`, closest to `name` first (edit distance, ignoring case; ties in the given order).
pub(super) fn by_similarity<'a>(name: &str, names: impl IntoIterator<Item = &'a str>) -> Vec<String> {
    let key = name.to_lowercase();
    let mut ranked: Vec<(usize, usize, &str)> = names
        .into_iter()
        .enumerate()
        .map(|(i, n)| (edit_distance(&key, &n.to_lowercase()), i, n))
        .collect();
    ranked.sort_unstable();
    ranked.into_iter().map(|(_, _, n)| n.to_string()).collect()
}

/// Levenshtein distance between two strings, by characters.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let next = (diagonal + usize::from(ca != *cb)).min(row[j] + 1).min(row[j + 1] + 1);
            diagonal = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

/// Records `name` as defined at `field`, or fails naming both places if it is already taken.
pub(super) fn claim_name<'a>(
    c: &Check<'_>,
    names: &mut Vec<(&'a str, String)>,
    name: &'a str,
    field: String,
) -> Result<(), SimError> {
    if let Some((_, first)) = names.iter().find(|(n, _)| *n == name) {
        return Err(c.invalid(field, format!("duplicate name `{name}` (first defined at {first})")));
    }
    names.push((name, field));
    Ok(())
}

/// Builds [`SimError::Invalid`] for one file.
pub(super) struct Check<'a> {
    pub(super) path: &'a Path,
}

impl Check<'_> {
    pub(super) fn invalid(&self, field: impl Into<String>, message: impl Into<String>) -> SimError {
        SimError::Invalid {
            path: self.path.to_path_buf(),
            field: field.into(),
            message: message.into(),
        }
    }

    pub(super) fn version_error(&self, got: i64) -> SimError {
        self.invalid(
            "version",
            format!("unsupported format version {got}; this build reads version {FORMAT_VERSION}"),
        )
    }

    pub(super) fn version(&self, v: u32) -> Result<(), SimError> {
        if v == FORMAT_VERSION {
            Ok(())
        } else {
            Err(self.version_error(i64::from(v)))
        }
    }

    pub(super) fn finite(&self, field: &str, v: f64) -> Result<(), SimError> {
        if v.is_finite() {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be a finite number (got {v})")))
        }
    }

    pub(super) fn finite_all(&self, field: &str, values: &[f64]) -> Result<(), SimError> {
        for (k, v) in values.iter().enumerate() {
            self.finite(&format!("{field}[{k}]"), *v)?;
        }
        Ok(())
    }

    /// A length of the tabletop world: finite, > 0 and at most [`MAX_LENGTH`] (physics engines fail
    /// on absurd sizes such as 1e300).
    pub(super) fn length(&self, field: &str, v: f64) -> Result<(), SimError> {
        self.positive(field, v)?;
        if v <= MAX_LENGTH {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be at most {MAX_LENGTH} m (got {v:e})")))
        }
    }

    /// Coordinates within [`MAX_LENGTH`] of the world origin.
    pub(super) fn coordinates(&self, field: &str, values: &[f64]) -> Result<(), SimError> {
        self.finite_all(field, values)?;
        for (k, v) in values.iter().enumerate() {
            if v.abs() > MAX_LENGTH {
                return Err(self.invalid(
                    format!("{field}[{k}]"),
                    format!("must be within ±{MAX_LENGTH} m (got {v:e})"),
                ));
            }
        }
        Ok(())
    }

    /// At most `max` entries in the array `field` of `what` (a scene, a catalog).
    pub(super) fn count(&self, field: &str, n: usize, max: usize, what: &str) -> Result<(), SimError> {
        if n <= max {
            Ok(())
        } else {
            Err(self.invalid(
                field,
                format!("{n} entries; {what} may hold at most {max} (a limit on the cost of a run)"),
            ))
        }
    }

    /// Within the range [`SCENE_RANGES`] gives `key`; `field` names the value in the message.
    pub(super) fn within(&self, field: &str, key: &str, v: f64) -> Result<(), SimError> {
        self.finite(field, v)?;
        let (lo, hi, unit) = scene_range(key);
        if (lo..=hi).contains(&v) {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be in [{lo}, {hi}] {unit} (got {v:e})")))
        }
    }

    pub(super) fn positive(&self, field: &str, v: f64) -> Result<(), SimError> {
        self.finite(field, v)?;
        if v > 0.0 {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be > 0 (got {v})")))
        }
    }

    pub(super) fn unit_interval(&self, field: &str, v: f64) -> Result<(), SimError> {
        self.finite(field, v)?;
        if (0.0..=1.0).contains(&v) {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be in [0, 1] (got {v})")))
        }
    }

    pub(super) fn hsv(&self, field: &str, hsv: &[f64; 3]) -> Result<(), SimError> {
        self.finite_all(field, hsv)?;
        if !(0.0..360.0).contains(&hsv[0]) {
            return Err(self.invalid(
                format!("{field}[0]"),
                format!("hue must be in [0, 360) degrees (got {})", hsv[0]),
            ));
        }
        for (k, what) in [(1, "saturation"), (2, "value")] {
            if !(0.0..=1.0).contains(&hsv[k]) {
                return Err(self.invalid(
                    format!("{field}[{k}]"),
                    format!("{what} must be in [0, 1] (got {})", hsv[k]),
                ));
            }
        }
        Ok(())
    }

    /// Names: non-empty, letters, digits, `_`, `-` and `.` only (`#` numbers duplicates in a scene).
    pub(super) fn name(&self, field: &str, name: &str) -> Result<(), SimError> {
        if name.is_empty() {
            return Err(self.invalid(field, "must not be empty"));
        }
        if let Some(bad) = name
            .chars()
            .find(|ch| !(ch.is_alphanumeric() || matches!(ch, '_' | '-' | '.')))
        {
            return Err(self.invalid(
                field,
                format!("`{name}` contains `{bad}`; names use letters, digits, `_`, `-` and `.`"),
            ));
        }
        Ok(())
    }
}

/// Deserialises exactly `N` numbers: TOML arrays with extra elements are an error (serde's fixed-size
/// arrays silently drop them), and the message says how many were given.
pub(super) fn exact_array<'de, D, const N: usize>(d: D) -> Result<[f64; N], D::Error>
where
    D: serde::Deserializer<'de>,
{
    use serde::de::Error as _;
    let v: Vec<f64> = serde::Deserialize::deserialize(d)?;
    let n = v.len();
    v.try_into()
        .map_err(|_| D::Error::invalid_length(n, &format!("exactly {N} numbers").as_str()))
}

//! The grasp corpus: object presentations, their appearance and their demonstrated pre-grasps (§6.2).
//!
//! # File format (`pbd-grasp-corpus`, version 1)
//!
//! ```json
//! {
//!   "format": "pbd-grasp-corpus",
//!   "version": 1,
//!   "objects": [
//!     {
//!       "name": "jif-1",
//!       "appearance": [[1.2e-3, 2.0e-4], [2.0e-4, 6.0e-4]],
//!       "grasps": [
//!         { "position": [0.01, -0.02, 0.11], "orientation": [0.0, 1.0, 0.0, 0.0] },
//!         { "position": [0.00, 0.09, 0.03], "orientation": [0.5, 0.5, -0.5, 0.5],
//!           "appearance": [[1.1e-3, 1.0e-4], [1.0e-4, 6.5e-4]] }
//!       ]
//!     }
//!   ]
//! }
//! ```
//!
//! - `name`: the presentation (object and pose, e.g. `jif-1`); unique, non-empty.
//! - `appearance`: b_m, the 2×2 second-moment covariance of the object's image segment averaged over
//!   the left and right cameras (§6.2.1), row-major, symmetric positive definite, in px² (or any
//!   consistent unit).
//! - `grasps[].position`: x, the palm-surface position (m) in the object frame O: origin at the
//!   triangulated centroid, axes parallel to the world (table) frame, z up (§6.2.2).
//! - `grasps[].orientation`: the palm-surface orientation in the same frame as a unit quaternion
//!   `[w, x, y, z]` (palm normal = hand +z = approach direction, finger 3 on hand +y). Learning
//!   replaces it by the nearest of Q canonical orientations (§6.2.2).
//! - `grasps[].appearance` (optional): b measured at this demonstration, if the object was segmented
//!   anew for each grasp; otherwise the object's `appearance` is used (the model has one b per grasp,
//!   6.11).
//!
//! Everything is validated on read, with errors naming the field.

use std::path::Path;

use nalgebra::{Matrix2, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{GraspError, Result, check_finite, invalid};
use crate::math::{a2, cholesky, m2};

/// The `format` tag of corpus files.
pub const CORPUS_FORMAT: &str = "pbd-grasp-corpus";
/// The corpus file version this build writes and reads.
pub const CORPUS_VERSION: u32 = 1;

/// One demonstrated pre-grasp (§6.2.2).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DemoGrasp {
    /// Palm-surface position x (m) in the object frame (centroid origin, world-aligned axes).
    pub position: [f64; 3],
    /// Palm-surface orientation, unit quaternion `[w, x, y, z]`, in the same frame.
    pub orientation: [f64; 4],
    /// b measured at this demonstration, if any (else the object's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub appearance: Option<[[f64; 2]; 2]>,
}

impl DemoGrasp {
    /// A grasp from nalgebra types (object-frame position and palm orientation).
    pub fn new(position: &Vector3<f64>, orientation: &UnitQuaternion<f64>) -> Self {
        let q = orientation.quaternion();
        Self {
            position: [position.x, position.y, position.z],
            orientation: [q.w, q.i, q.j, q.k],
            appearance: None,
        }
    }

    /// The position as a vector.
    pub fn position(&self) -> Vector3<f64> {
        Vector3::from(self.position)
    }

    /// The orientation, renormalised.
    pub fn orientation(&self) -> UnitQuaternion<f64> {
        let [w, x, y, z] = self.orientation;
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
    }
}

/// One object presentation with its appearance and demonstrated grasps.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CorpusObject {
    /// Presentation name (object and pose), unique in the corpus.
    pub name: String,
    /// b_m: 2×2 second-moment covariance of the segment, averaged over the stereo pair (row-major).
    pub appearance: [[f64; 2]; 2],
    /// The demonstrated pre-grasps.
    pub grasps: Vec<DemoGrasp>,
}

impl CorpusObject {
    /// The appearance as a matrix.
    pub fn appearance(&self) -> Matrix2<f64> {
        m2(&self.appearance)
    }
}

/// A grasp corpus: the training data 𝒟 = (b, x, w) of §6.3 before orientations are quantised.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Corpus {
    /// Always [`CORPUS_FORMAT`].
    pub format: String,
    /// Always [`CORPUS_VERSION`].
    pub version: u32,
    /// The object presentations.
    pub objects: Vec<CorpusObject>,
}

impl Default for Corpus {
    fn default() -> Self {
        Self::new()
    }
}

#[derive(Deserialize)]
struct RawCorpus {
    format: Option<String>,
    version: Option<u32>,
    objects: Option<Vec<RawObject>>,
}

#[derive(Deserialize)]
struct RawObject {
    name: Option<String>,
    appearance: Option<Vec<Vec<f64>>>,
    grasps: Option<Vec<RawGrasp>>,
}

#[derive(Deserialize)]
struct RawGrasp {
    position: Option<Vec<f64>>,
    orientation: Option<Vec<f64>>,
    appearance: Option<Vec<Vec<f64>>>,
}

fn vec_n<const N: usize>(field: &str, v: Option<Vec<f64>>) -> Result<[f64; N]> {
    let v = v.ok_or_else(|| invalid(field, "missing"))?;
    if v.len() != N {
        return Err(GraspError::DimensionMismatch {
            field: field.to_string(),
            expected: N,
            got: v.len(),
        });
    }
    let mut out = [0.0; N];
    out.copy_from_slice(&v);
    Ok(out)
}

fn mat2(field: &str, v: Option<Vec<Vec<f64>>>) -> Result<[[f64; 2]; 2]> {
    let v = v.ok_or_else(|| invalid(field, "missing"))?;
    if v.len() != 2 {
        return Err(GraspError::DimensionMismatch {
            field: format!("{field} (rows)"),
            expected: 2,
            got: v.len(),
        });
    }
    let mut out = [[0.0; 2]; 2];
    for (i, row) in v.into_iter().enumerate() {
        out[i] = vec_n::<2>(&format!("{field}[{i}]"), Some(row))?;
    }
    Ok(out)
}

/// Checks that a 2×2 appearance feature is finite, symmetric and positive definite.
pub(crate) fn validate_spd2(field: &str, a: &[[f64; 2]; 2]) -> Result<()> {
    check_finite(|| field.to_string(), &[a[0][0], a[0][1], a[1][0], a[1][1]])?;
    let scale = a[0][0].abs().max(a[1][1].abs()).max(f64::MIN_POSITIVE);
    if (a[0][1] - a[1][0]).abs() > 1e-9 * scale {
        return Err(GraspError::NotPositiveDefinite {
            field: field.to_string(),
            reason: format!("asymmetric: [0][1] = {} but [1][0] = {}", a[0][1], a[1][0]),
        });
    }
    let m = m2(a);
    let det = m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)];
    if cholesky(&m).is_none() || det.is_nan() || det <= 1e-12 * scale * scale {
        return Err(GraspError::NotPositiveDefinite {
            field: field.to_string(),
            reason: format!("diagonal ({}, {}), determinant {det:e}", a[0][0], a[1][1]),
        });
    }
    Ok(())
}

impl Corpus {
    /// An empty corpus (add objects with [`Corpus::push_object`]).
    pub fn new() -> Self {
        Self {
            format: CORPUS_FORMAT.to_string(),
            version: CORPUS_VERSION,
            objects: Vec::new(),
        }
    }

    /// Adds an object presentation.
    pub fn push_object(&mut self, name: impl Into<String>, appearance: &Matrix2<f64>, grasps: Vec<DemoGrasp>) {
        self.objects.push(CorpusObject {
            name: name.into(),
            appearance: a2(appearance),
            grasps,
        });
    }

    /// Total number of demonstrated grasps.
    pub fn num_grasps(&self) -> usize {
        self.objects.iter().map(|o| o.grasps.len()).sum()
    }

    /// Index of the object named `name`.
    pub fn object_index(&self, name: &str) -> Result<usize> {
        self.objects
            .iter()
            .position(|o| o.name == name)
            .ok_or_else(|| GraspError::UnknownObject { name: name.to_string() })
    }

    /// Checks every field: format and version, at least one grasp, unique non-empty names, finite
    /// numbers, symmetric positive-definite appearance features, unit quaternions (within 1e-3).
    pub fn validate(&self) -> Result<()> {
        if self.format != CORPUS_FORMAT || self.version != CORPUS_VERSION {
            return Err(GraspError::UnsupportedFormat {
                what: "grasp corpus",
                found: format!("{} v{}", self.format, self.version),
                expected: format!("{CORPUS_FORMAT} v{CORPUS_VERSION}"),
            });
        }
        if self.objects.is_empty() {
            return Err(GraspError::EmptyCorpus {
                reason: "no objects".into(),
            });
        }
        let mut names = std::collections::HashSet::new();
        for (m, o) in self.objects.iter().enumerate() {
            let f = format!("objects[{m}]");
            if o.name.trim().is_empty() {
                return Err(invalid(format!("{f}.name"), "empty"));
            }
            if !names.insert(o.name.as_str()) {
                return Err(invalid(format!("{f}.name"), format!("duplicate name {:?}", o.name)));
            }
            validate_spd2(&format!("{f}.appearance"), &o.appearance)?;
            if o.grasps.is_empty() {
                return Err(GraspError::EmptyCorpus {
                    reason: format!("{f} ({:?}) has no grasps", o.name),
                });
            }
            for (i, g) in o.grasps.iter().enumerate() {
                let gf = format!("{f}.grasps[{i}]");
                check_finite(|| format!("{gf}.position"), &g.position)?;
                check_finite(|| format!("{gf}.orientation"), &g.orientation)?;
                let n = g.orientation.iter().map(|v| v * v).sum::<f64>().sqrt();
                if (n - 1.0).abs() > 1e-3 {
                    return Err(invalid(
                        format!("{gf}.orientation"),
                        format!("not a unit quaternion [w, x, y, z] (norm {n})"),
                    ));
                }
                if let Some(b) = &g.appearance {
                    validate_spd2(&format!("{gf}.appearance"), b)?;
                }
            }
        }
        Ok(())
    }

    /// Parses and validates a corpus from JSON text.
    pub fn from_json_str(text: &str) -> Result<Self> {
        if let Err(dup) = bayes::input::check_json_keys(text) {
            return Err(invalid(dup.path.clone(), dup.to_string()));
        }
        let raw: RawCorpus = serde_json::from_str(text).map_err(|source| GraspError::Json {
            what: "grasp corpus",
            source,
        })?;
        let format = raw.format.ok_or_else(|| invalid("format", "missing"))?;
        let version = raw.version.ok_or_else(|| invalid("version", "missing"))?;
        if format != CORPUS_FORMAT || version != CORPUS_VERSION {
            return Err(GraspError::UnsupportedFormat {
                what: "grasp corpus",
                found: format!("{format} v{version}"),
                expected: format!("{CORPUS_FORMAT} v{CORPUS_VERSION}"),
            });
        }
        let raw_objects = raw.objects.ok_or_else(|| invalid("objects", "missing"))?;
        let mut objects = Vec::with_capacity(raw_objects.len());
        for (m, o) in raw_objects.into_iter().enumerate() {
            let f = format!("objects[{m}]");
            let name = o.name.ok_or_else(|| invalid(format!("{f}.name"), "missing"))?;
            let appearance = mat2(&format!("{f}.appearance"), o.appearance)?;
            let raw_grasps = o.grasps.ok_or_else(|| invalid(format!("{f}.grasps"), "missing"))?;
            let mut grasps = Vec::with_capacity(raw_grasps.len());
            for (i, g) in raw_grasps.into_iter().enumerate() {
                let gf = format!("{f}.grasps[{i}]");
                grasps.push(DemoGrasp {
                    position: vec_n::<3>(&format!("{gf}.position"), g.position)?,
                    orientation: vec_n::<4>(&format!("{gf}.orientation"), g.orientation)?,
                    appearance: match g.appearance {
                        Some(b) => Some(mat2(&format!("{gf}.appearance"), Some(b))?),
                        None => None,
                    },
                });
            }
            objects.push(CorpusObject {
                name,
                appearance,
                grasps,
            });
        }
        let c = Self {
            format,
            version,
            objects,
        };
        c.validate()?;
        Ok(c)
    }

    /// Pretty JSON text (validated first, so a written corpus always reads back).
    pub fn to_json_string(&self) -> Result<String> {
        self.validate()?;
        serde_json::to_string_pretty(self).map_err(|source| GraspError::Json {
            what: "grasp corpus",
            source,
        })
    }

    /// Reads and validates a corpus file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = bayes::input::read_text(path).map_err(|source| GraspError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_json_str(&text).map_err(|e| GraspError::InFile {
            path: path.display().to_string(),
            error: Box::new(e),
        })
    }

    /// Writes the corpus as JSON.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let text = self.to_json_string()?;
        std::fs::write(path, text).map_err(|source| GraspError::Io {
            path: path.display().to_string(),
            source,
        })
    }
}

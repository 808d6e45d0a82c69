//! The calibration file: a [`Calibration`] as CBOR (RFC 8949), so that a robot calibrates its
//! cleared workcell once and every later run loads the result (`pbd calibrate`, then `pbd execute
//! --calibration FILE`). The format is in the book (`docs/src/formats/calibration.md`); in short,
//! one map
//!
//! ```text
//! { "format": "pbd-calibration", "version": 1, "writer": "pbd 0.1.0",
//!   "banks": [ { "camera": "head/left", "plane_z": 0.75,
//!                "views": [ { "camera": { "width": 320, "height": 240,
//!                                         "fx": …, "fy": …, "cx": …, "cy": …,
//!                                         "translation": [x, y, z],
//!                                         "rotation": [x, y, z, w] },
//!                             "image": h'…',     // 3·width·height bytes, RGB, row-major
//!                             "valid": h'…' } ] } ] }   // bits, pixel i = bit i % 8 of byte i / 8
//! ```
//!
//! Images are CBOR byte strings (not arrays of numbers); the validity mask is packed eight pixels
//! to a byte, least significant bit first (an empty mask: every pixel valid). Numbers are written
//! exactly (CBOR floats; a saved calibration loads equal to the original). Reading trusts nothing:
//! the format and version are checked first, then every size against `width × height`, every number
//! for finiteness, the banks and their camera names; any failure is a [`CalibrationFileError`]
//! naming the file and the field, never a panic. [`Calibration::save`] writes through a temporary
//! file beside the target and a rename, so a reader never sees half a file.

use std::io::{Read, Write};
use std::path::Path;

use control_basis::hardware::{Camera, Image, MAX_IMAGE_SIDE};
use control_basis::math::Iso3;
use nalgebra::{Quaternion, Translation3, UnitQuaternion};
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::{Deserialize, Serialize, Serializer};

use super::Calibration;
use crate::vision::{BackgroundBank, BackgroundView};

/// The value of the file's `format` key.
pub const FORMAT: &str = "pbd-calibration";

/// The version of the format this build writes, and the only one it reads.
pub const VERSION: u64 = 1;

/// The name a reader or writer without a path is reported as.
const NO_PATH: &str = "<calibration>";

/// Longest camera name (bytes).
const MAX_NAME_LEN: usize = 256;

/// Largest distance of a rotation quaternion's norm from 1.
const UNIT_TOLERANCE: f64 = 1e-6;

/// What is wrong with a calibration file (or with a calibration that cannot be written as one).
/// Every variant names the file (`<calibration>` for a reader or writer without a path).
#[derive(Debug, thiserror::Error)]
pub enum CalibrationFileError {
    /// The file cannot be read (missing, a directory, a pipe, larger than the input limit).
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The file cannot be written.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The file.
        path: String,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The bytes are not CBOR of the expected shape (cut short, a wrong type, a missing or unknown
    /// key).
    #[error("{path}: not a readable pbd calibration file: {message}")]
    Decode {
        /// The file.
        path: String,
        /// What the decoder found.
        message: String,
    },
    /// The file's `format` is not `pbd-calibration`.
    #[error("{path}: not a pbd calibration file (its `format` is {found}, expected \"{FORMAT}\")")]
    Format {
        /// The file.
        path: String,
        /// The `format` it has (or `missing`).
        found: String,
    },
    /// The file is of another version of the format.
    #[error(
        "{path}: calibration format version {found} is not supported: this pbd reads version {VERSION} \
         (calibrate again with `pbd calibrate`, or load it with the pbd that wrote it)"
    )]
    Version {
        /// The file.
        path: String,
        /// The `version` it has (or `missing`).
        found: String,
    },
    /// A value is not valid: a size that does not match `width × height`, a number that is not
    /// finite, an empty bank, a camera name given twice.
    #[error("{path}: {field}: {message}")]
    Invalid {
        /// The file.
        path: String,
        /// The field (`banks[1].views[3].image`).
        field: String,
        /// What is wrong.
        message: String,
    },
}

impl CalibrationFileError {
    /// The file the error is about.
    pub fn path(&self) -> &str {
        match self {
            Self::Read { path, .. }
            | Self::Write { path, .. }
            | Self::Decode { path, .. }
            | Self::Format { path, .. }
            | Self::Version { path, .. }
            | Self::Invalid { path, .. } => path,
        }
    }

    /// The field the error is about, if it is about one.
    pub fn field(&self) -> Option<&str> {
        match self {
            Self::Invalid { field, .. } => Some(field),
            Self::Format { .. } => Some("format"),
            Self::Version { .. } => Some("version"),
            _ => None,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The wire form (version 1).

/// A byte string written as one CBOR byte string (major type 2), not as an array of numbers.
struct ByteSlice<'a>(&'a [u8]);

impl Serialize for ByteSlice<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(self.0)
    }
}

/// A byte string read back: a CBOR byte string, or (from writers that do not know byte strings) an
/// array of numbers 0–255.
#[derive(Debug, Default)]
struct ByteBuf(Vec<u8>);

impl<'de> Deserialize<'de> for ByteBuf {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ByteBuf;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a byte string")
            }
            fn visit_bytes<E: de::Error>(self, v: &[u8]) -> Result<ByteBuf, E> {
                Ok(ByteBuf(v.to_vec()))
            }
            fn visit_byte_buf<E: de::Error>(self, v: Vec<u8>) -> Result<ByteBuf, E> {
                Ok(ByteBuf(v))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<ByteBuf, A::Error> {
                let mut out = Vec::with_capacity(seq.size_hint().unwrap_or(0).min(1 << 16));
                while let Some(b) = seq.next_element::<u8>()? {
                    out.push(b);
                }
                Ok(ByteBuf(out))
            }
        }
        d.deserialize_byte_buf(V)
    }
}

/// A camera as written: intrinsics and the optical frame's pose in the world.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraV1 {
    width: u32,
    height: u32,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    /// Position of the optical frame (m, world).
    translation: [f64; 3],
    /// Orientation of the optical frame: unit quaternion x, y, z, w (scalar last).
    rotation: [f64; 4],
}

impl CameraV1 {
    fn of(c: &Camera) -> Self {
        let t = c.world_from_optical.translation.vector;
        let q = c.world_from_optical.rotation.quaternion().coords; // i, j, k, w
        CameraV1 {
            width: c.width,
            height: c.height,
            fx: c.fx,
            fy: c.fy,
            cx: c.cx,
            cy: c.cy,
            translation: [t.x, t.y, t.z],
            rotation: [q.x, q.y, q.z, q.w],
        }
    }

    /// The camera, after [`check_camera`] (the quaternion is taken as written, not renormalised,
    /// so that a saved camera loads bit for bit).
    fn camera(&self) -> Camera {
        let [x, y, z] = self.translation;
        let [qx, qy, qz, qw] = self.rotation;
        Camera {
            world_from_optical: Iso3::from_parts(
                Translation3::new(x, y, z),
                UnitQuaternion::new_unchecked(Quaternion::new(qw, qx, qy, qz)),
            ),
            width: self.width,
            height: self.height,
            fx: self.fx,
            fy: self.fy,
            cx: self.cx,
            cy: self.cy,
        }
    }
}

#[derive(Serialize)]
struct ViewOut<'a> {
    camera: CameraV1,
    image: ByteSlice<'a>,
    valid: ByteSlice<'a>,
}

#[derive(Serialize)]
struct BankOut<'a> {
    camera: &'a str,
    plane_z: f64,
    views: Vec<ViewOut<'a>>,
}

#[derive(Serialize)]
struct FileOut<'a> {
    format: &'a str,
    version: u64,
    writer: String,
    banks: Vec<BankOut<'a>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ViewIn {
    camera: CameraV1,
    image: ByteBuf,
    valid: ByteBuf,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BankIn {
    camera: String,
    plane_z: f64,
    views: Vec<ViewIn>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileIn {
    #[allow(dead_code)]
    format: String,
    #[allow(dead_code)]
    version: u64,
    #[serde(default)]
    #[allow(dead_code)]
    writer: String,
    banks: Vec<BankIn>,
}

/// The first pass: only the format and version (every other key skipped), so that a file of
/// another version is refused as such, not for a key this version does not know.
#[derive(Deserialize)]
struct Header {
    format: Option<ciborium::Value>,
    version: Option<ciborium::Value>,
}

/// `valid` packed eight pixels to a byte, least significant bit first (empty stays empty).
fn pack_bits(valid: &[bool]) -> Vec<u8> {
    let mut out = vec![0u8; valid.len().div_ceil(8)];
    for (i, &v) in valid.iter().enumerate() {
        if v {
            out[i / 8] |= 1 << (i % 8);
        }
    }
    out
}

fn unpack_bits(bytes: &[u8], n: usize) -> Vec<bool> {
    (0..n).map(|i| bytes[i / 8] & (1 << (i % 8)) != 0).collect()
}

fn describe(v: &ciborium::Value) -> String {
    match v {
        ciborium::Value::Text(s) => format!("{s:?}"),
        ciborium::Value::Integer(i) => i128::from(*i).to_string(),
        ciborium::Value::Float(x) => x.to_string(),
        other => format!("{other:?}").chars().take(60).collect(),
    }
}

/// Checks one camera of a view; `field` names it.
fn check_camera(c: &CameraV1, field: &str) -> Result<(), (String, String)> {
    let bad = |f: &str, m: String| Err((format!("{field}.{f}"), m));
    for (f, side) in [("width", c.width), ("height", c.height)] {
        if side == 0 || side > MAX_IMAGE_SIDE {
            return bad(f, format!("{side} px, expected 1 to {MAX_IMAGE_SIDE}"));
        }
    }
    for (f, v) in [("fx", c.fx), ("fy", c.fy)] {
        if !(v.is_finite() && v > 0.0) {
            return bad(f, format!("{v}, expected a finite focal length > 0 (px)"));
        }
    }
    for (f, v) in [("cx", c.cx), ("cy", c.cy)] {
        if !v.is_finite() {
            return bad(f, format!("{v}, expected a finite principal point (px)"));
        }
    }
    if let Some(v) = c.translation.iter().find(|v| !v.is_finite()) {
        return bad("translation", format!("{v}: every coordinate must be finite"));
    }
    if let Some(v) = c.rotation.iter().find(|v| !v.is_finite()) {
        return bad("rotation", format!("{v}: every component must be finite"));
    }
    let norm = c.rotation.iter().map(|v| v * v).sum::<f64>().sqrt();
    if (norm - 1.0).abs() > UNIT_TOLERANCE {
        return bad(
            "rotation",
            format!("a quaternion of norm {norm}, expected a unit quaternion [x, y, z, w]"),
        );
    }
    Ok(())
}

/// Checks the banks' contents, written or read: at least one bank, each with a distinct,
/// printable camera name, a finite plane height and at least one view, every view's camera valid,
/// its image `3 · width · height` bytes, its mask empty or `⌈width · height / 8⌉` bytes with no
/// bit set past the last pixel, and every view of a bank of the same size.
fn check_banks<'a>(
    banks: impl ExactSizeIterator<Item = (&'a str, f64, Vec<(CameraV1, &'a [u8], &'a [u8])>)>,
) -> Result<(), (String, String)> {
    if banks.len() == 0 {
        return Err((
            "banks".into(),
            "no bank: a calibration has views of at least one camera".into(),
        ));
    }
    let mut names: Vec<&str> = Vec::new();
    for (b, (name, plane_z, views)) in banks.enumerate() {
        let field = format!("banks[{b}]");
        if name.is_empty() || name.len() > MAX_NAME_LEN || name.chars().any(char::is_control) {
            return Err((
                format!("{field}.camera"),
                format!("{name:?}: expected a camera name of 1 to {MAX_NAME_LEN} printable characters"),
            ));
        }
        if names.contains(&name) {
            return Err((
                format!("{field}.camera"),
                format!("camera `{name}` has a second bank (one bank per camera)"),
            ));
        }
        names.push(name);
        if !plane_z.is_finite() {
            return Err((
                format!("{field}.plane_z"),
                format!("{plane_z}: expected a finite height (m)"),
            ));
        }
        if views.is_empty() {
            return Err((
                format!("{field}.views"),
                format!("camera `{name}` has no view of the empty workspace"),
            ));
        }
        let size = (views[0].0.width, views[0].0.height);
        for (v, (camera, image, valid)) in views.iter().enumerate() {
            let field = format!("{field}.views[{v}]");
            check_camera(camera, &format!("{field}.camera"))?;
            if (camera.width, camera.height) != size {
                return Err((
                    format!("{field}.camera"),
                    format!(
                        "a {}×{} view of camera `{name}`, whose first view is {}×{}",
                        camera.width, camera.height, size.0, size.1
                    ),
                ));
            }
            let pixels = camera.width as usize * camera.height as usize;
            if image.len() != 3 * pixels {
                return Err((
                    format!("{field}.image"),
                    format!(
                        "{} bytes, expected 3 × {} × {} = {} (RGB)",
                        image.len(),
                        camera.width,
                        camera.height,
                        3 * pixels
                    ),
                ));
            }
            if !valid.is_empty() {
                if valid.len() != pixels.div_ceil(8) {
                    return Err((
                        format!("{field}.valid"),
                        format!(
                            "{} bytes, expected none or ⌈{} × {} / 8⌉ = {} (one bit per pixel)",
                            valid.len(),
                            camera.width,
                            camera.height,
                            pixels.div_ceil(8)
                        ),
                    ));
                }
                if !pixels.is_multiple_of(8) && valid[valid.len() - 1] >> (pixels % 8) != 0 {
                    return Err((
                        format!("{field}.valid"),
                        "bits set past the last pixel (the last byte's unused high bits must be 0)".into(),
                    ));
                }
            }
        }
    }
    Ok(())
}

impl Calibration {
    /// Writes the calibration as CBOR to `writer` (see [the module](crate::calibration::file)).
    pub fn write_to(&self, writer: impl Write) -> Result<(), CalibrationFileError> {
        self.write_named(writer, NO_PATH)
    }

    fn write_named(&self, writer: impl Write, path: &str) -> Result<(), CalibrationFileError> {
        let packed: Vec<Vec<Vec<u8>>> = self
            .banks
            .iter()
            .map(|(_, b)| b.views().iter().map(|v| pack_bits(&v.valid)).collect())
            .collect();
        let banks: Vec<BankOut<'_>> = self
            .banks
            .iter()
            .zip(&packed)
            .map(|((name, bank), masks)| BankOut {
                camera: name,
                plane_z: bank.plane_z(),
                views: bank
                    .views()
                    .iter()
                    .zip(masks)
                    .map(|(v, m)| ViewOut {
                        camera: CameraV1::of(&v.camera),
                        image: ByteSlice(&v.image.rgb),
                        valid: ByteSlice(m),
                    })
                    .collect(),
            })
            .collect();
        check_banks(banks.iter().map(|b| {
            (
                b.camera,
                b.plane_z,
                b.views.iter().map(|v| (v.camera, v.image.0, v.valid.0)).collect(),
            )
        }))
        .map_err(|(field, message)| CalibrationFileError::Invalid {
            path: path.to_string(),
            field,
            message: format!("{message} (not written)"),
        })?;
        let file = FileOut {
            format: FORMAT,
            version: VERSION,
            writer: format!("pbd {}", env!("CARGO_PKG_VERSION")),
            banks,
        };
        ciborium::into_writer(&file, writer).map_err(|e| CalibrationFileError::Write {
            path: path.to_string(),
            source: match e {
                ciborium::ser::Error::Io(io) => io,
                ciborium::ser::Error::Value(m) => std::io::Error::other(m),
            },
        })
    }

    /// The calibration as the bytes of a calibration file.
    pub fn to_bytes(&self) -> Result<Vec<u8>, CalibrationFileError> {
        let mut out = Vec::new();
        self.write_to(&mut out)?;
        Ok(out)
    }

    /// Reads a calibration from the bytes of a calibration file; errors name the file `source`.
    pub fn from_bytes(bytes: &[u8], source: &str) -> Result<Self, CalibrationFileError> {
        let decode = |e: ciborium::de::Error<std::io::Error>| CalibrationFileError::Decode {
            path: source.to_string(),
            message: match e {
                ciborium::de::Error::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
                    "the file ends early (cut short?)".to_string()
                }
                ciborium::de::Error::Io(io) => io.to_string(),
                ciborium::de::Error::Syntax(at) => format!("malformed CBOR at byte {at}"),
                ciborium::de::Error::Semantic(at, m) => match at {
                    Some(at) => format!("{m} (at byte {at})"),
                    None => m,
                },
                ciborium::de::Error::RecursionLimitExceeded => "nested too deeply".to_string(),
            },
        };
        let header: Header = ciborium::from_reader(bytes).map_err(decode)?;
        match &header.format {
            Some(ciborium::Value::Text(f)) if f == FORMAT => {}
            Some(other) => {
                return Err(CalibrationFileError::Format {
                    path: source.to_string(),
                    found: describe(other),
                });
            }
            None => {
                return Err(CalibrationFileError::Format {
                    path: source.to_string(),
                    found: "missing".into(),
                });
            }
        }
        match &header.version {
            Some(ciborium::Value::Integer(v)) if i128::from(*v) == i128::from(VERSION) => {}
            Some(other) => {
                return Err(CalibrationFileError::Version {
                    path: source.to_string(),
                    found: describe(other),
                });
            }
            None => {
                return Err(CalibrationFileError::Version {
                    path: source.to_string(),
                    found: "missing".into(),
                });
            }
        }
        let mut rest = bytes;
        let file: FileIn = ciborium::from_reader(&mut rest).map_err(decode)?;
        if !rest.is_empty() {
            return Err(CalibrationFileError::Decode {
                path: source.to_string(),
                message: format!("{} trailing byte(s) after the end of the calibration", rest.len()),
            });
        }
        check_banks(file.banks.iter().map(|b| {
            (
                b.camera.as_str(),
                b.plane_z,
                b.views
                    .iter()
                    .map(|v| (v.camera, v.image.0.as_slice(), v.valid.0.as_slice()))
                    .collect(),
            )
        }))
        .map_err(|(field, message)| CalibrationFileError::Invalid {
            path: source.to_string(),
            field,
            message,
        })?;
        let mut banks = Vec::with_capacity(file.banks.len());
        for (b, bank_in) in file.banks.into_iter().enumerate() {
            let mut bank = BackgroundBank::new(bank_in.plane_z);
            for (v, view) in bank_in.views.into_iter().enumerate() {
                let camera = view.camera.camera();
                let pixels = camera.pixel_count();
                let valid = if view.valid.0.is_empty() {
                    Vec::new()
                } else {
                    unpack_bits(&view.valid.0, pixels)
                };
                let image = Image {
                    width: camera.width,
                    height: camera.height,
                    rgb: view.image.0,
                };
                bank.push(BackgroundView { camera, image, valid })
                    .map_err(|e| CalibrationFileError::Invalid {
                        path: source.to_string(),
                        field: format!("banks[{b}].views[{v}]"),
                        message: e.to_string(),
                    })?;
            }
            banks.push((bank_in.camera, bank));
        }
        Ok(Calibration { banks })
    }

    /// Reads a calibration file from `reader` (at most the input limit of
    /// [`bayes::input::max_input_bytes`]); errors name the file `source`.
    pub fn read_from(mut reader: impl Read, source: &str) -> Result<Self, CalibrationFileError> {
        let max = bayes::input::max_input_bytes();
        let mut bytes = Vec::new();
        let read_err = |e| CalibrationFileError::Read {
            path: source.to_string(),
            source: e,
        };
        (&mut reader)
            .take(max.saturating_add(1))
            .read_to_end(&mut bytes)
            .map_err(read_err)?;
        if bytes.len() as u64 > max {
            return Err(read_err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("larger than the input limit of {max} bytes (set PBD_MAX_INPUT_BYTES to change it)"),
            )));
        }
        Self::from_bytes(&bytes, source)
    }

    /// Loads the calibration file at `path`, checking everything in it (see [the module](crate::calibration::file)).
    pub fn load(path: impl AsRef<Path>) -> Result<Self, CalibrationFileError> {
        let path = path.as_ref();
        let name = path.display().to_string();
        let file = bayes::input::open_input(path).map_err(|source| CalibrationFileError::Read {
            path: name.clone(),
            source,
        })?;
        if file.metadata().is_ok_and(|m| m.is_dir()) {
            return Err(CalibrationFileError::Read {
                path: name,
                source: std::io::Error::new(std::io::ErrorKind::InvalidInput, "a directory, not a file"),
            });
        }
        Self::read_from(std::io::BufReader::new(file), &name)
    }

    /// Writes the calibration file `path`: through a temporary file in the same directory and a
    /// rename, so that a reader never sees a half-written file and a failed write leaves any old
    /// file as it was. Returns the file's size (bytes). A calibration that could not be loaded back
    /// (no bank, a view whose sizes disagree, a number that is not finite) is refused before
    /// anything is written.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<u64, CalibrationFileError> {
        let path = path.as_ref();
        let name = path.display().to_string();
        let write_err = |source| CalibrationFileError::Write {
            path: name.clone(),
            source,
        };
        let file_name = path
            .file_name()
            .ok_or_else(|| write_err(std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name")))?;
        if path.is_dir() {
            return Err(write_err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "it is a directory",
            )));
        }
        // Encoded in memory first: an invalid calibration leaves no temporary file behind.
        let mut bytes = Vec::new();
        self.write_named(&mut bytes, &name)?;
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(file_name);
        tmp_name.push(format!(".{}.tmp", std::process::id()));
        let tmp = path.with_file_name(tmp_name);
        let written = (|| -> std::io::Result<()> {
            let mut f = std::fs::File::create(&tmp)?;
            f.write_all(&bytes)?;
            f.sync_all()?;
            drop(f);
            std::fs::rename(&tmp, path)
        })();
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp);
            return Err(write_err(e));
        }
        Ok(bytes.len() as u64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ciborium::Value;

    /// A small calibration: two cameras, odd sizes (masks with a partial last byte), a NaN-free
    /// pose with a rotation, one view with an empty mask.
    fn sample() -> Calibration {
        let camera = |w: u32, h: u32, x: f64| Camera {
            world_from_optical: Iso3::from_parts(
                Translation3::new(x, -0.25, 1.5),
                UnitQuaternion::from_euler_angles(0.3, -1.1, 0.7),
            ),
            width: w,
            height: h,
            fx: 123.456,
            fy: 123.456,
            cx: 0.5 * (w as f64 - 1.0),
            cy: 0.5 * (h as f64 - 1.0),
        };
        let view = |w: u32, h: u32, x: f64, seed: u8, masked: bool| {
            let n = (w * h) as usize;
            BackgroundView {
                camera: camera(w, h, x),
                image: Image {
                    width: w,
                    height: h,
                    rgb: (0..3 * n)
                        .map(|i| (i as u8).wrapping_mul(31).wrapping_add(seed))
                        .collect(),
                },
                valid: if masked {
                    (0..n).map(|i| !(i * 7 + seed as usize).is_multiple_of(5)).collect()
                } else {
                    Vec::new()
                },
            }
        };
        let mut a = BackgroundBank::new(0.75);
        a.push(view(5, 3, 0.1, 1, true)).unwrap();
        a.push(view(5, 3, 0.2, 2, false)).unwrap();
        let mut b = BackgroundBank::new(0.75);
        b.push(view(4, 4, -0.1, 3, true)).unwrap();
        Calibration::from_banks(vec![("head/left".into(), a), ("chassis/right".into(), b)])
    }

    fn value(c: &Calibration) -> Value {
        ciborium::from_reader(c.to_bytes().unwrap().as_slice()).unwrap()
    }

    fn bytes_of(v: &Value) -> Vec<u8> {
        let mut out = Vec::new();
        ciborium::into_writer(v, &mut out).unwrap();
        out
    }

    /// The entry `key` of map `v`.
    fn get<'a>(v: &'a mut Value, key: &str) -> &'a mut Value {
        let Value::Map(m) = v else { panic!("not a map") };
        &mut m.iter_mut().find(|(k, _)| k.as_text() == Some(key)).expect(key).1
    }

    fn at(v: &mut Value, i: usize) -> &mut Value {
        let Value::Array(a) = v else { panic!("not an array") };
        &mut a[i]
    }

    /// The first view's map of the first bank.
    fn view0(v: &mut Value) -> &mut Value {
        at(get(at(get(v, "banks"), 0), "views"), 0)
    }

    fn load_err(bytes: &[u8]) -> CalibrationFileError {
        let r = std::panic::catch_unwind(|| Calibration::from_bytes(bytes, "cal.bin"));
        match r {
            Ok(Err(e)) => {
                assert_eq!(e.path(), "cal.bin");
                e
            }
            Ok(Ok(_)) => panic!("loaded"),
            Err(_) => panic!("panicked"),
        }
    }

    #[test]
    fn a_calibration_round_trips_bit_for_bit_and_compactly() {
        let c = sample();
        let bytes = c.to_bytes().unwrap();
        assert_eq!(Calibration::from_bytes(&bytes, "x").unwrap(), c);
        // Images as byte strings, masks as bits: little beyond the pixels themselves.
        let pixels: usize = 2 * 15 + 16;
        assert!(bytes.len() < 3 * pixels + pixels / 8 + 3 * 400, "{} bytes", bytes.len());
        let mut v = value(&c);
        assert_eq!(get(&mut v, "format").as_text(), Some(FORMAT));
        assert!(matches!(get(view0(&mut v), "image"), Value::Bytes(b) if b.len() == 45));
        assert!(matches!(get(view0(&mut v), "valid"), Value::Bytes(b) if b.len() == 2));
        // Through a file.
        let dir = std::env::temp_dir().join(format!("dexter-cal-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("w.cal");
        assert_eq!(c.save(&path).unwrap(), bytes.len() as u64);
        assert_eq!(Calibration::load(&path).unwrap(), c);
        // Nothing but the file is left in the directory.
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn arrays_of_numbers_are_read_as_byte_strings() {
        let c = sample();
        let mut v = value(&c);
        let img = get(view0(&mut v), "image");
        let Value::Bytes(b) = img.clone() else { panic!() };
        *img = Value::Array(b.into_iter().map(|x| Value::Integer(x.into())).collect());
        assert_eq!(Calibration::from_bytes(&bytes_of(&v), "x").unwrap(), c);
    }

    #[test]
    fn a_truncated_file_is_refused_at_every_cut() {
        let bytes = sample().to_bytes().unwrap();
        for cut in (0..bytes.len()).step_by(7) {
            let e = load_err(&bytes[..cut]);
            assert!(matches!(e, CalibrationFileError::Decode { .. }), "cut {cut}: {e}");
        }
        let e = load_err(&bytes[..bytes.len() - 1]);
        assert!(e.to_string().contains("ends early"), "{e}");
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(load_err(&longer).to_string().contains("1 trailing byte(s)"));
        assert!(matches!(
            load_err(b"not cbor at all"),
            CalibrationFileError::Decode { .. }
        ));
    }

    #[test]
    fn another_format_or_version_is_refused_by_name() {
        let c = sample();
        let mut v = value(&c);
        *get(&mut v, "format") = Value::Text("pbd-model".into());
        let e = load_err(&bytes_of(&v));
        assert!(matches!(e, CalibrationFileError::Format { .. }), "{e}");
        assert!(e.to_string().contains("\"pbd-model\""), "{e}");
        let mut v = value(&c);
        *get(&mut v, "version") = Value::Integer(2.into());
        // A version 2 file may have keys version 1 does not know: refused for its version.
        let Value::Map(m) = &mut v else { panic!() };
        m.push((Value::Text("lens_distortion".into()), Value::Bool(true)));
        let e = load_err(&bytes_of(&v));
        assert!(matches!(e, CalibrationFileError::Version { .. }), "{e}");
        assert!(e.to_string().contains("version 2 is not supported"), "{e}");
        assert_eq!(e.field(), Some("version"));
        let mut v = value(&c);
        let Value::Map(m) = &mut v else { panic!() };
        m.retain(|(k, _)| k.as_text() != Some("version"));
        assert!(load_err(&bytes_of(&v)).to_string().contains("version missing"));
        // Not a map at all.
        assert!(matches!(
            load_err(&bytes_of(&Value::Array(vec![]))),
            CalibrationFileError::Decode { .. }
        ));
        // An unknown key in version 1.
        let mut v = value(&c);
        let Value::Map(m) = &mut v else { panic!() };
        m.push((Value::Text("extra".into()), Value::Bool(true)));
        assert!(load_err(&bytes_of(&v)).to_string().contains("extra"));
    }

    /// Mutates the first view of a valid file and expects an `Invalid` error on `field` mentioning
    /// `needle`.
    fn refused(edit: impl FnOnce(&mut Value), field: &str, needle: &str) {
        let mut v = value(&sample());
        edit(&mut v);
        let e = load_err(&bytes_of(&v));
        assert!(matches!(e, CalibrationFileError::Invalid { .. }), "{field}: {e}");
        assert_eq!(e.field(), Some(field), "{e}");
        assert!(e.to_string().contains(needle), "{e}");
        assert!(e.to_string().starts_with("cal.bin: "), "{e}");
    }

    #[test]
    fn wrong_sizes_and_values_are_refused_naming_the_field() {
        let cam = |v: &mut Value, k: &str, x: Value| *get(get(view0(v), "camera"), k) = x;
        refused(
            |v| *get(view0(v), "image") = Value::Bytes(vec![0; 44]),
            "banks[0].views[0].image",
            "44 bytes, expected 3 × 5 × 3 = 45",
        );
        refused(
            |v| *get(view0(v), "valid") = Value::Bytes(vec![0; 3]),
            "banks[0].views[0].valid",
            "3 bytes",
        );
        refused(
            |v| *get(view0(v), "valid") = Value::Bytes(vec![0xff; 2]),
            "banks[0].views[0].valid",
            "past the last pixel",
        );
        refused(
            |v| cam(v, "width", Value::Integer(6.into())),
            "banks[0].views[0].image",
            "expected 3 × 6 × 3",
        );
        refused(
            |v| cam(v, "width", Value::Integer(0.into())),
            "banks[0].views[0].camera.width",
            "0 px",
        );
        refused(
            |v| cam(v, "fx", Value::Float(f64::NAN)),
            "banks[0].views[0].camera.fx",
            "NaN",
        );
        refused(
            |v| cam(v, "cy", Value::Float(f64::INFINITY)),
            "banks[0].views[0].camera.cy",
            "inf",
        );
        refused(
            |v| *at(get(get(view0(v), "camera"), "translation"), 1) = Value::Float(f64::NAN),
            "banks[0].views[0].camera.translation",
            "finite",
        );
        refused(
            |v| *at(get(get(view0(v), "camera"), "rotation"), 3) = Value::Float(3.0),
            "banks[0].views[0].camera.rotation",
            "unit quaternion",
        );
        refused(
            |v| *get(at(get(v, "banks"), 1), "plane_z") = Value::Float(f64::NAN),
            "banks[1].plane_z",
            "NaN",
        );
        refused(
            |v| *get(at(get(v, "banks"), 1), "views") = Value::Array(vec![]),
            "banks[1].views",
            "no view",
        );
        refused(|v| *get(v, "banks") = Value::Array(vec![]), "banks", "no bank");
        refused(
            |v| *get(at(get(v, "banks"), 1), "camera") = Value::Text("head/left".into()),
            "banks[1].camera",
            "second bank",
        );
        refused(
            |v| *get(at(get(v, "banks"), 1), "camera") = Value::Text(String::new()),
            "banks[1].camera",
            "camera name",
        );
        // A second view of another size in the same bank.
        refused(
            |v| {
                let views = get(at(get(v, "banks"), 0), "views");
                let view = at(views, 1);
                *get(get(view, "camera"), "width") = Value::Integer(3.into());
                *get(get(view, "camera"), "height") = Value::Integer(5.into());
            },
            "banks[0].views[1].camera",
            "whose first view is 5×3",
        );
        // Wrong types are decoding errors naming the key.
        let mut v = value(&sample());
        cam(&mut v, "width", Value::Text("wide".into()));
        let e = load_err(&bytes_of(&v));
        assert!(matches!(e, CalibrationFileError::Decode { .. }), "{e}");
    }

    #[test]
    fn an_invalid_calibration_is_not_written_and_a_file_is_replaced_whole() {
        let dir = std::env::temp_dir().join(format!("dexter-cal-w-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("w.cal");
        let e = Calibration::default().save(&path).unwrap_err();
        assert!(e.to_string().contains("no bank"), "{e}");
        assert!(!path.exists());
        let mut c = sample();
        c.save(&path).unwrap();
        let before = std::fs::read(&path).unwrap();
        c.banks[0].1 = {
            let mut b = BackgroundBank::new(0.75);
            let mut view = c.banks[0].1.views()[0].clone();
            view.camera.fy = f64::NAN;
            b.push(view).unwrap();
            b
        };
        let e = c.save(&path).unwrap_err();
        assert_eq!(e.field(), Some("banks[0].views[0].camera.fy"), "{e}");
        assert_eq!(std::fs::read(&path).unwrap(), before, "the old file was changed");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "a temporary file was left");
        // Into a directory that does not exist; onto a directory.
        assert!(matches!(
            sample().save(dir.join("no/such/dir.cal")),
            Err(CalibrationFileError::Write { .. })
        ));
        assert!(matches!(sample().save(&dir), Err(CalibrationFileError::Write { .. })));
        assert!(matches!(
            Calibration::load(&dir),
            Err(CalibrationFileError::Read { .. })
        ));
        assert!(matches!(
            Calibration::load(dir.join("missing.cal")),
            Err(CalibrationFileError::Read { .. })
        ));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn cameras_of_another_robot_are_refused() {
        use control_basis::hardware::{CameraInfo, Intrinsics};
        let c = sample();
        // fx = 123.456 for a width of 5 px: the field of view that gives it.
        let hfov = |w: u32| 2.0 * (0.5 * w as f64 / 123.456).atan().to_degrees();
        let info = |name: &str, w: u32, h: u32| CameraInfo {
            name: name.into(),
            optical_frame: "x".into(),
            intrinsics: Intrinsics {
                width: w,
                height: h,
                hfov_deg: hfov(w),
            },
            pixel_noise: 0.0,
        };
        let robot = [
            info("head/left", 5, 3),
            info("chassis/right", 4, 4),
            info("head/right", 5, 3),
        ];
        c.check_cameras(&robot).unwrap();
        let e = c.check_cameras(&robot[..1]).unwrap_err().to_string();
        assert!(e.contains("chassis/right") && e.contains("does not have"), "{e}");
        let e = c
            .check_cameras(&[info("head/left", 10, 6), robot[1].clone()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("5×3 px") && e.contains("10×6 px"), "{e}");
        let mut wide = robot[0].clone();
        wide.intrinsics.hfov_deg *= 1.5;
        let e = c.check_cameras(&[wide, robot[1].clone()]).unwrap_err().to_string();
        assert!(e.contains("focal length"), "{e}");
    }
}

//! Object catalogs and scenes (TOML), validated on load.
//!
//! Units: metres, kilograms, radians unless a field name says `_deg`. Colours are HSV with
//! h in degrees [0, 360), s and v in [0, 1]. See the README section "File formats" for the full schema.

use crate::error::SimError;
use control_basis::math::Iso3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Current version of the catalog and scene formats.
pub const FORMAT_VERSION: u32 = 1;

/// A primitive shape in the object's own frame (origin at the shape's centre; cylinder and capsule
/// axes along local z).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum Shape {
    /// A box with full side lengths `size = [x, y, z]`.
    Box {
        /// Full side lengths (m).
        size: [f64; 3],
    },
    /// An upright cylinder.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Full height (m).
        height: f64,
    },
    /// A sphere.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// A capsule: a cylinder of `height` (the straight part) capped by two hemispheres.
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Length of the straight part (m).
        height: f64,
    },
}

/// One colour patch of an object's surface.
///
/// Patches are laid out as bands along the object's local z axis, bottom to top, each band's height
/// proportional to its `fraction` (fractions sum to 1). This makes objects multi-coloured like
/// packaging while keeping the area of each colour known.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColorPatch {
    /// `[h_deg, s, v]`: hue in degrees [0, 360), saturation and value in [0, 1].
    pub hsv: [f64; 3],
    /// Share of the surface (0, 1].
    pub fraction: f64,
}

/// A way of resting an object on the table ("jif" upright, "jif-1" on its side…).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PresentationSpec {
    /// Presentation name, unique in the catalog (e.g. `jif-1`).
    pub name: String,
    /// Roll, pitch, yaw (degrees) of the object frame relative to upright; the object is lowered
    /// until it rests on the table.
    #[serde(default)]
    pub rpy_deg: [f64; 3],
}

/// An object kind in a catalog.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    /// Unique name (e.g. `jif`); also the name of its upright presentation.
    pub name: String,
    /// Geometry.
    pub shape: Shape,
    /// Mass (kg), > 0.
    pub mass: f64,
    /// Coulomb friction coefficient, > 0.
    #[serde(default = "default_friction")]
    pub friction: f64,
    /// Colour patches (at least one; fractions sum to 1).
    pub colors: Vec<ColorPatch>,
    /// Hand label: colour class (`red`, `blue`, …), used only to score experiments.
    #[serde(default)]
    pub color_class: Option<String>,
    /// Hand label: size class (`small`, `medium`, `large`), used only to score experiments.
    #[serde(default)]
    pub size_class: Option<String>,
    /// Extra presentations besides the upright one.
    #[serde(default)]
    pub presentations: Vec<PresentationSpec>,
}

fn default_friction() -> f64 {
    0.9
}

/// A catalog: a list of object kinds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Catalog {
    /// Format version ([`FORMAT_VERSION`]).
    pub version: u32,
    /// The objects.
    pub objects: Vec<ObjectSpec>,
    /// Where it was loaded from (not in the file).
    #[serde(skip)]
    pub path: PathBuf,
}

/// The table: a box whose top surface is at `height`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TableSpec {
    /// Height of the top surface above the floor (m).
    pub height: f64,
    /// Centre of the top surface in x, y (m, world).
    pub center: [f64; 2],
    /// Full extent in x, y (m).
    pub size: [f64; 2],
    /// Colour of the top, HSV.
    #[serde(default = "default_table_hsv")]
    pub hsv: [f64; 3],
    /// Friction coefficient.
    #[serde(default = "default_friction")]
    pub friction: f64,
}

fn default_table_hsv() -> [f64; 3] {
    [30.0, 0.25, 0.55]
}

/// A place objects are put: a bin (a tray with low walls) or a marked region on the table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaceSpec {
    /// Unique name (e.g. `bin-a`).
    pub name: String,
    /// Centre of the floor of the place on the table, x, y (m, world).
    pub center: [f64; 2],
    /// Inner size x, y (m).
    pub size: [f64; 2],
    /// Wall height (m); 0 = a flat marked region.
    #[serde(default)]
    pub wall_height: f64,
    /// Colour, HSV.
    #[serde(default = "default_place_hsv")]
    pub hsv: [f64; 3],
}

fn default_place_hsv() -> [f64; 3] {
    [0.0, 0.0, 0.35]
}

/// One object put on the table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectPlacement {
    /// Presentation name from the catalog (`jif`, `jif-1`).
    pub presentation: String,
    /// Position on the table x, y (m, world).
    pub xy: [f64; 2],
    /// Yaw about world z (degrees).
    #[serde(default)]
    pub yaw_deg: f64,
}

/// A camera model shared by all four cameras.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Image width (px).
    #[serde(default = "default_width")]
    pub width: u32,
    /// Image height (px).
    #[serde(default = "default_height")]
    pub height: u32,
    /// Horizontal field of view (degrees).
    #[serde(default = "default_fov")]
    pub hfov_deg: f64,
    /// Frame rate (Hz).
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// Pixel noise (standard deviation on each RGB channel in [0, 1]), seeded.
    #[serde(default = "default_pixel_noise")]
    pub pixel_noise: f64,
}

fn default_width() -> u32 {
    160
}
fn default_height() -> u32 {
    120
}
fn default_fov() -> f64 {
    60.0
}
fn default_rate() -> f64 {
    10.0
}
fn default_pixel_noise() -> f64 {
    0.01
}

impl Default for CameraSpec {
    fn default() -> Self {
        Self {
            width: default_width(),
            height: default_height(),
            hfov_deg: default_fov(),
            rate_hz: default_rate(),
            pixel_noise: default_pixel_noise(),
        }
    }
}

/// Lighting: one directional light plus ambient.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// Direction the light travels (world), normalised on load.
    #[serde(default = "default_light_dir")]
    pub direction: [f64; 3],
    /// Ambient share in [0, 1].
    #[serde(default = "default_ambient")]
    pub ambient: f64,
}

fn default_light_dir() -> [f64; 3] {
    [0.3, 0.2, -1.0]
}
fn default_ambient() -> f64 {
    0.45
}

impl Default for LightSpec {
    fn default() -> Self {
        Self { direction: default_light_dir(), ambient: default_ambient() }
    }
}

/// A scene: the table, places, objects on the table, camera and lighting, a seed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Format version ([`FORMAT_VERSION`]).
    pub version: u32,
    /// Scene name.
    pub name: String,
    /// Catalog file, relative to the scene file (or `builtin:household`).
    pub catalog: String,
    /// Default seed for noise (the CLI's `--seed` overrides it).
    #[serde(default)]
    pub seed: u64,
    /// The table.
    pub table: TableSpec,
    /// Bins and places.
    #[serde(default)]
    pub places: Vec<PlaceSpec>,
    /// Objects on the table.
    #[serde(default)]
    pub objects: Vec<ObjectPlacement>,
    /// Cameras.
    #[serde(default)]
    pub camera: CameraSpec,
    /// Light.
    #[serde(default)]
    pub light: LightSpec,
}

/// A scene with its catalog resolved and validated: what the simulator builds from.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The scene as written.
    pub spec: SceneSpec,
    /// Its catalog.
    pub catalog: Catalog,
    /// Where the scene came from.
    pub path: PathBuf,
    /// Each placed object, resolved: (object index in the catalog, world pose of the object frame at rest).
    pub resolved: Vec<ResolvedObject>,
}

/// A placed object resolved against the catalog.
#[derive(Debug, Clone)]
pub struct ResolvedObject {
    /// The presentation name (`jif-1`).
    pub presentation: String,
    /// Index into `catalog.objects`.
    pub object: usize,
    /// World pose of the object frame, resting on the table.
    pub pose: Iso3,
}

#[allow(dead_code)]
fn _unused(_: &Path) -> Result<(), SimError> {
    Ok(())
}

//! Object catalogs and scenes (TOML), validated on load.
//!
//! Units: metres, kilograms, radians unless a field name says `_deg`. Colours are HSV with
//! h in degrees [0, 360), s and v in [0, 1]. `assets/README-scenes.md` documents both formats field
//! by field.
//!
//! Every loader returns [`SimError::Parse`] for TOML syntax and type errors (with toml's line, column
//! and key) and [`SimError::Invalid`] for values that parse but make no sense, naming the file and the
//! field as a TOML path (`objects[3].shape.radius`).
//!
//! ```
//! use dexter_sim::scene::Scene;
//! let scene = Scene::builtin("sorting").unwrap();
//! let jif = scene.object_index("jif").unwrap();
//! let pose = scene.resolved[jif].pose;
//! assert!(pose.translation.z > scene.spec.table.height);
//! assert!(scene.place("bin-left").is_ok());
//! ```

use crate::error::SimError;
use crate::geometry::support_half_extent;
use control_basis::math::{Iso3, Rot3, Vec3};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Current version of the catalog and scene formats.
pub const FORMAT_VERSION: u32 = 1;

/// Gap between an object's lowest point and the table top in its computed resting pose (m).
pub const REST_CLEARANCE: f64 = 0.001;

/// The `catalog` value of a scene that names the built-in household catalog.
pub const BUILTIN_HOUSEHOLD: &str = "builtin:household";

/// The size classes a catalog may use in `size_class`.
pub const SIZE_CLASSES: [&str; 3] = ["small", "medium", "large"];

/// Largest accepted camera image side (px).
pub const MAX_IMAGE_SIDE: u32 = 4096;

/// Tolerance on the sum of an object's colour fractions.
pub const FRACTION_TOLERANCE: f64 = 1e-6;

const HOUSEHOLD_TOML: &str = include_str!("../../../assets/objects/household.toml");

/// The catalog path the shipped scenes use; built-in scenes resolve it to the built-in catalog.
const SHIPPED_CATALOG: &str = "../objects/household.toml";

const BUILTIN_SCENE_NAMES: [&str; 4] = ["sorting", "pick-place", "sorting-new", "sorting-demo"];

fn builtin_scene_text(name: &str) -> Option<&'static str> {
    match name {
        "sorting" => Some(include_str!("../../../assets/scenes/sorting.toml")),
        "pick-place" => Some(include_str!("../../../assets/scenes/pick-place.toml")),
        "sorting-new" => Some(include_str!("../../../assets/scenes/sorting-new.toml")),
        "sorting-demo" => Some(include_str!("../../../assets/scenes/sorting-demo.toml")),
        _ => None,
    }
}

pub use crate::geometry::Shape;

/// One colour patch of an object's surface.
///
/// Patches are laid out as bands along the object's local z axis, bottom to top, each band's height
/// proportional to its `fraction` (fractions sum to 1). This makes objects multi-coloured like
/// packaging while keeping the area of each colour known.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColorPatch {
    /// `[h_deg, s, v]`: hue in degrees [0, 360), saturation and value in [0, 1].
    #[serde(deserialize_with = "exact_array")]
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
    /// Roll, pitch, yaw (degrees) of the object frame relative to upright, applied as
    /// `Rz(yaw)·Ry(pitch)·Rx(roll)`; the object is lowered until it rests on the table.
    #[serde(default)]
    #[serde(deserialize_with = "exact_array")]
    pub rpy_deg: [f64; 3],
}

/// An object kind in a catalog.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    /// Unique name (e.g. `jif`); also the name of its default presentation.
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
    /// Hand label: size class (one of [`SIZE_CLASSES`]), used only to score experiments.
    #[serde(default)]
    pub size_class: Option<String>,
    /// Roll, pitch, yaw (degrees) of the default presentation (the one named like the object);
    /// `[0, 0, 0]` (the default) is upright. Capsules, which cannot stand on an end, lie down here.
    #[serde(default)]
    #[serde(deserialize_with = "exact_array")]
    pub rpy_deg: [f64; 3],
    /// Extra presentations besides the default one.
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
    #[serde(deserialize_with = "exact_array")]
    pub center: [f64; 2],
    /// Full extent in x, y (m).
    #[serde(deserialize_with = "exact_array")]
    pub size: [f64; 2],
    /// Colour of the top, HSV.
    #[serde(default = "default_table_hsv")]
    #[serde(deserialize_with = "exact_array")]
    pub hsv: [f64; 3],
    /// Friction coefficient.
    #[serde(default = "default_friction")]
    pub friction: f64,
}

impl TableSpec {
    /// The table top as `[x_min, x_max, y_min, y_max]` (m, world).
    pub fn bounds(&self) -> [f64; 4] {
        let [cx, cy] = self.center;
        let [sx, sy] = self.size;
        [cx - sx / 2.0, cx + sx / 2.0, cy - sy / 2.0, cy + sy / 2.0]
    }
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
    #[serde(deserialize_with = "exact_array")]
    pub center: [f64; 2],
    /// Inner size x, y (m).
    #[serde(deserialize_with = "exact_array")]
    pub size: [f64; 2],
    /// Wall height (m); 0 = a flat marked region.
    #[serde(default)]
    pub wall_height: f64,
    /// Wall thickness (m), built outside the inner size; ignored when `wall_height` is 0.
    #[serde(default = "default_wall_thickness")]
    pub wall_thickness: f64,
    /// Colour, HSV.
    #[serde(default = "default_place_hsv")]
    #[serde(deserialize_with = "exact_array")]
    pub hsv: [f64; 3],
}

impl PlaceSpec {
    /// Outer size x, y (m): the inner size plus the walls.
    pub fn outer_size(&self) -> [f64; 2] {
        let t = if self.wall_height > 0.0 {
            2.0 * self.wall_thickness
        } else {
            0.0
        };
        [self.size[0] + t, self.size[1] + t]
    }

    /// Whether the world point `xy` lies inside the inner area of the place.
    pub fn contains(&self, xy: [f64; 2]) -> bool {
        (xy[0] - self.center[0]).abs() <= self.size[0] / 2.0 && (xy[1] - self.center[1]).abs() <= self.size[1] / 2.0
    }
}

fn default_place_hsv() -> [f64; 3] {
    [0.0, 0.0, 0.35]
}

fn default_wall_thickness() -> f64 {
    0.01
}

/// One object put on the table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectPlacement {
    /// Presentation name from the catalog (`jif`, `jif-1`).
    pub presentation: String,
    /// Position on the table x, y (m, world).
    #[serde(deserialize_with = "exact_array")]
    pub xy: [f64; 2],
    /// Yaw about world z (degrees).
    #[serde(default)]
    pub yaw_deg: f64,
    /// Height of the object frame (m, world). Absent (the usual case): resting on the table, see
    /// [`Catalog::rest_pose`]. Given: the object starts there (it must not be in the table) and falls.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z: Option<f64>,
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
    #[serde(deserialize_with = "exact_array")]
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
        Self {
            direction: default_light_dir(),
            ambient: default_ambient(),
        }
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
    /// The scene as written (light direction normalised).
    pub spec: SceneSpec,
    /// Its catalog.
    pub catalog: Catalog,
    /// Where the scene came from (`builtin:<name>` for the shipped scenes).
    pub path: PathBuf,
    /// Each placed object, resolved, in the order of `spec.objects`.
    pub resolved: Vec<ResolvedObject>,
}

/// A placed object resolved against the catalog.
#[derive(Debug, Clone)]
pub struct ResolvedObject {
    /// The presentation name (`jif-1`).
    pub presentation: String,
    /// A name unique in the scene: the presentation name, or `jif-1#2` for the second of several
    /// placements of the same presentation (numbered from 1 in file order).
    pub label: String,
    /// Index into `catalog.objects`.
    pub object: usize,
    /// World pose of the object frame, resting on the table (or at the given `z`).
    pub pose: Iso3,
}

// ---------------------------------------------------------------------------------------------
// Catalog
// ---------------------------------------------------------------------------------------------

impl Catalog {
    /// Parses and validates a catalog; `path` is only used in error messages and kept in `self.path`.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Catalog, SimError> {
        let mut catalog: Catalog = parse_toml(text, path).map_err(|e| {
            // A scene given where a catalog belongs: say so, rather than "unknown field `catalog`".
            let scene_keys = toml::from_str::<toml::Table>(text)
                .is_ok_and(|t| ["table", "places", "catalog"].iter().any(|k| t.contains_key(*k)));
            if scene_keys {
                SimError::Parse {
                    path: path.to_path_buf(),
                    message: "this is a scene file (it has `table`, `places` or `catalog`), not an object catalog; a \
                              scene names its catalog with `catalog = …`"
                        .into(),
                }
            } else {
                e
            }
        })?;
        catalog.path = path.to_path_buf();
        catalog.validate()?;
        Ok(catalog)
    }

    /// Reads, parses and validates a catalog file.
    pub fn load(path: impl AsRef<Path>) -> Result<Catalog, SimError> {
        let path = path.as_ref();
        let text = read_file(path)?;
        Catalog::from_toml_str(&text, path)
    }

    /// The shipped household catalog (`assets/objects/household.toml`, compiled in); its path is
    /// `builtin:household`.
    pub fn builtin_household() -> Result<Catalog, SimError> {
        Catalog::from_toml_str(HOUSEHOLD_TOML, Path::new(BUILTIN_HOUSEHOLD))
    }

    /// The object called `name`.
    pub fn object(&self, name: &str) -> Result<&ObjectSpec, SimError> {
        self.objects
            .iter()
            .find(|o| o.name == name)
            .ok_or_else(|| SimError::Unknown {
                kind: "object",
                name: name.to_string(),
                candidates: by_similarity(name, self.objects.iter().map(|o| o.name.as_str())),
            })
    }

    /// The presentation called `name`: the index of its object in `self.objects` and the object's
    /// orientation on the table before the placement's yaw. The default presentation is named like
    /// the object; extra ones come from `presentations`.
    pub fn presentation(&self, name: &str) -> Result<(usize, Rot3), SimError> {
        for (i, object) in self.objects.iter().enumerate() {
            if object.name == name {
                return Ok((i, rot_from_rpy_deg(object.rpy_deg)));
            }
            if let Some(p) = object.presentations.iter().find(|p| p.name == name) {
                return Ok((i, rot_from_rpy_deg(p.rpy_deg)));
            }
        }
        Err(SimError::Unknown {
            kind: "presentation",
            name: name.to_string(),
            candidates: by_similarity(name, self.presentation_names()),
        })
    }

    /// Every presentation name, in catalog order (each object's default presentation first).
    pub fn presentation_names(&self) -> Vec<&str> {
        self.objects
            .iter()
            .flat_map(|o| std::iter::once(o.name.as_str()).chain(o.presentations.iter().map(|p| p.name.as_str())))
            .collect()
    }

    /// World pose of presentation `presentation` resting on a table whose top is at `table_height`,
    /// at `xy` with yaw `yaw_deg` about world z: orientation `Rz(yaw)·R_presentation`, origin
    /// raised so that the lowest point is [`REST_CLEARANCE`] above the table.
    pub fn rest_pose(
        &self,
        presentation: &str,
        xy: [f64; 2],
        yaw_deg: f64,
        table_height: f64,
    ) -> Result<Iso3, SimError> {
        let (index, r) = self.presentation(presentation)?;
        let shape = &self.objects[index].shape;
        let orientation = Rot3::from_axis_angle(&Vec3::z_axis(), yaw_deg.to_radians()) * r;
        let z = table_height + lowest_point_depth(shape, &orientation) + REST_CLEARANCE;
        Ok(Iso3::from_parts(
            nalgebra::Translation3::new(xy[0], xy[1], z),
            orientation,
        ))
    }

    fn validate(&self) -> Result<(), SimError> {
        let c = Check { path: &self.path };
        c.version(self.version)?;
        if self.objects.is_empty() {
            return Err(c.invalid("objects", "a catalog needs at least one object"));
        }
        c.count("objects", self.objects.len(), MAX_CATALOG_OBJECTS, "a catalog")?;
        // Presentation names so far, with the field that defined each.
        let mut names: Vec<(&str, String)> = Vec::new();
        for (i, object) in self.objects.iter().enumerate() {
            let f = format!("objects[{i}]");
            let named = |e| in_context(e, &object.name);
            c.name(&format!("{f}.name"), &object.name)?;
            claim_name(&c, &mut names, &object.name, format!("{f}.name"))?;
            validate_object(&c, &f, object).map_err(named)?;
            for (j, p) in object.presentations.iter().enumerate() {
                let pf = format!("{f}.presentations[{j}]");
                c.name(&format!("{pf}.name"), &p.name).map_err(named)?;
                claim_name(&c, &mut names, &p.name, format!("{pf}.name"))?;
                c.finite_all(&format!("{pf}.rpy_deg"), &p.rpy_deg).map_err(named)?;
            }
        }
        Ok(())
    }
}

/// Records `name` as defined at `field`, or fails naming both places if it is already taken.
fn claim_name<'a>(
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

fn validate_object(c: &Check<'_>, f: &str, object: &ObjectSpec) -> Result<(), SimError> {
    match object.shape {
        Shape::Box { size } => {
            for (k, s) in size.iter().enumerate() {
                c.length(&format!("{f}.shape.size[{k}]"), *s)?;
            }
        }
        Shape::Cylinder { radius, height } | Shape::Capsule { radius, height } => {
            c.length(&format!("{f}.shape.radius"), radius)?;
            c.length(&format!("{f}.shape.height"), height)?;
        }
        Shape::Sphere { radius } => c.length(&format!("{f}.shape.radius"), radius)?,
    }
    c.positive(&format!("{f}.mass"), object.mass)?;
    c.positive(&format!("{f}.friction"), object.friction)?;
    if object.colors.is_empty() {
        return Err(c.invalid(format!("{f}.colors"), "at least one colour patch is required"));
    }
    let mut sum = 0.0;
    for (j, patch) in object.colors.iter().enumerate() {
        let pf = format!("{f}.colors[{j}]");
        c.hsv(&format!("{pf}.hsv"), &patch.hsv)?;
        let fraction = patch.fraction;
        c.finite(&format!("{pf}.fraction"), fraction)?;
        if !(fraction > 0.0 && fraction <= 1.0) {
            return Err(c.invalid(format!("{pf}.fraction"), format!("must be in (0, 1] (got {fraction})")));
        }
        sum += fraction;
    }
    if (sum - 1.0).abs() > FRACTION_TOLERANCE {
        return Err(c.invalid(
            format!("{f}.colors"),
            format!(
                "fractions must sum to 1 (± {FRACTION_TOLERANCE:e}), got {}",
                (sum * 1e9).round() / 1e9
            ),
        ));
    }
    if let Some(class) = &object.color_class {
        c.name(&format!("{f}.color_class"), class)?;
    }
    if let Some(class) = &object.size_class
        && !SIZE_CLASSES.contains(&class.as_str())
    {
        return Err(c.invalid(
            format!("{f}.size_class"),
            format!("must be one of {} (got `{class}`)", SIZE_CLASSES.join(", ")),
        ));
    }
    c.finite_all(&format!("{f}.rpy_deg"), &object.rpy_deg)
}

// ---------------------------------------------------------------------------------------------
// Scene
// ---------------------------------------------------------------------------------------------

impl Scene {
    /// Reads, parses and validates a scene file and its catalog (resolved relative to the scene file).
    pub fn load(path: impl AsRef<Path>) -> Result<Scene, SimError> {
        let path = path.as_ref();
        let text = read_file(path)?;
        Scene::from_toml_str(&text, path)
    }

    /// Parses and validates a scene; `path` names it in errors and is the base for a relative
    /// `catalog` path.
    pub fn from_toml_str(text: &str, path: impl AsRef<Path>) -> Result<Scene, SimError> {
        Scene::from_text(text, path.as_ref(), false)
    }

    /// A shipped scene by name (one of [`Scene::builtin_names`]), compiled in; it uses the built-in
    /// catalog and its path is `builtin:<name>`.
    pub fn builtin(name: &str) -> Result<Scene, SimError> {
        let text = builtin_scene_text(name).ok_or_else(|| SimError::Unknown {
            kind: "built-in scene",
            name: name.to_string(),
            candidates: by_similarity(name, BUILTIN_SCENE_NAMES),
        })?;
        Scene::from_text(text, Path::new(&format!("builtin:{name}")), true)
    }

    /// Names of the shipped scenes.
    pub fn builtin_names() -> &'static [&'static str] {
        &BUILTIN_SCENE_NAMES
    }

    /// A scene file if `name_or_path` is an existing file or looks like a path (has a `/` or ends in
    /// `.toml`), otherwise the built-in scene of that name: what a `--scene` option takes.
    pub fn open(name_or_path: &str) -> Result<Scene, SimError> {
        let path = Path::new(name_or_path);
        let looks_like_path = name_or_path.contains(['/', '\\']) || name_or_path.ends_with(".toml");
        if path.is_file() || looks_like_path {
            Scene::load(path)
        } else {
            Scene::builtin(name_or_path)
        }
    }

    /// Validates a scene built in code against `catalog` (validated too) and resolves its objects.
    /// `path` names the scene in errors.
    pub fn new(mut spec: SceneSpec, catalog: Catalog, path: impl Into<PathBuf>) -> Result<Scene, SimError> {
        let path = path.into();
        catalog.validate()?;
        let c = Check { path: &path };
        validate_setup(&c, &mut spec)?;
        let resolved = resolve_objects(&c, &spec, &catalog)?;
        Ok(Scene {
            spec,
            catalog,
            path,
            resolved,
        })
    }

    /// The same scene with other objects on the table (validated): e.g. one presentation at a time
    /// on the `pick-place` scene.
    pub fn with_objects(&self, objects: Vec<ObjectPlacement>) -> Result<Scene, SimError> {
        let mut spec = self.spec.clone();
        spec.objects = objects;
        Scene::new(spec, self.catalog.clone(), self.path.clone())
    }

    /// The place (bin or region) called `name`.
    pub fn place(&self, name: &str) -> Result<&PlaceSpec, SimError> {
        self.spec
            .places
            .iter()
            .find(|p| p.name == name)
            .ok_or_else(|| SimError::Unknown {
                kind: "place",
                name: name.to_string(),
                candidates: by_similarity(name, self.spec.places.iter().map(|p| p.name.as_str())),
            })
    }

    /// Index (into `resolved` and `spec.objects`) of a placed object, by its label (`jif`, `jif#2`;
    /// see [`ResolvedObject::label`]) or its presentation name (the first such placement).
    pub fn object_index(&self, name: &str) -> Result<usize, SimError> {
        if let Some(i) = self.resolved.iter().position(|r| r.label == name) {
            return Ok(i);
        }
        if let Some(i) = self.resolved.iter().position(|r| r.presentation == name) {
            return Ok(i);
        }
        if let Some((base, k)) = name.rsplit_once('#')
            && let Ok(k) = k.parse::<usize>()
            && let Some(nth) = k.checked_sub(1)
            && let Some(i) = (self.resolved.iter().enumerate())
                .filter(|(_, r)| r.presentation == base)
                .nth(nth)
                .map(|(i, _)| i)
        {
            return Ok(i);
        }
        Err(SimError::Unknown {
            kind: "placed object",
            name: name.to_string(),
            candidates: by_similarity(name, self.resolved.iter().map(|r| r.label.as_str())),
        })
    }

    /// Horizontal gap (m) between the footprints (projections on the table plane) of placed objects
    /// `a` and `b`: their distance, or minus the penetration depth when they overlap. `None` for an
    /// index out of range.
    pub fn object_gap(&self, a: usize, b: usize) -> Option<f64> {
        Some(footprint_gap(&self.object_footprint(a)?, &self.object_footprint(b)?))
    }

    /// Horizontal gap (m) between the footprint of placed object `object` and the outer footprint
    /// (walls included) of place `place`, as in [`Scene::object_gap`].
    pub fn place_gap(&self, object: usize, place: usize) -> Option<f64> {
        let p = self.spec.places.get(place)?;
        Some(footprint_gap(&self.object_footprint(object)?, &place_footprint(p)))
    }

    fn object_footprint(&self, index: usize) -> Option<Footprint> {
        let r = self.resolved.get(index)?;
        let shape = self.catalog.objects.get(r.object)?.shape.clone();
        Some(Footprint {
            shape,
            orientation: r.pose.rotation,
            center: [r.pose.translation.x, r.pose.translation.y],
        })
    }

    fn from_text(text: &str, path: &Path, builtin: bool) -> Result<Scene, SimError> {
        let spec: SceneSpec = parse_toml(text, path)?;
        let c = Check { path };
        c.version(spec.version)?;
        c.count("objects", spec.objects.len(), MAX_SCENE_OBJECTS, "a scene")?;
        let catalog = if spec.catalog == BUILTIN_HOUSEHOLD || (builtin && spec.catalog == SHIPPED_CATALOG) {
            Catalog::builtin_household()?
        } else if builtin {
            return Err(c.invalid(
                "catalog",
                format!("a built-in scene can only use `{BUILTIN_HOUSEHOLD}`"),
            ));
        } else if spec.catalog.trim().is_empty() {
            return Err(c.invalid(
                "catalog",
                format!("must be a catalog file path or `{BUILTIN_HOUSEHOLD}`"),
            ));
        } else if let Some(name) = spec.catalog.strip_prefix("builtin:") {
            return Err(c.invalid(
                "catalog",
                format!("no built-in catalog `{name}` (the built-in catalog is `{BUILTIN_HOUSEHOLD}`)"),
            ));
        } else {
            let catalog_path = path.parent().unwrap_or(Path::new("")).join(&spec.catalog);
            Catalog::load(&catalog_path).map_err(|e| match e {
                SimError::Io { path, source } => {
                    c.invalid("catalog", format!("cannot read catalog {}: {source}", path.display()))
                }
                other => other,
            })?
        };
        Scene::new(spec, catalog, path)
    }
}

/// Largest length or coordinate a scene may hold (m): a room, not a planet.
pub const MAX_LENGTH: f64 = 100.0;

/// Most objects a scene may place. A tabletop within Dexter's reach holds a few dozen at most (the
/// shipped scenes 1 to 7), while cost grows with the count: with 64, `pbd sim pick-place` takes
/// about 1 s and `pbd execute` about 10 s; 1,000 took 11 s for one pick and 10,000 ran past 30 s.
/// Checked on load, before the catalog is read ([`Scene::load`], [`Scene::new`]).
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
fn scene_range(field: &str) -> (f64, f64, &'static str) {
    SCENE_RANGES
        .iter()
        .find(|r| r.0 == field)
        .map(|r| (r.1, r.2, r.3))
        .unwrap_or((f64::NEG_INFINITY, f64::INFINITY, ""))
}

/// Validates everything in a scene but the objects; normalises the light direction.
fn validate_setup(c: &Check<'_>, spec: &mut SceneSpec) -> Result<(), SimError> {
    c.version(spec.version)?;
    c.count("objects", spec.objects.len(), MAX_SCENE_OBJECTS, "a scene")?;
    if spec.name.trim().is_empty() {
        return Err(c.invalid("name", "must not be empty"));
    }
    if spec.name.chars().any(char::is_control) {
        return Err(c.invalid("name", "must not hold control characters (NUL, ESC, line breaks …)"));
    }
    let table = &spec.table;
    c.within("table.height", "table.height", table.height)?;
    c.coordinates("table.center", &table.center)?;
    for (k, s) in table.size.iter().enumerate() {
        c.length(&format!("table.size[{k}]"), *s)?;
    }
    c.hsv("table.hsv", &table.hsv)?;
    c.positive("table.friction", table.friction)?;
    let bounds = table.bounds();

    let mut names: Vec<(&str, String)> = Vec::new();
    for (i, place) in spec.places.iter().enumerate() {
        let f = format!("places[{i}]");
        c.name(&format!("{f}.name"), &place.name)?;
        claim_name(c, &mut names, &place.name, format!("{f}.name"))?;
        let named = |e| in_context(e, &place.name);
        c.coordinates(&format!("{f}.center"), &place.center).map_err(named)?;
        for (k, s) in place.size.iter().enumerate() {
            c.length(&format!("{f}.size[{k}]"), *s).map_err(named)?;
        }
        c.within(&format!("{f}.wall_height"), "places[].wall_height", place.wall_height)
            .map_err(named)?;
        c.within(
            &format!("{f}.wall_thickness"),
            "places[].wall_thickness",
            place.wall_thickness,
        )
        .map_err(named)?;
        c.hsv(&format!("{f}.hsv"), &place.hsv).map_err(named)?;
        let rect = place_rect(place);
        if !rect_within(&rect, &bounds) {
            return Err(c.invalid(
                format!("{f}.center"),
                format!(
                    "place `{}` {} extends past the table {}",
                    place.name,
                    show_rect(&rect),
                    show_rect(&bounds)
                ),
            ));
        }
        if let Some((j, other)) = spec.places[..i]
            .iter()
            .enumerate()
            .find(|(_, other)| rects_overlap(&rect, &place_rect(other)))
        {
            return Err(c.invalid(
                format!("{f}.center"),
                format!("place `{}` overlaps place `{}` (places[{j}])", place.name, other.name),
            ));
        }
    }

    let camera = &spec.camera;
    for (field, side) in [("camera.width", camera.width), ("camera.height", camera.height)] {
        if side == 0 || side > MAX_IMAGE_SIDE {
            return Err(c.invalid(field, format!("must be in 1..={MAX_IMAGE_SIDE} px (got {side})")));
        }
    }
    c.finite("camera.hfov_deg", camera.hfov_deg)?;
    if !(camera.hfov_deg > 1.0 && camera.hfov_deg < 170.0) {
        return Err(c.invalid(
            "camera.hfov_deg",
            format!("must be in (1, 170) degrees (got {})", camera.hfov_deg),
        ));
    }
    c.within("camera.rate_hz", "camera.rate_hz", camera.rate_hz)?;
    c.unit_interval("camera.pixel_noise", camera.pixel_noise)?;

    let light = &mut spec.light;
    c.finite_all("light.direction", &light.direction)?;
    let d = Vec3::from(light.direction);
    let norm = d.norm();
    if norm < 1e-9 {
        return Err(c.invalid("light.direction", "must not be the zero vector"));
    }
    light.direction = (d / norm).into();
    c.unit_interval("light.ambient", light.ambient)?;
    Ok(())
}

/// Resolves each placement against the catalog and checks it: on the table, not in it, clear of
/// places and of the other objects.
fn resolve_objects(c: &Check<'_>, spec: &SceneSpec, catalog: &Catalog) -> Result<Vec<ResolvedObject>, SimError> {
    let table = &spec.table;
    let bounds = table.bounds();
    let places: Vec<Footprint> = spec.places.iter().map(place_footprint).collect();
    let mut resolved: Vec<ResolvedObject> = Vec::with_capacity(spec.objects.len());
    // Footprint and vertical extent of each object resolved so far.
    let mut placed: Vec<(Footprint, [f64; 2])> = Vec::with_capacity(spec.objects.len());
    for (i, o) in spec.objects.iter().enumerate() {
        let f = format!("objects[{i}]");
        let (index, upright) = catalog.presentation(&o.presentation).map_err(|e| match e {
            SimError::Unknown { name, candidates, .. } => c.invalid(
                format!("{f}.presentation"),
                format!(
                    "unknown presentation `{name}` in catalog {}; closest: {}",
                    catalog.path.display(),
                    candidates
                        .iter()
                        .take(6)
                        .map(|s| format!("`{s}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ),
            other => other,
        })?;
        let named = |e| in_context(e, &o.presentation);
        c.finite_all(&format!("{f}.xy"), &o.xy).map_err(named)?;
        c.within(&format!("{f}.yaw_deg"), "objects[].yaw_deg", o.yaw_deg)
            .map_err(named)?;
        let shape = &catalog.objects[index].shape;
        let orientation = Rot3::from_axis_angle(&Vec3::z_axis(), o.yaw_deg.to_radians()) * upright;
        let depth = lowest_point_depth(shape, &orientation);
        let z = match o.z {
            None => table.height + depth + REST_CLEARANCE,
            Some(z) => {
                c.finite(&format!("{f}.z"), z).map_err(named)?;
                if z > table.height + scene_range("objects[].z above the table").1 {
                    c.within(&format!("{f}.z"), "objects[].z above the table", z - table.height)
                        .map_err(named)?;
                }
                if z < table.height {
                    return Err(named(c.invalid(
                        format!("{f}.z"),
                        format!("is under the table: z = {z} is below the table top at {}", table.height),
                    )));
                }
                let lowest = z - depth;
                if lowest < table.height - 1e-9 {
                    return Err(named(c.invalid(
                        format!("{f}.z"),
                        format!(
                            "puts the object {:.1} mm into the table (its lowest point would be at z = {lowest:.4}, \
                             the table top is at {}; resting it needs z ≥ {:.4})",
                            (table.height - lowest) * 1e3,
                            table.height,
                            table.height + depth
                        ),
                    )));
                }
                z
            }
        };
        let footprint = Footprint {
            shape: shape.clone(),
            orientation,
            center: o.xy,
        };
        let rect = footprint.rect();
        if !rect_within(&rect, &bounds) {
            return Err(named(c.invalid(
                format!("{f}.xy"),
                format!(
                    "the object {} extends past the table {}",
                    show_rect(&rect),
                    show_rect(&bounds)
                ),
            )));
        }
        for (k, place) in places.iter().enumerate() {
            let gap = footprint_gap(&footprint, place);
            if gap < -OVERLAP_TOLERANCE {
                let name = &spec.places[k].name;
                return Err(named(c.invalid(
                    format!("{f}.xy"),
                    format!(
                        "the object overlaps place `{name}` (places[{k}]) by {:.1} cm",
                        -gap * 100.0
                    ),
                )));
            }
        }
        let vertical = [z - depth, z + depth];
        for (j, (other, other_vertical)) in placed.iter().enumerate() {
            let stacked = vertical[0] >= other_vertical[1] || other_vertical[0] >= vertical[1];
            let gap = footprint_gap(&footprint, other);
            if !stacked && gap < -OVERLAP_TOLERANCE {
                return Err(c.invalid(
                    format!("{f}.xy"),
                    format!(
                        "`{}` (objects[{i}]) overlaps `{}` (objects[{j}]) by {:.1} cm",
                        o.presentation,
                        spec.objects[j].presentation,
                        -gap * 100.0
                    ),
                ));
            }
        }
        placed.push((footprint, vertical));
        resolved.push(ResolvedObject {
            presentation: o.presentation.clone(),
            label: o.presentation.clone(),
            object: index,
            pose: Iso3::from_parts(nalgebra::Translation3::new(o.xy[0], o.xy[1], z), orientation),
        });
    }
    // Number the labels of presentations placed more than once.
    for i in 0..resolved.len() {
        let same = |r: &ResolvedObject| r.presentation == resolved[i].presentation;
        if resolved.iter().filter(|r| same(r)).count() > 1 {
            let k = resolved[..i].iter().filter(|r| same(r)).count() + 1;
            resolved[i].label = format!("{}#{k}", resolved[i].presentation);
        }
    }
    Ok(resolved)
}

// ---------------------------------------------------------------------------------------------
// Geometry of resting and footprints
// ---------------------------------------------------------------------------------------------

/// Overlaps shallower than this (m) are not reported (rounding in the footprint computation).
const OVERLAP_TOLERANCE: f64 = 1e-6;

/// Rotation `Rz(yaw)·Ry(pitch)·Rx(roll)` from `[roll, pitch, yaw]` in degrees.
pub fn rot_from_rpy_deg(rpy_deg: [f64; 3]) -> Rot3 {
    Rot3::from_euler_angles(
        rpy_deg[0].to_radians(),
        rpy_deg[1].to_radians(),
        rpy_deg[2].to_radians(),
    )
}

/// How far below the object frame's origin the lowest point of `shape` lies when the object has
/// `orientation` (object → world): its support distance along world −z.
pub fn lowest_point_depth(shape: &Shape, orientation: &Rot3) -> f64 {
    support_half_extent(shape, &(orientation.inverse() * -Vec3::z()))
}

/// Whether `shape` resting on a horizontal plane with `orientation` is in stable or neutral
/// equilibrium: no small tilt (2°, any horizontal axis) lowers its centre, taken as the centre of
/// mass. A box on a face or an upright cylinder is stable, a lying cylinder neutral (it rolls), a
/// capsule on an end or a box on an edge unstable.
pub fn rests_stably(shape: &Shape, orientation: &Rot3) -> bool {
    let height = lowest_point_depth(shape, orientation);
    let tilt = 2f64.to_radians();
    (0..24).all(|k| {
        let a = f64::from(k) * std::f64::consts::TAU / 24.0;
        let axis = nalgebra::Unit::new_normalize(Vec3::new(a.cos(), a.sin(), 0.0));
        let tilted = Rot3::from_axis_angle(&axis, tilt) * orientation;
        lowest_point_depth(shape, &tilted) >= height - 1e-9
    })
}

/// A convex, centrally symmetric shape seen from above.
#[derive(Debug, Clone)]
struct Footprint {
    shape: Shape,
    orientation: Rot3,
    center: [f64; 2],
}

impl Footprint {
    /// Support distance of the projection along the horizontal unit direction `d`.
    fn half_width(&self, d: [f64; 2]) -> f64 {
        support_half_extent(&self.shape, &(self.orientation.inverse() * Vec3::new(d[0], d[1], 0.0)))
    }

    /// Axis-aligned bounds `[x_min, x_max, y_min, y_max]`.
    fn rect(&self) -> [f64; 4] {
        let hx = self.half_width([1.0, 0.0]);
        let hy = self.half_width([0.0, 1.0]);
        [
            self.center[0] - hx,
            self.center[0] + hx,
            self.center[1] - hy,
            self.center[1] + hy,
        ]
    }

    /// Horizontal directions that separate polygonal projections exactly: the projected local axes
    /// and their normals.
    fn axes(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        [Vec3::x(), Vec3::y(), Vec3::z()].into_iter().flat_map(move |e| {
            let w = self.orientation * e;
            let n = w.x.hypot(w.y);
            let pair = if n > 1e-9 {
                Some([[w.x / n, w.y / n], [-w.y / n, w.x / n]])
            } else {
                None
            };
            pair.into_iter().flatten()
        })
    }
}

fn place_footprint(place: &PlaceSpec) -> Footprint {
    let [sx, sy] = place.outer_size();
    Footprint {
        shape: Shape::Box {
            size: [sx, sy, place.wall_height.max(0.0)],
        },
        orientation: Rot3::identity(),
        center: place.center,
    }
}

/// Distance between the projections of `a` and `b` on the table plane; negative (minus the
/// penetration depth) when they overlap. Exact for polygons and discs, within 1e-4 of the size
/// otherwise: the maximum over horizontal directions `d` of `|Δc·d| − h_a(d) − h_b(d)`, over
/// 360 sampled directions plus the centre line and the shapes' own axes.
fn footprint_gap(a: &Footprint, b: &Footprint) -> f64 {
    let delta = [b.center[0] - a.center[0], b.center[1] - a.center[1]];
    let separation = |d: [f64; 2]| (delta[0] * d[0] + delta[1] * d[1]).abs() - a.half_width(d) - b.half_width(d);
    let samples = (0..360).map(|k| {
        let t = f64::from(k) * std::f64::consts::PI / 360.0;
        [t.cos(), t.sin()]
    });
    let n = delta[0].hypot(delta[1]);
    let centre_line = (n > 1e-12).then(|| [delta[0] / n, delta[1] / n]);
    samples
        .chain(centre_line)
        .chain(a.axes())
        .chain(b.axes())
        .map(separation)
        .fold(f64::NEG_INFINITY, f64::max)
}

fn place_rect(place: &PlaceSpec) -> [f64; 4] {
    let [sx, sy] = place.outer_size();
    let [cx, cy] = place.center;
    [cx - sx / 2.0, cx + sx / 2.0, cy - sy / 2.0, cy + sy / 2.0]
}

fn rect_within(inner: &[f64; 4], outer: &[f64; 4]) -> bool {
    const EPS: f64 = 1e-9;
    inner[0] >= outer[0] - EPS && inner[1] <= outer[1] + EPS && inner[2] >= outer[2] - EPS && inner[3] <= outer[3] + EPS
}

fn rects_overlap(a: &[f64; 4], b: &[f64; 4]) -> bool {
    a[0] < b[1] && b[0] < a[1] && a[2] < b[3] && b[2] < a[3]
}

fn show_rect(r: &[f64; 4]) -> String {
    format!("(x {:.3}..{:.3}, y {:.3}..{:.3})", r[0], r[1], r[2], r[3])
}

// ---------------------------------------------------------------------------------------------
// Parsing and checking helpers
// ---------------------------------------------------------------------------------------------

fn read_file(path: &Path) -> Result<String, SimError> {
    bayes::input::read_text(path).map_err(|source| SimError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Parses TOML into `T`; a `version` other than [`FORMAT_VERSION`] is reported before any other
/// problem (a newer file may have fields this build does not know).
fn parse_toml<T: serde::de::DeserializeOwned>(text: &str, path: &Path) -> Result<T, SimError> {
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
fn in_context(e: SimError, name: &str) -> SimError {
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
fn by_similarity<'a>(name: &str, names: impl IntoIterator<Item = &'a str>) -> Vec<String> {
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

/// Builds [`SimError::Invalid`] for one file.
struct Check<'a> {
    path: &'a Path,
}

impl Check<'_> {
    fn invalid(&self, field: impl Into<String>, message: impl Into<String>) -> SimError {
        SimError::Invalid {
            path: self.path.to_path_buf(),
            field: field.into(),
            message: message.into(),
        }
    }

    fn version_error(&self, got: i64) -> SimError {
        self.invalid(
            "version",
            format!("unsupported format version {got}; this build reads version {FORMAT_VERSION}"),
        )
    }

    fn version(&self, v: u32) -> Result<(), SimError> {
        if v == FORMAT_VERSION {
            Ok(())
        } else {
            Err(self.version_error(i64::from(v)))
        }
    }

    fn finite(&self, field: &str, v: f64) -> Result<(), SimError> {
        if v.is_finite() {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be a finite number (got {v})")))
        }
    }

    fn finite_all(&self, field: &str, values: &[f64]) -> Result<(), SimError> {
        for (k, v) in values.iter().enumerate() {
            self.finite(&format!("{field}[{k}]"), *v)?;
        }
        Ok(())
    }

    /// A length of the tabletop world: finite, > 0 and at most [`MAX_LENGTH`] (physics engines fail
    /// on absurd sizes such as 1e300).
    fn length(&self, field: &str, v: f64) -> Result<(), SimError> {
        self.positive(field, v)?;
        if v <= MAX_LENGTH {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be at most {MAX_LENGTH} m (got {v:e})")))
        }
    }

    /// Coordinates within [`MAX_LENGTH`] of the world origin.
    fn coordinates(&self, field: &str, values: &[f64]) -> Result<(), SimError> {
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
    fn count(&self, field: &str, n: usize, max: usize, what: &str) -> Result<(), SimError> {
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
    fn within(&self, field: &str, key: &str, v: f64) -> Result<(), SimError> {
        self.finite(field, v)?;
        let (lo, hi, unit) = scene_range(key);
        if (lo..=hi).contains(&v) {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be in [{lo}, {hi}] {unit} (got {v:e})")))
        }
    }

    fn positive(&self, field: &str, v: f64) -> Result<(), SimError> {
        self.finite(field, v)?;
        if v > 0.0 {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be > 0 (got {v})")))
        }
    }

    fn unit_interval(&self, field: &str, v: f64) -> Result<(), SimError> {
        self.finite(field, v)?;
        if (0.0..=1.0).contains(&v) {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be in [0, 1] (got {v})")))
        }
    }

    fn hsv(&self, field: &str, hsv: &[f64; 3]) -> Result<(), SimError> {
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
    fn name(&self, field: &str, name: &str) -> Result<(), SimError> {
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
fn exact_array<'de, D, const N: usize>(d: D) -> Result<[f64; N], D::Error>
where
    D: serde::Deserializer<'de>,
{
    use serde::de::Error as _;
    let v: Vec<f64> = serde::Deserialize::deserialize(d)?;
    let n = v.len();
    v.try_into()
        .map_err(|_| D::Error::invalid_length(n, &format!("exactly {N} numbers").as_str()))
}

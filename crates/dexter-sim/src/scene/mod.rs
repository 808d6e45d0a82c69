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
//!
//! # Files
//! `catalog.rs` is the object catalog (its format and checks), `spec.rs` the scene file (table,
//! places, placements, cameras, light) and the checks of everything but its objects, `resolve.rs`
//! rests each placed object on the table and checks it is clear of the rest, `footprint.rs` the
//! geometry of resting and of footprints on the table, `generate.rs` a seeded catalog generator, `check.rs` parsing, the format version, the
//! bounds on numbers and names, and error messages. This file is the [`Scene`]: loading, the
//! built-in scenes and the queries on a loaded scene.

use std::path::{Path, PathBuf};

use crate::error::SimError;

mod catalog;
mod check;
mod footprint;
pub mod generate;
mod resolve;
mod spec;

pub use crate::geometry::Shape;
pub use catalog::{
    BUILTIN_HOUSEHOLD, Catalog, ColorPatch, FRACTION_TOLERANCE, ObjectSpec, PresentationSpec, SIZE_CLASSES,
};
pub use check::{FORMAT_VERSION, MAX_CATALOG_OBJECTS, MAX_IMAGE_SIDE, MAX_LENGTH, MAX_SCENE_OBJECTS, SCENE_RANGES};
pub use footprint::{REST_CLEARANCE, lowest_point_depth, rests_stably, rot_from_rpy_deg};
pub use resolve::ResolvedObject;
pub use spec::{CameraSpec, LightSpec, ObjectPlacement, PlaceSpec, SceneSpec, TableSpec};

use check::{Check, by_similarity, parse_toml, read_file};
use footprint::{Footprint, footprint_gap};
use resolve::resolve_objects;
use spec::{place_footprint, validate_setup};

/// The catalog path the shipped scenes use; built-in scenes resolve it to the built-in catalog.
const SHIPPED_CATALOG: &str = "../objects/household.toml";

const BUILTIN_SCENE_NAMES: [&str; 6] = [
    "sorting",
    "pick-place",
    "sorting-new",
    "sorting-demo",
    "sorting-teach",
    "sorting-sizes",
];

fn builtin_scene_text(name: &str) -> Option<&'static str> {
    match name {
        "sorting" => Some(include_str!("../../../../assets/scenes/sorting.toml")),
        "pick-place" => Some(include_str!("../../../../assets/scenes/pick-place.toml")),
        "sorting-new" => Some(include_str!("../../../../assets/scenes/sorting-new.toml")),
        "sorting-demo" => Some(include_str!("../../../../assets/scenes/sorting-demo.toml")),
        "sorting-teach" => Some(include_str!("../../../../assets/scenes/sorting-teach.toml")),
        "sorting-sizes" => Some(include_str!("../../../../assets/scenes/sorting-sizes.toml")),
        _ => None,
    }
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

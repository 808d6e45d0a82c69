//! The object catalog (TOML): the object kinds, their shapes, masses, colours and the ways they
//! rest on the table (presentations), validated on load.

use std::path::{Path, PathBuf};

use control_basis::math::{Iso3, Rot3, Vec3};
use serde::{Deserialize, Serialize};

use super::check::{
    Check, MAX_CATALOG_OBJECTS, by_similarity, claim_name, exact_array, in_context, parse_toml, read_file,
};
use super::footprint::{REST_CLEARANCE, lowest_point_depth, rot_from_rpy_deg};
use crate::error::SimError;
use crate::geometry::Shape;

/// The `catalog` value of a scene that names the built-in household catalog.
pub const BUILTIN_HOUSEHOLD: &str = "builtin:household";

/// The size classes a catalog may use in `size_class`.
pub const SIZE_CLASSES: [&str; 3] = ["small", "medium", "large"];

/// Tolerance on the sum of an object's colour fractions.
pub const FRACTION_TOLERANCE: f64 = 1e-6;

const HOUSEHOLD_TOML: &str = include_str!("../../../../assets/objects/household.toml");

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

pub(super) fn default_friction() -> f64 {
    0.9
}

/// A catalog: a list of object kinds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Catalog {
    /// Format version ([`FORMAT_VERSION`](super::check::FORMAT_VERSION)).
    pub version: u32,
    /// The objects.
    pub objects: Vec<ObjectSpec>,
    /// Where it was loaded from (not in the file).
    #[serde(skip)]
    pub path: PathBuf,
}

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

    pub(super) fn validate(&self) -> Result<(), SimError> {
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

//! The scene file (TOML): the table, the places, the objects put on the table, the cameras and
//! the light; and the checks of everything in it but the objects ([`validate_setup`]).

use control_basis::math::{Rot3, Vec3};
use serde::{Deserialize, Serialize};

use super::catalog::default_friction;
use super::check::{Check, MAX_IMAGE_SIDE, MAX_SCENE_OBJECTS, claim_name, exact_array, in_context};
use super::footprint::{Footprint, rect_within, rects_overlap, show_rect};
use crate::error::SimError;
use crate::geometry::Shape;

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
    /// [`Catalog::rest_pose`](super::catalog::Catalog::rest_pose). Given: the object starts there (it must not be in the table) and falls.
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
    /// Format version ([`FORMAT_VERSION`](super::check::FORMAT_VERSION)).
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

/// Validates everything in a scene but the objects; normalises the light direction.
pub(super) fn validate_setup(c: &Check<'_>, spec: &mut SceneSpec) -> Result<(), SimError> {
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

pub(super) fn place_footprint(place: &PlaceSpec) -> Footprint {
    let [sx, sy] = place.outer_size();
    Footprint {
        shape: Shape::Box {
            size: [sx, sy, place.wall_height.max(0.0)],
        },
        orientation: Rot3::identity(),
        center: place.center,
    }
}

fn place_rect(place: &PlaceSpec) -> [f64; 4] {
    let [sx, sy] = place.outer_size();
    let [cx, cy] = place.center;
    [cx - sx / 2.0, cx + sx / 2.0, cy - sy / 2.0, cy + sy / 2.0]
}

//! The grasp grid of `../shared/NOTES-grasp-physics.md`, on Dexter's right WAM + BarrettHand: a
//! physics regression check for the simulator (issue 17), not a perception or planning experiment.
//!
//! **Grid**: 32 objects — 12 boxes, 10 upright cylinders, 10 spheres; 4–12 cm across, 0.05–0.8 kg,
//! friction 0.8–1.2 (each spread evenly over its range, interleaved so that size, mass and friction
//! are not correlated) — × 3 approach offsets: centred, +1.5 cm along the opposition axis, and
//! +1 cm along it with the hand turned 20° about the vertical = **96 trials**.
//!
//! **Procedure** (the NOTES' palm-down grasp): the object stands alone at the pick-place scene's
//! presentation point; the palm faces down, finger 3 on one side of the opposition axis (a box's
//! narrower side; any horizontal axis of a round object), fingers 1 and 2 opposite (spread 0); the
//! palm surface is at `table + max(0.075 + H/2, H + 0.025)`. The trial is
//! [`grasp_trial::execute`]: hover, approach 10 cm along the palm normal, close until the Grasp
//! predicate holds, lift 10 cm, hold 1 s.
//!
//! **Success** (the NOTES' criterion, the world's view): the object rose ≥ 8 cm, sank < 2 cm in the
//! hand, and ≥ 2 hand parts touch it after the hold. **Penetration**: the deepest hand–object
//! overlap, sampled after closing, after the lift and every 50 ms of the hold.
//!
//! **Subset**: the trials on objects ≥ 5 cm wide both ways and ≥ 6 cm tall (spheres ≥ 7 cm).
//!
//! The object pose is the world's (this is a probe of the physics: the hand is placed exactly as the
//! NOTES placed it), so no robot-side code reads it.

use control_basis::math::{Iso3, Rot3, Vec3};
use serde::Serialize;

use crate::error::SimError;
use crate::grasp_trial::{self, Percept, PreGraspCommand};
use crate::physics::SimSettings;
use crate::scene::{ColorPatch, ObjectSpec, Scene, Shape};
use crate::snapshot::Arm;

/// Where the objects are presented (the pick-place scene's presentation point, m, world).
pub const PRESENT_XY: [f64; 2] = [0.55, 0.0];
/// The rise (m) a success needs (the NOTES: ≥ 8 cm).
pub const ROSE_MIN: f64 = 0.08;
/// The most an object may sink in the hand (m) and still count (the NOTES: < 2 cm).
pub const SANK_MAX: f64 = 0.02;

/// One object of the grid.
#[derive(Debug, Clone, Serialize)]
pub struct GridObject {
    /// Name (`box-06x04x10` …).
    pub name: String,
    /// Geometry (upright).
    pub shape: Shape,
    /// Mass (kg).
    pub mass: f64,
    /// Coulomb friction coefficient.
    pub friction: f64,
}

impl GridObject {
    /// Horizontal extents (m) along world x and y, and the height (m).
    pub fn extents(&self) -> [f64; 3] {
        match &self.shape {
            Shape::Box { size } => *size,
            Shape::Cylinder { radius, height } | Shape::Capsule { radius, height } => {
                [2.0 * radius, 2.0 * radius, *height]
            }
            Shape::Sphere { radius } => [2.0 * radius; 3],
        }
    }

    /// Whether the object is in the NOTES' subset (≥ 5 cm wide both ways and ≥ 6 cm tall; spheres
    /// ≥ 7 cm).
    pub fn in_subset(&self) -> bool {
        let [x, y, z] = self.extents();
        match &self.shape {
            Shape::Sphere { radius } => 2.0 * radius >= 0.07 - 1e-9,
            _ => x.min(y) >= 0.05 - 1e-9 && z >= 0.06 - 1e-9,
        }
    }
}

/// Evenly spread values over `[lo, hi]`, `n` of them, visited in a stride that decorrelates them
/// from the object's index.
fn spread(lo: f64, hi: f64, n: usize, i: usize, stride: usize) -> f64 {
    let k = (i * stride) % n;
    lo + (hi - lo) * k as f64 / (n - 1) as f64
}

/// The 32 objects of the grid (deterministic).
pub fn objects() -> Vec<GridObject> {
    let cm = 0.01;
    // Boxes: [x, y, z] in cm; the narrower of x, y is the opposition axis.
    let boxes: [[f64; 3]; 12] = [
        [4.0, 4.0, 6.0],
        [5.0, 5.0, 8.0],
        [6.0, 4.0, 10.0],
        [6.0, 6.0, 6.0],
        [7.0, 5.0, 12.0],
        [8.0, 6.0, 9.0],
        [8.0, 8.0, 8.0],
        [9.0, 5.0, 11.0],
        [10.0, 6.0, 7.0],
        [10.0, 8.0, 12.0],
        [12.0, 6.0, 10.0],
        [12.0, 10.0, 8.0],
    ];
    // Cylinders: diameter, height (cm).
    let cylinders: [[f64; 2]; 10] = [
        [4.0, 8.0],
        [5.0, 10.0],
        [5.5, 6.0],
        [6.0, 12.0],
        [7.0, 9.0],
        [7.5, 14.0],
        [8.0, 7.0],
        [9.0, 11.0],
        [10.0, 10.0],
        [12.0, 8.0],
    ];
    // Spheres: diameter (cm).
    let spheres: [f64; 10] = [4.0, 5.0, 6.0, 7.0, 8.0, 8.5, 9.0, 10.0, 11.0, 12.0];
    let mut out = Vec::with_capacity(32);
    let n = boxes.len() + cylinders.len() + spheres.len();
    let mut push = |name: String, shape: Shape| {
        let i = out.len();
        out.push(GridObject {
            name,
            shape,
            mass: spread(0.05, 0.8, n, i, 7),
            friction: spread(0.8, 1.2, n, i, 13),
        });
    };
    for [x, y, z] in boxes {
        push(
            format!("box-{x:02.0}x{y:02.0}x{z:02.0}"),
            Shape::Box {
                size: [x * cm, y * cm, z * cm],
            },
        );
    }
    for [d, h] in cylinders {
        push(
            format!("cylinder-d{:03.0}-h{h:02.0}", d * 10.0),
            Shape::Cylinder {
                radius: 0.5 * d * cm,
                height: h * cm,
            },
        );
    }
    for d in spheres {
        push(
            format!("sphere-d{:03.0}", d * 10.0),
            Shape::Sphere { radius: 0.5 * d * cm },
        );
    }
    out
}

/// An approach offset of the grid.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum Offset {
    /// The palm centred over the object.
    Centred,
    /// +1.5 cm along the opposition axis.
    Along15mm,
    /// +1 cm along the opposition axis, the hand turned 20° about the vertical.
    Yawed20deg,
}

impl Offset {
    /// The three offsets, in the grid's order.
    pub const ALL: [Offset; 3] = [Offset::Centred, Offset::Along15mm, Offset::Yawed20deg];

    /// Name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Offset::Centred => "centred",
            Offset::Along15mm => "+1.5 cm",
            Offset::Yawed20deg => "+1 cm, 20° yaw",
        }
    }

    fn shift_and_yaw(self) -> (f64, f64) {
        match self {
            Offset::Centred => (0.0, 0.0),
            Offset::Along15mm => (0.015, 0.0),
            Offset::Yawed20deg => (0.010, 20f64.to_radians()),
        }
    }
}

/// One trial of the grid: object `trial / 3`, offset `trial % 3`.
#[derive(Debug, Clone, Serialize)]
pub struct GridRow {
    /// Trial index (0–95).
    pub trial: usize,
    /// Object name.
    pub object: String,
    /// Offset name.
    pub offset: &'static str,
    /// In the NOTES' subset.
    pub subset: bool,
    /// The NOTES' criterion.
    pub success: bool,
    /// How far the object rose (m).
    pub rose: f64,
    /// How far it sank in the hand during the lift and hold (m).
    pub sank: f64,
    /// Hand parts touching it after the hold.
    pub parts: usize,
    /// The deepest hand–object penetration (m).
    pub max_penetration: f64,
    /// The trial's own account (`lifted`, or why not).
    pub outcome: String,
    /// Wall time (s).
    pub wall_time: f64,
}

/// The scene of trial `trial`'s object alone on the pick-place table.
pub fn scene(object: &GridObject) -> Result<Scene, SimError> {
    let mut base = Scene::builtin("pick-place")?;
    base.catalog.objects = vec![ObjectSpec {
        name: object.name.clone(),
        shape: object.shape.clone(),
        mass: object.mass,
        friction: object.friction,
        colors: vec![ColorPatch {
            hsv: [0.0, 0.8, 0.8],
            fraction: 1.0,
        }],
        color_class: None,
        size_class: None,
        rpy_deg: [0.0; 3],
        presentations: Vec::new(),
    }];
    grasp_trial::present(&base, &object.name, PRESENT_XY, 0.0)
}

/// The palm-down pre-grasp of `object` (resting at `xy` on a table at `table_z`) for `offset`.
pub fn pre_grasp(object: &GridObject, xy: [f64; 2], table_z: f64, offset: Offset) -> Iso3 {
    let [ex, ey, h] = object.extents();
    // Opposition axis: across the narrower horizontal side (world y when they are equal), finger 3
    // towards −x / −y (with +y the right WAM's wrist would have to turn over to face down).
    let axis0 = if ex < ey { -Vec3::x() } else { -Vec3::y() };
    let (shift, yaw) = offset.shift_and_yaw();
    let turn = Rot3::from_axis_angle(&Vec3::z_axis(), yaw);
    let y = turn * axis0;
    let z = -Vec3::z();
    let x = y.cross(&z);
    let rot = Rot3::from_matrix(&control_basis::math::Mat3::from_columns(&[x, y, z]));
    let height = (0.075 + 0.5 * h).max(h + 0.025);
    let p = Vec3::new(xy[0], xy[1], table_z + height) + axis0 * shift;
    Iso3::from_parts(p.into(), rot)
}

/// What the hand is told about the object (the truth: this is a physics probe).
fn percept(object: &GridObject, scene: &Scene) -> Percept {
    let pose = scene.resolved[0].pose;
    let [ex, ey, h] = object.extents();
    let (major, half_major, half_minor) = if ex >= ey {
        ([1.0, 0.0], 0.5 * ex, 0.5 * ey)
    } else {
        ([0.0, 1.0], 0.5 * ey, 0.5 * ex)
    };
    let t = pose.translation.vector;
    let table_z = scene.spec.table.height;
    Percept {
        presentation: object.name.clone(),
        centroid: [t.x, t.y, t.z],
        appearance: [[0.0; 2]; 2],
        extent: schema::SeenExtent {
            height: h,
            center: [t.x, t.y],
            major_axis: major,
            half_major,
            half_minor,
            model: "prism".into(),
        },
        table_z,
        true_position: [t.x, t.y, t.z],
        vision_error: 0.0,
        frames: 0,
    }
}

/// Runs trial `trial` (0–95) with `settings` on the right arm.
pub fn run_trial(trial: usize, settings: &SimSettings) -> Result<GridRow, SimError> {
    let objects = objects();
    let object = objects.get(trial / 3).ok_or_else(|| SimError::Invalid {
        path: "<grasp grid>".into(),
        field: "trial".into(),
        message: format!("trial {trial} is not in the grid (0–{})", 3 * objects.len() - 1),
    })?;
    let offset = Offset::ALL[trial % 3];
    let scene = scene(object)?;
    let table_z = scene.spec.table.height;
    let seen = percept(object, &scene);
    let cmd = PreGraspCommand {
        world_from_palm: pre_grasp(object, PRESENT_XY, table_z, offset),
        preshape: 0.0,
        spread: 0.0,
    };
    let out = grasp_trial::execute(&scene, settings, Arm::Right, &cmd, &seen)?;
    let parts = out.touching_parts;
    Ok(GridRow {
        trial,
        object: object.name.clone(),
        offset: offset.name(),
        subset: object.in_subset(),
        success: out.rose >= ROSE_MIN && out.sank < SANK_MAX && parts >= 2,
        rose: out.rose,
        sank: out.sank,
        parts,
        max_penetration: out.max_penetration,
        outcome: out.outcome,
        wall_time: out.wall_time,
    })
}

/// The grid's score: successes over all trials and over the subset, the deepest penetration.
#[derive(Debug, Clone, Serialize)]
pub struct GridSummary {
    /// Successes / trials.
    pub grid: (usize, usize),
    /// Successes / trials in the subset.
    pub subset: (usize, usize),
    /// The deepest penetration over the successful trials (m).
    pub max_penetration_success: f64,
    /// The deepest penetration over all trials (m).
    pub max_penetration: f64,
}

/// Scores `rows`.
pub fn summarize(rows: &[GridRow]) -> GridSummary {
    let count = |f: &dyn Fn(&GridRow) -> bool| rows.iter().filter(|r| f(r)).count();
    GridSummary {
        grid: (count(&|r| r.success), rows.len()),
        subset: (count(&|r| r.subset && r.success), count(&|r| r.subset)),
        max_penetration_success: rows
            .iter()
            .filter(|r| r.success)
            .map(|r| r.max_penetration)
            .fold(0.0, f64::max),
        max_penetration: rows.iter().map(|r| r.max_penetration).fold(0.0, f64::max),
    }
}

//! Synthetic scenes for tests, benchmarks and examples of the vision pipeline: Dexter's head
//! cameras, a table with two bins, catalog-like objects and a stand-in for the robot's link shapes.

use crate::error::SimError;
use crate::scene::{CameraSpec, ColorPatch, Shape};
use crate::vision::camera::SpecCamera;
use crate::vision::render::{ItemLabel, RenderItem, RenderScene};
use crate::vision::stereo::StereoCameras;
use bayes::rng::{Draw, Generator};
use control_basis::hardware::Camera;
use control_basis::math::{Iso3, Rot3, Vec3};
use nalgebra::{Translation3, Unit};
use parry3d_f64::shape::SharedShape;

/// Head camera centres at zero joint angles: left (+y) and right (−y), world (m).
pub const HEAD_LEFT_EYE: [f64; 3] = [0.05, 0.06, 1.5];
/// See [`HEAD_LEFT_EYE`].
pub const HEAD_RIGHT_EYE: [f64; 3] = [0.05, -0.06, 1.5];
/// Height of the table top (m).
pub const TABLE_TOP: f64 = 0.75;
/// Table extent in x (m).
pub const TABLE_X: [f64; 2] = [0.3, 0.9];
/// Table extent in y (m).
pub const TABLE_Y: [f64; 2] = [-0.7, 0.7];
/// A fixation point on the table in front of the robot.
pub const TABLE_FIXATION: [f64; 3] = [0.6, 0.0, 0.8];
/// Centres (x, y) of the two bins built by [`table_and_bins`].
pub const BIN_CENTERS: [[f64; 2]; 2] = [[0.45, 0.5], [0.45, -0.5]];
/// HSV of the table top.
pub const TABLE_HSV: [f64; 3] = [30.0, 0.25, 0.55];

/// Dexter's head stereo pair, both cameras verged on `fixation` (camera centres at
/// [`HEAD_LEFT_EYE`], [`HEAD_RIGHT_EYE`] — the head tilt and vergence are folded into the look-at).
pub fn head_cameras(spec: &CameraSpec, fixation: Vec3) -> Result<StereoCameras, SimError> {
    crate::vision::camera::validate_spec(spec)?;
    StereoCameras::verged(
        &spec.intrinsics(),
        Vec3::from(HEAD_LEFT_EYE),
        Vec3::from(HEAD_RIGHT_EYE),
        fixation,
    )
    .map_err(|e| SimError::Invalid {
        path: "<camera>".into(),
        field: "camera".into(),
        message: e.to_string(),
    })
}

/// Dexter's head stereo pair after panning by `pan` (rad, positive = left) and tilting by `tilt`
/// (rad, positive = down) about the point between the cameras, parallel optical axes.
pub fn head_cameras_pan_tilt(spec: &CameraSpec, pan: f64, tilt: f64) -> Result<StereoCameras, SimError> {
    let mid = 0.5 * (Vec3::from(HEAD_LEFT_EYE) + Vec3::from(HEAD_RIGHT_EYE));
    let rot = Rot3::from_axis_angle(&Vec3::z_axis(), pan) * Rot3::from_axis_angle(&Vec3::y_axis(), tilt);
    let fwd = rot * Vec3::x();
    let left = mid + rot * Vec3::new(0.0, 0.06, 0.0);
    let right = mid + rot * Vec3::new(0.0, -0.06, 0.0);
    Ok(StereoCameras {
        left: Camera::look_at(spec, left, left + fwd)?,
        right: Camera::look_at(spec, right, right + fwd)?,
    })
}

/// The empty scene: the table (a 5 cm slab whose top is at [`TABLE_TOP`]) and two grey bins
/// (20 × 20 cm trays with 4 cm walls at [`BIN_CENTERS`]), all [`ItemLabel::Static`].
pub fn table_and_bins() -> RenderScene {
    let mut s = RenderScene::new();
    let (cx, cy) = (0.5 * (TABLE_X[0] + TABLE_X[1]), 0.5 * (TABLE_Y[0] + TABLE_Y[1]));
    let t = 0.05;
    s.push(RenderItem::uniform_box(
        [TABLE_X[1] - TABLE_X[0], TABLE_Y[1] - TABLE_Y[0], t],
        Iso3::translation(cx, cy, TABLE_TOP - 0.5 * t),
        TABLE_HSV,
        ItemLabel::Static,
    ));
    let grey = [0.0, 0.0, 0.35];
    for [x, y] in BIN_CENTERS {
        let (size, wall, h, floor) = (0.2, 0.01, 0.04, 0.004);
        s.push(RenderItem::uniform_box(
            [size, size, floor],
            Iso3::translation(x, y, TABLE_TOP + 0.5 * floor),
            grey,
            ItemLabel::Static,
        ));
        let zc = TABLE_TOP + 0.5 * h;
        let off = 0.5 * (size - wall);
        for (sz, dx, dy) in [
            ([size, wall, h], 0.0, off),
            ([size, wall, h], 0.0, -off),
            ([wall, size - 2.0 * wall, h], off, 0.0),
            ([wall, size - 2.0 * wall, h], -off, 0.0),
        ] {
            s.push(RenderItem::uniform_box(
                sz,
                Iso3::translation(x + dx, y + dy, zc),
                grey,
                ItemLabel::Static,
            ));
        }
    }
    s
}

fn segment_item(a: Vec3, b: Vec3, radius: f64, hsv: [f64; 3]) -> RenderItem {
    let d = b - a;
    let len = d.norm().max(1e-6);
    // Parry cylinders run along their local y.
    let rot = Rot3::rotation_between(&Vec3::y(), &(d / len))
        .unwrap_or_else(|| Rot3::from_axis_angle(&Unit::new_normalize(Vec3::x()), std::f64::consts::PI));
    let pose = Iso3::from_parts(Translation3::from(0.5 * (a + b)), rot);
    RenderItem {
        shape: SharedShape::cylinder(0.5 * len, radius),
        world_from_shape: pose,
        object_from_shape: Iso3::identity(),
        material: crate::vision::Material::Uniform(hsv),
        label: ItemLabel::Robot,
    }
}

/// Adds a stand-in for Dexter's collision shapes (41 items, all [`ItemLabel::Robot`]): torso, head,
/// neck, and per arm a shoulder ball, a mounting block, 7 cylindrical links, a palm and 3 fingers × 3 phalanges. `reach` in [0, 1] moves the
/// hands from beside the torso (0) to over the near edge of the table (1), where they enter the view.
pub fn add_robot(scene: &mut RenderScene, reach: f64) {
    let reach = reach.clamp(0.0, 1.0);
    let metal = [210.0, 0.08, 0.75];
    let dark = [0.0, 0.0, 0.2];
    scene.push(RenderItem::uniform_box(
        [0.25, 0.4, 0.6],
        Iso3::translation(-0.1, 0.0, 1.05),
        metal,
        ItemLabel::Robot,
    ));
    scene.push(RenderItem::uniform_box(
        [0.08, 0.24, 0.06],
        Iso3::translation(0.0, 0.0, 1.42),
        dark,
        ItemLabel::Robot,
    ));
    scene.push(segment_item(
        Vec3::new(-0.02, 0.0, 1.35),
        Vec3::new(-0.02, 0.0, 1.4),
        0.04,
        dark,
    ));
    for side in [1.0, -1.0] {
        let shoulder = Vec3::new(0.0, side * 0.3, 1.25);
        scene.push(RenderItem {
            shape: SharedShape::ball(0.07),
            ..RenderItem::uniform_box(
                [0.0; 3],
                Iso3::translation(shoulder.x, shoulder.y, shoulder.z),
                metal,
                ItemLabel::Robot,
            )
        });
        scene.push(RenderItem::uniform_box(
            [0.12, 0.08, 0.12],
            Iso3::translation(-0.05, side * 0.22, 1.25),
            dark,
            ItemLabel::Robot,
        ));
        let elbow = Vec3::new(0.15 + 0.1 * reach, side * 0.42, 1.05 - 0.05 * reach);
        let wrist = Vec3::new(0.2 + 0.25 * reach, side * (0.38 - 0.08 * reach), 0.95 - 0.05 * reach);
        let palm = wrist + Vec3::new(0.08, 0.0, -0.02);
        let joints = [
            shoulder,
            shoulder + (elbow - shoulder) * 0.3,
            shoulder + (elbow - shoulder) * 0.7,
            elbow,
            elbow + (wrist - elbow) * 0.4,
            elbow + (wrist - elbow) * 0.8,
            wrist,
            wrist + (palm - wrist) * 0.6,
        ];
        for (k, w) in joints.windows(2).enumerate() {
            scene.push(segment_item(w[0], w[1], 0.06 - 0.004 * k as f64, metal));
        }
        scene.push(RenderItem::uniform_box(
            [0.05, 0.09, 0.09],
            Iso3::translation(palm.x, palm.y, palm.z),
            dark,
            ItemLabel::Robot,
        ));
        for f in 0..3 {
            let mut base = palm + Vec3::new(0.03, side * (f as f64 - 1.0) * 0.03, -0.02);
            for _ in 0..3 {
                let tip = base + Vec3::new(0.03, 0.0, -0.02);
                scene.push(segment_item(base, tip, 0.009, dark));
                base = tip;
            }
        }
    }
}

/// A random catalog-like object: a box, cylinder or sphere of 4–14 cm with 1–3 colour bands of
/// well-separated saturated hues.
pub fn random_object(rng: &mut Generator) -> (Shape, Vec<ColorPatch>) {
    let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.uniform();
    let shape = match (u(0.0, 3.0)) as u32 {
        0 => Shape::Box {
            size: [u(0.04, 0.14), u(0.04, 0.14), u(0.04, 0.14)],
        },
        1 => Shape::Cylinder {
            radius: u(0.02, 0.06),
            height: u(0.04, 0.14),
        },
        _ => Shape::Sphere { radius: u(0.02, 0.06) },
    };
    let n = 1 + (u(0.0, 3.0) as usize).min(2);
    let hue0 = u(0.0, 360.0);
    let mut colors = Vec::with_capacity(n);
    for k in 0..n {
        colors.push(ColorPatch {
            hsv: [(hue0 + 120.0 * k as f64) % 360.0, u(0.6, 0.95), u(0.55, 0.95)],
            fraction: 1.0,
        });
    }
    let total = n as f64;
    for c in &mut colors {
        c.fraction /= total;
    }
    (shape, colors)
}

/// The pose of an object resting upright on the table at `(x, y)` with yaw `yaw` (rad).
pub fn resting_pose(shape: &Shape, x: f64, y: f64, yaw: f64) -> Iso3 {
    let h = crate::geometry::support_half_extent(shape, &Vec3::z());
    Iso3::from_parts(
        Translation3::new(x, y, TABLE_TOP + h + 1e-4),
        Rot3::from_axis_angle(&Vec3::z_axis(), yaw),
    )
}

/// A typical scene: table, bins, `n_objects` random objects on a jittered grid over x 0.4–0.8,
/// y −0.35–0.35, and (if `robot`) the 40 robot shapes with the hands over the table edge.
/// Returns the scene and, per object, its item index and true centroid.
pub fn typical_scene(seed: u64, n_objects: usize, robot: bool) -> (RenderScene, Vec<(usize, Vec3)>) {
    let mut rng = bayes::rng::seeded(seed);
    let mut scene = table_and_bins();
    if robot {
        add_robot(&mut scene, 1.0);
    }
    let (cols, rows) = (4usize, n_objects.div_ceil(4).max(1));
    let mut truth = Vec::with_capacity(n_objects);
    for k in 0..n_objects {
        let (i, j) = (k % cols, k / cols);
        let cx = if rows > 1 {
            0.42 + 0.36 * j as f64 / (rows - 1) as f64
        } else {
            0.6
        };
        let cy = -0.3 + 0.6 * i as f64 / (cols - 1) as f64;
        let (shape, colors) = random_object(&mut rng);
        let jx = 0.02 * (rng.uniform() - 0.5);
        let jy = 0.02 * (rng.uniform() - 0.5);
        let yaw = rng.uniform() * std::f64::consts::PI;
        let pose = resting_pose(&shape, cx + jx, cy + jy, yaw);
        let idx = scene.push(RenderItem::from_catalog(&shape, pose, &colors, ItemLabel::Object(k)));
        truth.push((idx, pose.translation.vector));
    }
    (scene, truth)
}

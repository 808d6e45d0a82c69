//! The robot drawn in Foxglove: its links' URDF `<visual>` shapes as scene entities locked to the
//! link frames of `/tf`, and the fingertip force/torque readings as arrows.
//!
//! Each link is one entity `link/<name>` in the frame `<name>` with `frame_locked`, so the 3D panel
//! moves it with every `/tf` message; the entities are written once (and again when the model
//! changes). Primitives follow the URDF: boxes, spheres, cylinders along z, capsules as a cylinder
//! with two spheres. Mesh visuals are left out (Dexter's URDF has none; a mesh would need its file
//! in the log).
//!
//! The fingertip arrows (`/fingertips/arrows`) are one entity per sensor `fingertip/<arm>/<finger>`
//! in `world`, drawn at the tip link's origin along the measured contact force, [`ARROW_M_PER_N`]
//! long per newton; a sensor that reads less than [`ARROW_MIN_FORCE`] has an entity with no arrow.

use control_basis::math::{Iso3, Rot3, Vec3};
use control_basis::{RobotModel, VisualGeometry};
use dexter_sim::snapshot::FingertipWrench;
use foxglove::messages as fm;

use super::messages::{
    ArrowPrimitive, Color, CylinderPrimitive, Pose, SceneEntity, SceneUpdate, SizedPrimitive, Time, Vector3,
};

/// Prefix of a link's scene-entity id: `link/<name>`.
pub(super) const LINK_PREFIX: &str = "link/";

/// Arrow length per newton of fingertip force (m/N): a 5 N squeeze is a 10 cm arrow.
pub const ARROW_M_PER_N: f64 = 0.02;
/// Longest arrow drawn (m).
pub const ARROW_MAX_LENGTH: f64 = 0.25;
/// Forces below this (N) draw no arrow.
pub const ARROW_MIN_FORCE: f64 = 0.05;

/// Colour of links whose material gives none.
const DEFAULT_LINK_COLOR: Color = Color {
    r: 0.7,
    g: 0.7,
    b: 0.72,
    a: 1.0,
};

/// The robot's links as a scene update that replaces everything on the robot topic.
pub(super) fn robot_update(model: &RobotModel, timestamp: Time) -> SceneUpdate {
    let visuals = model.visuals();
    let mut entities: Vec<SceneEntity> = Vec::new();
    for (link, l) in model.links.iter().enumerate() {
        let mut e = SceneEntity::new(timestamp, &l.name, format!("{LINK_PREFIX}{}", l.name), true)
            .with_metadata(&[("kind", "link"), ("link", &l.name)]);
        for v in visuals.iter().filter(|v| v.link == link) {
            let color = v.rgba.map_or(DEFAULT_LINK_COLOR, |[r, g, b, a]| Color { r, g, b, a });
            let pose = Pose::of(&v.origin);
            match v.geometry {
                VisualGeometry::Box { size: [x, y, z] } => e.cubes.push(SizedPrimitive {
                    pose,
                    size: Vector3 { x, y, z },
                    color,
                }),
                VisualGeometry::Sphere { radius } => e.spheres.push(sphere(pose, radius, color)),
                VisualGeometry::Cylinder { radius, length } => e.cylinders.push(cylinder(pose, radius, length, color)),
                VisualGeometry::Capsule { radius, length } => {
                    e.cylinders.push(cylinder(pose, radius, length, color));
                    for side in [-0.5, 0.5] {
                        let end = v.origin * Iso3::translation(0.0, 0.0, side * length);
                        e.spheres.push(sphere(Pose::of(&end), radius, color));
                    }
                }
                VisualGeometry::Mesh { .. } => {}
            }
        }
        if !(e.cubes.is_empty() && e.spheres.is_empty() && e.cylinders.is_empty()) {
            entities.push(e);
        }
    }
    SceneUpdate::replacing_all(timestamp, entities)
}

fn sphere(pose: Pose, radius: f64, color: Color) -> SizedPrimitive {
    let d = 2.0 * radius;
    SizedPrimitive {
        pose,
        size: Vector3 { x: d, y: d, z: d },
        color,
    }
}

fn cylinder(pose: Pose, radius: f64, length: f64, color: Color) -> CylinderPrimitive {
    let d = 2.0 * radius;
    CylinderPrimitive {
        pose,
        size: Vector3 { x: d, y: d, z: length },
        bottom_scale: 1.0,
        top_scale: 1.0,
        color,
    }
}

/// The arrow of one fingertip reading at `origin` (world), or `None` below [`ARROW_MIN_FORCE`] or
/// for a non-finite reading.
pub(super) fn force_arrow(origin: &Vec3, force: [f64; 3], in_contact: bool) -> Option<ArrowPrimitive> {
    let f = Vec3::from(force);
    let n = f.norm();
    if !(n >= ARROW_MIN_FORCE && n.is_finite() && origin.iter().all(|x| x.is_finite())) {
        return None;
    }
    // +x of the arrow's pose along the force; antiparallel to x has no unique shortest rotation.
    let rotation = Rot3::rotation_between(&Vec3::x(), &f)
        .unwrap_or_else(|| Rot3::from_axis_angle(&Vec3::z_axis(), std::f64::consts::PI));
    let length = (n * ARROW_M_PER_N).min(ARROW_MAX_LENGTH);
    let head = (0.3 * length).min(0.02);
    // On the 2⁻²⁰ grid of `/tf` (a micrometre): Protobuf doubles whose low bits zstd packs.
    let mut pose = Pose::of(&Iso3::from_parts((*origin).into(), rotation));
    let r = super::messages::round_bits;
    let (p, q) = (&mut pose.position, &mut pose.orientation);
    (p.x, p.y, p.z) = (r(p.x), r(p.y), r(p.z));
    (q.x, q.y, q.z, q.w) = (r(q.x), r(q.y), r(q.z), r(q.w));
    Some(ArrowPrimitive {
        pose,
        shaft_length: r(length - head),
        shaft_diameter: 0.004,
        head_length: r(head),
        head_diameter: 0.01,
        // Orange while the sensor registers a contact, grey for a residual reading.
        color: if in_contact {
            Color {
                r: 1.0,
                g: 0.45,
                b: 0.0,
                a: 1.0,
            }
        } else {
            Color {
                r: 0.6,
                g: 0.6,
                b: 0.6,
                a: 0.8,
            }
        },
    })
}

/// `foxglove.SceneUpdate` with one entity per fingertip sensor (`ids`: `fingertip/<arm>/<finger>`,
/// parallel to `arrows`), each with its arrow or none.
pub(super) fn arrow_update(timestamp: Time, ids: &[String], arrows: &[Option<ArrowPrimitive>]) -> fm::SceneUpdate {
    let timestamp = Some(timestamp.proto());
    fm::SceneUpdate {
        deletions: Vec::new(),
        entities: ids
            .iter()
            .zip(arrows)
            .map(|(id, arrow)| fm::SceneEntity {
                timestamp,
                frame_id: super::messages::WORLD_FRAME.to_owned(),
                id: id.clone(),
                lifetime: Some(fm::Duration::new(0, 0)),
                arrows: arrow.iter().map(ArrowPrimitive::proto).collect(),
                ..Default::default()
            })
            .collect(),
    }
}

/// Sensor ids and tip-link indices of the fingertip readings, in reading order.
pub(super) fn fingertip_ids(fingertips: &[FingertipWrench]) -> Vec<String> {
    fingertips
        .iter()
        .map(|f| format!("fingertip/{}/{}", arm_name(f.arm), f.finger))
        .collect()
}

/// The tip link's name of a reading (`left/bhand/finger_1/tip_link`).
pub(super) fn tip_link(f: &FingertipWrench) -> String {
    format!("{}/bhand/finger_{}/tip_link", arm_name(f.arm), f.finger)
}

fn arm_name(arm: dexter_sim::Arm) -> &'static str {
    match arm {
        dexter_sim::Arm::Left => "left",
        dexter_sim::Arm::Right => "right",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_arrow_points_along_the_force_and_scales_with_it() {
        let a = force_arrow(&Vec3::new(0.1, 0.2, 0.3), [0.0, 0.0, -5.0], true).unwrap();
        let q = &a.pose.orientation;
        let rot = Rot3::from_quaternion(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z));
        let x = rot * Vec3::x();
        // Poses and lengths are on the 2⁻²⁰ grid (≈ 1 µm) of `/tf`.
        const GRID: f64 = 1.0 / (1u64 << 20) as f64;
        assert!((x - Vec3::new(0.0, 0.0, -1.0)).norm() < GRID, "{x}");
        assert!((a.shaft_length + a.head_length - 5.0 * ARROW_M_PER_N).abs() <= GRID);
        let p = &a.pose.position;
        assert!((Vec3::new(p.x, p.y, p.z) - Vec3::new(0.1, 0.2, 0.3)).norm() <= GRID);
        for v in [p.x, p.y, p.z, a.shaft_length, a.head_length] {
            assert_eq!(
                v * (1u64 << 20) as f64,
                (v * (1u64 << 20) as f64).round(),
                "{v} on the grid"
            );
        }
        // Antiparallel to x, capped, and none below the threshold or for NaN.
        let b = force_arrow(&Vec3::zeros(), [-1e3, 0.0, 0.0], false).unwrap();
        assert!((b.shaft_length + b.head_length - ARROW_MAX_LENGTH).abs() <= GRID);
        assert!(force_arrow(&Vec3::zeros(), [0.01, 0.0, 0.0], true).is_none());
        assert!(force_arrow(&Vec3::zeros(), [f64::NAN, 0.0, 0.0], true).is_none());
    }

    #[test]
    fn dexter_is_drawn_link_by_link() {
        let model = RobotModel::from_urdf_str(dexter_sim::physics::DEXTER_URDF).unwrap();
        let u = robot_update(&model, Time { sec: 0, nsec: 0 });
        // Every link with a visual is an entity in its own frame.
        let with_visuals: std::collections::BTreeSet<usize> = model.visuals().iter().map(|v| v.link).collect();
        assert_eq!(u.entities.len(), with_visuals.len());
        assert!(u.entities.len() > 40, "{} links drawn", u.entities.len());
        for e in &u.entities {
            assert!(e.frame_locked);
            assert_eq!(e.id, format!("{LINK_PREFIX}{}", e.frame_id));
        }
        let primitives: usize = u
            .entities
            .iter()
            .map(|e| e.cubes.len() + e.spheres.len() + e.cylinders.len())
            .sum();
        let visuals = dexter_sim::physics::DEXTER_URDF.matches("<visual>").count();
        assert_eq!(
            primitives, visuals,
            "one primitive per <visual> of assets/dexter.urdf (no capsules)"
        );
        let torso = u.entities.iter().find(|e| e.frame_id == "torso_link").unwrap();
        assert_eq!(torso.cubes.len(), 2);
        assert!((torso.cubes[0].color.b - 0.5).abs() < 1e-12, "material torso_blue");
    }
}

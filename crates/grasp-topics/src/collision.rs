//! Collision filtering of candidate pre-grasps (the seed filtered by hand, §6.6): drop those where
//! the pre-shaped BarrettHand would intersect the object or the table, rank the rest by how far the
//! arm must reach.
//!
//! The hand is a few convex primitives in the palm-surface frame (+z = palm normal = approach, F3 on
//! +y; dimensions from `assets/dexter.urdf`, BH8-280): the palm box 0.09 × 0.09 × 0.08 m behind the
//! palm surface, a wrist capsule behind that, and for each finger a capsule per link (inner 0.070 m,
//! outer 0.050 m, radius 0.01 m) at the pre-shape flexion, with the outer link's fixed 45° bend and
//! the coupled outer flexion (outer = inner/3). This is the only module that touches parry types.

use nalgebra::{Isometry3, Vector3};
use parry3d_f64::glamx::{DPose3, DQuat, DVec3};
use parry3d_f64::shape::{Ball, Capsule, Cuboid, Cylinder, HalfSpace, Shape};
use serde::{Deserialize, Serialize};

use crate::error::{Result, check_finite, invalid};
use crate::model::PreGrasp;

/// An object's collision shape in its own frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ObjectShape {
    /// A box with half extents (m) along the object's x, y, z.
    Box {
        /// Half extents (m).
        half_extents: [f64; 3],
    },
    /// A cylinder whose axis is the object's z.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Half the height (m).
        half_height: f64,
    },
    /// A sphere.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// A capsule whose axis is the object's z (half_height excludes the caps).
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Half the length of the segment (m).
        half_height: f64,
    },
}

impl ObjectShape {
    /// The object's extents (m) along its own axes, e.g. for [`crate::naive_baseline`].
    pub fn dimensions(&self) -> Vector3<f64> {
        match *self {
            ObjectShape::Box { half_extents } => Vector3::from(half_extents) * 2.0,
            ObjectShape::Cylinder { radius, half_height } => {
                Vector3::new(2.0 * radius, 2.0 * radius, 2.0 * half_height)
            }
            ObjectShape::Sphere { radius } => Vector3::repeat(2.0 * radius),
            ObjectShape::Capsule { radius, half_height } => {
                Vector3::new(2.0 * radius, 2.0 * radius, 2.0 * (half_height + radius))
            }
        }
    }

    fn validate(&self) -> Result<()> {
        let vals: Vec<f64> = match *self {
            ObjectShape::Box { half_extents } => half_extents.to_vec(),
            ObjectShape::Cylinder { radius, half_height } => vec![radius, half_height],
            ObjectShape::Sphere { radius } => vec![radius],
            ObjectShape::Capsule { radius, half_height } => vec![radius, half_height],
        };
        check_finite(|| "object shape".into(), &vals)?;
        if vals.iter().any(|&v| v <= 0.0) {
            return Err(invalid("object shape", format!("sizes must be > 0, got {self:?}")));
        }
        Ok(())
    }

    /// The parry shape and the pose of that shape in the object frame (parry's cylinders and
    /// capsules are along y; ours along z).
    fn parry(&self) -> (Box<dyn Shape>, DPose3) {
        let to_z = DPose3::from_parts(DVec3::ZERO, DQuat::from_rotation_x(std::f64::consts::FRAC_PI_2));
        match *self {
            ObjectShape::Box { half_extents } => (
                Box::new(Cuboid::new(DVec3::new(
                    half_extents[0],
                    half_extents[1],
                    half_extents[2],
                ))),
                DPose3::IDENTITY,
            ),
            ObjectShape::Cylinder { radius, half_height } => (Box::new(Cylinder::new(half_height, radius)), to_z),
            ObjectShape::Sphere { radius } => (Box::new(Ball::new(radius)), DPose3::IDENTITY),
            ObjectShape::Capsule { radius, half_height } => (Box::new(Capsule::new_y(half_height, radius)), to_z),
        }
    }
}

/// The pre-shaped hand used for collision tests.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HandModel {
    /// Spread of F1/F2 (rad): 0 = F1 and F2 side by side opposite F3 (the opposing grasp of §6.4.1);
    /// π/3 = the three fingers equidistant (the naive baseline of §6.5.1).
    pub spread: f64,
    /// Inner-link flexion of the pre-shape (rad, 0 = fingers straight out parallel to the palm).
    pub flexion: f64,
    /// Length (m) of the wrist capsule behind the palm (stands in for the forearm's end).
    pub wrist_length: f64,
    /// A hand part closer than this (m) to the object or table counts as a collision.
    pub clearance: f64,
}

impl Default for HandModel {
    fn default() -> Self {
        Self {
            spread: 0.0,
            flexion: 0.6,
            wrist_length: 0.10,
            clearance: 0.0,
        }
    }
}

/// Palm-frame geometry of the BH8-280 in `assets/dexter.urdf`, shifted to the palm-surface frame.
const PALM_HALF: [f64; 3] = [0.045, 0.045, 0.04];
const PALM_SURFACE_Z: f64 = 0.08;
const KNUCKLE_Z: f64 = 0.0754;
const KNUCKLE_RADIAL: f64 = 0.05;
const INNER_LEN: f64 = 0.06994;
const OUTER_LEN: f64 = 0.05;
const FINGER_RADIUS: f64 = 0.01;
const WRIST_RADIUS: f64 = 0.04;

impl HandModel {
    /// The hand's convex parts as (shape, pose in the palm-surface frame).
    fn parts(&self) -> Vec<(Box<dyn Shape>, DPose3)> {
        let mut parts: Vec<(Box<dyn Shape>, DPose3)> = vec![
            (
                Box::new(Cuboid::new(DVec3::from_array(PALM_HALF))),
                DPose3::from_translation(DVec3::new(0.0, 0.0, -PALM_HALF[2])),
            ),
            (
                Box::new(Capsule::new(
                    DVec3::new(0.0, 0.0, -2.0 * PALM_HALF[2] - WRIST_RADIUS),
                    DVec3::new(
                        0.0,
                        0.0,
                        -2.0 * PALM_HALF[2] - WRIST_RADIUS - self.wrist_length.max(0.0),
                    ),
                    WRIST_RADIUS,
                )),
                DPose3::IDENTITY,
            ),
        ];
        let s = self.spread;
        let fingers = [
            (DVec3::new(-0.025, 0.0, 0.0), DVec3::new(-s.sin(), -s.cos(), 0.0)),
            (DVec3::new(0.025, 0.0, 0.0), DVec3::new(s.sin(), -s.cos(), 0.0)),
            (DVec3::ZERO, DVec3::new(0.0, 1.0, 0.0)),
        ];
        let m = self.flexion;
        let outer_angle = m + std::f64::consts::FRAC_PI_4 + m / 3.0;
        for (base, dir) in fingers {
            let knuckle = base + dir * KNUCKLE_RADIAL + DVec3::new(0.0, 0.0, KNUCKLE_Z - PALM_SURFACE_Z);
            let inner_end = knuckle + (dir * m.cos() + DVec3::Z * m.sin()) * INNER_LEN;
            let tip = inner_end + (dir * outer_angle.cos() + DVec3::Z * outer_angle.sin()) * OUTER_LEN;
            parts.push((
                Box::new(Capsule::new(knuckle, inner_end, FINGER_RADIUS)),
                DPose3::IDENTITY,
            ));
            parts.push((Box::new(Capsule::new(inner_end, tip, FINGER_RADIUS)), DPose3::IDENTITY));
        }
        parts
    }
}

/// Where the object and table are and where the arm reaches from (world frame, z up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GraspScene {
    /// The object's shape.
    pub shape: ObjectShape,
    /// Pose of the object's shape frame in the world.
    pub world_from_object: Isometry3<f64>,
    /// World position of the pre-grasps' frame origin (the visual centroid); the frame's axes are
    /// the world's.
    pub centroid: Vector3<f64>,
    /// Height of the table top (m); everything below is solid.
    pub table_height: f64,
    /// The point distances are ranked from (e.g. the shoulder of the arm that will grasp).
    pub reach_origin: Vector3<f64>,
}

/// Why a candidate was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Rejection {
    /// The hand would intersect the object.
    HitsObject,
    /// The hand would intersect the table.
    HitsTable,
}

/// A collision-free candidate with its world pose and reach distance.
#[derive(Debug, Clone, PartialEq)]
pub struct RankedPreGrasp {
    /// The candidate.
    pub pre_grasp: PreGrasp,
    /// Palm-surface pose in the world.
    pub world_from_palm: Isometry3<f64>,
    /// Distance (m) from the reach origin to the palm surface.
    pub reach_distance: f64,
}

/// The outcome of [`filter_and_rank`].
#[derive(Debug, Clone, PartialEq)]
pub struct FilterResult {
    /// Collision-free candidates, nearest to the reach origin first.
    pub kept: Vec<RankedPreGrasp>,
    /// Dropped candidates and why.
    pub rejected: Vec<(PreGrasp, Rejection)>,
}

fn to_pose(p: &Isometry3<f64>) -> DPose3 {
    let q = p.rotation.quaternion();
    let t = p.translation.vector;
    DPose3::from_parts(DVec3::new(t.x, t.y, t.z), DQuat::from_xyzw(q.i, q.j, q.k, q.w))
}

/// Drops candidates whose hand (pre-shaped as `hand`) would touch the object or the table, and
/// sorts the rest by distance from `scene.reach_origin` (ties keep input order).
pub fn filter_and_rank(candidates: &[PreGrasp], scene: &GraspScene, hand: &HandModel) -> Result<FilterResult> {
    scene.shape.validate()?;
    check_finite(|| "scene.centroid".into(), scene.centroid.as_slice())?;
    check_finite(|| "scene.reach_origin".into(), scene.reach_origin.as_slice())?;
    check_finite(|| "scene.table_height".into(), &[scene.table_height])?;
    check_finite(
        || "hand".into(),
        &[hand.spread, hand.flexion, hand.wrist_length, hand.clearance],
    )?;
    let parts = hand.parts();
    let (obj_shape, obj_local) = scene.shape.parry();
    let obj_pose = to_pose(&scene.world_from_object) * obj_local;
    let table = HalfSpace::new(DVec3::Z);
    let table_pose = DPose3::from_translation(DVec3::new(0.0, 0.0, scene.table_height));
    let touches = |pose: &DPose3, shape: &dyn Shape, other_pose: &DPose3, other: &dyn Shape| -> bool {
        match parry3d_f64::query::distance(pose, shape, other_pose, other) {
            Ok(d) => d.distance <= hand.clearance,
            // Every pair used here is supported; count an unsupported one as a collision.
            Err(_) => true,
        }
    };
    let mut kept = Vec::new();
    let mut rejected = Vec::new();
    for c in candidates {
        check_finite(|| "pre_grasp.position".into(), &c.position)?;
        check_finite(|| "pre_grasp.orientation".into(), &c.orientation)?;
        let world_from_palm = Isometry3::from_parts(
            nalgebra::Translation3::from(scene.centroid + c.position()),
            c.orientation(),
        );
        let palm_pose = to_pose(&world_from_palm);
        let mut why = None;
        for (shape, local) in &parts {
            let pose = palm_pose * *local;
            if touches(&pose, shape.as_ref(), &table_pose, &table) {
                why = Some(Rejection::HitsTable);
                break;
            }
            if touches(&pose, shape.as_ref(), &obj_pose, obj_shape.as_ref()) {
                why = Some(Rejection::HitsObject);
                break;
            }
        }
        match why {
            Some(r) => rejected.push((c.clone(), r)),
            None => kept.push(RankedPreGrasp {
                pre_grasp: c.clone(),
                reach_distance: (world_from_palm.translation.vector - scene.reach_origin).norm(),
                world_from_palm,
            }),
        }
    }
    kept.sort_by(|a, b| a.reach_distance.total_cmp(&b.reach_distance));
    Ok(FilterResult { kept, rejected })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::quat_array;
    use nalgebra::UnitQuaternion;

    fn top_down(pos: [f64; 3]) -> PreGrasp {
        // Palm normal (+z hand) pointing down.
        let rot = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI);
        PreGrasp {
            prototype: None,
            orientation_index: None,
            position: pos,
            orientation: quat_array(&rot),
        }
    }

    #[test]
    fn filters_object_and_table_and_ranks_by_reach() {
        let scene = GraspScene {
            shape: ObjectShape::Box {
                half_extents: [0.03, 0.03, 0.05],
            },
            world_from_object: Isometry3::translation(0.6, 0.0, 0.05),
            centroid: Vector3::new(0.6, 0.0, 0.05),
            table_height: 0.0,
            reach_origin: Vector3::new(0.0, 0.0, 0.5),
        };
        let hand = HandModel::default();
        let cands = vec![
            top_down([0.0, 0.0, 0.25]),  // well above: fine
            top_down([0.0, 0.0, 0.0]),   // inside the object
            top_down([0.3, 0.0, -0.02]), // palm at the table, away from the object
            top_down([-0.1, 0.0, 0.25]), // nearer the reach origin
        ];
        let r = filter_and_rank(&cands, &scene, &hand).unwrap();
        assert_eq!(r.kept.len(), 2, "{:?}", r.rejected);
        assert_eq!(r.kept[0].pre_grasp.position, [-0.1, 0.0, 0.25]);
        assert!(r.rejected.contains(&(cands[1].clone(), Rejection::HitsObject)));
        assert!(r.rejected.contains(&(cands[2].clone(), Rejection::HitsTable)));
    }
}

//! Catalog shapes as parry shapes, and the few geometric facts the simulator needs about them.
//!
//! Parry's cylinders and capsules have their axis along local **y**; our catalog puts it along local
//! **z**. [`to_parry`] therefore returns the shape with the transform from the parry shape's frame to
//! the object frame: `world_from_shape = world_from_object * object_from_shape`.

use control_basis::math::{Iso3, Rot3, Vec3};
use parry3d_f64::shape::SharedShape;
use serde::{Deserialize, Serialize};

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

impl Shape {
    /// The `kind` string of the shape in TOML (`box`, `cylinder`, `sphere`, `capsule`).
    pub fn kind(&self) -> &'static str {
        match self {
            Shape::Box { .. } => "box",
            Shape::Cylinder { .. } => "cylinder",
            Shape::Sphere { .. } => "sphere",
            Shape::Capsule { .. } => "capsule",
        }
    }
}

/// The parry shape of `shape` and `object_from_shape` (identity for boxes and spheres, +90° about x
/// for cylinders and capsules so that their axis is the object's z).
pub fn to_parry(shape: &Shape) -> (SharedShape, Iso3) {
    let axis_to_z = Iso3::from_parts(
        nalgebra::Translation3::identity(),
        Rot3::from_axis_angle(&Vec3::x_axis(), std::f64::consts::FRAC_PI_2),
    );
    match *shape {
        Shape::Box { size } => (
            SharedShape::cuboid(size[0] / 2.0, size[1] / 2.0, size[2] / 2.0),
            Iso3::identity(),
        ),
        Shape::Sphere { radius } => (SharedShape::ball(radius), Iso3::identity()),
        Shape::Cylinder { radius, height } => (SharedShape::cylinder(height / 2.0, radius), axis_to_z),
        Shape::Capsule { radius, height } => (SharedShape::capsule_y(height / 2.0, radius), axis_to_z),
    }
}

/// Half the extent of `shape` along the unit direction `dir` given in the object frame (its support
/// distance; all catalog shapes are centrally symmetric).
pub fn support_half_extent(shape: &Shape, dir: &Vec3) -> f64 {
    let d = dir.normalize();
    match *shape {
        Shape::Box { size } => 0.5 * (size[0] * d.x.abs() + size[1] * d.y.abs() + size[2] * d.z.abs()),
        Shape::Sphere { radius } => radius,
        Shape::Cylinder { radius, height } => 0.5 * height * d.z.abs() + radius * (1.0 - d.z * d.z).max(0.0).sqrt(),
        Shape::Capsule { radius, height } => 0.5 * height * d.z.abs() + radius,
    }
}

/// Volume (m³).
pub fn volume(shape: &Shape) -> f64 {
    use std::f64::consts::PI;
    match *shape {
        Shape::Box { size } => size[0] * size[1] * size[2],
        Shape::Sphere { radius } => 4.0 / 3.0 * PI * radius.powi(3),
        Shape::Cylinder { radius, height } => PI * radius * radius * height,
        Shape::Capsule { radius, height } => PI * radius * radius * height + 4.0 / 3.0 * PI * radius.powi(3),
    }
}

/// Radius of the smallest sphere about the origin that holds the shape.
pub fn bounding_radius(shape: &Shape) -> f64 {
    match *shape {
        Shape::Box { size } => 0.5 * (size[0] * size[0] + size[1] * size[1] + size[2] * size[2]).sqrt(),
        Shape::Sphere { radius } => radius,
        Shape::Cylinder { radius, height } => (radius * radius + 0.25 * height * height).sqrt(),
        Shape::Capsule { radius, height } => radius + 0.5 * height,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cylinder_axis_is_object_z() {
        let s = Shape::Cylinder {
            radius: 0.03,
            height: 0.2,
        };
        let (shape, object_from_shape) = to_parry(&s);
        let aabb = shape.compute_aabb(&crate::convert::iso_to_glam(&object_from_shape));
        assert!((aabb.maxs.z - 0.1).abs() < 1e-12 && (aabb.maxs.x - 0.03).abs() < 1e-12);
        assert!((support_half_extent(&s, &Vec3::z()) - 0.1).abs() < 1e-15);
    }
}

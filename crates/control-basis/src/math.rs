//! The one place that names the math types used across pbd.
//!
//! Everything is `f64` and `nalgebra`. Poses are [`Iso3`]: `world_from_link * point_in_link`
//! gives the point in world. Rotations are unit quaternions internally; matrices are exposed where a
//! user expects them (printing, JSON).

use nalgebra::{Isometry3, Matrix3, Translation3, Unit, UnitQuaternion, Vector3};

/// A rigid transform (rotation + translation), `a_from_b`.
pub type Iso3 = Isometry3<f64>;
/// A 3-vector in metres (positions) or radians (rotation vectors).
pub type Vec3 = Vector3<f64>;
/// A unit 3-vector (joint axes).
pub type UnitVec3 = Unit<Vector3<f64>>;
/// A rotation.
pub type Rot3 = UnitQuaternion<f64>;
/// A 3×3 matrix.
pub type Mat3 = Matrix3<f64>;

/// URDF `origin` (`xyz`, `rpy` with fixed-axis roll-pitch-yaw, R = Rz(y) Ry(p) Rx(r)) as an isometry.
pub fn iso_from_xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Iso3 {
    Iso3::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        Rot3::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}

/// The rotation vector (axis·angle, angle in [0, π]) of `rot`: the SO(3) logarithm.
///
/// This is the proper orientation error used by the orientation potential: its norm is the geodesic
/// distance on SO(3), unlike the difference of Euler angles or of rotation matrix entries.
pub fn rotation_log(rot: &Rot3) -> Vec3 {
    rot.scaled_axis()
}

/// `[v]×`, the skew-symmetric matrix with `[v]× w = v × w`.
pub fn skew(v: &Vec3) -> Mat3 {
    Mat3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

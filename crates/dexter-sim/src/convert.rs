//! The one place where nalgebra (pbd's math) meets glam (rapier's and parry's math).
//!
//! Everything outside this module speaks [`control_basis::math`] types; rapier and parry types are
//! converted here and nowhere else.

use control_basis::math::{Iso3, Rot3, Vec3};
use nalgebra::{Quaternion, Translation3, UnitQuaternion};
use parry3d_f64::glamx::{DPose3, DQuat, DVec3};

/// nalgebra vector → glam.
#[inline]
pub fn vec_to_glam(v: &Vec3) -> DVec3 {
    DVec3::new(v.x, v.y, v.z)
}

/// glam vector → nalgebra.
#[inline]
pub fn vec_from_glam(v: DVec3) -> Vec3 {
    Vec3::new(v.x, v.y, v.z)
}

/// nalgebra rotation → glam quaternion.
#[inline]
pub fn rot_to_glam(r: &Rot3) -> DQuat {
    let q = r.quaternion();
    DQuat::from_xyzw(q.i, q.j, q.k, q.w)
}

/// glam quaternion → nalgebra rotation (renormalised).
#[inline]
pub fn rot_from_glam(q: DQuat) -> Rot3 {
    UnitQuaternion::from_quaternion(Quaternion::new(q.w, q.x, q.y, q.z))
}

/// nalgebra isometry → glam pose.
#[inline]
pub fn iso_to_glam(p: &Iso3) -> DPose3 {
    DPose3::from_parts(vec_to_glam(&p.translation.vector), rot_to_glam(&p.rotation))
}

/// glam pose → nalgebra isometry.
#[inline]
pub fn iso_from_glam(p: &DPose3) -> Iso3 {
    Iso3::from_parts(
        Translation3::from(vec_from_glam(p.translation)),
        rot_from_glam(p.rotation),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use control_basis::math::iso_from_xyz_rpy;

    #[test]
    fn round_trip_is_exact_enough() {
        let p = iso_from_xyz_rpy([0.1, -0.2, 0.3], [0.4, -0.5, 0.6]);
        let back = iso_from_glam(&iso_to_glam(&p));
        assert!((back.to_homogeneous() - p.to_homogeneous()).abs().max() < 1e-15);
        let pt = Vec3::new(0.3, 0.2, -0.1);
        let a = p * nalgebra::Point3::from(pt);
        let b = iso_to_glam(&p) * vec_to_glam(&pt);
        assert!((a.coords - vec_from_glam(b)).norm() < 1e-15);
    }
}

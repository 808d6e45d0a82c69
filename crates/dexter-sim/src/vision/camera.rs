//! The simulated cameras' specification ([`CameraSpec`]) as the robot's calibration: intrinsics and
//! cameras built from a spec.

use crate::error::SimError;
use crate::scene::CameraSpec;
use control_basis::hardware::{Camera, Intrinsics};
use control_basis::math::{Iso3, Vec3};

pub use control_basis::hardware::MAX_IMAGE_SIDE;

fn invalid(field: &str, message: String) -> SimError {
    SimError::Invalid {
        path: "<camera>".into(),
        field: field.to_owned(),
        message,
    }
}

/// Checks a camera specification: sizes in 1..=[`MAX_IMAGE_SIDE`], field of view in (0°, 179°],
/// non-negative finite noise.
pub fn validate_spec(spec: &CameraSpec) -> Result<(), SimError> {
    for (field, side) in [("camera.width", spec.width), ("camera.height", spec.height)] {
        if side == 0 || side > MAX_IMAGE_SIDE {
            return Err(invalid(field, format!("{side} px is not in 1..={MAX_IMAGE_SIDE}")));
        }
    }
    if !(spec.hfov_deg.is_finite() && spec.hfov_deg > 0.0 && spec.hfov_deg <= 179.0) {
        return Err(invalid(
            "camera.hfov_deg",
            format!("{} is not in (0, 179]", spec.hfov_deg),
        ));
    }
    if !(spec.pixel_noise.is_finite() && spec.pixel_noise >= 0.0) {
        return Err(invalid(
            "camera.pixel_noise",
            format!("{} is not a finite value >= 0", spec.pixel_noise),
        ));
    }
    Ok(())
}

impl CameraSpec {
    /// The intrinsic calibration of this spec.
    pub fn intrinsics(&self) -> Intrinsics {
        Intrinsics {
            width: self.width,
            height: self.height,
            hfov_deg: self.hfov_deg,
        }
    }
}

/// Cameras built from a scene's [`CameraSpec`].
pub trait SpecCamera: Sized {
    /// A camera with the intrinsics of `spec` at `world_from_optical`.
    fn from_spec(spec: &CameraSpec, world_from_optical: Iso3) -> Result<Self, SimError>;
    /// A camera at `eye` whose optical axis points at `target`, without roll.
    fn look_at(spec: &CameraSpec, eye: Vec3, target: Vec3) -> Result<Self, SimError>;
}

impl SpecCamera for Camera {
    fn from_spec(spec: &CameraSpec, world_from_optical: Iso3) -> Result<Self, SimError> {
        validate_spec(spec)?;
        Camera::new(&spec.intrinsics(), world_from_optical).map_err(|e| invalid("camera.pose", e.to_string()))
    }

    fn look_at(spec: &CameraSpec, eye: Vec3, target: Vec3) -> Result<Self, SimError> {
        let pose = Camera::pose_looking_at(eye, target).map_err(|e| invalid("camera.target", e.to_string()))?;
        Self::from_spec(spec, pose)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn project_and_ray_agree() {
        let cam = Camera::look_at(
            &CameraSpec::default(),
            Vec3::new(0.05, 0.06, 1.5),
            Vec3::new(0.6, 0.0, 0.8),
        )
        .unwrap();
        let (u, v) = cam.project(&Vec3::new(0.6, 0.0, 0.8)).unwrap();
        assert!((u - cam.cx).abs() < 1e-9 && (v - cam.cy).abs() < 1e-9);
        let p = Vec3::new(0.5, 0.2, 0.75);
        let (u, v) = cam.project(&p).unwrap();
        let (o, d) = cam.ray(u, v);
        let q = o + d * (p - o).dot(&d);
        assert!((q - p).norm() < 1e-12);
        // image x points right: a point to the camera's right (−y) has larger u.
        let (u2, _) = cam.project(&Vec3::new(0.6, -0.1, 0.8)).unwrap();
        assert!(u2 > cam.cx);
        // image y points down: a lower point has larger v.
        let (_, v2) = cam.project(&Vec3::new(0.6, 0.0, 0.7)).unwrap();
        assert!(v2 > cam.cy);
        assert!(cam.project(&Vec3::new(-1.0, 0.0, 1.5)).is_none());
    }

    #[test]
    fn bad_specs_are_errors() {
        let pose = Iso3::identity();
        let mut s = CameraSpec {
            width: 0,
            ..CameraSpec::default()
        };
        assert!(Camera::from_spec(&s, pose).is_err());
        s = CameraSpec {
            hfov_deg: f64::NAN,
            ..CameraSpec::default()
        };
        assert!(Camera::from_spec(&s, pose).is_err());
        s = CameraSpec {
            pixel_noise: -1.0,
            ..CameraSpec::default()
        };
        assert!(Camera::from_spec(&s, pose).is_err());
        assert!(Camera::look_at(&CameraSpec::default(), Vec3::zeros(), Vec3::new(0.0, 0.0, -1.0)).is_err());
    }
}

//! Pinhole cameras in the ROS optical convention.

use crate::error::SimError;
use crate::scene::CameraSpec;
use control_basis::math::{Iso3, Rot3, Vec3};
use nalgebra::{Matrix3, Point3, Translation3};

pub use crate::scene::MAX_IMAGE_SIDE;

/// A pinhole camera without distortion.
///
/// The optical frame follows ROS: z along the viewing axis, x to the right of the image, y down.
/// Pixel `(u, v)` is column `u`, row `v`; pixel centres are at integer coordinates, so the image
/// spans `[-0.5, width - 0.5] × [-0.5, height - 0.5]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Pose of the optical frame in the world.
    pub world_from_optical: Iso3,
    /// Image width (px).
    pub width: u32,
    /// Image height (px).
    pub height: u32,
    /// Focal length along u (px).
    pub fx: f64,
    /// Focal length along v (px).
    pub fy: f64,
    /// Principal point u (px).
    pub cx: f64,
    /// Principal point v (px).
    pub cy: f64,
}

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

fn finite_iso(p: &Iso3) -> bool {
    p.translation.vector.iter().all(|x| x.is_finite()) && p.rotation.coords.iter().all(|x| x.is_finite())
}

impl Camera {
    /// A camera with the intrinsics of `spec` (square pixels, principal point at the image centre,
    /// `fx = (width / 2) / tan(hfov / 2)`) at `world_from_optical`.
    pub fn from_spec(spec: &CameraSpec, world_from_optical: Iso3) -> Result<Self, SimError> {
        validate_spec(spec)?;
        if !finite_iso(&world_from_optical) {
            return Err(invalid("camera.pose", "the pose is not finite".into()));
        }
        let fx = 0.5 * spec.width as f64 / (0.5 * spec.hfov_deg.to_radians()).tan();
        Ok(Self {
            world_from_optical,
            width: spec.width,
            height: spec.height,
            fx,
            fy: fx,
            cx: 0.5 * (spec.width as f64 - 1.0),
            cy: 0.5 * (spec.height as f64 - 1.0),
        })
    }

    /// A camera at `eye` whose optical axis points at `target`, with the image x axis horizontal
    /// (no roll about the optical axis; world z is up). Fails if the axis is vertical or degenerate.
    pub fn look_at(spec: &CameraSpec, eye: Vec3, target: Vec3) -> Result<Self, SimError> {
        Self::from_spec(spec, optical_look_at(eye, target)?)
    }

    /// `world_from_optical` for a camera at `eye` looking at `target` without roll (see [`Camera::look_at`]).
    pub fn pose_looking_at(eye: Vec3, target: Vec3) -> Result<Iso3, SimError> {
        optical_look_at(eye, target)
    }

    /// The camera centre in the world.
    pub fn position(&self) -> Vec3 {
        self.world_from_optical.translation.vector
    }

    /// The viewing direction (optical z) in the world.
    pub fn axis(&self) -> Vec3 {
        self.world_from_optical.rotation * Vec3::z()
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Pixel coordinates of a world point in front of the camera, whether or not inside the image.
    pub fn project_unbounded(&self, p_world: &Vec3) -> Option<(f64, f64)> {
        let p = self.world_from_optical.inverse_transform_point(&Point3::from(*p_world));
        (p.z > 1e-9 && p.z.is_finite()).then(|| (self.fx * p.x / p.z + self.cx, self.fy * p.y / p.z + self.cy))
    }

    /// Pixel coordinates of a world point, or `None` if it is behind the camera or outside the image.
    pub fn project(&self, p_world: &Vec3) -> Option<(f64, f64)> {
        self.project_unbounded(p_world).filter(|&(u, v)| self.contains(u, v))
    }

    /// Whether `(u, v)` lies on the image.
    pub fn contains(&self, u: f64, v: f64) -> bool {
        (-0.5..=self.width as f64 - 0.5).contains(&u) && (-0.5..=self.height as f64 - 0.5).contains(&v)
    }

    /// The ray through pixel coordinates `(u, v)`: (origin, unit direction), in the world.
    pub fn ray(&self, u: f64, v: f64) -> (Vec3, Vec3) {
        let d = Vec3::new((u - self.cx) / self.fx, (v - self.cy) / self.fy, 1.0).normalize();
        (self.position(), self.world_from_optical.rotation * d)
    }

    /// Size in metres of one pixel at depth `z` (along the optical axis).
    pub fn metres_per_pixel(&self, z: f64) -> f64 {
        z / (0.5 * (self.fx + self.fy))
    }
}

fn optical_look_at(eye: Vec3, target: Vec3) -> Result<Iso3, SimError> {
    let fwd = target - eye;
    let n = fwd.norm();
    if !(n.is_finite() && n > 1e-9) {
        return Err(invalid(
            "camera.target",
            "eye and target coincide or are not finite".into(),
        ));
    }
    let z = fwd / n;
    let right = z.cross(&Vec3::z());
    if right.norm() < 1e-9 {
        return Err(invalid(
            "camera.target",
            "the optical axis is vertical; the roll is undefined".into(),
        ));
    }
    let x = right.normalize();
    let y = z.cross(&x);
    let rot = Rot3::from_matrix(&Matrix3::from_columns(&[x, y, z]));
    Ok(Iso3::from_parts(Translation3::from(eye), rot))
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

//! The hardware interfaces: what a robot's computer can read and command — nothing else.
//!
//! A real Dexter offers joint encoders and motor units (the [`Plant`] below them), fingertip
//! six-axis force/torque sensors, calibrated cameras and a clock. The robot side of pbd (skills,
//! perception, the executive) reaches the world only through [`Hardware`], so the same code runs on
//! the simulator, on a kinematic plant with scripted sensors, or on the robot itself, and it cannot
//! read what a real robot could not sense (object poses, identities, shapes). This is the seed's
//! premise (§3.2, §4.3): the robot acts on the convergence of its own controllers on its own percepts.
//!
//! Camera extrinsics are *not* part of a frame: the robot knows where its cameras are from its own
//! kinematics (the optical-frame links of its URDF at the measured joint angles).

use crate::error::CbError;
use crate::math::{Iso3, Rot3, Vec3};
use crate::model::RobotModel;
use crate::plant::Plant;
use nalgebra::{Matrix3, Point3, Translation3};

/// Largest image side (px) any camera may have.
pub const MAX_IMAGE_SIDE: u32 = 4096;

/// An 8-bit RGB image, row-major.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Image {
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// `3 · width · height` bytes: R, G, B of pixel (0, 0), then (1, 0), …
    pub rgb: Vec<u8>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            rgb: vec![0; 3 * width as usize * height as usize],
        }
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The pixel at column `u`, row `v`, if inside.
    pub fn pixel(&self, u: u32, v: u32) -> Option<[u8; 3]> {
        (u < self.width && v < self.height).then(|| self.px(v as usize * self.width as usize + u as usize))
    }

    /// The pixel with linear index `i = v · width + u` (panics if out of range).
    #[inline]
    pub fn px(&self, i: usize) -> [u8; 3] {
        [self.rgb[3 * i], self.rgb[3 * i + 1], self.rgb[3 * i + 2]]
    }

    /// Resizes (keeping the allocation when it is large enough); contents are unspecified.
    pub fn resize(&mut self, width: u32, height: u32) {
        self.width = width;
        self.height = height;
        self.rgb.resize(3 * width as usize * height as usize, 0);
    }

    /// Copies `other` into `self`, reusing the allocation.
    pub fn copy_from(&mut self, other: &Image) {
        self.width = other.width;
        self.height = other.height;
        self.rgb.clear();
        self.rgb.extend_from_slice(&other.rgb);
    }

    /// Writes a binary PPM (P6), for debugging.
    pub fn write_ppm(&self, mut out: impl std::io::Write) -> std::io::Result<()> {
        write!(out, "P6\n{} {}\n255\n", self.width, self.height)?;
        out.write_all(&self.rgb)
    }

    /// Saves a binary PPM (P6) file, for debugging.
    pub fn save_ppm(&self, path: impl AsRef<std::path::Path>) -> std::io::Result<()> {
        use std::io::Write;
        let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
        self.write_ppm(&mut f)?;
        f.flush()
    }
}

/// A camera's intrinsic calibration: image size and horizontal field of view (square pixels,
/// principal point at the image centre, no distortion).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Image width (px).
    pub width: u32,
    /// Image height (px).
    pub height: u32,
    /// Horizontal field of view (degrees).
    pub hfov_deg: f64,
}

impl Intrinsics {
    /// Checks sizes in 1..=[`MAX_IMAGE_SIDE`] and a field of view in (0°, 179°].
    pub fn validate(&self) -> Result<(), CbError> {
        for (name, side) in [("camera.width", self.width), ("camera.height", self.height)] {
            if side == 0 || side > MAX_IMAGE_SIDE {
                return Err(CbError::InvalidParameter {
                    name,
                    value: f64::from(side),
                    expected: "an image side in 1..=4096 px",
                });
            }
        }
        if !(self.hfov_deg.is_finite() && self.hfov_deg > 0.0 && self.hfov_deg <= 179.0) {
            return Err(CbError::InvalidParameter {
                name: "camera.hfov_deg",
                value: self.hfov_deg,
                expected: "a field of view in (0, 179] degrees",
            });
        }
        Ok(())
    }
}

/// A pinhole camera without distortion, at a pose.
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

fn finite_iso(p: &Iso3) -> bool {
    p.translation.vector.iter().all(|x| x.is_finite()) && p.rotation.coords.iter().all(|x| x.is_finite())
}

impl Camera {
    /// A camera with `intrinsics` (`fx = (width / 2) / tan(hfov / 2)`) at `world_from_optical`.
    pub fn new(intrinsics: &Intrinsics, world_from_optical: Iso3) -> Result<Self, CbError> {
        intrinsics.validate()?;
        if !finite_iso(&world_from_optical) {
            return Err(CbError::InvalidParameter {
                name: "camera.pose",
                value: f64::NAN,
                expected: "a finite pose",
            });
        }
        let fx = 0.5 * intrinsics.width as f64 / (0.5 * intrinsics.hfov_deg.to_radians()).tan();
        Ok(Self {
            world_from_optical,
            width: intrinsics.width,
            height: intrinsics.height,
            fx,
            fy: fx,
            cx: 0.5 * (intrinsics.width as f64 - 1.0),
            cy: 0.5 * (intrinsics.height as f64 - 1.0),
        })
    }

    /// `world_from_optical` for a camera at `eye` looking at `target` without roll (image x
    /// horizontal; world z is up). Fails if the axis is vertical or degenerate.
    pub fn pose_looking_at(eye: Vec3, target: Vec3) -> Result<Iso3, CbError> {
        let fwd = target - eye;
        let n = fwd.norm();
        if !(n.is_finite() && n > 1e-9) {
            return Err(CbError::InvalidParameter {
                name: "camera.target",
                value: n,
                expected: "a target apart from the eye (eye and target coincide or are not finite)",
            });
        }
        let z = fwd / n;
        let right = z.cross(&Vec3::z());
        if right.norm() < 1e-9 {
            return Err(CbError::InvalidParameter {
                name: "camera.target",
                value: z.z,
                expected: "a non-vertical optical axis (the roll is undefined)",
            });
        }
        let x = right.normalize();
        let y = z.cross(&x);
        let rot = Rot3::from_matrix(&Matrix3::from_columns(&[x, y, z]));
        Ok(Iso3::from_parts(Translation3::from(eye), rot))
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

/// One camera of the robot: its name, the URDF link of its optical frame (ROS convention) and its
/// intrinsic calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraInfo {
    /// Name (`head/left`, …).
    pub name: String,
    /// The link of the optical frame in the robot model.
    pub optical_frame: String,
    /// Intrinsics.
    pub intrinsics: Intrinsics,
    /// Per-channel pixel noise (standard deviation, [0, 1]) the calibration measured.
    pub pixel_noise: f64,
}

/// One six-axis force/torque reading (a fingertip sensor), world-aligned: force (N) on the sensor
/// and torque (N·m) about the sensor's origin. A real sensor reports in its own frame; the driver
/// rotates the reading by the sensor link's orientation from forward kinematics.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ForceTorque {
    /// Force (N).
    pub force: [f64; 3],
    /// Torque (N·m).
    pub torque: [f64; 3],
    /// Whether the sensor registers a contact.
    pub in_contact: bool,
}

impl ForceTorque {
    /// |f| (N).
    pub fn force_norm(&self) -> f64 {
        (self.force[0].powi(2) + self.force[1].powi(2) + self.force[2].powi(2)).sqrt()
    }
}

/// A failure of the hardware (a driver error, a broken simulator) — not a skill's outcome.
#[derive(Debug, thiserror::Error)]
pub enum HardwareError {
    /// A device index that does not exist.
    #[error("no {device} {index} (the robot has {count})")]
    NoSuchDevice {
        /// `camera`, `force/torque sensor`, `joint`.
        device: &'static str,
        /// The index asked for.
        index: usize,
        /// How many there are.
        count: usize,
    },
    /// The device failed.
    #[error("{device}: {message}")]
    Device {
        /// Which device.
        device: String,
        /// What went wrong.
        message: String,
    },
    /// A model or parameter error.
    #[error(transparent)]
    Model(#[from] CbError),
    /// The operator asked the robot to stop (Ctrl-C, an e-stop): the run ends here.
    #[error("interrupted: a stop was requested")]
    Interrupted,
}

/// What a robot offers its computer: joint encoders and motor units (through [`Plant`]), their
/// velocities, six-axis force/torque sensors, calibrated cameras and a clock.
///
/// Motor units (§3.1) are setpoint controllers: the control basis writes a position reference and a
/// velocity feed-forward per degree of freedom and reads the encoders back.
pub trait Hardware: Plant {
    /// The robot's own model (its URDF): links, joints, camera and sensor frames.
    fn model(&self) -> &RobotModel;
    /// Encoder readings (rad or m), in the order of [`Plant::joint_names`].
    fn joint_positions(&self) -> &[f64];
    /// Joint velocities (rad/s or m/s), same order.
    fn joint_velocities(&self) -> &[f64];
    /// Sends one motor unit its reference: position `q` and velocity feed-forward `qd`.
    fn set_joint_reference(&mut self, dof: usize, q: f64, qd: f64);
    /// Runs for `dt_secs` with the current references (a simulator steps its world; a robot waits
    /// for the next control period).
    fn advance(&mut self, dt_secs: f64) -> Result<(), HardwareError>;
    /// Names (links) of the force/torque sensors.
    fn force_torque_frames(&self) -> &[String];
    /// Reads every force/torque sensor into `out` (length [`Hardware::force_torque_frames`]).
    fn read_force_torque(&self, out: &mut [ForceTorque]);
    /// The cameras.
    fn cameras(&self) -> &[CameraInfo];
    /// Captures camera `camera`'s current image into `out` — the image alone, as a camera gives
    /// it. What the robot knows of its own body in the image (a self-mask) and of the empty
    /// workspace (backgrounds from a calibration before any object was placed) it computes itself.
    fn capture(&mut self, camera: usize, out: &mut Image) -> Result<(), HardwareError>;
    /// Captures the cameras `cameras` at the same instant, image `k` into `out[k]` — a stereo
    /// pair's two views. The default captures them one after the other; hardware that exposes them
    /// together (or renders them on several cores) overrides it. Errors when the two lengths differ.
    fn capture_many(&mut self, cameras: &[usize], out: &mut [Image]) -> Result<(), HardwareError> {
        capture_one_by_one(self, cameras, out)
    }
    /// Index of the camera named `name`.
    fn camera_index(&self, name: &str) -> Result<usize, HardwareError> {
        let cams = self.cameras();
        cams.iter()
            .position(|c| c.name == name)
            .ok_or(HardwareError::NoSuchDevice {
                device: "camera",
                index: usize::MAX,
                count: cams.len(),
            })
    }
    /// Index of the degree of freedom named `name`.
    fn dof_index(&self, name: &str) -> Result<usize, CbError> {
        self.joint_names()
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| CbError::UnknownJoint { name: name.to_string() })
    }
}

/// [`Hardware::capture_many`] one camera after the other (its default, and the fallback of hardware
/// that captures only some sets at once). Errors when the two lengths differ.
pub fn capture_one_by_one<H: Hardware + ?Sized>(
    hw: &mut H,
    cameras: &[usize],
    out: &mut [Image],
) -> Result<(), HardwareError> {
    if cameras.len() != out.len() {
        return Err(HardwareError::Device {
            device: "cameras".into(),
            message: format!("{} cameras asked for into {} images", cameras.len(), out.len()),
        });
    }
    for (&camera, image) in cameras.iter().zip(out.iter_mut()) {
        hw.capture(camera, image)?;
    }
    Ok(())
}

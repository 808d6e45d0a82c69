//! Calibration of the robot's eyes in its workcell, before any object is placed: for each camera a
//! bank of views of the empty workspace ([`BackgroundBank`]), from which the eyes predict the
//! background at whatever pose the head has during a task.
//!
//! The head visits a grid of pan/tilt poses spanning the table (its corners and edges, and the
//! places at transport height); at each it waits for the head to settle, takes
//! [`CalibrationSettings::frames`] frames per camera (one per camera period) and keeps their mean
//! with the camera pose from its own kinematics. The chassis pair is fixed: one view each. Only
//! [`Hardware::capture`] is used — the same images a task sees — so calibrating a real robot is
//! this same routine run on the cleared table. (The routine is in `calibrate.rs`, this file the
//! calibration as data, which the eyes read.)
//!
//! A calibration is kept in a file ([`Calibration::save`], [`Calibration::load`]; the format is
//! in [`file`]), so that a robot calibrates its cleared workcell once and loads the result for
//! every later run; [`Calibration::check_cameras`] refuses one taken with other cameras.

use std::sync::Arc;

use control_basis::hardware::CameraInfo;

use crate::error::RobotError;
use crate::vision::BackgroundBank;

pub mod file;

pub use file::{CalibrationFileError, FORMAT, VERSION};

/// How the calibration views are taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationSettings {
    /// Frames averaged per view.
    pub frames: usize,
    /// Largest pan step between neighbouring head poses (rad).
    pub pan_step: f64,
    /// Largest tilt step between neighbouring head poses (rad).
    pub tilt_step: f64,
    /// Margin added around the pan/tilt range of the workspace (rad).
    pub margin: f64,
    /// The head has settled when every head joint is this close to its reference (rad)…
    pub settle_tolerance: f64,
    /// …or after this long (s).
    pub settle_timeout: f64,
}

impl Default for CalibrationSettings {
    /// Four frames per view; a grid with steps of at most 0.4 rad in pan and 0.3 rad in tilt (the
    /// 60° × 46° head views overlap by about half), 0.15 rad beyond the workspace.
    fn default() -> Self {
        Self {
            frames: 4,
            pan_step: 0.4,
            tilt_step: 0.3,
            margin: 0.15,
            settle_tolerance: 2e-3,
            settle_timeout: 1.5,
        }
    }
}

/// What the robot measured of its empty workcell: a background bank per camera.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Calibration {
    pub(crate) banks: Vec<(String, BackgroundBank)>,
}

impl Calibration {
    /// A calibration from explicit banks (camera name, bank).
    pub fn from_banks(banks: Vec<(String, BackgroundBank)>) -> Self {
        Self { banks }
    }

    /// The bank of the camera named `camera`.
    pub fn bank(&self, camera: &str) -> Option<&BackgroundBank> {
        self.banks.iter().find(|(n, _)| n == camera).map(|(_, b)| b)
    }

    /// Every (camera name, bank).
    pub fn banks(&self) -> &[(String, BackgroundBank)] {
        &self.banks
    }

    /// Number of views over all cameras.
    pub fn view_count(&self) -> usize {
        self.banks.iter().map(|(_, b)| b.views().len()).sum()
    }

    /// Checks that the calibration was taken with `cameras` (a robot's [`Hardware::cameras`]):
    /// every bank names one of them, and every view has that camera's image size and focal length
    /// (within 0.1 %). A calibration loaded from a file of another robot, or of this one before a
    /// camera changed, is refused here rather than warped into wrong backgrounds. Cameras without a
    /// bank are not an error here ([`crate::eyes::Eyes::new`] refuses the ones it needs).
    ///
    /// [`Hardware::cameras`]: control_basis::Hardware::cameras
    pub fn check_cameras(&self, cameras: &[CameraInfo]) -> Result<(), RobotError> {
        let names = || {
            cameras
                .iter()
                .map(|c| format!("`{}`", c.name))
                .collect::<Vec<_>>()
                .join(", ")
        };
        for (name, bank) in &self.banks {
            let Some(info) = cameras.iter().find(|c| &c.name == name) else {
                return Err(RobotError::invalid(
                    "<calibration>",
                    name,
                    format!(
                        "the calibration has views of a camera the robot does not have (its cameras: {})",
                        names()
                    ),
                ));
            };
            let k = &info.intrinsics;
            let fx = 0.5 * k.width as f64 / (0.5 * k.hfov_deg.to_radians()).tan();
            for view in bank.views() {
                let c = &view.camera;
                if (c.width, c.height) != (k.width, k.height) {
                    return Err(RobotError::invalid(
                        "<calibration>",
                        name,
                        format!(
                            "the calibration's views are {}×{} px, the robot's camera takes {}×{} px \
                             (calibrate this robot again)",
                            c.width, c.height, k.width, k.height
                        ),
                    ));
                }
                // Written so that a focal length that is not a number is refused too.
                let close = (c.fx - fx).abs() <= 1e-3 * fx;
                if !close {
                    return Err(RobotError::invalid(
                        "<calibration>",
                        name,
                        format!(
                            "the calibration's views have a focal length of {:.2} px, the robot's camera \
                             {fx:.2} px ({}° field of view; calibrate this robot again)",
                            c.fx, k.hfov_deg
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// A shared calibration (the eyes of several runs in one workcell use the same one).
pub type SharedCalibration = Arc<Calibration>;

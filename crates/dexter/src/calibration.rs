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

use std::sync::Arc;

use crate::vision::BackgroundBank;

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
}

/// A shared calibration (the eyes of several runs in one workcell use the same one).
pub type SharedCalibration = Arc<Calibration>;

//! What the simulator reports at one instant, for logs (MCAP) and reports.
//!
//! A [`Snapshot`] is plain data: no rapier types, nothing borrowed, so a logger in another crate can
//! turn it into Foxglove messages. Static facts (link names, joint names, the scene) are given once by
//! [`SnapshotHeader`].

use control_basis::math::{Iso3, Vec3};
use serde::{Deserialize, Serialize};

pub use dexter::Arm;

/// Names that do not change during a run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SnapshotHeader {
    /// Independent joint names, in the order of [`Snapshot::q`].
    pub joint_names: Vec<String>,
    /// Names of the robot links whose poses are in [`Snapshot::link_poses`] (every URDF link).
    pub link_names: Vec<String>,
    /// Parent of each link (`None` for the root `world`), same order.
    pub link_parents: Vec<Option<String>>,
    /// Names of the placed objects (presentation names, made unique with `#k` if repeated), in the
    /// order of [`Snapshot::objects`].
    pub object_names: Vec<String>,
}

/// One fingertip's 6-axis force/torque reading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FingertipWrench {
    /// The hand.
    pub arm: Arm,
    /// Finger 1, 2 or 3.
    pub finger: u8,
    /// Force on the finger from contacts (N), in the world frame.
    pub force: [f64; 3],
    /// Torque about the fingertip frame's origin (N·m), world frame.
    pub torque: [f64; 3],
    /// Whether any contact touches the finger's distal link or tip.
    pub in_contact: bool,
}

/// The state of one placed object.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ObjectState {
    /// World pose of the object frame.
    pub pose: Iso3,
    /// Linear velocity (m/s).
    pub linvel: Vec3,
}

/// The simulator at one instant.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Snapshot {
    /// Simulated time (s).
    pub time: f64,
    /// Encoder readings, same order as [`SnapshotHeader::joint_names`] (rad).
    pub q: Vec<f64>,
    /// Joint velocities (rad/s).
    pub qd: Vec<f64>,
    /// Motor setpoints (rad), same order.
    pub q_ref: Vec<f64>,
    /// World pose of every link, same order as [`SnapshotHeader::link_names`].
    pub link_poses: Vec<Iso3>,
    /// Every placed object, same order as [`SnapshotHeader::object_names`].
    pub objects: Vec<ObjectState>,
    /// Fingertip sensors, left hand F1–F3 then right hand F1–F3.
    pub fingertips: Vec<FingertipWrench>,
    /// What the task layer is doing (e.g. `reach left → jif`), empty if nothing.
    pub activity: String,
}

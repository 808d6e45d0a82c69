//! The ROS 2 messages pbd speaks, as serde structs in the field order of their `.msg` definitions
//! (CDR, the encoding of every ROS 2 rmw, serialises fields in declaration order, so these structs
//! are wire-compatible with `sensor_msgs`, `geometry_msgs`, `std_msgs`, `trajectory_msgs` and
//! `builtin_interfaces` of Humble, Iron and Jazzy).

use ros2_client::Message;
use serde::{Deserialize, Serialize};

/// `builtin_interfaces/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, `0..1e9`.
    pub nanosec: u32,
}

impl Time {
    /// The time `secs` (s) since the clock's origin, rounded to the nanosecond; negative or
    /// non-finite times are 0.
    pub fn from_secs(secs: f64) -> Self {
        if !(secs.is_finite() && secs > 0.0) {
            return Self::default();
        }
        let ns = (secs * 1e9).round() as i64;
        Time {
            sec: (ns / 1_000_000_000).min(i64::from(i32::MAX)) as i32,
            nanosec: (ns % 1_000_000_000) as u32,
        }
    }

    /// Seconds since the clock's origin: the whole nanoseconds divided by 10⁹, correctly rounded.
    pub fn secs(&self) -> f64 {
        (f64::from(self.sec) * 1e9 + f64::from(self.nanosec)) / 1e9
    }
}

/// `builtin_interfaces/Duration`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Duration {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, `0..1e9`.
    pub nanosec: u32,
}

impl Duration {
    /// `secs` (s), rounded to the nanosecond.
    pub fn from_secs(secs: f64) -> Self {
        let t = Time::from_secs(secs);
        Duration {
            sec: t.sec,
            nanosec: t.nanosec,
        }
    }

    /// Seconds.
    pub fn secs(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

/// `std_msgs/Header`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Header {
    /// When the data was taken.
    pub stamp: Time,
    /// The frame the data is expressed in.
    pub frame_id: String,
}
impl Message for Header {}

/// `sensor_msgs/JointState`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointState {
    /// Stamp of the reading.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions (rad or m).
    pub position: Vec<f64>,
    /// Velocities (rad/s or m/s).
    pub velocity: Vec<f64>,
    /// Efforts (N·m or N).
    pub effort: Vec<f64>,
}
impl Message for JointState {}

/// `geometry_msgs/Vector3`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl Vector3 {
    /// From an array.
    pub fn from_array(v: [f64; 3]) -> Self {
        Vector3 {
            x: v[0],
            y: v[1],
            z: v[2],
        }
    }
    /// As an array.
    pub fn to_array(self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
}

/// `geometry_msgs/Wrench`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Wrench {
    /// Force (N).
    pub force: Vector3,
    /// Torque (N·m).
    pub torque: Vector3,
}

/// `geometry_msgs/WrenchStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct WrenchStamped {
    /// Stamp and the frame the wrench is expressed in.
    pub header: Header,
    /// The wrench.
    pub wrench: Wrench,
}
impl Message for WrenchStamped {}

/// `sensor_msgs/Image`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Image {
    /// Stamp and the camera's optical frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel encoding (`rgb8`, `bgr8`, `mono8`, …).
    pub encoding: String,
    /// Whether multi-byte values are big-endian.
    pub is_bigendian: u8,
    /// Bytes per row.
    pub step: u32,
    /// The pixels, row by row.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}
impl Message for Image {}

/// `sensor_msgs/RegionOfInterest`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct RegionOfInterest {
    /// Left column.
    pub x_offset: u32,
    /// Top row.
    pub y_offset: u32,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Whether to rectify.
    pub do_rectify: bool,
}

/// `sensor_msgs/CameraInfo`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CameraInfo {
    /// Stamp and the camera's optical frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// `plumb_bob`, `rational_polynomial`, … (empty: none).
    pub distortion_model: String,
    /// Distortion coefficients.
    pub d: Vec<f64>,
    /// Intrinsic matrix, row-major: fx 0 cx / 0 fy cy / 0 0 1.
    pub k: [f64; 9],
    /// Rectification rotation, row-major.
    pub r: [f64; 9],
    /// Projection matrix, row-major 3 × 4.
    pub p: [f64; 12],
    /// Horizontal binning.
    pub binning_x: u32,
    /// Vertical binning.
    pub binning_y: u32,
    /// Region of interest.
    pub roi: RegionOfInterest,
}
impl Message for CameraInfo {}

/// `std_msgs/MultiArrayDimension`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MultiArrayDimension {
    /// Label.
    pub label: String,
    /// Size.
    pub size: u32,
    /// Stride.
    pub stride: u32,
}

/// `std_msgs/MultiArrayLayout`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MultiArrayLayout {
    /// Dimensions.
    pub dim: Vec<MultiArrayDimension>,
    /// Offset of the first element.
    pub data_offset: u32,
}

/// `std_msgs/Float64MultiArray` (what ros2_control's forward command controllers take).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Float64MultiArray {
    /// Layout (ros2_control ignores it).
    pub layout: MultiArrayLayout,
    /// Values.
    pub data: Vec<f64>,
}
impl Message for Float64MultiArray {}

/// `trajectory_msgs/JointTrajectoryPoint`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointTrajectoryPoint {
    /// Positions.
    pub positions: Vec<f64>,
    /// Velocities.
    pub velocities: Vec<f64>,
    /// Accelerations.
    pub accelerations: Vec<f64>,
    /// Efforts.
    pub effort: Vec<f64>,
    /// When to be there, from the trajectory's start.
    pub time_from_start: Duration,
}

/// `trajectory_msgs/JointTrajectory` (ros2_control's joint trajectory controller).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointTrajectory {
    /// Stamp (zero: start now).
    pub header: Header,
    /// Joint names.
    pub joint_names: Vec<String>,
    /// Points.
    pub points: Vec<JointTrajectoryPoint>,
}
impl Message for JointTrajectory {}

/// ROS 2 type names (`package/msg/Type` → DDS `package::msg::dds_::Type_`, which ros2-client forms).
pub mod types {
    /// (package, type) of each message.
    pub const JOINT_STATE: (&str, &str) = ("sensor_msgs", "JointState");
    /// `geometry_msgs/WrenchStamped`.
    pub const WRENCH_STAMPED: (&str, &str) = ("geometry_msgs", "WrenchStamped");
    /// `sensor_msgs/Image`.
    pub const IMAGE: (&str, &str) = ("sensor_msgs", "Image");
    /// `sensor_msgs/CameraInfo`.
    pub const CAMERA_INFO: (&str, &str) = ("sensor_msgs", "CameraInfo");
    /// `std_msgs/Float64MultiArray`.
    pub const FLOAT64_MULTI_ARRAY: (&str, &str) = ("std_msgs", "Float64MultiArray");
    /// `trajectory_msgs/JointTrajectory`.
    pub const JOINT_TRAJECTORY: (&str, &str) = ("trajectory_msgs", "JointTrajectory");
    /// `std_msgs/Header` (camera triggers).
    pub const HEADER: (&str, &str) = ("std_msgs", "Header");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_round_trips_to_the_nanosecond() {
        for s in [0.0, 0.002, 1.5, 123.456_789_012] {
            let t = Time::from_secs(s);
            assert!((t.secs() - s).abs() < 1e-9, "{s} -> {t:?}");
            assert!(t.nanosec < 1_000_000_000);
        }
        assert_eq!(Time::from_secs(f64::NAN), Time::default());
        assert_eq!(Time::from_secs(-1.0), Time::default());
    }
}

//! The ROS 2 messages pbd speaks and records, as serde structs in the field order of their `.msg`
//! definitions (CDR, the encoding of every ROS 2 rmw, serialises fields in declaration order, so
//! these structs are wire-compatible with `sensor_msgs`, `geometry_msgs`, `std_msgs`,
//! `trajectory_msgs`, `tf2_msgs`, `visualization_msgs`, `rcl_interfaces` and `builtin_interfaces`
//! of Humble, Iron and Jazzy). Each has its definition in [`crate::definitions`].

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

/// `geometry_msgs/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w (the scalar part).
    pub w: f64,
}

impl Default for Quaternion {
    /// The identity rotation.
    fn default() -> Self {
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

/// `geometry_msgs/Transform`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Transform {
    /// Translation (m).
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/TransformStamped`: `child_frame_id`'s pose in `header.frame_id`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child's pose in the parent.
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage` (`/tf`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

/// `geometry_msgs/Point`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// Position (m).
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `std_msgs/ColorRGBA` (each 0–1).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ColorRgba {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Opacity.
    pub a: f32,
}

/// `visualization_msgs/Marker` (the Humble definition, which Iron and Jazzy readers accept from
/// the schema a recording carries).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Marker {
    /// Stamp and the frame `pose` is in.
    pub header: Header,
    /// Namespace (with `id`, the marker's identity).
    pub ns: String,
    /// Id within the namespace.
    pub id: i32,
    /// Shape: [`Marker::ARROW`], [`Marker::CUBE`], … .
    #[serde(rename = "type")]
    pub kind: i32,
    /// [`Marker::ADD`], [`Marker::DELETE`] or [`Marker::DELETEALL`].
    pub action: i32,
    /// Pose in `header.frame_id`.
    pub pose: Pose,
    /// Size (m; per shape).
    pub scale: Vector3,
    /// Colour.
    pub color: ColorRgba,
    /// How long it stays (zero: until replaced).
    pub lifetime: Duration,
    /// Whether it moves with its frame after it was received.
    pub frame_locked: bool,
    /// Points (line and list shapes).
    pub points: Vec<Point>,
    /// Per-point colours.
    pub colors: Vec<ColorRgba>,
    /// Text ([`Marker::TEXT_VIEW_FACING`]).
    pub text: String,
    /// Mesh URI ([`Marker::MESH_RESOURCE`]).
    pub mesh_resource: String,
    /// Whether the mesh's own materials are used.
    pub mesh_use_embedded_materials: bool,
}

impl Marker {
    /// An arrow along the pose's x axis: `scale` = length, shaft and head diameters.
    pub const ARROW: i32 = 0;
    /// A box.
    pub const CUBE: i32 = 1;
    /// A sphere (an ellipsoid).
    pub const SPHERE: i32 = 2;
    /// A cylinder along z.
    pub const CYLINDER: i32 = 3;
    /// Text facing the viewer.
    pub const TEXT_VIEW_FACING: i32 = 9;
    /// Add or replace.
    pub const ADD: i32 = 0;
    /// Delete the marker `ns`/`id`.
    pub const DELETE: i32 = 2;
    /// Delete every marker of the topic.
    pub const DELETEALL: i32 = 3;
}

/// `visualization_msgs/MarkerArray`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MarkerArray {
    /// The markers, applied in order.
    pub markers: Vec<Marker>,
}

/// `rcl_interfaces/Log` (`/rosout`'s type; Foxglove's Log panel reads it).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Log {
    /// When.
    pub stamp: Time,
    /// [`Log::DEBUG`] … [`Log::FATAL`].
    pub level: u8,
    /// The logger (node) name.
    pub name: String,
    /// The message.
    pub msg: String,
    /// Source file.
    pub file: String,
    /// Function.
    pub function: String,
    /// Source line.
    pub line: u32,
}

impl Log {
    /// Debug.
    pub const DEBUG: u8 = 10;
    /// Info.
    pub const INFO: u8 = 20;
    /// Warning.
    pub const WARN: u8 = 30;
    /// Error.
    pub const ERROR: u8 = 40;
    /// Fatal.
    pub const FATAL: u8 = 50;
}

/// `sensor_msgs/CompressedImage` (`format` `jpeg` or `png`, image_transport's `compressed`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Stamp and the camera's optical frame.
    pub header: Header,
    /// `jpeg` or `png`.
    pub format: String,
    /// The compressed image.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `foxglove_msgs/CompressedVideo`: one frame of a video stream (`format` `h264`: Annex B, the
/// NAL units of exactly one frame, a keyframe with its SPS and PPS).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CompressedVideo {
    /// Stamp of the frame.
    pub timestamp: Time,
    /// The camera's optical frame.
    pub frame_id: String,
    /// The encoded frame.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
    /// `h264`, `h265`, `vp9` or `av1`.
    pub format: String,
}

/// `geometry_msgs/PoseStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Stamp and the frame the pose is in.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

/// `std_msgs/Float64`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Float64 {
    /// The value.
    pub data: f64,
}

/// `std_msgs/String`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct StringMsg {
    /// The text.
    pub data: String,
}

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
    /// `geometry_msgs/PoseStamped` (a teleoperated hand's palm pose).
    pub const POSE_STAMPED: (&str, &str) = ("geometry_msgs", "PoseStamped");
    /// `std_msgs/Float64` (a teleoperated hand's finger flexion).
    pub const FLOAT64: (&str, &str) = ("std_msgs", "Float64");
}

/// `ros2_client::Message` for each message (what `pbd-ros2` publishes and subscribes).
#[cfg(feature = "ros2-client")]
mod dds {
    use super::*;
    macro_rules! messages {
        ($($t:ty),*) => { $(impl ros2_client::Message for $t {})* };
    }
    messages!(
        Header,
        JointState,
        WrenchStamped,
        Image,
        CameraInfo,
        Float64MultiArray,
        JointTrajectory,
        TfMessage,
        MarkerArray,
        Log,
        CompressedImage,
        StringMsg
    );
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

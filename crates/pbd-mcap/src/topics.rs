//! The topics of a pbd log and pbd's own JSON message helpers.

use crate::messages::{Time, time_ns};
use crate::schemas;

/// Robot links and objects (`foxglove.FrameTransforms`).
pub const TOPIC_TF: &str = "/tf";
/// Table, places and objects (`foxglove.SceneUpdate`).
pub const TOPIC_SCENE: &str = "/scene";
/// Text events (`foxglove.Log`).
pub const TOPIC_LOG: &str = "/log";
/// Joint encoders, velocities and setpoints (`pbd.JointState`).
pub const TOPIC_JOINT_STATES: &str = "/joint_states";
/// The motor references (`sensor_msgs/JointState`, in the ROS 2 encoding only: pbd's JSON
/// `/joint_states` holds them).
pub const TOPIC_JOINT_REFERENCES: &str = "/joint_references";
/// Fingertip force/torque sensors (`pbd.FingertipWrenches`).
pub const TOPIC_FINGERTIPS: &str = "/fingertips";
/// The task layer's activity text (`pbd.Activity`).
pub const TOPIC_ACTIVITY: &str = "/activity";
/// The robot's links drawn from its URDF visuals (`foxglove.SceneUpdate`).
pub const TOPIC_ROBOT: &str = "/robot";
/// Fingertip forces as arrows (`foxglove.SceneUpdate`).
pub const TOPIC_FINGERTIP_ARROWS: &str = "/fingertips/arrows";
/// Pre-grasp candidates of a grasp run (`foxglove.SceneUpdate`).
pub const TOPIC_GRASP_CANDIDATES: &str = "/grasp/candidates";

/// The Foxglove layout for pbd's logs (`assets/foxglove/pbd-layout.json`): the robot, scene and
/// fingertip arrows in 3D, the left head camera, the schema state and ln B10 as plots, fingertip
/// forces, the decisions and the log. Import it in Foxglove with Layouts → Import from file.
pub const FOXGLOVE_LAYOUT: &str = include_str!("../../../assets/foxglove/pbd-layout.json");

/// Where a schema stands, with its monitor observation (`pbd.SchemaState`): the inferred state
/// of a demonstration (`pbd infer`'s companion log) or the executive's during an execution.
pub const TOPIC_SCHEMA_STATE: &str = "/pbd/schema_state";
/// The robot's decision per seen segment: relevance, place, arms (`pbd.Decision`).
pub const TOPIC_DECISION: &str = "/pbd/decision";

/// The JSON Schema of [`TOPIC_SCHEMA_STATE`] for a library with these action names.
pub fn schema_state_schema(action_names: &[&str]) -> serde_json::Value {
    schemas::schema_state(action_names)
}

/// Simulated time `t` (s) as a Foxglove `time` (`{sec, nsec}`), for messages written with
/// [`McapLog::log_json`].
pub fn foxglove_time(t: f64) -> serde_json::Value {
    serde_json::to_value(Time::from_ns(time_ns(t))).unwrap_or(serde_json::Value::Null)
}

/// The JSON Schema of [`TOPIC_DECISION`].
pub fn decision_schema() -> serde_json::Value {
    schemas::decision()
}

/// The topic of a camera's images (`foxglove.CompressedImage` or `foxglove.RawImage`).
pub fn camera_topic(camera_name: &str) -> String {
    format!("/camera/{camera_name}/image")
}

/// The topic of a camera's calibration (`foxglove.CameraCalibration`).
pub fn calibration_topic(camera_name: &str) -> String {
    format!("/camera/{camera_name}/calibration")
}

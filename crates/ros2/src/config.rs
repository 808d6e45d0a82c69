//! The mapping of a robot onto ROS 2 topics (a TOML file; `assets/ros2/dexter.toml` is Dexter's,
//! documented in `docs/src/formats/ros2-config.md`).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::Ros2Error;

/// How motor-unit references are sent (ros2_control's conventions).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum CommandKind {
    /// `std_msgs/Float64MultiArray` of positions, one per joint of `command.joints`
    /// (`forward_command_controller` with the `position` interface).
    Position,
    /// `std_msgs/Float64MultiArray` of `[q₀, q̇₀, q₁, q̇₁, …]`
    /// (`multi_interface_forward_command_controller` with `position` and `velocity`).
    PositionVelocity,
    /// `trajectory_msgs/JointTrajectory` with one point: positions, velocities, and
    /// `time_from_start` = the control period (`joint_trajectory_controller`; also what a
    /// lock-step server, `pbd sim serve --ros2 --lockstep`, advances its world by).
    #[default]
    JointTrajectory,
}

/// The joint-state topic.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointStatesConfig {
    /// Topic of `sensor_msgs/JointState` (joint_state_broadcaster: `/joint_states`).
    pub topic: String,
}

/// The command topic.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommandConfig {
    /// Message and controller convention.
    #[serde(default)]
    pub kind: CommandKind,
    /// Topic (a forward controller's `~/commands`, or a trajectory controller's `~/joint_trajectory`).
    pub topic: String,
    /// The joints commanded, in the controller's order; empty: every joint of the joint states.
    #[serde(default)]
    pub joints: Vec<String>,
}

/// One six-axis force/torque sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceTorqueConfig {
    /// The sensor's link in the robot model (the robot side's name for it).
    pub frame: String,
    /// Topic of `geometry_msgs/WrenchStamped`, with `header.frame_id` either `world_frame` (a
    /// world-aligned reading) or a link of the robot's model (the sensor's own frame: the robot turns
    /// it into the world's axes with its own kinematics); any other frame is refused by name.
    pub topic: String,
}

/// One camera.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraConfig {
    /// The robot side's name (`head/left`, …).
    pub name: String,
    /// The optical-frame link in the robot model.
    pub optical_frame: String,
    /// Topic of `sensor_msgs/Image` (`rgb8`).
    pub image_topic: String,
    /// Topic of `sensor_msgs/CameraInfo` (intrinsics).
    pub info_topic: String,
    /// Topic of `std_msgs/Header` the camera takes software triggers on: a capture publishes one
    /// (stamp = now) and waits for an image at least as new. Absent: a capture takes the newest
    /// image, refused when older than `max_image_age_ms`.
    #[serde(default)]
    pub trigger_topic: Option<String>,
    /// Per-channel pixel noise (standard deviation, [0, 1]) a calibration measured.
    #[serde(default = "default_pixel_noise")]
    pub pixel_noise: f64,
}

/// One teleoperated hand: the teacher's palm pose and finger flexion, as a glove or tracker
/// publishes them (`pbd record --hardware ros2` drives the robot's hand from them; a served
/// simulator with a scripted teacher publishes them).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TeleopConfig {
    /// The robot side's hand (`left`, `right`).
    pub hand: String,
    /// Topic of `geometry_msgs/PoseStamped`: the palm surface's pose in `world_frame` (the stamp is
    /// the sample's time).
    pub pose_topic: String,
    /// Topic of `std_msgs/Float64`: the mean finger flexion (rad, 0 open).
    pub flexion_topic: String,
}

fn default_pixel_noise() -> f64 {
    0.01
}
fn default_node() -> String {
    "pbd".into()
}
fn default_world() -> String {
    "world".into()
}
fn default_timeout_ms() -> u64 {
    2000
}
fn default_image_age_ms() -> u64 {
    200
}

/// A robot on ROS 2: which topics carry its encoders, motor-unit references, force/torque sensors
/// and cameras.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ros2Config {
    /// Node name.
    #[serde(default = "default_node")]
    pub node: String,
    /// Node namespace (`/`).
    #[serde(default)]
    pub namespace: Option<String>,
    /// DDS domain (`ROS_DOMAIN_ID`); absent: `ROS_DOMAIN_ID` from the environment, else 0.
    #[serde(default)]
    pub domain_id: Option<u16>,
    /// The frame world-aligned readings are expressed in.
    #[serde(default = "default_world")]
    pub world_frame: String,
    /// Longest wait for any reading (ms); beyond it the robot stops commanding and the run fails,
    /// naming the topic.
    #[serde(default = "default_timeout_ms")]
    pub timeout_ms: u64,
    /// Oldest image a capture without a trigger accepts (ms, against the newest joint state).
    #[serde(default = "default_image_age_ms")]
    pub max_image_age_ms: u64,
    /// A fingertip registers a contact above this force (N).
    #[serde(default)]
    pub contact_force: f64,
    /// Joint states.
    pub joint_states: JointStatesConfig,
    /// Motor-unit references.
    pub command: CommandConfig,
    /// Force/torque sensors, in the robot side's order.
    #[serde(default)]
    pub force_torque: Vec<ForceTorqueConfig>,
    /// Cameras, in the robot side's order.
    #[serde(default)]
    pub camera: Vec<CameraConfig>,
    /// Teleoperated hands (for recording demonstrations).
    #[serde(default)]
    pub teleop: Vec<TeleopConfig>,
}

/// Dexter's mapping (`assets/ros2/dexter.toml`), built in.
pub const DEXTER_CONFIG: &str = include_str!("../../../assets/ros2/dexter.toml");

impl Ros2Config {
    /// Dexter's built-in mapping.
    pub fn dexter() -> Self {
        Self::from_toml(DEXTER_CONFIG, "<built-in assets/ros2/dexter.toml>").expect("the built-in mapping parses")
    }

    /// Parses and checks a mapping; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, Ros2Error> {
        let cfg: Ros2Config = toml::from_str(text).map_err(|e| Ros2Error::Config {
            file: origin.to_string(),
            message: e.to_string(),
        })?;
        cfg.validate().map_err(|message| Ros2Error::Config {
            file: origin.to_string(),
            message,
        })?;
        Ok(cfg)
    }

    /// Reads and checks a mapping file.
    pub fn open(path: &Path) -> Result<Self, Ros2Error> {
        let text = std::fs::read_to_string(path).map_err(|e| Ros2Error::Config {
            file: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// The DDS domain: the file's, else `ROS_DOMAIN_ID`, else 0.
    pub fn domain(&self) -> Result<u16, Ros2Error> {
        if let Some(d) = self.domain_id {
            return Ok(d);
        }
        match std::env::var("ROS_DOMAIN_ID") {
            Ok(v) if !v.trim().is_empty() => {
                v.trim()
                    .parse::<u16>()
                    .ok()
                    .filter(|d| *d <= 232)
                    .ok_or_else(|| Ros2Error::Config {
                        file: "ROS_DOMAIN_ID".into(),
                        message: format!("`{v}` is not a DDS domain (0..=232)"),
                    })
            }
            _ => Ok(0),
        }
    }

    fn validate(&self) -> Result<(), String> {
        let topic = |what: &str, t: &str| -> Result<(), String> {
            if !t.starts_with('/') {
                return Err(format!(
                    "{what}: `{t}` is not an absolute ROS 2 topic name (e.g. /joint_states)"
                ));
            }
            ros2_client::Name::parse(t)
                .map(|_| ())
                .map_err(|e| format!("{what}: `{t}` is not a ROS 2 topic name ({e:?})"))
        };
        if self.node.is_empty() || !self.node.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(format!("node: `{}` is not a ROS 2 node name", self.node));
        }
        if let Some(d) = self.domain_id
            && d > 232
        {
            return Err(format!("domain_id: {d} is not a DDS domain (0..=232)"));
        }
        if self.timeout_ms == 0 {
            return Err("timeout_ms: must be positive".into());
        }
        if !(self.contact_force.is_finite() && self.contact_force >= 0.0) {
            return Err(format!("contact_force: {} is not a force ≥ 0 N", self.contact_force));
        }
        topic("joint_states.topic", &self.joint_states.topic)?;
        topic("command.topic", &self.command.topic)?;
        for (i, f) in self.force_torque.iter().enumerate() {
            topic(&format!("force_torque[{i}].topic"), &f.topic)?;
            if f.frame.is_empty() {
                return Err(format!("force_torque[{i}].frame: empty"));
            }
        }
        for (i, c) in self.camera.iter().enumerate() {
            topic(&format!("camera[{i}].image_topic"), &c.image_topic)?;
            topic(&format!("camera[{i}].info_topic"), &c.info_topic)?;
            if let Some(t) = &c.trigger_topic {
                topic(&format!("camera[{i}].trigger_topic"), t)?;
            }
            if c.name.is_empty() || c.optical_frame.is_empty() {
                return Err(format!("camera[{i}]: name and optical_frame must be set"));
            }
            if !(c.pixel_noise.is_finite() && (0.0..=1.0).contains(&c.pixel_noise)) {
                return Err(format!("camera[{i}].pixel_noise: {} is not in [0, 1]", c.pixel_noise));
            }
        }
        let mut hands = std::collections::BTreeSet::new();
        for (i, t) in self.teleop.iter().enumerate() {
            topic(&format!("teleop[{i}].pose_topic"), &t.pose_topic)?;
            topic(&format!("teleop[{i}].flexion_topic"), &t.flexion_topic)?;
            if t.hand.is_empty() || !hands.insert(&t.hand) {
                return Err(format!("teleop[{i}].hand: `{}` is empty or listed twice", t.hand));
            }
        }
        let mut seen = std::collections::BTreeSet::new();
        for j in &self.command.joints {
            if !seen.insert(j) {
                return Err(format!("command.joints: `{j}` is listed twice"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_built_in_mapping_parses() {
        let c = Ros2Config::dexter();
        assert_eq!(c.force_torque.len(), 6);
        assert_eq!(c.camera.len(), 4);
        assert_eq!(c.command.kind, CommandKind::JointTrajectory);
        assert_eq!(c.teleop.len(), 2);
    }

    #[test]
    fn bad_mappings_are_refused_by_field() {
        let good = DEXTER_CONFIG;
        for (from, to, field) in [
            (
                "topic = \"/joint_states\"",
                "topic = \"joint_states\"",
                "joint_states.topic",
            ),
            ("kind = \"joint_trajectory\"", "kind = \"torque\"", "kind"),
            ("timeout_ms = 2000", "timeout_ms = 0", "timeout_ms"),
            ("pixel_noise = 0.01", "pixel_noise = -1.0", "pixel_noise"),
        ] {
            assert!(good.contains(from), "{from}");
            let text = good.replacen(from, to, 1);
            let e = Ros2Config::from_toml(&text, "x.toml").unwrap_err().to_string();
            assert!(e.contains("x.toml") && e.contains(field), "{e}");
        }
        let e = Ros2Config::from_toml("node = \"pbd\"\nfoo = 1\n", "y.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("y.toml"), "{e}");
    }
}

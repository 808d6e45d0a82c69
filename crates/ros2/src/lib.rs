//! pbd over ROS 2, in pure Rust (ros2-client on RustDDS: no ROS installation to build or test).
//!
//! - [`Ros2Hardware`] is a [`control_basis::Hardware`] whose encoders, force/torque sensors and
//!   cameras are ROS 2 topics and whose motor units are a ros2_control controller's command topic,
//!   as a TOML file ([`Ros2Config`]) maps them. The robot's code (skills, perception, the task loop
//!   of `dexter::task`) runs on it unchanged.
//! - [`serve`] is the other side: any `Hardware` (the simulated Dexter, `pbd sim serve --ros2`)
//!   published and commanded on the same topics, free-running in real time or in lock step with
//!   its commands (a deterministic co-simulation).
//!
//! The wire types are [`msg`]: `sensor_msgs/JointState`, `geometry_msgs/WrenchStamped`,
//! `sensor_msgs/Image` + `CameraInfo`, `std_msgs/Float64MultiArray`,
//! `trajectory_msgs/JointTrajectory`, in CDR as every ROS 2 rmw sends them.
#![warn(missing_docs)]

pub mod config;
mod dds;
pub mod hardware;
/// The wire types (the `pbd-ros2-msgs` crate's).
pub use pbd_ros2_msgs::msg;
pub mod serve;
pub mod teleop;
pub mod testing;

pub use config::{CommandKind, Ros2Config};
pub use hardware::Ros2Hardware;
pub use serve::{ServeOptions, ServeReport, serve, serve_with};
pub use teleop::{HandSample, Teleoperator};

/// What can go wrong between pbd and ROS 2.
#[derive(Debug, thiserror::Error)]
pub enum Ros2Error {
    /// A mapping file that does not parse or check.
    #[error("{file}: {message}")]
    Config {
        /// The file (or the environment variable).
        file: String,
        /// What is wrong, naming the field.
        message: String,
    },
    /// DDS could not create an entity.
    #[error("ROS 2 ({what}): {message}")]
    Dds {
        /// Which entity.
        what: String,
        /// The middleware's message.
        message: String,
    },
    /// Nothing arrived on a topic in time.
    #[error("{topic}: no {what} for {waited_ms} ms (is the robot's driver running, on the same ROS_DOMAIN_ID?)")]
    Timeout {
        /// The topic.
        topic: String,
        /// What was awaited.
        what: String,
        /// How long it waited.
        waited_ms: u64,
    },
    /// A message that cannot be used.
    #[error("{topic}: {message}")]
    Message {
        /// The topic.
        topic: String,
        /// What is wrong with it.
        message: String,
    },
    /// The hardware behind a server failed.
    #[error(transparent)]
    Hardware(#[from] control_basis::HardwareError),
    /// The teacher beside a served robot failed.
    #[error("the teacher: {0}")]
    Teacher(String),
}

impl From<Ros2Error> for control_basis::HardwareError {
    fn from(e: Ros2Error) -> Self {
        match e {
            Ros2Error::Hardware(h) => h,
            Ros2Error::Timeout { ref topic, .. } | Ros2Error::Message { ref topic, .. } => {
                control_basis::HardwareError::Device {
                    device: topic.clone(),
                    message: e.to_string(),
                }
            }
            other => control_basis::HardwareError::Device {
                device: "ROS 2".into(),
                message: other.to_string(),
            },
        }
    }
}

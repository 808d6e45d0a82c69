//! # dexter — the robot side of pbd
//!
//! What Dexter's own computer runs, and nothing it could not: perception from its cameras
//! ([`vision`], [`eyes`]: background subtraction, segments, colour terms, moments, triangulation,
//! support-plane height and footprint; tracking in [`watch`]), the control-basis skills
//! ([`control`], [`skills`]: Search-Track, Reach ◁ Manipulability, Grasp, Lift, Transport, Place,
//! Release, hand-to-hand transfer; ways around tall things in [`route`]), the plant adapter that lets the executive run a schema with
//! the procedural policy ψ ([`exec`]), and the task loop that looks over the table, decides per
//! segment and runs the schema on each ([`task`]).
//!
//! The robot reaches the world only through [`control_basis::Hardware`]: joint encoders and motor
//! units, fingertip force/torque sensors, calibrated cameras and a clock. It does not depend on the
//! simulator (`cargo tree -p dexter` holds neither `dexter-sim` nor Rapier), so no object pose,
//! identity or catalog shape can reach a decision — grasps are planned from what the cameras
//! measured (§6.2.1) and judged on the fingertips (§6.5), as on the real Dexter (§3.2, §4.3).
//!
//! `examples/kinematic_pick.rs` runs Pick-And-Place with ψ on a kinematic plant with scripted
//! sensors; the Rapier world implements the same trait in `dexter-sim`.
//!
//! ```
//! use dexter::Arm;
//! use dexter::skills::TouchState;
//! use control_basis::hardware::ForceTorque;
//! // Two fingers squeezing from opposite sides and carrying 2 N: a grasp that holds.
//! let f = |x: f64, z: f64| ForceTorque { force: [x, 0.0, z], torque: [0.0; 3], in_contact: true };
//! let touch = TouchState::of(&[f(1.0, -1.0), ForceTorque::default(), f(-1.0, -1.0)]);
//! assert!(touch.opposed && touch.holding() && (touch.load - 2.0).abs() < 1e-12);
//! assert_eq!(Arm::Left.other(), Arm::Right);
//! ```
#![warn(missing_docs)]

pub mod actions;
pub mod arm;
pub mod body;
mod calibrate;
pub mod calibration;
pub mod control;
pub mod error;
pub mod exec;
pub mod eyes;
pub mod route;
pub mod skills;
pub mod sweep;
pub mod task;
pub mod teach;
pub mod teleop;
pub mod vision;
pub mod watch;

pub use arm::Arm;
pub use error::RobotError;

//! Dexter in simulation.
#![warn(missing_docs)]

pub mod control;
pub mod convert;
pub mod error;
pub mod exec;
pub mod geometry;
pub mod grasp_trial;
pub mod perception;
pub mod physics;
pub mod rng;
pub mod scene;
pub mod snapshot;
pub mod task;
pub mod teleop;
pub mod vision;
pub mod watch;

pub use snapshot::Arm;

pub use error::SimError;

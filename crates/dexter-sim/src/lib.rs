//! Dexter in simulation.
#![warn(missing_docs)]

pub mod convert;
pub mod error;
pub mod geometry;
pub mod scene;
pub mod snapshot;
pub mod vision;

pub use snapshot::Arm;

pub use error::SimError;

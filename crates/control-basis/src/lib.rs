//! # control-basis — closed-loop controllers for pbd (Sweeney 2011, ch. 3)
//!
//! placeholder
#![warn(missing_docs)]

pub mod chain;
pub mod error;
pub mod math;
pub mod model;

pub use chain::{Chain, ChainJoint, ChainLink, ChainState, Dof, forward_kinematics, jacobian, link_jacobian, point_jacobian};
pub use error::CbError;
pub use model::{JointKind, JointLimits, RobotModel};

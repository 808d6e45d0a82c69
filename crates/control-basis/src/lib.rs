//! # control-basis — closed-loop controllers for pbd (Sweeney 2011, ch. 3)
//!
//! pbd's robot explains and reproduces demonstrations with its *own* closed-loop controllers. This crate
//! is that vocabulary, following the control basis of Huber and Grupen as the seed presents it:
//!
//! 1. **Kinematics** ([`model`], [`chain`]): any URDF, any serial chain between two links, forward
//!    kinematics of every link and the geometric Jacobian, with a constant [`Chain`] and a separate
//!    [`ChainState`] (Pinocchio's model/data split). Nothing allocates per call.
//! 2. **Controllers** ([`controller`]): C = (σ, ω, φ, τ) (Def. 3.1) built from a [`Sensor`] σ, an
//!    [`Operator`] ω, a [`Potential`] φ and [`MotorUnits`] τ. The control law is Δu = −κ J† ∂φ/∂f (3.4)
//!    with a damped least-squares pseudoinverse ([`linalg`]) that stays bounded at singularities.
//! 3. **Potentials** ([`potential`]): φ_U on positions, orientations (SO(3) log) and configurations
//!    (3.10–3.13), manipulability φ_M with its analytic gradient (3.14–3.16), a joint-limit potential, and
//!    the grasp controller's force residual (§3.1.3.3).
//! 4. **Composition** ([`ControlStack`]): C_k ◁ … ◁ C₂ ◁ C₁ for any number of ranked controllers,
//!    each inferior objective projected onto the exact null space of all superior ones (3.5–3.7); and the
//!    same composition as a QP with joint position and velocity limits ([`qp`], solved by Clarabel).
//! 5. **State** ([`predicate`]): the convergence predicate P_t(C) ∈ {*, ∅, 0, 1} (3.18) with a filtered
//!    φ̇, dwell and hysteresis; predicate vectors and the behaviour predicate (3.20). [`Monitor`]s (§4.2)
//!    are controllers without an effector, evaluated on observed state.
//! 6. **Plants** ([`plant`]): the [`Plant`] trait that the simulator, a [`KinematicPlant`] for tests, or a
//!    real robot implement; and [`hardware`]: the [`Hardware`] trait — encoders, motor units,
//!    fingertip force/torque sensors, calibrated cameras, a clock — the only way the robot side reaches
//!    the world.
//!
//! Start with `examples/embed_custom_robot.rs`: load your URDF, implement `Plant`, compose two controllers.
//!
//! ```
//! use control_basis::{Chain, ControlStack, Controller, ManipulabilityRows, Reference, RobotModel, StackSettings};
//! # let urdf = r#"<robot name="r"><link name="a"/><link name="b"/><link name="c"/>
//! # <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
//! #   <limit lower="-3" upper="3" effort="1" velocity="2"/></joint>
//! # <joint name="j2" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0.5 0 0"/><axis xyz="0 0 1"/>
//! #   <limit lower="-3" upper="3" effort="1" velocity="2"/></joint></robot>"#;
//! let model = RobotModel::from_urdf_str(urdf)?;
//! let chain = Chain::new(&model, "a", "c")?;
//! let mut state = chain.new_state();
//! let tip = chain.links().len() - 1;
//! let reach = Controller::reach_pose(&chain, tip, 2.0)?;
//! let mut stack = ControlStack::new(&chain, vec![reach], StackSettings::default())?;
//! stack.set_reference(&chain, 0, Reference::Undefined)?;
//! let du = stack.tick(&chain, &mut state, &[], 0.01);
//! assert_eq!(du.len(), 2);
//! # Ok::<(), control_basis::CbError>(())
//! ```
#![warn(missing_docs)]

pub mod chain;
pub mod controller;
pub mod error;
pub mod grasp;
pub mod hardware;
pub mod ik;
pub mod linalg;
pub mod math;
pub mod model;
pub mod monitor;
pub mod plant;
pub mod potential;
pub mod predicate;
pub mod qp;

pub use chain::{
    Chain, ChainJoint, ChainLink, ChainState, Dof, check_jacobian_matches_finite_difference, forward_kinematics,
    jacobian, link_jacobian, point_jacobian,
};
pub use controller::{
    ControlStack, Controller, DeclarativeType, FeedbackElement, FrameType, MotorUnits, Operator, Potential,
    PotentialType, Reference, Sensor, StackSettings, TaskBuffers, evaluate,
};
pub use error::CbError;
pub use hardware::{Camera, CameraInfo, ForceTorque, Hardware, HardwareError, Image, Intrinsics};
pub use ik::{IkSettings, IkSolution, inverse_kinematics};
pub use linalg::{DampedLeastSquares, DlsInfo, DlsSettings, RowSpaceBasis};
pub use model::{JointKind, JointLimits, RobotModel, Visual, VisualGeometry};
pub use monitor::Monitor;
pub use plant::{ChainBinding, KinematicPlant, Plant};
pub use potential::{Contact, ManipulabilityRows};
pub use predicate::{Predicate, PredicateSettings, PredicateTracker, behaviour_predicate};
pub use qp::{QpComposer, QpReport, QpSettings, QpStatus};

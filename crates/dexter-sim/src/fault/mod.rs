//! Injected faults (world side): the world, from its truth, decides when a fault fires and does it
//! **through the physics** — the holding hand's fingers open for a moment during transport (the
//! object falls, tips, rolls or bounces wherever the physics puts it), an impulse pushes the object
//! as the hand arrives above it, a fixed post appears in the path of the arm that reaches for the
//! object — or covers the head cameras, or sends bursts of noise through the encoders and fingertip
//! sensors. Nothing is teleported. The robot is never told: it has to notice from its own sensors
//! (the fingertips lose the load, a grasp closes on nothing, a reach does not converge, the cameras
//! lose the object) and take one of the schema's contingencies (§3.3.3).
//!
//! One [`Fault`] is armed per run and hooked into [`crate::hardware::SimRobot`] at one place: its
//! trigger is evaluated after every advance of the hardware, its effects on the motor references
//! and the sensors are applied where the robot commands and reads. Idle (armed, or done), it
//! allocates nothing per step; the buffers it needs are made when it is armed.
//!
//! `model.rs` is the fault model: the kinds, their triggers from the truth and their effects
//! ([`Fault`]); `trial.rs` one scene of the fault experiment, run with a fault armed and judged
//! ([`fault_trial`]). The model knows nothing of the executor; the trial runs it.

pub(crate) mod model;
mod trial;

pub use model::{Fault, FaultKind, FaultRecord, FaultSpec, OBSTACLE_GAP, OBSTACLE_SIZE, REACH_STARTED};
pub use trial::{FaultTrial, fault_scene, fault_trial};

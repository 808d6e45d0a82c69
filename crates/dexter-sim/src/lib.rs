//! # dexter-sim — the world Dexter acts in
//!
//! Rapier physics with Dexter's body from `assets/dexter.urdf` (multibody arms, hands and head,
//! PD motor units), scenes and object catalogs ([`scene`]), the sensor models (encoder noise,
//! fingertip force/torque from contact impulses, ray-cast cameras with pixel noise; [`vision`]),
//! teleoperation input and the scripted teachers ([`teleop`], [`teach`], [`grasp_trial`]), and the
//! **truth** (object poses and identities) — which only evaluators ([`pick_place`],
//! [`grasp_trial`]) and the `/pbd/truth` log read.
//!
//! The robot side (`dexter`) reaches this world only through [`hardware::SimRobot`], the
//! simulator's implementation of [`control_basis::Hardware`].
//!
//! ```no_run
//! use dexter_sim::physics::{DexterSim, SimSettings};
//! use dexter_sim::scene::Scene;
//! let scene = Scene::builtin("pick-place")?;
//! let mut sim = DexterSim::new(&scene, SimSettings::default())?;
//! dexter_sim::hardware::park_robot(&mut sim, scene.spec.table.height)?;
//! for _ in 0..100 {
//!     sim.step();
//! }
//! # Ok::<(), dexter_sim::SimError>(())
//! ```
#![warn(missing_docs)]

pub mod bench_scene;
pub mod calibrate;
pub mod convert;
pub mod error;
pub mod execute;
pub mod experiment;
pub mod fault;
pub mod geometry;
pub mod grasp_grid;
pub mod grasp_trial;
pub mod hardware;
pub mod perception;
pub mod physics;
pub mod pick_place;

pub mod scene;
pub mod snapshot;
pub mod teach;
pub mod teleop;
pub mod vision;

pub use snapshot::Arm;

pub use error::SimError;

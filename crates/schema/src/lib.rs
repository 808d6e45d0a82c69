//! Sensorimotor schemas (Sweeney 2011, ch. 3–5): the robot's declarative knowledge of what its
//! closed-loop skills achieve, used both to act and to understand a demonstration.
//!
//! - [`library`]: abstract actions d(C) (3.22) and schemas (Def. 3.3) as data, loaded from TOML.
//! - [`percept`]: what a robot perceives per observation step, in robot-neutral terms.
//! - [`infer`]: one HMM per schema with a miss/false-alarm observation model, the posterior over the
//!   library and "none" (4.10–4.21), Viterbi state paths, and segmentation into instances (§4.3.3).
//! - [`executive`]: runs a schema on any plant with a procedural policy ψ, taking contingencies.
//! - [`monitor`]: monitors (§4.2), their set predicates (4.17) and the observation vector x_t (4.19).
#![warn(missing_docs)]

pub mod error;
pub mod executive;
pub mod infer;
pub mod library;
pub mod monitor;
pub mod percept;
pub mod procedural;

pub use error::SchemaError;
pub use executive::{ActionOutcome, Binding, ExecReport, ProceduralPolicy, SchemaPlant, execute};
pub use infer::{Engine, Inference, InferenceConfig, Instance, Posterior};
pub use library::{Action, Expect, Library, Schema};
pub use monitor::{Hit, MonitorBank, MonitorConfig, Observation};
pub use percept::{HandPercept, Percept, PlacePercept, SeenExtent, SegmentPercept};

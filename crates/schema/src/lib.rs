//! Sensorimotor schemas (Sweeney 2011, ch. 3–5): the robot's declarative knowledge of what its
//! closed-loop skills achieve, used both to act and to understand a demonstration.
//!
//! - [`library`]: abstract actions d(C) (3.22) and schemas (Def. 3.3) as data, loaded from TOML.
//! - [`percept`]: what a robot perceives per observation step, in robot-neutral terms.
//! - [`infer`]: one HMM per schema with a miss/false-alarm observation model, the posterior over the
//!   library and "none" (4.10–4.21), Viterbi state paths, and segmentation into instances (§4.3.3).
//! - [`executive`]: runs a schema on any plant with a procedural policy ψ, taking contingencies.
//! - [`monitor`]: monitors (§4.2), their set predicates (4.17) and the observation vector x_t (4.19).
//! - [`procedural`]: the procedural model (ch. 5): which object features decide a task's reference
//!   (which bin), learned from one to a few examples, updated incrementally, explained in words.
//!
//! Learning where objects go from one red and one blue example, then asking about a new red one:
//!
//! ```
//! use schema::percept::COLOR_TERMS;
//! use schema::procedural::{Example, Features, Hyper, ProceduralModel};
//!
//! let term = |name: &str| COLOR_TERMS.iter().position(|t| *t == name).unwrap() as u8;
//! // Colour terms and the measured bounding box (m): footprint length, width, height.
//! let object = |colour: &str, side: f64| Features {
//!     colors: vec![(term(colour), 0.9), (term("white"), 0.1)],
//!     dimensions: Some([side, side, side]),
//!     ..Features::default()
//! };
//! let examples = [
//!     Example { features: object("red", 0.05), reference: "bin-right".into() },
//!     Example { features: object("blue", 0.07), reference: "bin-left".into() },
//! ];
//! let model = ProceduralModel::learn(Hyper::default(), &examples)?;
//! let p = model.predict(&object("red", 0.06))?;
//! assert_eq!(p.map_place, "bin-right");
//! println!("{}", model.explain()?.text);
//! # Ok::<(), schema::SchemaError>(())
//! ```
#![warn(missing_docs)]

pub mod error;
pub mod executive;
pub mod infer;
pub mod library;
pub mod monitor;
pub mod percept;
pub mod procedural;

pub use error::SchemaError;
pub use executive::{
    ActionOutcome, Binding, ExecReport, Failure, FailureCause, ProceduralPolicy, SchemaPlant, StepEvent, execute,
};
pub use infer::{Engine, Inference, InferenceConfig, Instance, Posterior};
pub use library::{Action, ActionKind, Expect, Library, Schema};
pub use monitor::{Hit, MonitorBank, MonitorConfig, Observation};
pub use percept::{HandPercept, Percept, PlacePercept, SeenExtent, SegmentPercept};

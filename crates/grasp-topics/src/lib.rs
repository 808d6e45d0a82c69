//! Visual grasp prototypes (Sweeney 2011, ch. 6): learn, from demonstrated pre-grasps on training
//! objects, a set of grasp prototypes shared across objects and tied to appearance, then propose
//! pre-grasps for objects never seen.
//!
//! # The idea
//!
//! A *grasp prototype* is a distribution over pre-grasps that start functionally equivalent grasps
//! (the handle of a mallet can be grasped from a continuum of nearby hand poses). Each prototype j
//! is a triple of distributions (§6.2): the object's appearance b (the 2×2 second moment of its image
//! segment) ~ Inv-Wishart(u, ψ_j) (6.6), the hand position x in the object-centroid frame
//! ~ Normal(μ_j, Σ_j) (6.7), and the hand orientation w, one of Q canonical orientations,
//! ~ Multinomial(φ_j) (6.8). Like topics in a topic model, prototypes are shared: each object m
//! mixes them with its own weights θ_m ~ Dirichlet(α) (6.9, 6.10). Objects that look alike
//! share prototypes, so for a new object with appearance b_t the prototypes that explain b_t best
//! propose its pre-grasps (6.25–6.28).
//!
//! # What is here
//!
//! - [`Corpus`]: the training data file (versioned JSON, validated with messages naming the field).
//! - [`CanonicalOrientations`]: Q orientations by seeded k-medoids under the rotation angle.
//! - [`GibbsState`]: the collapsed Gibbs sampler of §6.4 (6.15–6.24), O(A) per assignment with no
//!   allocation, with the exact Student-t position predictive (see [`gibbs`](GibbsState) for why).
//! - [`DpState`]: a Dirichlet-process mixture sampled by Neal's algorithm 8 that infers the number of
//!   prototypes (Appendix A.1.4; future work in the seed).
//! - [`GraspModel::learn`]: burn-in, thinning, several chains in parallel, log-joint traces and R̂,
//!   all from one seed; [`GraspModel::generate`] (6.25–6.28); [`naive_baseline`] (§6.5.1);
//!   [`GraspModel::sharing_table`] (Table 6.1).
//! - [`filter_and_rank`]: drop pre-grasps where the hand would hit the object or the table (parry
//!   convex shapes) and rank the rest by reach distance (the seed did this by hand, §6.6).
//! - [`synthetic`]: simulation from the model for tests, benches and Geweke checks.
//!
//! Where the seed is vague or approximate — the priors on μ_j and ψ_j, the moment-matched normal
//! (6.18–6.21), the appearance update (6.22–6.24) — the choices made are documented in
//! [`Hyperparameters`] and [`GibbsState`].
//!
//! Frames: positions and orientations are of the palm-surface frame (hand +z = palm normal =
//! approach direction, finger 3 on +y; `bhand/palm_surface_link` in `assets/dexter.urdf`) in the
//! object frame O, whose origin is the triangulated centroid and whose axes are the world's (z up).
//! Learning two prototypes from demonstrated grasps on two objects, then proposing pre-grasps for
//! a new object from its appearance alone:
//!
//! ```
//! use grasp_topics::{Config, Corpus, DemoGrasp, GraspModel};
//! use nalgebra::{Matrix2, UnitQuaternion, Vector3};
//!
//! let mut corpus = Corpus::new();
//! let top = UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0);
//! let side = UnitQuaternion::from_euler_angles(std::f64::consts::FRAC_PI_2, 0.0, 0.0);
//! let grasps = |q: &UnitQuaternion<f64>, z: f64| -> Vec<DemoGrasp> {
//!     (0..6).map(|i| DemoGrasp::new(&Vector3::new(0.002 * i as f64, 0.0, z), q)).collect()
//! };
//! corpus.push_object("box", &Matrix2::new(400.0, 0.0, 0.0, 100.0), grasps(&top, 0.1));
//! corpus.push_object("can", &Matrix2::new(120.0, 0.0, 0.0, 300.0), grasps(&side, 0.0));
//! let config = Config { prototypes: 2, orientations: 2, burn_in: 30, chains: 2, seed: 7, ..Config::default() };
//! let model = GraspModel::learn(&corpus, &config)?;
//! let mut rng = bayes::rng::seeded(1);
//! let pre_grasps = model.generate(&Matrix2::new(380.0, 0.0, 0.0, 110.0), 4, &mut rng)?;
//! assert_eq!(pre_grasps.len(), 4);
//! # Ok::<(), grasp_topics::GraspError>(())
//! ```
#![warn(missing_docs)]

mod collision;
mod corpus;
mod data;
mod dp;
mod error;
mod gibbs;
mod math;
mod metrics;
mod model;
mod orientation;
mod prior;
mod stats;
pub mod synthetic;

pub use collision::{FilterResult, GraspScene, HandModel, ObjectShape, RankedPreGrasp, Rejection, filter_and_rank};
pub use corpus::{CORPUS_FORMAT, CORPUS_VERSION, Corpus, CorpusObject, DemoGrasp};
pub use data::Dataset;
pub use dp::DpState;
pub use error::{GraspError, Result};
pub use gibbs::GibbsState;
pub use metrics::{adjusted_rand_index, gelman_rubin};
pub use model::{
    AppearancePosterior, ChainTrace, Config, Diagnostics, DpConfig, Fit, GraspModel, MAX_GENERATE, MODEL_FORMAT,
    MODEL_VERSION, PositionPosterior, PreGrasp, Prototype, SharingTable, fit, naive_baseline,
};
pub use orientation::{CanonicalOrientations, orientation_distance};
pub use prior::{AppearancePrior, Hyperparameters, PositionPredictive, PositionPrior};

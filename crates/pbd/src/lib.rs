//! # pbd — teleological robot programming by demonstration, as a library
//!
//! This is the facade: everything the `pbd` command does, callable from your own Rust program (and the
//! Python module). A robot that already owns closed-loop skills watches a teleoperated demonstration,
//! infers *which of its own schemas the teacher intended* (Sweeney 2011, §4.2), learns from one to a
//! few examples which object features decide the task's references (ch. 5), and does the task in new
//! scenes with the contingencies the teacher never showed (§4.3.2).
//!
//! The pipeline, one function per step at the crate root, each taking plain serde options and a
//! [`Progress`] callback (`pbd::record(&options, &progress)`; the modules hold the details):
//!
//! | step | function | options → report | writes |
//! |---|---|---|---|
//! | record a demonstration in the simulator | [`record()`] | [`RecordOptions`] → [`RecordReport`] | an MCAP file ([`mcap_log`]) |
//! | infer the schema and its instances | [`infer()`] | [`InferOptions`] → [`InferRun`] | `NAME.infer.json` ([`infer::InferFile`]) + a companion MCAP |
//! | learn the procedural model | [`learn()`] | [`LearnOptions`] → [`LearnReport`] | `model.json` |
//! | execute it in a new scene | [`execute()`] | [`ExecuteOptions`] → [`ExecuteReport`] | an MCAP log |
//! | all four on the built-in scenes | [`demo()`] | [`DemoOptions`] → [`DemoReport`] | `pbd-demo/` |
//! | check / repair a recording | [`doctor()`] | a path → [`DoctorReport`] | a repaired copy |
//! | calibrate the robot's eyes in the empty workcell | [`calibrate()`] | [`CalibrateOptions`] → [`CalibrateReport`] | a calibration file ([`dexter::calibration::file`]) |
//!
//! and the experiments of the seed: [`experiment::sorting`] (§5.1–5.3), [`experiment::execute`]
//! (execution on random new scenes) and [`grasp`] (grasp prototypes, ch. 6). Every random choice
//! comes from [`rng`] (xoshiro256++ with seeded streams) and parallel work runs on one rayon pool
//! ([`parallel`]): the same seed gives bit-identical files on any number of threads.
//!
//! Below this crate sit the robot ([`dexter`]: skills, perception, executive — reading only encoders,
//! fingertip F/T sensors and cameras), the world ([`dexter_sim`]: Rapier physics, rendering, truth),
//! learning ([`schema`], [`grasp_topics`]) and the bottom ([`control_basis`], [`bayes`]). The facade
//! re-exports them.
//!
//! ```no_run
//! use pbd::progress::Quiet;
//! # fn main() -> anyhow::Result<()> {
//! let report = pbd::demo(&pbd::DemoOptions::default(), &Quiet)?;
//! println!("{report}");
//! println!("placed {}/{}", report.execute.placed, report.execute.relevant);
//! # Ok(()) }
//! ```
//!
//! A quick, runnable taste — infer which schema explains a demonstration recorded a moment ago:
//!
//! ```
//! # fn main() -> anyhow::Result<()> {
//! let dir = std::env::temp_dir().join(format!("pbd-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir)?;
//! let options = pbd::RecordOptions {
//!     script: pbd::record::Script::Touch,
//!     output: dir.join("touch.mcap"),
//!     ..Default::default()
//! };
//! let recorded = pbd::record(&options, &pbd::Quiet)?;
//! assert!(recorded.demo.percepts > 0);
//! let summary = pbd::mcap_log::read_summary(&options.output)?;
//! assert!(summary.count(pbd::record::TOPIC_PERCEPT) > 0);
//! # std::fs::remove_dir_all(&dir)?;
//! # Ok(()) }
//! ```

#![warn(missing_docs)]

pub mod calibrate;
pub mod demo;
pub mod doctor;
pub mod error;
pub mod execute;
pub mod experiment;
pub mod figure;
pub mod files;
pub mod grasp;
pub mod infer;
pub mod learn;
pub mod limits;
pub mod logging;
pub mod parallel;
pub mod progress;
pub mod record;
pub mod robot;
pub mod ros2;
pub mod sim;
pub mod skills;
pub mod table;

pub use bayes::rng;
pub use calibrate::{CalibrateOptions, CalibrateReport, calibrate};
pub use demo::{DemoOptions, DemoReport, demo};
pub use doctor::{DoctorReport, doctor};
pub use error::{Error, ErrorKind, Result};
pub use execute::{ExecuteOptions, ExecuteReport, execute};
pub use infer::{InferOptions, InferRun, infer};
pub use learn::{LearnOptions, LearnReport, explain, learn};
pub use live::{LiveOptions, LiveView};
/// Recordings: MCAP writing and reading, doctor/repair, the Foxglove topics (the `pbd-mcap` crate).
pub use pbd_mcap as mcap_log;
/// The Foxglove live view (`pbd-mcap`'s).
pub use pbd_mcap::live;
pub use progress::{Progress, Quiet};
pub use record::{RecordOptions, RecordReport, record};
pub use {bayes, control_basis, dexter, dexter_sim, grasp_topics, schema};

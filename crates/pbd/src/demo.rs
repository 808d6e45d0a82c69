//! `pbd demo`: the whole story on the built-in scenes, with no files or flags needed.
//!
//! 1. **record** — the scripted teacher sorts a red and a blue object of the `sorting-teach` scene
//!    with whichever arm reaches (red → bin-right, blue → bin-left): one example per class; it leaves
//!    an orange, a green, a white and a black object alone;
//! 2. **infer** — which schema explains the demonstration, and its instances with their procedural
//!    facts (which object, which place, which arm, the object's features at the grasp);
//! 3. **learn** — the procedural model: which features decide the place, per place what it looks like,
//!    and what the objects the teacher left alone look like (the relevance background M₀);
//! 4. **execute** — in `sorting-demo`, objects never shown: a blue one only the left arm reaches, a red
//!    one only the right arm reaches, a red one whose bin needs a hand-to-hand transfer, and a green one
//!    that belongs to no bin.
//!
//! The demonstrated red object is the red block (the jar `jif` of `sorting` is red only from the
//! side — from Dexter's head its blue lid dominates the colour feature).
//!
//! Every file is written to [`DemoOptions::out`] (default `pbd-demo/`).

use std::fmt;
use std::path::PathBuf;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use crate::execute::{ExecuteOptions, ExecuteReport};
use crate::infer::{InferOptions, InferRun};
use crate::learn::{LearnOptions, LearnReport};
use crate::progress::Progress;
use crate::record::{RecordOptions, RecordReport, Script};

/// Options of [`demo`].
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DemoOptions {
    /// Directory for the files.
    pub out: PathBuf,
    /// Seed of every random choice.
    pub seed: u64,
    /// Serve the demonstration and the execution live to Foxglove (one view for both; default: no
    /// network listener).
    #[serde(default)]
    pub live: crate::live::LiveOptions,
}

impl Default for DemoOptions {
    fn default() -> Self {
        DemoOptions {
            out: PathBuf::from("pbd-demo"),
            seed: 1,
            live: crate::live::LiveOptions::default(),
        }
    }
}

/// The four steps' results.
#[derive(Debug, Clone, Serialize)]
pub struct DemoReport {
    /// Step 1: the recording.
    pub record: RecordReport,
    /// Step 2: the inference.
    pub infer: InferRun,
    /// Step 3: the procedural model.
    pub learn: LearnReport,
    /// Step 4: the execution in a new scene.
    pub execute: ExecuteReport,
    /// The directory of the files.
    pub out: PathBuf,
    /// Wall-clock time of the whole demo (s).
    pub wall_time: f64,
}

/// Runs the four steps; `progress` hears each as a phase (`"1/4 record"`, …).
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn demo(args: &DemoOptions, progress: &dyn Progress) -> crate::Result<DemoReport> {
    demo_impl(args, progress).map_err(crate::Error::from)
}

fn demo_impl(args: &DemoOptions, progress: &dyn Progress) -> Result<DemoReport> {
    let wall = std::time::Instant::now();
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let live = args.live.start()?;
    let live = live
        .as_ref()
        .map_or_else(crate::live::LiveOptions::default, crate::live::LiveOptions::view);
    let demo = args.out.join("demo.mcap");
    let infer = args.out.join("demo.infer.json");
    let model = args.out.join("model.json");
    let run = args.out.join("run.mcap");
    // The Foxglove layout beside the logs, for Layouts → Import from file.
    crate::files::write_atomic(
        &args.out.join("pbd-layout.json"),
        crate::mcap_log::FOXGLOVE_LAYOUT.as_bytes(),
    )?;

    progress.phase("1/4 record", None);
    let record = crate::record::record(
        &RecordOptions {
            scene: "sorting-teach".into(),
            script: Script::Sort,
            assign: Some("red_block=bin-right,blue_mug=bin-left".into()),
            seed: Some(args.seed),
            output: demo.clone(),
            // The head cameras at the percept rate, as H.264 video with their calibration.
            images: true,
            live: live.clone(),
            ..RecordOptions::default()
        },
        progress,
    )?;
    anyhow::ensure!(
        !record.demo.interrupted,
        "interrupted while recording; {} holds what was captured",
        demo.display()
    );
    progress.phase("2/4 infer", None);
    let infer = crate::infer::infer(
        &InferOptions {
            demo: demo.clone(),
            output: Some(infer.clone()),
            library: None,
        },
        progress,
    )?;
    progress.phase("3/4 learn", None);
    let learn = crate::learn::learn(
        &LearnOptions {
            demos: vec![infer.json_path.clone()],
            output: model.clone(),
            ..LearnOptions::default()
        },
        progress,
    )?;
    progress.phase("4/4 execute", None);
    let execute = crate::execute::execute(
        &ExecuteOptions {
            scene: "sorting-demo".into(),
            model: Some(model),
            seed: Some(args.seed),
            output: Some(run),
            live: live.clone(),
            ..ExecuteOptions::default()
        },
        progress,
    )?;
    progress.finish();
    Ok(DemoReport {
        record,
        infer,
        learn,
        execute,
        out: args.out.clone(),
        wall_time: wall.elapsed().as_secs_f64(),
    })
}

impl fmt::Display for DemoReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "1/4 record: the teacher sorts a red and a blue object of the `sorting-teach` scene (red → bin-right, blue → bin-left) and leaves the rest alone"
        )?;
        writeln!(
            f,
            "    {:.0} s of teleoperation recorded in {:.0} s → {}",
            self.record.demo.sim_time, self.record.wall_time, self.record.output
        )?;
        writeln!(f, "2/4 infer: which of the robot's schemas explains it?")?;
        let inf = &self.infer.file;
        writeln!(
            f,
            "    MAP schema: {} (p = {:.4}); {} instances:",
            inf.inference.posterior.map,
            inf.inference.posterior.map_posterior,
            inf.inference.instances.len()
        )?;
        for (i, inst) in inf.inference.instances.iter().enumerate() {
            let truth = inf
                .truth
                .get(i)
                .cloned()
                .flatten()
                .map(|t| t.object)
                .unwrap_or_default();
            writeln!(
                f,
                "      {}. {} of {} into {} with the {} arm (p = {:.3})",
                i + 1,
                inst.schema,
                truth,
                inst.place.as_deref().unwrap_or("-"),
                inst.arm.as_deref().unwrap_or("-"),
                inst.posterior.map_posterior
            )?;
        }
        writeln!(f, "3/4 learn: which features decide the bin?")?;
        for line in self.learn.explanation.lines() {
            writeln!(f, "    {line}")?;
        }
        writeln!(
            f,
            "4/4 execute: a new arrangement of objects never shown (scene `sorting-demo`)"
        )?;
        for line in self.execute.to_string().lines() {
            writeln!(f, "    {line}")?;
        }
        writeln!(
            f,
            "done in {:.0} s. Files in {}: demo.mcap (+ demo.infer.mcap: open both in Foxglove with the layout pbd-layout.json), demo.infer.json, model.json, run.mcap",
            self.wall_time,
            self.out.display()
        )?;
        write!(
            f,
            "next: `pbd learn --explain {} --samples 20` shows what the robot learned",
            self.learn.output
        )
    }
}

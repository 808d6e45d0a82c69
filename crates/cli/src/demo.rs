//! `pbd demo`: the whole story on the built-in scenes, with no files or flags needed.
//!
//! 1. **record** — the scripted teacher sorts a red and a blue object of the `sorting` scene with
//!    whichever arm reaches (red → bin-right, blue → bin-left): one example per class;
//! 2. **infer** — which schema explains the demonstration, and its instances with their procedural
//!    facts (which object, which place, which arm, the object's features at the grasp);
//! 3. **learn** — the procedural model: which features decide the place, per place what it looks like;
//! 4. **execute** — in `sorting-demo`, objects never shown: a blue one only the left arm reaches, a red
//!    one only the right arm reaches, a red one whose bin needs a hand-to-hand transfer, and a green one
//!    that belongs to no bin.
//!
//! The demonstrated red object is the red block: the jar (`jif`) is red only from the side — from
//! Dexter's head its blue lid dominates the colour feature.
//!
//! Every file is written to `--out` (default `pbd-demo/`).

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

use crate::execute::{ExecuteArgs, ExecuteReport};
use crate::infer::InferArgs;
use crate::learn::LearnArgs;
use crate::record::{RecordArgs, Script};
use crate::sim::ArmChoice;

/// Arguments of `pbd demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Directory for the files.
    #[arg(long, default_value = "pbd-demo")]
    pub out: PathBuf,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print the final execution report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs `pbd demo`.
pub fn main(args: DemoArgs, out: &mut dyn Write) -> Result<()> {
    let wall = std::time::Instant::now();
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let demo = args.out.join("demo.mcap");
    let infer = args.out.join("demo.infer.json");
    let model = args.out.join("model.json");
    let run = args.out.join("run.mcap");
    let quiet = args.json;
    let mut say = |text: String| -> Result<()> {
        if !quiet {
            writeln!(out, "{text}")?;
        }
        Ok(())
    };
    let mut sink: Vec<u8> = Vec::new();

    say("1/4 record: the teacher sorts a red and a blue object of the `sorting` scene (red → bin-right, blue → bin-left)".into())?;
    crate::record::main(
        RecordArgs {
            scene: "sorting".into(),
            script: Script::Sort,
            teleop: None,
            object: None,
            place: None,
            assign: Some("red_block=bin-right,blue_mug=bin-left".into()),
            arm: ArmChoice::Auto,
            retry: false,
            seed: Some(args.seed),
            output: demo.clone(),
            save_teleop: None,
            images: false,
            log_hz: 30.0,
            percept_hz: 10.0,
            max_seconds: 600.0,
            json: true,
        },
        &mut sink,
    )?;
    let rec: serde_json::Value = serde_json::from_slice(&sink)?;
    say(format!(
        "    {:.0} s of teleoperation recorded in {:.0} s → {}",
        rec["sim_time"].as_f64().unwrap_or(0.0),
        rec["wall_time"].as_f64().unwrap_or(0.0),
        demo.display()
    ))?;

    say("2/4 infer: which of the robot's schemas explains it?".into())?;
    sink.clear();
    crate::infer::main(
        InferArgs {
            demo: demo.clone(),
            output: Some(infer.clone()),
            library: None,
            json: true,
        },
        &mut sink,
    )?;
    let inf: crate::infer::InferFile = serde_json::from_slice(&sink)?;
    say(format!(
        "    MAP schema: {} (p = {:.4}); {} instances:",
        inf.inference.posterior.map,
        inf.inference.posterior.map_posterior,
        inf.inference.instances.len()
    ))?;
    for (i, inst) in inf.inference.instances.iter().enumerate() {
        let truth = inf
            .truth
            .get(i)
            .cloned()
            .flatten()
            .map(|t| t.object)
            .unwrap_or_default();
        say(format!(
            "      {}. {} of {} into {} with the {} arm (p = {:.3})",
            i + 1,
            inst.schema,
            truth,
            inst.place.as_deref().unwrap_or("-"),
            inst.arm.as_deref().unwrap_or("-"),
            inst.posterior.map_posterior
        ))?;
    }

    say("3/4 learn: which features decide the bin?".into())?;
    sink.clear();
    crate::learn::main(
        LearnArgs {
            demos: vec![infer.clone()],
            update: None,
            output: Some(model.clone()),
            explain: None,
            samples: 0,
            plots: None,
            relevance_threshold: 0.0,
            seed: args.seed,
            json: true,
        },
        &mut sink,
    )?;
    let learned: serde_json::Value = serde_json::from_slice(&sink)?;
    for line in learned["explanation"].as_str().unwrap_or("").lines() {
        say(format!("    {line}"))?;
    }

    say("4/4 execute: a new arrangement of objects never shown (scene `sorting-demo`)".into())?;
    sink.clear();
    crate::execute::main(
        ExecuteArgs {
            scene: "sorting-demo".into(),
            model: Some(model.clone()),
            demo: None,
            object: None,
            place: None,
            library: None,
            seed: Some(args.seed),
            output: Some(run.clone()),
            json: true,
        },
        &mut sink,
    )?;
    let report: ExecuteReport = serde_json::from_slice(&sink)?;
    if args.json {
        writeln!(out, "{}", String::from_utf8_lossy(&sink))?;
        return Ok(());
    }
    let mut table = Vec::new();
    crate::execute::print_report(&report, &mut table)?;
    for line in String::from_utf8_lossy(&table).lines() {
        say(format!("    {line}"))?;
    }
    say(format!(
        "done in {:.0} s. Files in {}: demo.mcap (+ demo.infer.mcap: open both in Foxglove), demo.infer.json, model.json, run.mcap",
        wall.elapsed().as_secs_f64(),
        args.out.display()
    ))?;
    say(format!(
        "next: `pbd learn --explain {} --samples 20` shows what the robot learned",
        model.display()
    ))?;
    Ok(())
}

//! `pbd record`: a teleoperated demonstration in the simulator, recorded to MCAP. Ctrl-C or SIGTERM
//! ends the recording cleanly with everything captured so far.

use std::io::Write;
use std::path::PathBuf;

use clap::Args;
use pbd::record::{RecordOptions, Script, record};
use pbd::sim::ArmChoice;

use crate::output::emit;
use crate::progress::Bars;

/// Arguments of `pbd record`.
#[derive(Debug, Args)]
pub struct RecordArgs {
    /// Scene: a built-in name (pick-place, sorting, sorting-new) or a TOML file.
    #[arg(long, default_value = "pick-place")]
    scene: String,
    /// The scripted teacher's task (ignored with --teleop).
    #[arg(long, value_enum, default_value_t = Script::PickPlace)]
    script: Script,
    /// Replay a glove/mocap stream instead (CSV or JSON lines; see the README).
    #[arg(long, conflicts_with = "script")]
    teleop: Option<PathBuf>,
    /// Object (scene label; default: the scene's first object).
    #[arg(long)]
    object: Option<String>,
    /// Place (default: a place the chosen arm reaches).
    #[arg(long)]
    place: Option<String>,
    /// For `--script sort`: OBJECT=PLACE pairs, comma-separated (default: by colour class, the classes
    /// in alphabetical order to the places in scene order).
    #[arg(long)]
    assign: Option<String>,
    /// The teacher's arm.
    #[arg(long, value_enum, default_value_t = ArmChoice::Auto)]
    arm: ArmChoice,
    /// The first grasp closes too early and is retried.
    #[arg(long)]
    retry: bool,
    /// Seed of every random choice (teacher, sensor noise); default: the scene's seed.
    #[arg(long)]
    seed: Option<u64>,
    /// Output MCAP file.
    #[arg(short, long)]
    output: PathBuf,
    /// Also write the teacher's hand commands as a teleop file (CSV if it ends in .csv, else JSON lines).
    #[arg(long)]
    save_teleop: Option<PathBuf>,
    /// Log the head cameras' images too, at the percept rate, with their calibration.
    #[arg(long)]
    images: bool,
    /// How images are stored: h264 (a video stream per camera, quantiser 26; Foxglove's
    /// CompressedVideo), h264:QP (0-51, lower is better), jpeg (each frame on its own, quality 85),
    /// jpeg:QUALITY (1-100), png (lossless) or raw (rgb8).
    #[arg(long, value_name = "FORMAT", default_value = "h264")]
    image_format: pbd::mcap_log::ImageFormat,
    /// Message encoding: foxglove (Foxglove's Protobuf and pbd's JSON) or ros2 (CDR with ROS 2
    /// message definitions, profile ros2: what `ros2 bag`, rosbags and Foxglove read).
    #[arg(long, value_name = "ENCODING", default_value = "foxglove")]
    encoding: pbd::mcap_log::Encoding,
    #[command(flatten)]
    live: crate::output::LiveArgs,
    /// Rate of /tf, joint states and fingertips (Hz of simulated time).
    #[arg(long, default_value_t = 30.0)]
    log_hz: f64,
    /// Rate of the robot's percepts (Hz).
    #[arg(long, default_value_t = 10.0)]
    percept_hz: f64,
    /// Longest recording (s of simulated time).
    #[arg(long, default_value_t = 600.0)]
    max_seconds: f64,
    /// The robot: the simulated Dexter in-process, or a robot over ROS 2 whose hands follow a
    /// teacher's glove on the mapping's [[teleop]] topics (--scene then names only its workcell,
    /// --calibration is required; the teacher and the seed are the other side's).
    #[arg(long, value_enum, default_value_t = crate::execute::Hardware::Sim)]
    hardware: crate::execute::Hardware,
    /// Short for --hardware ros2.
    #[arg(long, conflicts_with = "hardware")]
    ros2: bool,
    /// With --hardware ros2: the topic mapping (TOML; default: Dexter's built-in assets/ros2/dexter.toml).
    #[arg(long)]
    config: Option<PathBuf>,
    /// With --hardware ros2: the robot's calibration of its empty workcell (`pbd calibrate --hardware ros2`).
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// With --hardware ros2: the demonstration is over once no hand has sent a new sample for this
    /// long (s; 0: only --max-seconds or Ctrl-C end it).
    #[arg(long, default_value_t = 1.0)]
    idle_seconds: f64,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs `pbd record`.
pub fn main(a: RecordArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    pbd::record::check_rates(&[
        ("--log-hz", a.log_hz),
        ("--percept-hz", a.percept_hz),
        ("--max-seconds", a.max_seconds),
    ])?;
    let ros2 = a.ros2 || a.hardware == crate::execute::Hardware::Ros2;
    if !ros2 {
        for (given, flag) in [
            (a.config.is_some(), "--config"),
            (a.calibration.is_some(), "--calibration"),
        ] {
            anyhow::ensure!(!given, "{flag} is for a robot over ROS 2: pass --hardware ros2 too");
        }
    }
    if ros2 {
        // What the simulator's teacher would choose has no meaning for a robot whose teacher is
        // on the other side.
        for (given, flag) in [
            (a.teleop.is_some(), "--teleop"),
            (a.object.is_some(), "--object"),
            (a.place.is_some(), "--place"),
            (a.assign.is_some(), "--assign"),
            (a.seed.is_some(), "--seed"),
            (a.save_teleop.is_some(), "--save-teleop"),
            (a.retry, "--retry"),
        ] {
            anyhow::ensure!(
                !given,
                "{flag}: with --hardware ros2 the teacher is at the robot (its glove's topics), not pbd's"
            );
        }
        anyhow::ensure!(
            a.live.bind().is_none(),
            "--live: a recording over ROS 2 is not served live yet (open the file in Foxglove)"
        );
        let options = pbd::ros2::Ros2RecordOptions {
            scene: a.scene,
            calibration: a.calibration,
            config: a.config,
            output: a.output,
            images: a.images,
            image_format: a.image_format,
            encoding: a.encoding,
            log_hz: a.log_hz,
            percept_hz: a.percept_hz,
            max_seconds: a.max_seconds,
            idle_seconds: a.idle_seconds,
        };
        let report = pbd::ros2::record(&options, &Bars::new(a.json, true)?)?;
        return finish(a.json, &report, out);
    }
    let options = RecordOptions {
        scene: a.scene,
        script: a.script,
        teleop: a.teleop,
        object: a.object,
        place: a.place,
        assign: a.assign,
        arm: a.arm,
        retry: a.retry,
        seed: a.seed,
        output: a.output,
        save_teleop: a.save_teleop,
        images: a.images,
        image_format: a.image_format,
        encoding: a.encoding,
        live: pbd::LiveOptions::bind(a.live.bind()),
        log_hz: a.log_hz,
        percept_hz: a.percept_hz,
        max_seconds: a.max_seconds,
    };
    let report = record(&options, &Bars::new(a.json, true)?)?;
    finish(a.json, &report, out)
}

/// Prints the report; an interrupted recording is a complete file, but the exit status says so.
fn finish(json: bool, report: &pbd::record::RecordReport, out: &mut dyn Write) -> anyhow::Result<()> {
    emit(json, report, out)?;
    if report.demo.interrupted {
        anyhow::bail!(
            "interrupted after {:.1} s; {} holds what was captured",
            report.demo.sim_time,
            report.output
        );
    }
    Ok(())
}

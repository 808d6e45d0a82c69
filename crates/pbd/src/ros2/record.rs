//! `pbd record --hardware ros2`: a teleoperated demonstration recorded from a robot over ROS 2. The
//! teacher's glove (or tracker) publishes each hand's palm pose and flexion on the mapping's
//! `[[teleop]]` topics; the robot's hands follow them through its own [`TeleopDriver`]
//! (`dexter::teach::watch_demonstration`, the loop an in-process recording runs), its head follows
//! the working hand, and its own perception runs on the incoming images. The recording holds what the
//! robot knows — its joints, its own `/tf` (forward kinematics of its model at the measured angles),
//! fingertip wrenches, hand commands, percepts, images — and no truth: it is ready for `pbd infer`.
//!
//! [`TeleopDriver`]: dexter::teleop::TeleopDriver

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context as _, Result};
use control_basis::math::Iso3;
use control_basis::{ForceTorque, Hardware, Plant};
use dexter::eyes::Eyes;
use dexter::teach::{DemoObserver, HandSource, WatchSettings, watch_demonstration};
use dexter::teleop::HandCommand;
use dexter::watch::Watcher;
use dexter_sim::hardware::workspace;
use dexter_sim::physics::DEXTER_URDF;
use dexter_sim::scene::Scene;
use dexter_sim::snapshot::{FingertipWrench, Snapshot, SnapshotHeader};
use dexter_sim::teach::DemoReport;
use pbd_ros2::Ros2Hardware;
use schema::Percept;
use serde::{Deserialize, Serialize};

use crate::mcap_log::{CameraView, Encoding, ImageFormat, LogLevel, McapLog, McapLogOptions};
use crate::progress::Progress;
use crate::record::{RecordReport, check_rates, log_command, log_percept};

/// Options of [`record`].
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Ros2RecordOptions {
    /// The workcell: a built-in scene name or a TOML file (its table and places; never its objects).
    pub scene: String,
    /// The calibration of the empty workcell taken on this robot (`pbd calibrate --hardware ros2`);
    /// required.
    pub calibration: Option<PathBuf>,
    /// The topic mapping, with its `[[teleop]]` hands (default: Dexter's built-in one).
    pub config: Option<PathBuf>,
    /// Output MCAP file.
    pub output: PathBuf,
    /// Log the head cameras' images too, at the percept rate.
    pub images: bool,
    /// How images are stored.
    pub image_format: ImageFormat,
    /// Message encoding (Foxglove's Protobuf with pbd's JSON, or ROS 2's CDR).
    pub encoding: Encoding,
    /// Rate of `/tf`, joint states and fingertips (Hz of robot time).
    pub log_hz: f64,
    /// Rate of the robot's percepts (Hz).
    pub percept_hz: f64,
    /// Longest recording (s of robot time).
    pub max_seconds: f64,
    /// The demonstration is over when no hand has sent a new sample for this long (s of robot
    /// time, once one has); the recording goes on one more second. 0: only `max_seconds` or Ctrl-C
    /// end it (a glove that streams while the hand rests).
    pub idle_seconds: f64,
}

impl Default for Ros2RecordOptions {
    fn default() -> Self {
        Ros2RecordOptions {
            scene: "pick-place".into(),
            calibration: None,
            config: None,
            output: PathBuf::from("demo.mcap"),
            images: false,
            image_format: ImageFormat::default(),
            encoding: Encoding::default(),
            log_hz: 30.0,
            percept_hz: 10.0,
            max_seconds: 600.0,
            idle_seconds: 1.0,
        }
    }
}

/// The teleoperated hands' newest samples as hand commands (a zero-order hold, as a glove delivers
/// them), their times relative to the start.
struct Ros2Hands {
    t0: f64,
    arms: Vec<dexter::Arm>,
    last: [Option<f64>; 2],
    last_new: Option<f64>,
    idle: f64,
    finished_at: Option<f64>,
}

impl HandSource<Ros2Hardware> for Ros2Hands {
    type Error = anyhow::Error;

    fn commands(&mut self, hw: &mut Ros2Hardware, t: f64) -> Result<[Option<HandCommand>; 2]> {
        let mut out = [None, None];
        for (sample, &arm) in hw.teleop()?.iter().zip(&self.arms) {
            let Some(s) = sample else { continue };
            let c = HandCommand {
                t: s.stamp - self.t0,
                hand: arm,
                position: s.position,
                orientation: s.orientation,
                flexion: s.flexion,
            };
            if self.last[arm.index()] != Some(c.t) {
                self.last[arm.index()] = Some(c.t);
                self.last_new = Some(t);
            }
            out[arm.index()] = Some(c);
        }
        if self.idle > 0.0 && self.finished_at.is_none() && self.last_new.is_some_and(|last| t - last > self.idle) {
            self.finished_at = Some(t);
        }
        Ok(out)
    }

    fn finished_at(&self) -> Option<f64> {
        self.finished_at
    }
}

/// Writes what the robot knows into the log.
struct Ros2Sink<'a> {
    log: McapLog,
    header: SnapshotHeader,
    /// Each fingertip sensor's hand and finger (sensors that are not a Barrett finger tip: none).
    fingers: Vec<Option<(dexter::Arm, u8)>>,
    log_period: f64,
    next_log: f64,
    images: bool,
    cameras: Vec<(String, String, [f64; 2], [f64; 2])>,
    ft: Vec<ForceTorque>,
    poses: Vec<Iso3>,
    stop: bool,
    error: Option<anyhow::Error>,
    progress: &'a dyn Progress,
}

impl Ros2Sink<'_> {
    fn keep(&mut self, r: Result<()>) {
        if let Err(e) = r {
            self.error.get_or_insert(e);
            self.stop = true;
        }
    }

    fn snapshot(&mut self, hw: &Ros2Hardware) -> Snapshot {
        let names = hw.joint_names();
        let q = hw.joint_positions();
        hw.model().link_poses(
            &|name| names.iter().position(|n| n == name).map(|i| q[i]),
            &mut self.poses,
        );
        hw.read_force_torque(&mut self.ft);
        Snapshot {
            time: hw.time_secs(),
            q: q.to_vec(),
            qd: hw.joint_velocities().to_vec(),
            q_ref: hw.references().0.to_vec(),
            link_poses: self.poses.clone(),
            objects: Vec::new(),
            fingertips: self
                .ft
                .iter()
                .zip(&self.fingers)
                .filter_map(|(f, which)| {
                    which.map(|(arm, finger)| FingertipWrench {
                        arm,
                        finger,
                        force: f.force,
                        torque: f.torque,
                        in_contact: f.in_contact,
                    })
                })
                .collect(),
            activity: String::new(),
        }
    }
}

impl DemoObserver<Ros2Hardware> for Ros2Sink<'_> {
    fn tick(&mut self, hw: &Ros2Hardware, t: f64) {
        if t + 1e-9 >= self.next_log {
            self.next_log += self.log_period;
            let snap = self.snapshot(hw);
            let r = self.log.log_snapshot(&self.header, &snap);
            self.keep(r);
            self.progress.set_position((t * 10.0) as u64);
        }
    }

    fn command(&mut self, command: &HandCommand) {
        let r = log_command(&mut self.log, command);
        self.keep(r);
    }

    fn percept(&mut self, _hw: &Ros2Hardware, eyes: &Eyes, p: &Percept) {
        let views: Vec<CameraView<'_>> = self
            .cameras
            .iter()
            .map(|(name, frame, focal, principal)| CameraView {
                name,
                frame_id: frame,
                focal: *focal,
                principal: *principal,
            })
            .collect();
        let r = log_percept(&mut self.log, p, self.images.then_some((eyes, &views[..])));
        self.keep(r);
    }

    fn should_stop(&mut self) -> bool {
        self.stop || self.progress.should_stop()
    }
}

/// `left/bhand/finger_2/tip_link` → (left, 2).
fn finger_of(frame: &str) -> Option<(dexter::Arm, u8)> {
    let mut parts = frame.split('/');
    let arm = match parts.next()? {
        "left" => dexter::Arm::Left,
        "right" => dexter::Arm::Right,
        _ => return None,
    };
    let finger = parts.nth(1)?.strip_prefix("finger_")?.parse().ok()?;
    (parts.next()? == "tip_link").then_some((arm, finger))
}

/// Records a teleoperated demonstration from the robot `options.config` maps (see the module).
pub fn record(options: &Ros2RecordOptions, progress: &dyn Progress) -> crate::Result<RecordReport> {
    record_impl(options, progress).map_err(crate::Error::from)
}

fn record_impl(options: &Ros2RecordOptions, progress: &dyn Progress) -> Result<RecordReport> {
    check_rates(&[
        ("log_hz", options.log_hz),
        ("percept_hz", options.percept_hz),
        ("max_seconds", options.max_seconds),
    ])?;
    anyhow::ensure!(
        options.idle_seconds.is_finite() && options.idle_seconds >= 0.0,
        "--idle-seconds: {} is not a duration ≥ 0 s",
        options.idle_seconds
    );
    let cal_path = options.calibration.as_ref().context(
        "--calibration: a robot over ROS 2 needs a calibration of its empty workcell \
         (pbd calibrate --hardware ros2 with the table cleared)",
    )?;
    let cfg = super::config(options.config.as_deref())?;
    anyhow::ensure!(
        !cfg.teleop.is_empty(),
        "the ROS 2 mapping has no [[teleop]] hands: nothing would drive the robot's hands"
    );
    let arms = cfg
        .teleop
        .iter()
        .map(|t| match t.hand.as_str() {
            "left" => Ok(dexter::Arm::Left),
            "right" => Ok(dexter::Arm::Right),
            other => anyhow::bail!("teleop.hand: `{other}` is not one of Dexter's hands (left, right)"),
        })
        .collect::<Result<Vec<_>>>()?;
    let scene = Scene::open(&options.scene)?;
    let mut io = crate::files::IoPlan::new();
    io.read("--scene", &scene.path)
        .read("--calibration", cal_path)
        .write("-o", &options.output);
    if let Some(c) = &options.config {
        io.read("--config", c);
    }
    io.check()?;
    let ws = workspace(&scene);
    let wall = Instant::now();
    let mut hw = super::connect(cfg, progress)?;
    let calibration = crate::calibrate::load_for(cal_path, hw.cameras(), &scene, progress)?;
    let mut watcher = Watcher::new(&hw, ws.place_percepts(), ws.table_z, std::sync::Arc::new(calibration))?;

    let mut log = McapLog::create_with(
        &options.output,
        McapLogOptions {
            image_format: options.image_format,
            encoding: options.encoding,
            ..Default::default()
        },
    )?;
    log.attach("dexter.urdf", "application/xml", DEXTER_URDF.as_bytes())?;
    let source = format!(
        "ROS 2 teleoperation ({})",
        hw.config()
            .teleop
            .iter()
            .map(|t| t.pose_topic.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let meta: BTreeMap<String, String> = [
        ("command", "record".to_owned()),
        ("hardware", "ros2".to_owned()),
        ("scene", options.scene.clone()),
        ("source", source.clone()),
        ("tasks", "[]".to_owned()),
        ("percept_version", schema::percept::PERCEPT_VERSION.to_string()),
        ("percept_hz", options.percept_hz.to_string()),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_owned(), v))
    .collect();
    log.metadata("pbd", meta)?;
    let model = hw.model();
    let header = SnapshotHeader {
        joint_names: hw.joint_names().to_vec(),
        link_names: model.links.iter().map(|l| l.name.clone()).collect(),
        link_parents: model
            .links
            .iter()
            .map(|l| l.parent_joint.map(|j| model.links[model.joints[j].parent].name.clone()))
            .collect(),
        object_names: Vec::new(),
    };
    log.log_robot(model, hw.time_secs())?;
    let cameras = hw
        .cameras()
        .iter()
        .take(2)
        .map(|c| {
            let cam = control_basis::Camera::new(&c.intrinsics, Iso3::identity())?;
            Ok((
                c.name.replace('/', "_"),
                c.optical_frame.clone(),
                [cam.fx, cam.fy],
                [cam.cx, cam.cy],
            ))
        })
        .collect::<Result<Vec<_>>>()?;
    let fingers = hw.force_torque_frames().iter().map(|f| finger_of(f)).collect();
    let n_ft = hw.force_torque_frames().len();

    progress.phase("record", Some((options.max_seconds * 10.0) as u64));
    progress.message("robot s ×10 (the demonstration ends when the teacher's hands rest)");
    let mut sink = Ros2Sink {
        log,
        header,
        fingers,
        log_period: 1.0 / options.log_hz,
        next_log: 0.0,
        images: options.images,
        cameras,
        ft: vec![ForceTorque::default(); n_ft],
        poses: Vec::new(),
        stop: false,
        error: None,
        progress,
    };
    let mut hands = Ros2Hands {
        t0: hw.time_secs(),
        arms,
        last: [None, None],
        last_new: None,
        idle: options.idle_seconds,
        finished_at: None,
    };
    let settings = WatchSettings {
        percept_hz: options.percept_hz,
        max_seconds: options.max_seconds,
        tail_seconds: 1.0,
    };
    let run = watch_demonstration(&mut hw, &mut watcher, &mut hands, &settings, &mut sink);
    progress.finish();
    let Ros2Sink { mut log, error, .. } = sink;
    let report = match run {
        Ok(r) => r,
        Err(e) => {
            let _ = log.log_text(hw.time_secs(), LogLevel::Error, &format!("{e:#}"));
            let _ = log.finish();
            return Err(e.context("the demonstration over ROS 2 failed (what was captured is in the file)"));
        }
    };
    if let Some(e) = error {
        let _ = log.finish();
        return Err(e.context(format!("writing {}", options.output.display())));
    }
    if report.interrupted {
        log.log_text(
            hw.time_secs(),
            LogLevel::Warning,
            "recording interrupted; finished with what was captured",
        )?;
    }
    let stats = log.finish()?;
    let wall_time = wall.elapsed().as_secs_f64();
    Ok(RecordReport {
        output: options.output.display().to_string(),
        scene: options.scene.clone(),
        source,
        tasks: Vec::new(),
        demo: DemoReport {
            sim_time: report.seconds,
            steps: 0,
            percepts: report.percepts,
            commands: report.commands,
            interrupted: report.interrupted,
            notes: Vec::new(),
        },
        wall_time,
        real_time_factor: if wall_time > 0.0 {
            report.seconds / wall_time
        } else {
            0.0
        },
        messages: stats.messages,
        bytes: stats.bytes,
        saved_teleop: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fingertip_frames_name_their_hand_and_finger() {
        assert_eq!(finger_of("left/bhand/finger_2/tip_link"), Some((dexter::Arm::Left, 2)));
        assert_eq!(
            finger_of("right/bhand/finger_3/tip_link"),
            Some((dexter::Arm::Right, 3))
        );
        assert_eq!(finger_of("right/bhand/finger_3/link"), None);
        assert_eq!(finger_of("wrist/ft"), None);
    }
}

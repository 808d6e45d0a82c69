//! `pbd record`: a teleoperated demonstration in the Dexter simulator, recorded to MCAP.
//!
//! The teacher's hand poses come from the scripted, human-like teacher (`--script TASK`, the default)
//! or from a glove/mocap file (`--teleop FILE`, CSV or JSON lines, format in the README). Recorded:
//! Foxglove's `/tf`, `/scene`, `/log`, joint states and fingertip wrenches at `--log-hz`, the
//! teacher's commands on `/teleop/command`, what the robot perceives on `/pbd/percept` (hands,
//! tracked segments with their features, places, gaze — what `pbd infer` reads), the objects' true
//! poses on `/pbd/truth` (for evaluation only), optional head camera images, the task metadata and
//! the URDF. Ctrl-C or SIGTERM ends the recording cleanly with everything captured so far.

use std::collections::BTreeMap;
use std::fmt;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use dexter::eyes::Eyes;
use dexter_sim::Arm;
use dexter_sim::physics::{DEXTER_URDF, DexterSim, SimSettings};
use dexter_sim::scene::Scene;
use dexter_sim::teach::{DemoReport, DemoSettings, DemoSink, TeleopSource, run_demonstration};
use dexter_sim::teleop::{HandCommand, Replay, TeachTask, Teacher, TeleopStream};
use schema::Percept;
use serde::{Deserialize, Serialize};

use crate::mcap_log::{LogLevel, McapLog};
use crate::progress::Progress;
use crate::sim::ArmChoice;

/// Topic of the robot's percepts.
pub const TOPIC_PERCEPT: &str = "/pbd/percept";
/// Topic of the teacher's hand commands.
pub const TOPIC_TELEOP: &str = "/teleop/command";
/// Topic of the objects' true poses (evaluation only; inference never reads it).
pub const TOPIC_TRUTH: &str = "/pbd/truth";

/// What the scripted teacher demonstrates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Script {
    /// Pick an object and place it in a bin.
    #[default]
    PickPlace,
    /// Sort every object of the scene into the bins (one pick-and-place each).
    Sort,
    /// Pick an object with one arm, put it down between the hands, and place it with the other arm
    /// (the user-written `pass_and_place` of `assets/schemas/examples/pass-and-place.toml`).
    PassPlace,
    /// Pick an object up and hold it (a rival schema).
    PickHold,
    /// Pick an object up and hand it to the teacher (a rival schema).
    HandOver,
    /// Reach to an object and touch it (a rival schema).
    Touch,
    /// Move a hand about without touching anything (no schema explains it).
    Wander,
}

/// Options of [`record`].
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RecordOptions {
    /// Scene: a built-in name (pick-place, sorting, sorting-new) or a TOML file.
    pub scene: String,
    /// The scripted teacher's task (ignored with `teleop`).
    pub script: Script,
    /// Replay a glove/mocap stream instead (CSV or JSON lines; see the README).
    pub teleop: Option<PathBuf>,
    /// Object (scene label; default: the scene's first object).
    pub object: Option<String>,
    /// Place (default: a place the chosen arm reaches).
    pub place: Option<String>,
    /// For [`Script::Sort`]: OBJECT=PLACE pairs, comma-separated (default: by colour class, the
    /// classes in alphabetical order to the places in scene order).
    pub assign: Option<String>,
    /// The teacher's arm.
    pub arm: ArmChoice,
    /// The first grasp closes too early and is retried.
    pub retry: bool,
    /// Seed of every random choice (teacher, sensor noise); default: the scene's seed.
    pub seed: Option<u64>,
    /// Output MCAP file.
    pub output: PathBuf,
    /// Also write the teacher's hand commands as a teleop file (CSV if it ends in .csv, else JSON lines).
    pub save_teleop: Option<PathBuf>,
    /// Log the head cameras' images too, at the percept rate, with their calibration.
    pub images: bool,
    /// How images are stored: JPEG (default, quality 85), PNG or raw `rgb8`.
    #[serde(default)]
    pub image_format: crate::mcap_log::ImageFormat,
    /// How messages are encoded: Foxglove's Protobuf with pbd's JSON (default), or ROS 2's CDR
    /// (`ros2`, what `ros2 bag` and `rosbags` read; `pbd infer` reads both).
    #[serde(default)]
    pub encoding: crate::mcap_log::Encoding,
    /// Rate of /tf, joint states and fingertips (Hz of simulated time).
    pub log_hz: f64,
    /// Rate of the robot's percepts (Hz).
    pub percept_hz: f64,
    /// Longest recording (s of simulated time).
    pub max_seconds: f64,
    /// Serve the run live to Foxglove as well as writing the log (default: no network listener).
    #[serde(default)]
    pub live: crate::live::LiveOptions,
}

impl Default for RecordOptions {
    fn default() -> Self {
        RecordOptions {
            scene: "pick-place".into(),
            script: Script::PickPlace,
            teleop: None,
            object: None,
            place: None,
            assign: None,
            arm: ArmChoice::Auto,
            retry: false,
            seed: None,
            output: PathBuf::from("demo.mcap"),
            save_teleop: None,
            images: false,
            image_format: crate::mcap_log::ImageFormat::default(),
            encoding: crate::mcap_log::Encoding::default(),
            log_hz: 30.0,
            percept_hz: 10.0,
            max_seconds: 600.0,
            live: crate::live::LiveOptions::default(),
        }
    }
}

/// What [`record`] recorded.
#[derive(Debug, Clone, Serialize)]
pub struct RecordReport {
    /// The MCAP file.
    pub output: String,
    /// The scene.
    pub scene: String,
    /// Who taught: the scripted teacher or a teleop file.
    pub source: String,
    /// The scripted teacher's tasks.
    pub tasks: Vec<TeachTask>,
    /// The demonstration (simulated time, percepts, notes, interrupted?).
    #[serde(flatten)]
    pub demo: DemoReport,
    /// Wall-clock time (s).
    pub wall_time: f64,
    /// Simulated over wall-clock time.
    pub real_time_factor: f64,
    /// Messages written.
    pub messages: u64,
    /// Bytes written.
    pub bytes: u64,
    /// The teleop file written by `--save-teleop` and how many hand commands it holds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub saved_teleop: Option<SavedTeleop>,
}

/// The copy of the hand commands written by `--save-teleop`.
#[derive(Debug, Clone, Serialize)]
pub struct SavedTeleop {
    /// The file.
    pub path: String,
    /// Hand commands in it (0: none was sent, the interrupted run stopped first, and no file was
    /// written).
    pub samples: usize,
}

/// Objects' true positions, for evaluation.
#[derive(Debug, Serialize)]
struct Truth<'a> {
    t: f64,
    objects: Vec<(&'a str, [f64; 3])>,
}

/// Whether `arm`'s palm, pointing down as when parked, reaches 15 cm above `at` (IK from the parked
/// pose, `tries` restarts).
fn reaches_over(sim: &DexterSim, scene: &Scene, arm: Arm, at: [f64; 3], tries: u64) -> Result<bool> {
    let mut over = dexter::skills::park_pose(arm, scene.spec.table.height);
    over.translation.vector.x = at[0];
    over.translation.vector.y = at[1];
    over.translation.vector.z = at[2] + 0.15;
    Ok(dexter::skills::reachable(sim.model(), arm, &over, tries)?)
}

/// How far (m) the scripted teacher carries the object towards the receiving arm's side before
/// putting it down for the pass.
const PASS_SHIFT: f64 = 0.15;

/// The pass of `object` to `place` with `want` picking (default: the arm on the other side from the
/// place): the picking arm, and the spot on the table between the hands — the object's spot moved
/// [`PASS_SHIFT`] towards the place's side, where both arms reach.
fn pass_plan(sim: &DexterSim, scene: &Scene, object: &str, place: &str, want: Option<Arm>) -> Result<(Arm, [f64; 2])> {
    let p = scene.place(place)?;
    let receiver_side = if p.center[1] >= 0.0 { Arm::Left } else { Arm::Right };
    let arm = want.unwrap_or(receiver_side.other());
    let op = sim.object_state(sim.object(object)?).pose.translation.vector;
    let table_z = scene.spec.table.height;
    let toward = (p.center[1] - op.y).signum();
    let spot = [op.x, op.y + toward * PASS_SHIFT];
    if !reaches_over(sim, scene, arm, [op.x, op.y, op.z], 5)? {
        bail!("the {arm} arm cannot reach `{object}` to pass it");
    }
    for a in [arm, arm.other()] {
        if !reaches_over(sim, scene, a, [spot[0], spot[1], table_z], 5)? {
            bail!(
                "the {a} arm cannot reach the pass spot ({:.2}, {:.2}) next to `{object}`; move the object",
                spot[0],
                spot[1]
            );
        }
    }
    if !reaches_over(
        sim,
        scene,
        arm.other(),
        [p.center[0], p.center[1], table_z + p.wall_height],
        6,
    )? {
        bail!("the {} arm cannot reach `{place}`", arm.other());
    }
    Ok((arm, spot))
}

/// Which arm can take `object` to `place` (the requested one if it can).
fn choose_arm(sim: &DexterSim, scene: &Scene, object: &str, place: Option<&str>, want: Option<Arm>) -> Result<Arm> {
    let i = sim.object(object)?;
    let op = sim.object_state(i).pose;
    let pp = place.map(|p| scene.place(p)).transpose()?;
    let table_z = scene.spec.table.height;
    let ok = |arm: Arm| -> Result<bool> {
        let o = op.translation.vector;
        if !reaches_over(sim, scene, arm, [o.x, o.y, o.z], 5)? {
            return Ok(false);
        }
        match pp {
            Some(p) => reaches_over(sim, scene, arm, [p.center[0], p.center[1], table_z + p.wall_height], 6),
            None => Ok(true),
        }
    };
    let candidates: Vec<Arm> = match want {
        Some(a) => vec![a],
        None => Arm::BOTH.to_vec(),
    };
    for arm in candidates {
        if ok(arm)? {
            return Ok(arm);
        }
    }
    match want {
        Some(a) => bail!(
            "the {a} arm cannot reach `{object}`{}",
            place.map(|p| format!(" and `{p}`")).unwrap_or_default()
        ),
        None => bail!(
            "no arm reaches `{object}`{}",
            place.map(|p| format!(" and `{p}`")).unwrap_or_default()
        ),
    }
}

pub(crate) fn tasks(args: &RecordOptions, sim: &DexterSim, scene: &Scene) -> Result<Vec<TeachTask>> {
    let first_object = || {
        scene.resolved.first().map(|o| o.label.clone()).with_context(|| {
            format!(
                "scene {} has no objects to demonstrate with (add [[objects]] to it)",
                scene.path.display()
            )
        })
    };
    let want = args.arm.arm();
    let object = match &args.object {
        Some(o) => {
            sim.object(o)?;
            o.clone()
        }
        None => first_object()?,
    };
    Ok(match args.script {
        Script::PickPlace => {
            let place = match &args.place {
                Some(p) => {
                    scene.place(p)?;
                    p.clone()
                }
                None => {
                    // A place the arm reaches.
                    let mut found = None;
                    for p in &scene.spec.places {
                        if choose_arm(sim, scene, &object, Some(&p.name), want).is_ok() {
                            found = Some(p.name.clone());
                            break;
                        }
                    }
                    found.with_context(|| {
                        if scene.spec.places.is_empty() {
                            format!("scene {} has no places (add [[places]] to it)", scene.path.display())
                        } else {
                            let arm = match want {
                                Some(a) => format!("the {a} arm"),
                                None => "either arm".to_string(),
                            };
                            format!(
                                "{arm} cannot pick `{object}` and reach any place of the scene ({}); move the object or the places{}",
                                scene.spec.places.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join(", "),
                                if want.is_some() { ", or try --arm auto" } else { "" }
                            )
                        }
                    })?
                }
            };
            let arm = choose_arm(sim, scene, &object, Some(&place), want)?;
            vec![TeachTask::PickPlace {
                object,
                place,
                arm,
                retry: args.retry,
            }]
        }
        Script::Sort => {
            let pairs: Vec<(String, String)> = match &args.assign {
                Some(text) => text
                    .split(',')
                    .filter(|s| !s.trim().is_empty())
                    .map(|pair| {
                        let (o, p) = pair
                            .split_once('=')
                            .with_context(|| format!("--assign: `{pair}` is not OBJECT=PLACE"))?;
                        sim.object(o.trim())?;
                        scene.place(p.trim())?;
                        Ok((o.trim().to_string(), p.trim().to_string()))
                    })
                    .collect::<Result<_>>()?,
                None => {
                    let class = |label: &str| -> Option<String> {
                        let i = scene.resolved.iter().position(|r| r.label == label)?;
                        scene.catalog.objects[scene.resolved[i].object].color_class.clone()
                    };
                    let mut classes: Vec<String> = scene.resolved.iter().filter_map(|r| class(&r.label)).collect();
                    classes.sort();
                    classes.dedup();
                    scene
                        .resolved
                        .iter()
                        .filter_map(|r| {
                            let c = class(&r.label)?;
                            let k = classes.iter().position(|x| *x == c)?;
                            let place = scene.spec.places.get(k % scene.spec.places.len().max(1))?;
                            Some((r.label.clone(), place.name.clone()))
                        })
                        .collect()
                }
            };
            if pairs.is_empty() {
                bail!("nothing to sort: pass --assign OBJECT=PLACE,…");
            }
            let mut out = Vec::new();
            for (object, place) in pairs {
                let arm = choose_arm(sim, scene, &object, Some(&place), want)
                    .with_context(|| format!("sorting `{object}` into `{place}`"))?;
                out.push(TeachTask::PickPlace {
                    object,
                    place,
                    arm,
                    retry: false,
                });
            }
            out
        }
        Script::PassPlace => {
            let place =
                match &args.place {
                    Some(p) => {
                        scene.place(p)?;
                        p.clone()
                    }
                    None => scene.spec.places.first().map(|p| p.name.clone()).with_context(|| {
                        format!("scene {} has no places (add [[places]] to it)", scene.path.display())
                    })?,
                };
            let (arm, handoff) = pass_plan(sim, scene, &object, &place, want)?;
            vec![TeachTask::PassPlace {
                object,
                place,
                arm,
                handoff,
            }]
        }
        Script::PickHold => vec![TeachTask::PickHold {
            arm: choose_arm(sim, scene, &object, None, want)?,
            object,
        }],
        Script::HandOver => vec![TeachTask::HandOver {
            arm: choose_arm(sim, scene, &object, None, want)?,
            object,
        }],
        Script::Touch => vec![TeachTask::Touch {
            arm: choose_arm(sim, scene, &object, None, want)?,
            object,
        }],
        Script::Wander => vec![TeachTask::Wander {
            arm: want.unwrap_or(Arm::Left),
            seconds: 12.0,
        }],
    })
}

struct Sink<'a> {
    log: McapLog,
    header: dexter_sim::snapshot::SnapshotHeader,
    names: Vec<String>,
    log_period: f64,
    next_log: f64,
    images: bool,
    /// The head cameras: topic name, optical frame; and their focal lengths and principal point.
    cameras: [(&'static str, &'static str); 2],
    focal: [f64; 2],
    principal: [f64; 2],
    stop: bool,
    error: Option<anyhow::Error>,
    progress: &'a dyn Progress,
    percepts: usize,
}

impl Sink<'_> {
    fn keep(&mut self, r: Result<()>) {
        if let Err(e) = r {
            self.error.get_or_insert(e);
            // A log that cannot be written ends the recording.
            self.stop = true;
        }
    }
}

/// Logs a hand command on [`TOPIC_TELEOP`].
pub(crate) fn log_command(log: &mut McapLog, command: &HandCommand) -> Result<()> {
    log.log_json(TOPIC_TELEOP, "pbd.HandCommand", &any_schema(), command.t, command)
}

/// Logs a percept on [`TOPIC_PERCEPT`] and, when asked, the head cameras' images of the eyes that
/// made it (left, right) with their calibrations.
pub(crate) fn log_percept(
    log: &mut McapLog,
    p: &Percept,
    images: Option<(&Eyes, &[crate::mcap_log::CameraView<'_>])>,
) -> Result<()> {
    log.log_json(TOPIC_PERCEPT, "pbd.Percept", &any_schema(), p.t, p)?;
    if let Some((eyes, views)) = images {
        let (l, r) = eyes.images(dexter::eyes::Pair::Head);
        for (view, img) in views.iter().zip([l, r]) {
            log.log_camera_image(p.t, view, img.width, img.height, &img.rgb)?;
        }
    }
    Ok(())
}

pub(crate) fn any_schema() -> serde_json::Value {
    serde_json::json!({ "type": "object" })
}

impl DemoSink for Sink<'_> {
    fn tick(&mut self, sim: &DexterSim, t: f64) {
        if t + 1e-9 >= self.next_log {
            self.next_log += self.log_period;
            let r = self.log.log_snapshot(&self.header, &sim.snapshot("demonstration"));
            self.keep(r);
            self.progress.set_position((t * 10.0) as u64);
        }
    }

    fn command(&mut self, command: &HandCommand) {
        let r = log_command(&mut self.log, command);
        self.keep(r);
    }

    fn percept(&mut self, sim: &DexterSim, eyes: &Eyes, p: &Percept) {
        let truth = Truth {
            t: p.t,
            objects: self
                .names
                .iter()
                .enumerate()
                .map(|(i, n)| {
                    let v = sim.object_state(i).pose.translation.vector;
                    (n.as_str(), [v.x, v.y, v.z])
                })
                .collect(),
        };
        let r = self.log.log_json(TOPIC_TRUTH, "pbd.Truth", &any_schema(), p.t, &truth);
        self.keep(r);
        let views = self.cameras.map(|(name, frame_id)| crate::mcap_log::CameraView {
            name,
            frame_id,
            focal: self.focal,
            principal: self.principal,
        });
        let r = log_percept(&mut self.log, p, self.images.then_some((eyes, &views[..])));
        self.keep(r);
        self.percepts += 1;
    }

    fn should_stop(&mut self) -> bool {
        self.stop || self.progress.should_stop()
    }
}

/// The range of each rate and duration of a recording: (name, least, most).
pub const RECORD_RANGES: [(&str, f64, f64); 3] = [
    ("log_hz", 0.1, 1000.0),
    ("percept_hz", 0.1, 1000.0),
    ("max_seconds", 0.1, 3600.0),
];

/// Checks each (name, value) against [`RECORD_RANGES`] (names may be spelt as options:
/// `--log-hz`).
pub fn check_rates(values: &[(&str, f64)]) -> Result<()> {
    for &(name, v) in values {
        let key = name.trim_start_matches("--").replace('-', "_");
        let Some(&(_, lo, hi)) = RECORD_RANGES.iter().find(|r| r.0 == key) else {
            continue;
        };
        if !(v.is_finite() && (lo..=hi).contains(&v)) {
            bail!("{name} must be in [{lo}, {hi}] (got {v:e})");
        }
    }
    Ok(())
}

/// `pbd record`: runs the teacher (scripted or a teleop file) in the simulator and records the
/// demonstration to MCAP. When `progress` asks to stop (Ctrl-C), the file is finished with what was
/// captured and the report says `interrupted`.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn record(args: &RecordOptions, progress: &dyn Progress) -> crate::Result<RecordReport> {
    record_impl(args, progress).map_err(crate::Error::from)
}

fn record_impl(args: &RecordOptions, progress: &dyn Progress) -> Result<RecordReport> {
    // Config.
    check_rates(&[
        ("log_hz", args.log_hz),
        ("percept_hz", args.percept_hz),
        ("max_seconds", args.max_seconds),
    ])?;
    let scene = Scene::open(&args.scene)?;
    let seed = args.seed.unwrap_or(scene.spec.seed);
    let mut sim = dexter_sim::hardware::parked_sim(
        &scene,
        SimSettings {
            seed,
            ..SimSettings::default()
        },
    )?;
    let (source, task_list, source_name) = match &args.teleop {
        Some(path) => {
            let stream = TeleopStream::load(path)?;
            // A stream that begins after the end of the recording replays nothing: the run would
            // only watch the parked robot (and `--save-teleop` would have nothing to copy).
            let first = stream.samples.iter().map(|s| s.t).fold(f64::INFINITY, f64::min);
            if first > args.max_seconds {
                bail!(
                    "{}: its first sample is at t = {first} s, after the end of the recording \
                     (--max-seconds {}): nothing would be replayed",
                    path.display(),
                    args.max_seconds
                );
            }
            (
                TeleopSource::Replay(Replay::new(stream)),
                Vec::new(),
                format!("teleop file {}", path.display()),
            )
        }
        None => {
            let t = tasks(args, &sim, &scene)?;
            let teacher = Teacher::with_tasks(&sim, &scene, &t, seed)?;
            (
                TeleopSource::Script(Box::new(teacher)),
                t,
                format!("scripted teacher ({:?})", args.script),
            )
        }
    };
    if let Some(dir) = args.output.parent()
        && !dir.as_os_str().is_empty()
        && !dir.is_dir()
    {
        bail!(
            "cannot write {}: directory {} does not exist",
            args.output.display(),
            dir.display()
        );
    }
    // Every input (the scene's catalog included) and both outputs, checked before anything is written.
    let mut io = crate::files::IoPlan::new();
    io.read("--scene", &scene.path)
        .read("the scene's catalog", &scene.catalog.path);
    if let Some(t) = &args.teleop {
        io.read("--teleop", t);
    }
    io.write("-o", &args.output);
    if let Some(t) = &args.save_teleop {
        io.write("--save-teleop", t);
    }
    io.check()?;
    if let Some(t) = &args.save_teleop {
        crate::files::check_writable(t)?;
    }
    let mut log = McapLog::create_with(
        &args.output,
        crate::mcap_log::McapLogOptions {
            image_format: args.image_format,
            encoding: args.encoding,
            ..Default::default()
        },
    )?;
    if let Some(live) = args.live.start()? {
        progress.message(&format!(
            "live view on {} (Foxglove: Open connection → Foxglove WebSocket)",
            live.url()
        ));
        log.stream_to(live)?;
    }
    log.attach("dexter.urdf", "application/xml", DEXTER_URDF.as_bytes())?;
    let mut meta: BTreeMap<String, String> = BTreeMap::new();
    meta.insert("command".into(), "record".into());
    meta.insert("scene".into(), args.scene.clone());
    meta.insert("seed".into(), seed.to_string());
    meta.insert("source".into(), source_name.clone());
    meta.insert("tasks".into(), serde_json::to_string(&task_list)?);
    meta.insert("percept_version".into(), schema::percept::PERCEPT_VERSION.to_string());
    meta.insert("percept_hz".into(), args.percept_hz.to_string());
    // The scene file itself, so that `pbd infer` and `pbd execute` know the places and catalog.
    log.metadata("pbd", meta)?;
    log.log_scene(&scene, sim.header(), 0.0)?;
    log.log_robot(sim.model(), 0.0)?;
    let camera = control_basis::Camera::new(&scene.spec.camera.intrinsics(), control_basis::math::Iso3::identity())?;

    let max = match &source {
        TeleopSource::Replay(r) => (r.duration() + 2.0).min(args.max_seconds),
        TeleopSource::Script(_) => args.max_seconds,
    };
    progress.phase("record", Some((max * 10.0) as u64));
    progress.message("simulated s ×10");
    let wall = std::time::Instant::now();
    let mut sink = Sink {
        log,
        header: sim.header().clone(),
        names: sim.header().object_names.clone(),
        log_period: 1.0 / args.log_hz,
        next_log: 0.0,
        images: args.images,
        cameras: [
            ("head_left", dexter_sim::hardware::CAMERAS[0].1),
            ("head_right", dexter_sim::hardware::CAMERAS[1].1),
        ],
        focal: [camera.fx, camera.fy],
        principal: [camera.cx, camera.cy],
        stop: false,
        error: None,
        progress,
        percepts: 0,
    };
    let settings = DemoSettings {
        percept_hz: args.percept_hz,
        max_seconds: max,
        tail_seconds: 1.0,
        seed,
    };
    let (source_for_run, teleop_log) = (source, args.save_teleop.clone());
    let run = run_demonstration(&mut sim, &scene, source_for_run, &settings, &mut sink);
    progress.finish();
    let Sink { mut log, error, .. } = sink;
    let demo = match run {
        Ok(d) => d,
        Err(e) => {
            let _ = log.log_text(sim.time(), LogLevel::Error, &format!("{e}"));
            let _ = log.finish();
            return Err(anyhow::Error::from(e).context("the demonstration failed"));
        }
    };
    if let Some(e) = error {
        let _ = log.finish();
        return Err(e.context(format!("writing {}", args.output.display())));
    }
    for note in &demo.notes {
        log.log_text(demo.sim_time, LogLevel::Info, note)?;
    }
    if demo.interrupted {
        log.log_text(
            demo.sim_time,
            LogLevel::Warning,
            "recording interrupted; finished with what was captured",
        )?;
    }
    let stats = log.finish()?;
    let wall_time = wall.elapsed().as_secs_f64();
    let mut saved_teleop = None;
    if let Some(path) = teleop_log {
        // Rebuild the stream from the recording we just wrote: every hand command sent, the
        // scripted teacher's or the replayed file's (a sample of `--teleop` that a later one
        // replaced within the same control period was never sent, and is not copied): replaying
        // the copy drives the same run.
        let rec = crate::mcap_log::read_recording(&args.output, &[TOPIC_TELEOP])?;
        let samples = rec
            .topic(TOPIC_TELEOP)
            .map(|(_, d)| serde_json::from_slice::<HandCommand>(d))
            .collect::<Result<Vec<_>, _>>()?;
        let n = samples.len();
        if n == 0 {
            // An empty file is not a teleop stream (it would not read back): say so, write nothing.
            progress.warn(&format!(
                "--save-teleop {}: not written: no hand command was sent before the recording stopped",
                path.display()
            ));
        } else {
            let stream = TeleopStream { samples };
            let text = if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")) {
                stream.to_csv()
            } else {
                stream.to_jsonl()
            };
            crate::files::write_atomic(&path, text.as_bytes())?;
        }
        saved_teleop = Some(SavedTeleop {
            path: path.display().to_string(),
            samples: n,
        });
    }
    let report = RecordReport {
        output: args.output.display().to_string(),
        scene: args.scene.clone(),
        source: source_name,
        tasks: task_list,
        real_time_factor: if wall_time > 0.0 {
            demo.sim_time / wall_time
        } else {
            0.0
        },
        demo,
        wall_time,
        messages: stats.messages,
        bytes: stats.bytes,
        saved_teleop,
    };
    Ok(report)
}

impl fmt::Display for RecordReport {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let report = self;

        writeln!(
            out,
            "recorded {:.1} s of demonstration ({}) in {:.1} s wall (real-time factor {:.2}){}",
            report.demo.sim_time,
            report.source,
            report.wall_time,
            report.real_time_factor,
            if report.demo.interrupted {
                " — INTERRUPTED, kept what was captured"
            } else {
                ""
            }
        )?;
        for t in &report.tasks {
            writeln!(out, "  task      {}", describe(t))?;
        }
        for n in &report.demo.notes {
            writeln!(out, "  note      {n}")?;
        }
        writeln!(
            out,
            "  file      {} ({} messages, {:.1} MB; {} percepts) — open in Foxglove, or `pbd infer {}`",
            report.output,
            report.messages,
            report.bytes as f64 / 1e6,
            report.demo.percepts,
            report.output
        )?;
        match &report.saved_teleop {
            Some(SavedTeleop { path, samples: 0 }) => {
                writeln!(out, "  teleop    {path} NOT written: no hand command was sent")?
            }
            Some(SavedTeleop { path, samples }) => writeln!(
                out,
                "  teleop    {path} ({samples} hand commands: those that drove the run; `--teleop {path}` replays it)"
            )?,
            None => {}
        }

        Ok(())
    }
}

fn describe(t: &TeachTask) -> String {
    match t {
        TeachTask::PickPlace {
            object,
            place,
            arm,
            retry,
        } => format!(
            "pick-place `{object}` → `{place}` with the {arm} arm{}",
            if *retry { " (first grasp retried)" } else { "" }
        ),
        TeachTask::PassPlace {
            object,
            place,
            arm,
            handoff,
        } => format!(
            "pass-place `{object}` → `{place}`: the {arm} arm puts it down at ({:.2}, {:.2}), the {} arm places it",
            handoff[0],
            handoff[1],
            arm.other()
        ),
        TeachTask::PickHold { object, arm } => format!("pick-hold `{object}` with the {arm} arm"),
        TeachTask::HandOver { object, arm } => format!("hand-over `{object}` with the {arm} arm"),
        TeachTask::Touch { object, arm } => format!("touch `{object}` with the {arm} arm"),
        TeachTask::Wander { arm, seconds } => format!("wander for {seconds:.0} s with the {arm} arm"),
    }
}

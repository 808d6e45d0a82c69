//! pbd on a robot over ROS 2 (`crates/ros2`): the simulated Dexter served as a ROS 2 robot
//! (`pbd sim serve --ros2`) and the robot's own task loop run on any robot the mapping file
//! describes (`pbd execute --hardware ros2`).
//!
//! The two sides share nothing but topics. The served world keeps its truth to itself and reports
//! it when it stops (where each object ended, in which place); the robot reports what it decided
//! and what its own monitors saw.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result};
use control_basis::RobotModel;
use dexter_sim::hardware::{SimRobot, parked_sim, workspace};
use dexter_sim::physics::{DEXTER_URDF, SimSettings};
use dexter_sim::scene::Scene;
use pbd_ros2::{Ros2Config, Ros2Hardware};
use serde::{Deserialize, Serialize};

use crate::execute::{ExecuteOptions, plan_task};
use crate::progress::Progress;

pub use pbd_ros2::{CommandKind, ServeReport};

mod record;
pub use record::{Ros2RecordOptions, record};

/// The mapping named by `path`, or Dexter's built-in one (`assets/ros2/dexter.toml`).
pub fn config(path: Option<&std::path::Path>) -> Result<Ros2Config> {
    Ok(match path {
        Some(p) => Ros2Config::open(p)?,
        None => Ros2Config::dexter(),
    })
}

/// Options of [`serve_sim`].
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ServeOptions {
    /// The world: a built-in scene name or a TOML file.
    pub scene: String,
    /// Seed of the world's random choices (camera noise, faults); default: the scene's.
    pub seed: Option<u64>,
    /// The topic mapping (default: Dexter's built-in `assets/ros2/dexter.toml`).
    pub config: Option<PathBuf>,
    /// Advance the world only on commands (a deterministic co-simulation) instead of in real time.
    pub lockstep: bool,
    /// The control period (s).
    pub period: f64,
    /// End after this many seconds without a command, once one has arrived.
    pub idle_exit: Option<f64>,
    /// Serve the workcell without its objects (for `pbd calibrate --hardware ros2`).
    pub empty: bool,
    /// A scripted teacher at the robot's side, demonstrating this task on the mapping's
    /// `[[teleop]]` topics (for `pbd record --hardware ros2`); the task's object, place and arm as
    /// `pbd record` chooses them by default.
    pub teach: Option<crate::record::Script>,
    /// Publish the fingertip wrenches in their sensors' own frames, as real force/torque sensors do
    /// (the robot turns them with its kinematics), instead of world-aligned.
    pub sensor_frames: bool,
}

impl Default for ServeOptions {
    fn default() -> Self {
        ServeOptions {
            scene: "sorting-new".into(),
            seed: None,
            config: None,
            lockstep: false,
            period: 0.002,
            idle_exit: None,
            empty: false,
            teach: None,
            sensor_frames: false,
        }
    }
}

/// Where one object of the served world ended (the world's truth, reported when serving stops).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectTruth {
    /// The scene's label.
    pub object: String,
    /// Where it stood at the start (m, world).
    pub start: [f64; 3],
    /// Where it ended (m, world).
    pub end: [f64; 3],
    /// The place it ended in (inside its walls, on the table), if any.
    pub place: Option<String>,
    /// Its speed at the end (m/s).
    pub speed: f64,
}

/// What [`serve_sim`] did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ServeSimReport {
    /// The scene.
    pub scene: String,
    /// The seed.
    pub seed: u64,
    /// Whether it was the empty workcell.
    pub empty: bool,
    /// The server's counts and times.
    pub serve: ServeReport,
    /// Every object's end (the world's truth).
    pub objects: Vec<ObjectTruth>,
}

/// Serves the simulated Dexter in `options.scene` as a ROS 2 robot until `progress` asks to stop
/// (Ctrl-C, SIGTERM) or the idle time passes; then reports where every object ended.
pub fn serve_sim(options: &ServeOptions, progress: &dyn Progress) -> crate::Result<ServeSimReport> {
    serve_sim_impl(options, progress).map_err(crate::Error::from)
}

fn serve_sim_impl(options: &ServeOptions, progress: &dyn Progress) -> Result<ServeSimReport> {
    let cfg = config(options.config.as_deref())?;
    let full = Scene::open(&options.scene)?;
    let seed = options.seed.unwrap_or(full.spec.seed);
    let scene = if options.empty {
        dexter_sim::calibrate::empty_workcell(&full).0
    } else {
        full
    };
    let mut sim = parked_sim(
        &scene,
        SimSettings {
            seed,
            ..SimSettings::default()
        },
    )?;
    let start: Vec<[f64; 3]> = (0..sim.objects().len())
        .map(|i| sim.object_state(i).pose.translation.vector.into())
        .collect();
    progress.phase("serve", None);
    progress.message(&format!(
        "serving the simulated Dexter in `{}` on ROS 2 (domain {}, {}): Ctrl-C stops",
        options.scene,
        cfg.domain()?,
        if options.lockstep { "lock step" } else { "real time" }
    ));
    let mut teacher = match options.teach {
        Some(script) => {
            anyhow::ensure!(
                !cfg.teleop.is_empty(),
                "--teach: the ROS 2 mapping has no [[teleop]] hands to publish the teacher's samples on"
            );
            let args = crate::record::RecordOptions {
                scene: options.scene.clone(),
                script,
                seed: Some(seed),
                ..Default::default()
            };
            let tasks = crate::record::tasks(&args, &sim, &scene)?;
            Some(SimTeacher {
                teacher: dexter_sim::teleop::Teacher::with_tasks(&sim, &scene, &tasks, seed)?,
                scene: &scene,
                t0: sim.time(),
                last: [None, None],
            })
        }
        None => None,
    };
    let serve = {
        let mut hw = SimRobot::new(&mut sim, &scene, seed)?;
        pbd_ros2::serve_with(
            &mut hw,
            &cfg,
            &pbd_ros2::ServeOptions {
                lockstep: options.lockstep,
                period: options.period,
                idle_exit: options.idle_exit.map(Duration::from_secs_f64),
                sensor_frames: options.sensor_frames,
                ..pbd_ros2::ServeOptions::default()
            },
            &|| progress.should_stop(),
            teacher
                .as_mut()
                .map(|t| t as &mut dyn pbd_ros2::Teleoperator<SimRobot<'_>>),
        )?
    };
    let table_z = scene.spec.table.height;
    let objects = (0..sim.objects().len())
        .map(|i| {
            let s = sim.object_state(i);
            let p = s.pose.translation.vector;
            let place = scene
                .spec
                .places
                .iter()
                .find(|spec| spec.contains([p.x, p.y]) && p.z < table_z + spec.wall_height + 0.2)
                .map(|spec| spec.name.clone());
            ObjectTruth {
                object: scene.resolved[i].label.clone(),
                start: start[i],
                end: p.into(),
                place,
                speed: s.linvel.norm(),
            }
        })
        .collect();
    Ok(ServeSimReport {
        scene: options.scene.clone(),
        seed,
        empty: options.empty,
        serve,
        objects,
    })
}

/// The scripted teacher beside the served world: it sees the world (as a person at a glove does)
/// and publishes its new samples, stamped with the world's clock, until it has finished.
struct SimTeacher<'s> {
    teacher: dexter_sim::teleop::Teacher,
    scene: &'s Scene,
    t0: f64,
    last: [Option<f64>; 2],
}

impl pbd_ros2::Teleoperator<SimRobot<'_>> for SimTeacher<'_> {
    fn samples(
        &mut self,
        hw: &mut SimRobot<'_>,
        out: &mut Vec<pbd_ros2::HandSample>,
    ) -> Result<(), pbd_ros2::Ros2Error> {
        let t = hw.sim().time() - self.t0;
        if self.teacher.finished() {
            // The teacher is done and puts the glove down: nothing more is published.
            return Ok(());
        }
        let commands = self
            .teacher
            .command(hw.sim_mut(), self.scene, t)
            .map_err(|e| pbd_ros2::Ros2Error::Teacher(e.to_string()))?;
        for c in commands.iter().flatten() {
            let k = c.hand.index();
            if self.last[k] != Some(c.t) {
                self.last[k] = Some(c.t);
                out.push(pbd_ros2::HandSample {
                    hand: c.hand.prefix().to_owned(),
                    stamp: self.t0 + c.t,
                    position: c.position,
                    orientation: c.orientation,
                    flexion: c.flexion,
                });
            }
        }
        Ok(())
    }
}

/// Options of [`execute`]: the task as for an in-process run (`execute.scene` names the
/// workcell — its table and places, never its objects; `execute.calibration` is required: a
/// calibration of the empty workcell taken on this robot), and the robot's topic mapping.
#[derive(Debug, Clone, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct Ros2ExecuteOptions {
    /// The task and the workcell.
    pub execute: ExecuteOptions,
    /// The topic mapping (default: Dexter's built-in one).
    pub config: Option<PathBuf>,
}

/// What the robot did with one segment, by its own account.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SegmentReport {
    /// The robot's segment (track id).
    pub segment: u32,
    /// Where it was seen (m, world).
    pub at: [f64; 3],
    /// `execute`, `ignore` or `skip`.
    pub decision: String,
    /// The place it was put in, if the task has one.
    pub place: Option<String>,
    /// Arms used.
    pub arms: Vec<String>,
    /// Contingencies taken.
    pub contingencies: Vec<String>,
    /// The schema ran and the robot's monitors saw its goal state.
    pub reached_goal: bool,
    /// Why (the decision's reason, or what failed).
    pub why: String,
}

/// What [`execute`] did, by the robot's own account (the world's truth is the server's).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Ros2ExecuteReport {
    /// The workcell's scene.
    pub scene: String,
    /// The schema run per segment.
    pub schema: String,
    /// Per segment taken up.
    pub segments: Vec<SegmentReport>,
    /// Segments acted on.
    pub executed: usize,
    /// Of those, the ones whose goal the robot's monitors saw.
    pub reached_goal: usize,
    /// Robot time (s, the joint states' clock).
    pub robot_time: f64,
    /// Wall time (s).
    pub wall_time: f64,
}

/// Runs the robot's task loop (`dexter::task::run_task`) on the robot `options.config` maps.
pub fn execute(options: &Ros2ExecuteOptions, progress: &dyn Progress) -> crate::Result<Ros2ExecuteReport> {
    execute_impl(options, progress).map_err(crate::Error::from)
}

fn execute_impl(options: &Ros2ExecuteOptions, progress: &dyn Progress) -> Result<Ros2ExecuteReport> {
    let args = &options.execute;
    anyhow::ensure!(
        args.output.is_none(),
        "-o: a run over ROS 2 is recorded by the robot's own tools (ros2 bag); pbd does not log it yet"
    );
    let cal_path = args.calibration.as_ref().context(
        "--calibration: a robot over ROS 2 needs a calibration of its empty workcell \
         (pbd calibrate --hardware ros2 with the table cleared)",
    )?;
    let cfg = config(options.config.as_deref())?;
    let scene = Scene::open(&args.scene)?;
    let plan = plan_task(args, &scene)?;
    let ws = workspace(&scene);
    let wall = Instant::now();
    let mut hw = connect(cfg, progress)?;
    let calibration = std::sync::Arc::new(crate::calibrate::load_for(
        cal_path,
        control_basis::Hardware::cameras(&hw),
        &scene,
        progress,
    )?);
    progress.phase("execute", None);
    let task = plan.task();
    let mut sink = dexter::exec::NoSink;
    let runs = {
        let mut plant = dexter::exec::RobotPlant::new(&mut hw, &ws, calibration, &plan.library, &mut sink)?;
        dexter::task::run_task(&mut plant, &task, &mut dexter::task::NoTaskSink)?
    };
    let segments: Vec<SegmentReport> = runs.iter().map(segment_report).collect();
    Ok(Ros2ExecuteReport {
        scene: args.scene.clone(),
        schema: plan.schema.clone(),
        executed: segments.iter().filter(|s| s.decision == "execute").count(),
        reached_goal: segments.iter().filter(|s| s.reached_goal).count(),
        segments,
        robot_time: control_basis::Plant::time_secs(&hw),
        wall_time: wall.elapsed().as_secs_f64(),
    })
}

/// Connects to the robot `cfg` maps (Dexter's model).
fn connect(cfg: Ros2Config, progress: &dyn Progress) -> Result<Ros2Hardware> {
    progress.phase("connect", None);
    progress.message(&format!(
        "waiting for the robot on {} (ROS 2 domain {})",
        cfg.joint_states.topic,
        cfg.domain()?
    ));
    let model = RobotModel::from_urdf_str(DEXTER_URDF)?;
    Ok(Ros2Hardware::connect(cfg, model)?)
}

/// `pbd calibrate --hardware ros2`: the robot over ROS 2 calibrates its eyes in its workcell, which
/// must be cleared of objects (`options.scene` gives the table and places), and the calibration is
/// written to `options.output` (through a temporary file and a rename) and read back.
pub fn calibrate(
    options: &crate::calibrate::CalibrateOptions,
    config_path: Option<&std::path::Path>,
    progress: &dyn Progress,
) -> crate::Result<crate::calibrate::CalibrateReport> {
    calibrate_impl(options, config_path, progress).map_err(crate::Error::from)
}

fn calibrate_impl(
    options: &crate::calibrate::CalibrateOptions,
    config_path: Option<&std::path::Path>,
    progress: &dyn Progress,
) -> Result<crate::calibrate::CalibrateReport> {
    let cfg = config(config_path)?;
    let scene = Scene::open(&options.scene)?;
    crate::calibrate::check_output(&scene, &options.output)?;
    let mut hw = connect(cfg, progress)?;
    progress.phase("calibrate", None);
    let t0 = control_basis::Plant::time_secs(&hw);
    let wall = Instant::now();
    let calibration = crate::calibrate::calibrate_hardware(
        &mut hw,
        &workspace(&scene),
        &dexter::calibration::CalibrationSettings::default(),
    )?;
    let wall_time = wall.elapsed().as_secs_f64();
    let sim_time = control_basis::Plant::time_secs(&hw) - t0;
    // The robot's own noise: no seed of pbd's (reported as 0).
    crate::calibrate::save_and_report(
        &calibration,
        &options.scene,
        0,
        &options.output,
        sim_time,
        wall_time,
        progress,
    )
}

fn segment_report(run: &dexter::task::SegmentRun) -> SegmentReport {
    use dexter::task::Taken;
    let d = &run.decision;
    let (decision, place, arms, contingencies, why) = match &run.taken {
        Taken::Ignored { why } => ("ignore", None, Vec::new(), Vec::new(), why.clone()),
        Taken::Skipped { place, why } => ("skip", place.clone(), Vec::new(), Vec::new(), why.clone()),
        Taken::Executed {
            place,
            arms,
            contingencies,
            execution,
            ..
        } => (
            "execute",
            place.clone(),
            arms.clone(),
            contingencies.clone(),
            if execution.reached_goal {
                d.reason.clone()
            } else {
                format!("the schema ended in `{}`", execution.final_state)
            },
        ),
    };
    SegmentReport {
        segment: d.segment,
        at: d.at,
        decision: decision.into(),
        place,
        arms,
        contingencies,
        reached_goal: run.reached_goal(),
        why,
    }
}

impl std::fmt::Display for ServeSimReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = &self.serve;
        writeln!(
            f,
            "served `{}`{} (seed {}): {} commands, {} advances, {} images; {:.2} s simulated in {:.1} s ({})",
            self.scene,
            if self.empty { " without its objects" } else { "" },
            self.seed,
            s.commands,
            s.advances,
            s.images,
            s.time,
            s.wall_time,
            s.ended
        )?;
        for o in &self.objects {
            writeln!(
                f,
                "  {:<24} ({:+.3}, {:+.3}, {:.3}) -> ({:+.3}, {:+.3}, {:.3})  {}",
                o.object,
                o.start[0],
                o.start[1],
                o.start[2],
                o.end[0],
                o.end[1],
                o.end[2],
                o.place.as_deref().map_or("-".to_string(), |p| format!("in {p}"))
            )?;
        }
        Ok(())
    }
}

impl std::fmt::Display for Ros2ExecuteReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} over ROS 2 in `{}`: {} segments, {} acted on, {} reached their goal (the robot's monitors); {:.1} s robot time, {:.1} s wall",
            self.schema,
            self.scene,
            self.segments.len(),
            self.executed,
            self.reached_goal,
            self.robot_time,
            self.wall_time
        )?;
        for s in &self.segments {
            writeln!(
                f,
                "  segment {:>3} at ({:+.3}, {:+.3}): {:<7} {:<10} {} {}",
                s.segment,
                s.at[0],
                s.at[1],
                s.decision,
                s.place.as_deref().unwrap_or("-"),
                if s.reached_goal { "goal" } else { "    " },
                s.why
            )?;
        }
        Ok(())
    }
}

//! [`serve`]: any [`Hardware`] as a ROS 2 robot on the topics of a [`Ros2Config`] — joint states,
//! world-aligned fingertip wrenches, camera images and their `CameraInfo` published; motor-unit
//! references taken from the command topic; images rendered on each software trigger.
//!
//! **Free-running** (default): the world advances in real time, one `period` per tick, holding the
//! newest references, like a robot's driver. **Lock step** (`lockstep`): the world advances only when a
//! command arrives — by its `time_from_start` (a `JointTrajectory`) or one `period` (an array) — then
//! publishes the new state: a deterministic co-simulation in which the robot in another process
//! sees the world exactly as it would in-process, however long it thinks.

use std::time::{Duration, Instant};

use control_basis::{ForceTorque, Hardware, Image};
use ros2_client::{Publisher, Subscription};
use serde::{Deserialize, Serialize};
use tracing::debug;

use crate::Ros2Error;
use crate::config::{CommandKind, Ros2Config};
use crate::dds::{Endpoint, publish, take};
use crate::hardware::info_from_intrinsics;
use crate::msg::{self, types};
use crate::teleop::{HandSample, Teleoperator};

/// How [`serve`] runs.
#[derive(Debug, Clone)]
pub struct ServeOptions {
    /// Advance only on commands (a co-simulation) instead of in real time.
    pub lockstep: bool,
    /// The control period (s): a free-running tick, and a lock step for array commands.
    pub period: f64,
    /// Images per second of cameras without a trigger topic, free-running.
    pub camera_rate_hz: f64,
    /// End after this long without a command, once one has arrived.
    pub idle_exit: Option<Duration>,
    /// Publish each wrench in its sensor's own frame (as a real force/torque sensor does) instead
    /// of world-aligned.
    pub sensor_frames: bool,
}

impl Default for ServeOptions {
    fn default() -> Self {
        ServeOptions {
            lockstep: false,
            period: 0.002,
            camera_rate_hz: 15.0,
            idle_exit: None,
            sensor_frames: false,
        }
    }
}

/// What a [`serve`] did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ServeReport {
    /// Commands applied.
    pub commands: u64,
    /// Times the world advanced.
    pub advances: u64,
    /// Images published.
    pub images: u64,
    /// Hardware time at the end (s).
    pub time: f64,
    /// Wall time served (s).
    pub wall_time: f64,
    /// Why it ended: `stop`, `idle`.
    pub ended: String,
}

enum CommandSub {
    Array(Subscription<msg::Float64MultiArray>),
    Trajectory(Subscription<msg::JointTrajectory>),
}

struct ServedCamera {
    index: usize,
    frame: String,
    image: Publisher<msg::Image>,
    info: Publisher<msg::CameraInfo>,
    trigger: Option<Subscription<msg::Header>>,
    next_free: f64,
}

struct TeleopOut {
    pose_topic: String,
    flexion_topic: String,
    pose: Publisher<msg::PoseStamped>,
    flexion: Publisher<msg::Float64>,
}

struct Server<'a, H: Hardware + ?Sized> {
    hw: &'a mut H,
    teacher: Option<&'a mut dyn Teleoperator<H>>,
    teleop: Vec<(String, TeleopOut)>,
    samples: Vec<HandSample>,
    config: &'a Ros2Config,
    endpoint: Endpoint,
    joint_states: Publisher<msg::JointState>,
    wrenches: Vec<(usize, Publisher<msg::WrenchStamped>)>,
    command: CommandSub,
    cameras: Vec<ServedCamera>,
    command_dofs: Vec<usize>,
    traj_names: Vec<String>,
    traj_dofs: Vec<usize>,
    ft: Vec<ForceTorque>,
    /// Link poses, for wrenches in sensor frames (`None`: world-aligned).
    fk: Option<Vec<control_basis::math::Iso3>>,
    image: Image,
    report: ServeReport,
}

/// Serves `hw` on `config`'s topics until `stop` says so (asked every tick; Ctrl-C, SIGTERM) or the
/// idle time passes.
pub fn serve<H: Hardware + ?Sized>(
    hw: &mut H,
    config: &Ros2Config,
    options: &ServeOptions,
    stop: &dyn Fn() -> bool,
) -> Result<ServeReport, Ros2Error> {
    serve_with(hw, config, options, stop, None)
}

/// [`serve`] with a teacher at the robot's side: after each advance of the world (and once at the
/// start) `teacher`'s new hand samples are published on the mapping's `[[teleop]]` topics — each
/// hand's flexion, then its pose — before the state of that instant, so that a robot that has the
/// state finds the samples of the same instant waiting.
pub fn serve_with<'a, H: Hardware + ?Sized>(
    hw: &'a mut H,
    config: &'a Ros2Config,
    options: &ServeOptions,
    stop: &dyn Fn() -> bool,
    teacher: Option<&'a mut dyn Teleoperator<H>>,
) -> Result<ServeReport, Ros2Error> {
    if !(options.period.is_finite() && options.period > 0.0) {
        return Err(Ros2Error::Config {
            file: "--period".into(),
            message: format!("{} is not a control period in seconds", options.period),
        });
    }
    let mut endpoint = Endpoint::new(
        config.domain()?,
        config.namespace.as_deref(),
        &format!("{}_robot", config.node),
    )?;
    let joint_states = endpoint.publisher(&config.joint_states.topic, types::JOINT_STATE)?;
    let mut wrenches = Vec::new();
    for f in &config.force_torque {
        let k = hw
            .force_torque_frames()
            .iter()
            .position(|n| n == &f.frame)
            .ok_or_else(|| Ros2Error::Config {
                file: "force_torque.frame".into(),
                message: format!("the served robot has no force/torque sensor `{}`", f.frame),
            })?;
        wrenches.push((k, endpoint.publisher(&f.topic, types::WRENCH_STAMPED)?));
    }
    let command = match config.command.kind {
        CommandKind::JointTrajectory => {
            CommandSub::Trajectory(endpoint.subscription(&config.command.topic, types::JOINT_TRAJECTORY)?)
        }
        _ => CommandSub::Array(endpoint.subscription(&config.command.topic, types::FLOAT64_MULTI_ARRAY)?),
    };
    let mut cameras = Vec::new();
    for c in &config.camera {
        let index = hw.camera_index(&c.name).map_err(|_| Ros2Error::Config {
            file: "camera.name".into(),
            message: format!("the served robot has no camera `{}`", c.name),
        })?;
        cameras.push(ServedCamera {
            index,
            frame: c.optical_frame.clone(),
            image: endpoint.publisher(&c.image_topic, types::IMAGE)?,
            info: endpoint.publisher(&c.info_topic, types::CAMERA_INFO)?,
            trigger: match &c.trigger_topic {
                Some(t) => Some(endpoint.subscription(t, types::HEADER)?),
                None => None,
            },
            next_free: 0.0,
        });
    }
    let command_dofs = if config.command.joints.is_empty() {
        (0..hw.dof()).collect()
    } else {
        config
            .command
            .joints
            .iter()
            .map(|j| {
                hw.joint_names()
                    .iter()
                    .position(|n| n == j)
                    .ok_or_else(|| Ros2Error::Config {
                        file: "command.joints".into(),
                        message: format!("the served robot has no joint `{j}`"),
                    })
            })
            .collect::<Result<_, _>>()?
    };
    let mut teleop = Vec::new();
    if teacher.is_some() {
        for t in &config.teleop {
            teleop.push((
                t.hand.clone(),
                TeleopOut {
                    pose_topic: t.pose_topic.clone(),
                    flexion_topic: t.flexion_topic.clone(),
                    pose: endpoint.publisher(&t.pose_topic, types::POSE_STAMPED)?,
                    flexion: endpoint.publisher(&t.flexion_topic, types::FLOAT64)?,
                },
            ));
        }
    }
    let n_ft = hw.force_torque_frames().len();
    let mut s = Server {
        hw,
        teacher,
        teleop,
        samples: Vec::new(),
        config,
        endpoint,
        joint_states,
        wrenches,
        command,
        cameras,
        command_dofs,
        traj_names: Vec::new(),
        traj_dofs: Vec::new(),
        ft: vec![ForceTorque::default(); n_ft],
        fk: options.sensor_frames.then(Vec::new),
        image: Image::default(),
        report: ServeReport {
            commands: 0,
            advances: 0,
            images: 0,
            time: 0.0,
            wall_time: 0.0,
            ended: String::new(),
        },
    };
    s.run(options, stop)
}

impl<H: Hardware + ?Sized> Server<'_, H> {
    fn run(&mut self, options: &ServeOptions, stop: &dyn Fn() -> bool) -> Result<ServeReport, Ros2Error> {
        let wall = Instant::now();
        for k in 0..self.cameras.len() {
            self.publish_info(k)?;
        }
        self.publish_teleop()?;
        self.publish_state()?;
        let mut last_command = Instant::now();
        let mut commanded = false;
        let mut next_tick = Instant::now();
        let tick = Duration::from_secs_f64(options.period);
        loop {
            if stop() {
                self.report.ended = "stop".into();
                break;
            }
            if commanded && options.idle_exit.is_some_and(|d| last_command.elapsed() > d) {
                self.report.ended = "idle".into();
                break;
            }
            let n = self.take_commands(options)?;
            if n > 0 {
                commanded = true;
                last_command = Instant::now();
            }
            self.answer_triggers()?;
            if options.lockstep {
                if n == 0 {
                    self.endpoint.wait(Instant::now() + Duration::from_millis(50));
                }
                continue;
            }
            // Free-running: one period per tick, in real time.
            let now = Instant::now();
            if now >= next_tick {
                self.hw.advance(options.period)?;
                self.report.advances += 1;
                self.publish_teleop()?;
                self.publish_state()?;
                self.free_cameras(options)?;
                next_tick += tick;
                if now > next_tick + 50 * tick {
                    next_tick = now; // fell behind (a slow render): do not race to catch up
                }
            } else {
                self.endpoint.wait(next_tick);
            }
        }
        self.report.time = self.hw.time_secs();
        self.report.wall_time = wall.elapsed().as_secs_f64();
        Ok(self.report.clone())
    }

    /// Applies every command that arrived; in lock step each advances the world and publishes.
    fn take_commands(&mut self, options: &ServeOptions) -> Result<usize, Ros2Error> {
        let topic = self.config.command.topic.clone();
        let mut n = 0;
        loop {
            let dt = match &self.command {
                CommandSub::Array(sub) => match take(sub, &topic)? {
                    Some(m) => {
                        self.apply_array(&m, &topic)?;
                        options.period
                    }
                    None => break,
                },
                CommandSub::Trajectory(sub) => match take(sub, &topic)? {
                    Some(m) => {
                        let dt = self.apply_trajectory(&m, &topic)?;
                        if dt > 0.0 { dt } else { options.period }
                    }
                    None => break,
                },
            };
            n += 1;
            self.report.commands += 1;
            if options.lockstep {
                self.hw.advance(dt)?;
                self.report.advances += 1;
                self.publish_teleop()?;
                self.publish_state()?;
            }
        }
        Ok(n)
    }

    fn apply_array(&mut self, m: &msg::Float64MultiArray, topic: &str) -> Result<(), Ros2Error> {
        let per = if self.config.command.kind == CommandKind::PositionVelocity {
            2
        } else {
            1
        };
        let want = per * self.command_dofs.len();
        if m.data.len() != want || m.data.iter().any(|v| !v.is_finite()) {
            return Err(Ros2Error::Message {
                topic: topic.to_string(),
                message: format!("{} values (finite) expected, got {}", want, m.data.len()),
            });
        }
        for (i, &d) in self.command_dofs.iter().enumerate() {
            let (q, qd) = if per == 2 {
                (m.data[2 * i], m.data[2 * i + 1])
            } else {
                (m.data[i], 0.0)
            };
            self.hw.set_joint_reference(d, q, qd);
        }
        Ok(())
    }

    fn apply_trajectory(&mut self, m: &msg::JointTrajectory, topic: &str) -> Result<f64, Ros2Error> {
        let bad = |s: String| Ros2Error::Message {
            topic: topic.to_string(),
            message: s,
        };
        let Some(p) = m.points.first() else {
            return Err(bad("a trajectory without points".into()));
        };
        if m.joint_names != self.traj_names {
            self.traj_dofs = m
                .joint_names
                .iter()
                .map(|n| {
                    self.hw
                        .joint_names()
                        .iter()
                        .position(|j| j == n)
                        .ok_or_else(|| bad(format!("no joint `{n}`")))
                })
                .collect::<Result<_, _>>()?;
            self.traj_names = m.joint_names.clone();
        }
        let n = self.traj_dofs.len();
        if p.positions.len() != n || !(p.velocities.is_empty() || p.velocities.len() == n) {
            return Err(bad(format!(
                "{n} joints, {} positions, {} velocities",
                p.positions.len(),
                p.velocities.len()
            )));
        }
        if p.positions.iter().chain(&p.velocities).any(|v| !v.is_finite()) {
            return Err(bad("a reference that is not finite".into()));
        }
        for (i, &d) in self.traj_dofs.iter().enumerate() {
            self.hw
                .set_joint_reference(d, p.positions[i], p.velocities.get(i).copied().unwrap_or(0.0));
        }
        Ok(p.time_from_start.secs())
    }

    fn answer_triggers(&mut self) -> Result<(), Ros2Error> {
        for k in 0..self.cameras.len() {
            let topic = self.config.camera[k].trigger_topic.clone().unwrap_or_default();
            let mut asked = false;
            if let Some(sub) = &self.cameras[k].trigger {
                while take(sub, &topic)?.is_some() {
                    asked = true;
                }
            }
            if asked {
                self.publish_image(k)?;
            }
        }
        Ok(())
    }

    fn free_cameras(&mut self, options: &ServeOptions) -> Result<(), Ros2Error> {
        let t = self.hw.time_secs();
        for k in 0..self.cameras.len() {
            if self.cameras[k].trigger.is_none() && t >= self.cameras[k].next_free && options.camera_rate_hz > 0.0 {
                self.cameras[k].next_free = t + 1.0 / options.camera_rate_hz;
                self.publish_image(k)?;
            }
        }
        Ok(())
    }

    fn stamp(&self, frame: &str) -> msg::Header {
        msg::Header {
            stamp: msg::Time::from_secs(self.hw.time_secs()),
            frame_id: frame.to_string(),
        }
    }

    /// The teacher's new samples, if there is a teacher.
    fn publish_teleop(&mut self) -> Result<(), Ros2Error> {
        let Some(teacher) = self.teacher.as_deref_mut() else {
            return Ok(());
        };
        self.samples.clear();
        teacher.samples(self.hw, &mut self.samples)?;
        for sample in &self.samples {
            let Some((_, out)) = self.teleop.iter().find(|(hand, _)| *hand == sample.hand) else {
                return Err(Ros2Error::Config {
                    file: "teleop.hand".into(),
                    message: format!("the mapping has no teleoperated hand `{}`", sample.hand),
                });
            };
            publish(&out.flexion, &out.flexion_topic, msg::Float64 { data: sample.flexion })?;
            let [x, y, z] = sample.position;
            let [qx, qy, qz, qw] = sample.orientation;
            let pose = msg::PoseStamped {
                header: msg::Header {
                    stamp: msg::Time::from_secs(sample.stamp),
                    frame_id: self.config.world_frame.clone(),
                },
                pose: msg::Pose {
                    position: msg::Point { x, y, z },
                    orientation: msg::Quaternion {
                        x: qx,
                        y: qy,
                        z: qz,
                        w: qw,
                    },
                },
            };
            publish(&out.pose, &out.pose_topic, pose)?;
        }
        Ok(())
    }

    fn publish_state(&mut self) -> Result<(), Ros2Error> {
        self.hw.read_force_torque(&mut self.ft);
        if let Some(fk) = &mut self.fk {
            let (names, q) = (self.hw.joint_names(), self.hw.joint_positions());
            self.hw
                .model()
                .link_poses(&|j| names.iter().position(|n| n == j).map(|i| q[i]), fk);
        }
        for (k, p) in &self.wrenches {
            let f = self.ft[*k];
            let sensor = &self.hw.force_torque_frames()[*k];
            let (frame, force, torque) = match (&self.fk, self.hw.model().link(sensor)) {
                // The sensor's own frame: the world-aligned reading turned into its axes.
                (Some(fk), Ok(link)) => {
                    let r = fk[link].rotation.inverse();
                    let turn = |v: [f64; 3]| (r * control_basis::math::Vec3::from(v)).into();
                    (sensor.as_str(), turn(f.force), turn(f.torque))
                }
                _ => (self.config.world_frame.as_str(), f.force, f.torque),
            };
            let m = msg::WrenchStamped {
                header: self.stamp(frame),
                wrench: msg::Wrench {
                    force: msg::Vector3::from_array(force),
                    torque: msg::Vector3::from_array(torque),
                },
            };
            publish(
                p,
                &self
                    .config
                    .force_torque
                    .iter()
                    .find(|c| self.hw.force_torque_frames()[*k] == c.frame)
                    .map(|c| c.topic.clone())
                    .unwrap_or_default(),
                m,
            )?;
        }
        // The joint state last: a robot that has it finds every other reading of the step waiting.
        let m = msg::JointState {
            header: self.stamp(""),
            name: self.hw.joint_names().to_vec(),
            position: self.hw.joint_positions().to_vec(),
            velocity: self.hw.joint_velocities().to_vec(),
            effort: Vec::new(),
        };
        publish(&self.joint_states, &self.config.joint_states.topic, m)
    }

    fn publish_info(&mut self, k: usize) -> Result<(), Ros2Error> {
        let c = &self.cameras[k];
        let info = info_from_intrinsics(
            &self.hw.cameras()[c.index].intrinsics,
            msg::Time::from_secs(self.hw.time_secs()),
            &c.frame,
        );
        publish(&c.info, &self.config.camera[k].info_topic, info)
    }

    fn publish_image(&mut self, k: usize) -> Result<(), Ros2Error> {
        let index = self.cameras[k].index;
        self.hw.capture(index, &mut self.image)?;
        let m = msg::Image {
            header: self.stamp(&self.cameras[k].frame),
            height: self.image.height,
            width: self.image.width,
            encoding: "rgb8".into(),
            is_bigendian: 0,
            step: 3 * self.image.width,
            data: self.image.rgb.clone(),
        };
        publish(&self.cameras[k].image, &self.config.camera[k].image_topic, m)?;
        self.publish_info(k)?;
        self.report.images += 1;
        debug!(camera = k, t = self.hw.time_secs(), "image published");
        Ok(())
    }
}

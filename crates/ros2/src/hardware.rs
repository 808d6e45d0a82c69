//! [`Ros2Hardware`]: a robot whose devices are ROS 2 topics.
//!
//! Each [`Hardware::advance`] sends the motor-unit references (the command topic, in the convention
//! of [`CommandKind`]) and waits for the joint state one control period newer, then for every
//! force/torque sensor's reading at least as new. A capture asks a triggered camera for an image
//! taken now, or takes the newest image of a free-running one. Anything that does not arrive within
//! `timeout_ms` is an error naming its topic, and from then on the robot sends nothing.

use std::time::{Duration, Instant};

use control_basis::{CameraInfo, CbError, ForceTorque, Hardware, HardwareError, Image, Intrinsics, Plant, RobotModel};
use ros2_client::{Publisher, Subscription};
use tracing::{debug, warn};

use crate::Ros2Error;
use crate::config::{CommandKind, Ros2Config};
use crate::dds::{Endpoint, publish, take};
use crate::msg::{self, types};

enum CommandPub {
    Array(Publisher<msg::Float64MultiArray>),
    Trajectory(Publisher<msg::JointTrajectory>),
}

struct CameraLink {
    image: Subscription<msg::Image>,
    info: Subscription<msg::CameraInfo>,
    trigger: Option<Publisher<msg::Header>>,
    latest: Option<msg::Image>,
}

/// A [`Hardware`] on ROS 2 topics ([`Ros2Config`]).
pub struct Ros2Hardware {
    config: Ros2Config,
    model: RobotModel,
    endpoint: Endpoint,
    joint_states: Subscription<msg::JointState>,
    command: CommandPub,
    wrenches: Vec<Subscription<msg::WrenchStamped>>,
    cameras: Vec<CameraLink>,
    joint_names: Vec<String>,
    /// Index of each joint-state name in `joint_names`, for the last name list seen.
    state_names: Vec<String>,
    state_index: Vec<usize>,
    /// Plant DOF of each command joint.
    command_index: Vec<usize>,
    q: Vec<f64>,
    qd: Vec<f64>,
    time: f64,
    have_state: bool,
    ref_q: Vec<f64>,
    ref_qd: Vec<f64>,
    /// Joints the robot has sent a reference since it connected: a trajectory command names only
    /// these (the controller keeps its own reference for the others); an array command, which
    /// must hold every joint, holds the others at their first measured position.
    commanded: Vec<bool>,
    ft_frames: Vec<String>,
    ft: Vec<ForceTorque>,
    ft_time: Vec<f64>,
    camera_infos: Vec<CameraInfo>,
    /// The teleoperated hands' topics (empty unless the mapping has `[[teleop]]`).
    teleop: crate::teleop::TeleopInput,
    /// Every link's pose (wrenches in a sensor's own frame are turned with it).
    fk: Vec<control_basis::math::Iso3>,
    /// Each sensor's last reading as sent, and the link it is in (`None`: world-aligned).
    ft_raw: Vec<[[f64; 3]; 2]>,
    ft_link: Vec<Option<usize>>,
    failed: Option<String>,
}

impl std::fmt::Debug for Ros2Hardware {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros2Hardware")
            .field("node", &self.config.node)
            .field("time", &self.time)
            .field("joints", &self.joint_names.len())
            .finish_non_exhaustive()
    }
}

fn timeout(topic: &str, what: &str, d: Duration) -> Ros2Error {
    Ros2Error::Timeout {
        topic: topic.to_string(),
        what: what.to_string(),
        waited_ms: d.as_millis() as u64,
    }
}

/// Intrinsics from a `CameraInfo`'s K (square pixels; the horizontal field of view from fx).
pub fn intrinsics_from_info(info: &msg::CameraInfo, topic: &str) -> Result<Intrinsics, Ros2Error> {
    let fx = info.k[0];
    let bad = |m: String| Ros2Error::Message {
        topic: topic.to_string(),
        message: m,
    };
    if !(fx.is_finite() && fx > 0.0) {
        return Err(bad(format!("K[0] (fx) = {fx} is not a focal length in pixels")));
    }
    // Rounded to 1e-9° (2e-11 rad): K's round trip through floating point then gives back the
    // field of view a robot's description states exactly (60°, not 59.99999999999999°).
    let hfov_deg = (2.0 * (f64::from(info.width) / (2.0 * fx)).atan().to_degrees() * 1e9).round() / 1e9;
    let i = Intrinsics {
        width: info.width,
        height: info.height,
        hfov_deg,
    };
    i.validate().map_err(|e| bad(e.to_string()))?;
    Ok(i)
}

/// A `CameraInfo` for `intrinsics` (square pixels, the principal point at the image centre, no
/// distortion).
pub fn info_from_intrinsics(i: &Intrinsics, stamp: msg::Time, frame: &str) -> msg::CameraInfo {
    let w = f64::from(i.width);
    let h = f64::from(i.height);
    let f = (w / 2.0) / (i.hfov_deg.to_radians() / 2.0).tan();
    let (cx, cy) = (w / 2.0, h / 2.0);
    msg::CameraInfo {
        header: msg::Header {
            stamp,
            frame_id: frame.to_string(),
        },
        height: i.height,
        width: i.width,
        distortion_model: "plumb_bob".into(),
        d: vec![0.0; 5],
        k: [f, 0.0, cx, 0.0, f, cy, 0.0, 0.0, 1.0],
        r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: [f, 0.0, cx, 0.0, 0.0, f, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
        binning_x: 0,
        binning_y: 0,
        roi: msg::RegionOfInterest::default(),
    }
}

/// Copies an `rgb8`, `bgr8` or `mono8` image into `out`.
pub fn image_from_msg(m: &msg::Image, topic: &str, out: &mut Image) -> Result<(), Ros2Error> {
    let bad = |s: String| Ros2Error::Message {
        topic: topic.to_string(),
        message: s,
    };
    let channels = match m.encoding.as_str() {
        "rgb8" | "bgr8" => 3,
        "mono8" => 1,
        e => return Err(bad(format!("image encoding `{e}` (pbd reads rgb8, bgr8 and mono8)"))),
    };
    let (w, h) = (m.width as usize, m.height as usize);
    if m.width == 0
        || m.height == 0
        || m.width > control_basis::hardware::MAX_IMAGE_SIDE
        || m.height > control_basis::hardware::MAX_IMAGE_SIDE
    {
        return Err(bad(format!("image size {}×{}", m.width, m.height)));
    }
    let step = m.step as usize;
    if step < channels * w || m.data.len() < step * (h - 1) + channels * w {
        return Err(bad(format!(
            "{} bytes with step {} cannot hold {}×{} {}",
            m.data.len(),
            m.step,
            m.width,
            m.height,
            m.encoding
        )));
    }
    out.resize(m.width, m.height);
    for v in 0..h {
        let row = &m.data[v * step..v * step + channels * w];
        let dst = &mut out.rgb[3 * v * w..3 * (v + 1) * w];
        match m.encoding.as_str() {
            "rgb8" => dst.copy_from_slice(row),
            "bgr8" => {
                for (d, s) in dst.chunks_exact_mut(3).zip(row.chunks_exact(3)) {
                    d.copy_from_slice(&[s[2], s[1], s[0]]);
                }
            }
            _ => {
                for (d, s) in dst.chunks_exact_mut(3).zip(row) {
                    d.copy_from_slice(&[*s, *s, *s]);
                }
            }
        }
    }
    Ok(())
}

impl Ros2Hardware {
    /// Connects to the robot `config` maps: waits (up to `timeout_ms` each) for the first joint
    /// state and every camera's `CameraInfo`. `model` is the robot's URDF.
    pub fn connect(config: Ros2Config, model: RobotModel) -> Result<Self, Ros2Error> {
        let domain = config.domain()?;
        let mut endpoint = Endpoint::new(domain, config.namespace.as_deref(), &config.node)?;
        let joint_states = endpoint.subscription(&config.joint_states.topic, types::JOINT_STATE)?;
        let command = match config.command.kind {
            CommandKind::JointTrajectory => {
                CommandPub::Trajectory(endpoint.publisher(&config.command.topic, types::JOINT_TRAJECTORY)?)
            }
            CommandKind::Position | CommandKind::PositionVelocity => {
                CommandPub::Array(endpoint.publisher(&config.command.topic, types::FLOAT64_MULTI_ARRAY)?)
            }
        };
        let wrenches = config
            .force_torque
            .iter()
            .map(|f| endpoint.subscription(&f.topic, types::WRENCH_STAMPED))
            .collect::<Result<Vec<_>, _>>()?;
        let cameras = config
            .camera
            .iter()
            .map(|c| -> Result<CameraLink, Ros2Error> {
                Ok(CameraLink {
                    image: endpoint.subscription(&c.image_topic, types::IMAGE)?,
                    info: endpoint.subscription(&c.info_topic, types::CAMERA_INFO)?,
                    trigger: match &c.trigger_topic {
                        Some(t) => Some(endpoint.publisher(t, types::HEADER)?),
                        None => None,
                    },
                    latest: None,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let teleop = crate::teleop::TeleopInput::new(&mut endpoint, &config.teleop)?;
        let n_ft = config.force_torque.len();
        let mut hw = Ros2Hardware {
            ft_frames: config.force_torque.iter().map(|f| f.frame.clone()).collect(),
            model,
            endpoint,
            joint_states,
            command,
            wrenches,
            cameras,
            joint_names: Vec::new(),
            state_names: Vec::new(),
            state_index: Vec::new(),
            command_index: Vec::new(),
            q: Vec::new(),
            qd: Vec::new(),
            time: 0.0,
            have_state: false,
            ref_q: Vec::new(),
            ref_qd: Vec::new(),
            commanded: Vec::new(),
            ft: vec![ForceTorque::default(); n_ft],
            ft_time: vec![f64::NEG_INFINITY; n_ft],
            camera_infos: Vec::new(),
            teleop,
            fk: Vec::new(),
            ft_raw: vec![[[0.0; 3]; 2]; n_ft],
            ft_link: vec![None; n_ft],
            failed: None,
            config,
        };
        let limit = hw.timeout();
        let start = Instant::now();
        while !hw.have_state {
            hw.drain()?;
            if hw.have_state {
                break;
            }
            if start.elapsed() > limit {
                return Err(timeout(&hw.config.joint_states.topic, "sensor_msgs/JointState", limit));
            }
            hw.endpoint.wait(start + limit);
        }
        hw.ref_q = hw.q.clone();
        hw.ref_qd = vec![0.0; hw.q.len()];
        hw.commanded = vec![false; hw.q.len()];
        hw.command_index = if hw.config.command.joints.is_empty() {
            (0..hw.joint_names.len()).collect()
        } else {
            hw.config
                .command
                .joints
                .iter()
                .map(|j| {
                    hw.joint_names
                        .iter()
                        .position(|n| n == j)
                        .ok_or_else(|| Ros2Error::Config {
                            file: "command.joints".into(),
                            message: format!("`{j}` is not in the joint states of {}", hw.config.joint_states.topic),
                        })
                })
                .collect::<Result<_, _>>()?
        };
        let mut infos: Vec<Option<CameraInfo>> = vec![None; hw.cameras.len()];
        for (k, cam) in hw.config.camera.clone().iter().enumerate() {
            let start = Instant::now();
            loop {
                hw.drain()?;
                if let Some(m) = take_last(&hw.cameras[k].info, &cam.info_topic)? {
                    infos[k] = Some(CameraInfo {
                        name: cam.name.clone(),
                        optical_frame: cam.optical_frame.clone(),
                        intrinsics: intrinsics_from_info(&m, &cam.info_topic)?,
                        pixel_noise: cam.pixel_noise,
                    });
                    break;
                }
                if start.elapsed() > limit {
                    return Err(timeout(&cam.info_topic, "sensor_msgs/CameraInfo", limit));
                }
                hw.endpoint.wait(start + limit);
            }
        }
        hw.camera_infos = infos
            .into_iter()
            .map(|i| i.expect("every camera's info was read"))
            .collect();
        debug!(
            joints = hw.joint_names.len(),
            cameras = hw.camera_infos.len(),
            time = hw.time,
            "connected to the robot over ROS 2"
        );
        Ok(hw)
    }

    fn timeout(&self) -> Duration {
        Duration::from_millis(self.config.timeout_ms)
    }

    /// The mapping in use.
    pub fn config(&self) -> &Ros2Config {
        &self.config
    }

    /// The newest sample of each teleoperated hand of the mapping's `[[teleop]]` (in its order;
    /// `None` until a hand's first pose arrives): what arrived since the last call is taken now.
    /// A pose in another frame than `world_frame`, or not finite, is an error naming its topic.
    pub fn teleop(&mut self) -> Result<&[Option<crate::HandSample>], Ros2Error> {
        self.teleop.poll(&self.config.world_frame)
    }

    /// The motor-unit references last sent (position, velocity per joint of the joint states;
    /// the measured position of a joint never commanded).
    pub fn references(&self) -> (&[f64], &[f64]) {
        (&self.ref_q, &self.ref_qd)
    }

    /// Reads every sample that has arrived.
    fn drain(&mut self) -> Result<(), Ros2Error> {
        let mut turn = false;
        while let Some(m) = take(&self.joint_states, &self.config.joint_states.topic)? {
            self.apply_state(m)?;
            turn = true;
        }
        for k in 0..self.wrenches.len() {
            let topic = &self.config.force_torque[k].topic;
            while let Some(m) = take(&self.wrenches[k], topic)? {
                let (f, t) = (m.wrench.force.to_array(), m.wrench.torque.to_array());
                if f.iter().chain(&t).any(|v| !v.is_finite()) {
                    return Err(Ros2Error::Message {
                        topic: topic.clone(),
                        message: "a wrench that is not finite".into(),
                    });
                }
                let mut link = None;
                if m.header.frame_id != self.config.world_frame {
                    // In a link's own frame (a real sensor's): turned into the world's axes below.
                    let Ok(l) = self.model.link(&m.header.frame_id) else {
                        return Err(Ros2Error::Message {
                            topic: topic.clone(),
                            message: format!(
                                "a wrench in frame `{}`, which is neither `{}` nor a link of the robot's model",
                                m.header.frame_id, self.config.world_frame
                            ),
                        });
                    };
                    link = Some(l);
                }
                self.ft_link[k] = link;
                turn = turn || link.is_some();
                let norm = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
                self.ft_raw[k] = [f, t];
                self.ft[k] = ForceTorque {
                    force: f,
                    torque: t,
                    in_contact: norm > self.config.contact_force,
                };
                self.ft_time[k] = m.header.stamp.secs();
            }
        }
        if turn && self.ft_link.iter().any(Option::is_some) {
            // Readings in their sensors' own frames, in the world's axes at the newest measured
            // joint angles (a state and the wrenches of its instant arrive in either order: this
            // runs again when the other comes). The torque stays about the sensor's origin.
            let (names, q) = (&self.joint_names, &self.q);
            self.model
                .link_poses(&|j| names.iter().position(|n| n == j).map(|i| q[i]), &mut self.fk);
            for k in 0..self.ft.len() {
                if let Some(link) = self.ft_link[k] {
                    let r = self.fk[link].rotation;
                    let [f, t] = self.ft_raw[k];
                    self.ft[k].force = (r * control_basis::math::Vec3::from(f)).into();
                    self.ft[k].torque = (r * control_basis::math::Vec3::from(t)).into();
                }
            }
        }
        for k in 0..self.cameras.len() {
            let topic = &self.config.camera[k].image_topic;
            while let Some(m) = take(&self.cameras[k].image, topic)? {
                self.cameras[k].latest = Some(m);
            }
        }
        Ok(())
    }

    fn apply_state(&mut self, m: msg::JointState) -> Result<(), Ros2Error> {
        let topic = &self.config.joint_states.topic;
        let bad = |s: String| Ros2Error::Message {
            topic: topic.clone(),
            message: s,
        };
        if m.position.len() != m.name.len() || !(m.velocity.is_empty() || m.velocity.len() == m.name.len()) {
            return Err(bad(format!(
                "{} names, {} positions, {} velocities",
                m.name.len(),
                m.position.len(),
                m.velocity.len()
            )));
        }
        if self.joint_names.is_empty() {
            if m.name.is_empty() {
                return Err(bad("a joint state without joints".into()));
            }
            for n in &m.name {
                self.model
                    .joint(n)
                    .map_err(|_| bad(format!("joint `{n}` is not in the robot model")))?;
            }
            self.joint_names = m.name.clone();
            self.q = vec![0.0; m.name.len()];
            self.qd = vec![0.0; m.name.len()];
        }
        if m.name != self.state_names {
            self.state_index = m
                .name
                .iter()
                .map(|n| {
                    self.joint_names
                        .iter()
                        .position(|j| j == n)
                        .ok_or_else(|| bad(format!("joint `{n}` appeared after the first joint state")))
                })
                .collect::<Result<_, _>>()?;
            self.state_names = m.name.clone();
        }
        for (i, &dof) in self.state_index.iter().enumerate() {
            let (q, qd) = (m.position[i], m.velocity.get(i).copied().unwrap_or(0.0));
            if !(q.is_finite() && qd.is_finite()) {
                return Err(bad(format!("joint `{}`: position {q}, velocity {qd}", m.name[i])));
            }
            self.q[dof] = q;
            self.qd[dof] = qd;
        }
        self.time = m.header.stamp.secs();
        self.have_state = true;
        Ok(())
    }

    fn send_command(&mut self, dt: f64) -> Result<(), Ros2Error> {
        let topic = &self.config.command.topic;
        match &self.command {
            CommandPub::Array(p) => {
                let data = match self.config.command.kind {
                    CommandKind::PositionVelocity => self
                        .command_index
                        .iter()
                        .flat_map(|&d| [self.ref_q[d], self.ref_qd[d]])
                        .collect(),
                    _ => self.command_index.iter().map(|&d| self.ref_q[d]).collect(),
                };
                publish(
                    p,
                    topic,
                    msg::Float64MultiArray {
                        layout: msg::MultiArrayLayout::default(),
                        data,
                    },
                )
            }
            CommandPub::Trajectory(p) => {
                // Only the joints the robot has commanded: the controller holds its own reference
                // for the others (`allow_partial_joints_goal` in joint_trajectory_controller).
                let dofs = self.command_index.iter().copied().filter(|&d| self.commanded[d]);
                publish(
                    p,
                    topic,
                    msg::JointTrajectory {
                        header: msg::Header::default(),
                        joint_names: dofs.clone().map(|d| self.joint_names[d].clone()).collect(),
                        points: vec![msg::JointTrajectoryPoint {
                            positions: dofs.clone().map(|d| self.ref_q[d]).collect(),
                            velocities: dofs.map(|d| self.ref_qd[d]).collect(),
                            accelerations: Vec::new(),
                            effort: Vec::new(),
                            time_from_start: msg::Duration::from_secs(dt),
                        }],
                    },
                )
            }
        }
    }

    fn advance_inner(&mut self, dt: f64) -> Result<(), Ros2Error> {
        self.send_command(dt)?;
        let target = self.time + dt - (0.25 * dt).max(1e-7);
        let limit = self.timeout();
        let start = Instant::now();
        loop {
            self.drain()?;
            if self.time >= target {
                break;
            }
            if start.elapsed() > limit {
                return Err(timeout(
                    &self.config.joint_states.topic,
                    "newer sensor_msgs/JointState",
                    limit,
                ));
            }
            self.endpoint.wait(start + limit);
        }
        // Every force/torque reading as new as the joint state.
        loop {
            let late = self.ft_time.iter().position(|&t| t < self.time - 1e-7);
            let Some(k) = late else { break };
            if start.elapsed() > limit {
                return Err(timeout(
                    &self.config.force_torque[k].topic,
                    "geometry_msgs/WrenchStamped",
                    limit,
                ));
            }
            self.endpoint.wait(start + limit);
            self.drain()?;
        }
        Ok(())
    }

    fn capture_inner(&mut self, camera: usize, out: &mut Image) -> Result<(), Ros2Error> {
        let cfg = &self.config.camera[camera];
        let (image_topic, trigger_topic) = (cfg.image_topic.clone(), cfg.trigger_topic.clone());
        let now = self.time;
        let oldest = match (&self.cameras[camera].trigger, &trigger_topic) {
            (Some(p), Some(t)) => {
                publish(
                    p,
                    t,
                    msg::Header {
                        stamp: msg::Time::from_secs(now),
                        frame_id: cfg.optical_frame.clone(),
                    },
                )?;
                now - 1e-7
            }
            _ => now - self.config.max_image_age_ms as f64 * 1e-3,
        };
        let limit = self.timeout();
        let start = Instant::now();
        loop {
            self.drain()?;
            if let Some(m) = &self.cameras[camera].latest
                && m.header.stamp.secs() >= oldest
            {
                return image_from_msg(m, &image_topic, out);
            }
            if start.elapsed() > limit {
                return Err(timeout(&image_topic, "sensor_msgs/Image", limit));
            }
            self.endpoint.wait(start + limit);
        }
    }

    fn fail(&mut self, e: Ros2Error) -> HardwareError {
        warn!(error = %e, "ROS 2 robot: stopping (no further commands)");
        self.failed = Some(e.to_string());
        e.into()
    }
}

fn take_last<M: serde::de::DeserializeOwned + 'static>(
    sub: &Subscription<M>,
    topic: &str,
) -> Result<Option<M>, Ros2Error> {
    let mut last = None;
    while let Some(m) = take(sub, topic)? {
        last = Some(m);
    }
    Ok(last)
}

impl Plant for Ros2Hardware {
    fn joint_names(&self) -> &[String] {
        &self.joint_names
    }
    fn read_joint_positions(&self, q: &mut [f64]) {
        q.copy_from_slice(&self.q);
    }
    fn command(&mut self, references: &[f64]) -> Result<(), CbError> {
        if references.len() != self.q.len() {
            return Err(CbError::DimensionMismatch {
                what: "references".into(),
                expected: self.q.len(),
                got: references.len(),
            });
        }
        self.ref_q.copy_from_slice(references);
        self.ref_qd.fill(0.0);
        self.commanded.fill(true);
        Ok(())
    }
    fn step(&mut self, dt_secs: f64) -> Result<(), CbError> {
        self.advance(dt_secs).map_err(|e| CbError::Solver(e.to_string()))
    }
    fn time_secs(&self) -> f64 {
        self.time
    }
}

impl Hardware for Ros2Hardware {
    fn model(&self) -> &RobotModel {
        &self.model
    }
    fn joint_positions(&self) -> &[f64] {
        &self.q
    }
    fn joint_velocities(&self) -> &[f64] {
        &self.qd
    }
    fn set_joint_reference(&mut self, dof: usize, q: f64, qd: f64) {
        if dof < self.ref_q.len() {
            self.ref_q[dof] = q;
            self.ref_qd[dof] = qd;
            self.commanded[dof] = true;
        }
    }
    fn advance(&mut self, dt_secs: f64) -> Result<(), HardwareError> {
        if let Some(why) = &self.failed {
            return Err(HardwareError::Device {
                device: "ROS 2 robot".into(),
                message: format!("stopped after an earlier error: {why}"),
            });
        }
        if !(dt_secs.is_finite() && dt_secs > 0.0) {
            return Err(HardwareError::Model(CbError::NotFinite {
                what: "advance (s)".into(),
                index: 0,
                value: dt_secs,
            }));
        }
        self.advance_inner(dt_secs).map_err(|e| self.fail(e))
    }
    fn force_torque_frames(&self) -> &[String] {
        &self.ft_frames
    }
    fn read_force_torque(&self, out: &mut [ForceTorque]) {
        for (o, f) in out.iter_mut().zip(&self.ft) {
            *o = *f;
        }
    }
    fn cameras(&self) -> &[CameraInfo] {
        &self.camera_infos
    }
    fn capture(&mut self, camera: usize, out: &mut Image) -> Result<(), HardwareError> {
        if camera >= self.cameras.len() {
            return Err(HardwareError::NoSuchDevice {
                device: "camera",
                index: camera,
                count: self.cameras.len(),
            });
        }
        if let Some(why) = &self.failed {
            return Err(HardwareError::Device {
                device: "ROS 2 robot".into(),
                message: format!("stopped after an earlier error: {why}"),
            });
        }
        self.capture_inner(camera, out).map_err(|e| self.fail(e))
    }
}

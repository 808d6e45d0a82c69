//! A two-joint robot for tests, benches and examples of the ROS 2 bridge: its joints follow their
//! references at a first-order rate, its one fingertip sensor reads the second joint's error, and
//! its camera's 8 × 6 image encodes the time — everything deterministic, so a run served over
//! ROS 2 can be compared bit for bit with the same run in-process.

use crate::config::{CameraConfig, CommandConfig, ForceTorqueConfig, JointStatesConfig, TeleopConfig};
use crate::serve::{ServeOptions, ServeReport, serve_with};
use crate::teleop::{HandSample, Teleoperator};
use crate::{CommandKind, Ros2Config};
use control_basis::{CameraInfo, CbError, ForceTorque, Hardware, HardwareError, Image, Intrinsics, Plant, RobotModel};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// The toy's URDF (joints `j1`, `j2`; links `b` with the sensor and `cam` with the camera).
pub const TOY_URDF: &str = r#"<robot name="two">
  <link name="base"/><link name="a"/><link name="b"/><link name="cam"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0.3 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <joint name="c" type="fixed"><parent link="base"/><child link="cam"/><origin xyz="0 0 1"/></joint>
</robot>"#;

/// A two-joint robot whose joints follow their references at a first-order rate, a fingertip
/// sensor that reads the joints' error, and a camera whose image encodes the time.
pub struct ToyRobot {
    model: RobotModel,
    names: Vec<String>,
    q: Vec<f64>,
    qd: Vec<f64>,
    r: Vec<f64>,
    rd: Vec<f64>,
    t: f64,
    ft_frames: Vec<String>,
    cams: Vec<CameraInfo>,
}

impl ToyRobot {
    /// The robot at rest at (0.1, −0.2) rad.
    pub fn new() -> Self {
        ToyRobot {
            model: RobotModel::from_urdf_str(TOY_URDF).expect("the toy's URDF parses"),
            names: vec!["j1".into(), "j2".into()],
            q: vec![0.1, -0.2],
            qd: vec![0.0; 2],
            r: vec![0.1, -0.2],
            rd: vec![0.0; 2],
            t: 0.0,
            ft_frames: vec!["b".into()],
            cams: vec![CameraInfo {
                name: "eye".into(),
                optical_frame: "cam".into(),
                intrinsics: Intrinsics {
                    width: 8,
                    height: 6,
                    hfov_deg: 60.0,
                },
                pixel_noise: 0.01,
            }],
        }
    }
}

impl Plant for ToyRobot {
    fn joint_names(&self) -> &[String] {
        &self.names
    }
    fn read_joint_positions(&self, q: &mut [f64]) {
        q.copy_from_slice(&self.q);
    }
    fn command(&mut self, references: &[f64]) -> Result<(), CbError> {
        self.r.copy_from_slice(references);
        Ok(())
    }
    fn step(&mut self, dt: f64) -> Result<(), CbError> {
        self.advance(dt).map_err(|e| CbError::Solver(e.to_string()))
    }
    fn time_secs(&self) -> f64 {
        self.t
    }
}

impl Hardware for ToyRobot {
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
        self.r[dof] = q;
        self.rd[dof] = qd;
    }
    fn advance(&mut self, dt: f64) -> Result<(), HardwareError> {
        for i in 0..2 {
            self.qd[i] = 5.0 * (self.r[i] - self.q[i]) + self.rd[i];
            self.q[i] += dt * self.qd[i];
        }
        self.t += dt;
        Ok(())
    }
    fn force_torque_frames(&self) -> &[String] {
        &self.ft_frames
    }
    fn read_force_torque(&self, out: &mut [ForceTorque]) {
        let e = self.r[1] - self.q[1];
        out[0] = ForceTorque {
            force: [e, 0.0, 1.0],
            torque: [0.0, e, 0.0],
            in_contact: true,
        };
    }
    fn cameras(&self) -> &[CameraInfo] {
        &self.cams
    }
    fn capture(&mut self, _camera: usize, out: &mut Image) -> Result<(), HardwareError> {
        out.resize(8, 6);
        let v = ((self.t * 1000.0).round() as u64 % 256) as u8;
        for (i, b) in out.rgb.iter_mut().enumerate() {
            *b = v.wrapping_add(i as u8);
        }
        Ok(())
    }
}

impl Default for ToyRobot {
    fn default() -> Self {
        Self::new()
    }
}

impl std::fmt::Debug for ToyRobot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ToyRobot")
            .field("t", &self.t)
            .field("q", &self.q)
            .finish()
    }
}

/// A teacher at the toy's hand `tip`: after each advance one sample stamped with the toy's time
/// `t`, at `[t, 2t, 0]` with flexion `t` and the identity orientation.
#[derive(Debug)]
pub struct ToyTeacher;

impl Teleoperator<ToyRobot> for ToyTeacher {
    fn samples(&mut self, hw: &mut ToyRobot, out: &mut Vec<HandSample>) -> Result<(), crate::Ros2Error> {
        let t = hw.time_secs();
        out.push(HandSample {
            hand: "tip".into(),
            stamp: t,
            position: [t, 2.0 * t, 0.0],
            orientation: [0.0, 0.0, 0.0, 1.0],
            flexion: t,
        });
        Ok(())
    }
}

/// The toy's topics (`/toy/…`) on DDS domain `domain`, commanded with `kind`; its camera takes
/// software triggers.
pub fn toy_config(domain: u16, kind: CommandKind) -> Ros2Config {
    Ros2Config {
        node: "pbd_test".into(),
        namespace: None,
        domain_id: Some(domain),
        world_frame: "world".into(),
        timeout_ms: 3000,
        max_image_age_ms: 200,
        contact_force: 0.0,
        joint_states: JointStatesConfig {
            topic: "/toy/joint_states".into(),
        },
        command: CommandConfig {
            kind,
            topic: "/toy/commands".into(),
            joints: Vec::new(),
        },
        force_torque: vec![ForceTorqueConfig {
            frame: "b".into(),
            topic: "/toy/tip/wrench".into(),
        }],
        camera: vec![CameraConfig {
            name: "eye".into(),
            optical_frame: "cam".into(),
            image_topic: "/toy/eye/image_raw".into(),
            info_topic: "/toy/eye/camera_info".into(),
            trigger_topic: Some("/toy/eye/trigger".into()),
            pixel_noise: 0.01,
        }],
        teleop: vec![TeleopConfig {
            hand: "tip".into(),
            pose_topic: "/toy/teleop/pose".into(),
            flexion_topic: "/toy/teleop/flexion".into(),
        }],
    }
}

/// A [`ToyRobot`] served on a thread of its own until [`ServedToy::stop`].
#[derive(Debug)]
pub struct ServedToy {
    stop: Arc<AtomicBool>,
    thread: std::thread::JoinHandle<Result<ServeReport, crate::Ros2Error>>,
}

impl ServedToy {
    /// Serves a fresh toy on `config`'s topics with `options`.
    pub fn start(config: &Ros2Config, options: ServeOptions) -> Self {
        Self::spawn(config, options, false)
    }

    /// [`ServedToy::start`] with a [`ToyTeacher`] at the toy's side.
    pub fn start_with_teacher(config: &Ros2Config, options: ServeOptions) -> Self {
        Self::spawn(config, options, true)
    }

    fn spawn(config: &Ros2Config, options: ServeOptions, teach: bool) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let (config, flag) = (config.clone(), stop.clone());
        let thread = std::thread::spawn(move || {
            let mut toy = ToyRobot::new();
            let mut teacher = ToyTeacher;
            let teacher: Option<&mut dyn Teleoperator<ToyRobot>> = if teach { Some(&mut teacher) } else { None };
            serve_with(&mut toy, &config, &options, &|| flag.load(Ordering::Relaxed), teacher)
        });
        ServedToy { stop, thread }
    }

    /// Stops serving; the server's report (or its error, or a message if its thread panicked).
    pub fn stop(self) -> Result<ServeReport, String> {
        self.stop.store(true, Ordering::Relaxed);
        match self.thread.join() {
            Ok(r) => r.map_err(|e| e.to_string()),
            Err(_) => Err("the server's thread panicked".into()),
        }
    }
}

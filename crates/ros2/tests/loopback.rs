//! A robot served over ROS 2 in one thread and driven through `Ros2Hardware` in another, on
//! localhost DDS: in lock step the driven robot sees exactly what the same robot shows in-process.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use control_basis::{CameraInfo, CbError, ForceTorque, Hardware, HardwareError, Image, Intrinsics, Plant, RobotModel};
use pbd_ros2::config::{CameraConfig, CommandConfig, ForceTorqueConfig, JointStatesConfig};
use pbd_ros2::{CommandKind, Ros2Config, Ros2Hardware, ServeOptions, serve};

const URDF: &str = r#"<robot name="two">
  <link name="base"/><link name="a"/><link name="b"/><link name="cam"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0.3 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <joint name="c" type="fixed"><parent link="base"/><child link="cam"/><origin xyz="0 0 1"/></joint>
</robot>"#;

/// A two-joint robot whose joints follow their references at a first-order rate, a fingertip
/// sensor that reads the joints' error, and a camera whose image encodes the time.
struct Toy {
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

impl Toy {
    fn new() -> Self {
        Toy {
            model: RobotModel::from_urdf_str(URDF).unwrap(),
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

impl Plant for Toy {
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

impl Hardware for Toy {
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

fn config(domain: u16, kind: CommandKind) -> Ros2Config {
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
    }
}

/// A domain of its own per test and process (tests of several processes may run at once).
fn domain(k: u16) -> u16 {
    100 + ((std::process::id() % 40) as u16) * 3 + k
}

/// What the script read at one step: time, joint positions, the fingertip force, an image (or none).
type Reading = (f64, Vec<f64>, [f64; 3], Vec<u8>);

/// Drives `hw` through a fixed script: references, advances, captures; returns what it read.
fn script(hw: &mut dyn Hardware) -> Vec<Reading> {
    let mut out = Vec::new();
    let mut img = Image::default();
    let mut ft = [ForceTorque::default()];
    for k in 0..60 {
        let s = k as f64 * 0.05;
        hw.set_joint_reference(0, 0.5 * s.sin(), 0.5 * s.cos());
        hw.set_joint_reference(1, -0.3 + 0.1 * s, 0.1);
        hw.advance(0.002).unwrap();
        hw.read_force_torque(&mut ft);
        let bytes = if k % 10 == 0 {
            hw.capture(0, &mut img).unwrap();
            img.rgb.clone()
        } else {
            Vec::new()
        };
        out.push((hw.time_secs(), hw.joint_positions().to_vec(), ft[0].force, bytes));
    }
    out
}

#[test]
fn lock_step_over_dds_reads_what_the_robot_shows_in_process() {
    let cfg = config(domain(0), CommandKind::JointTrajectory);
    let stop = Arc::new(AtomicBool::new(false));
    let server = {
        let (cfg, stop) = (cfg.clone(), stop.clone());
        std::thread::spawn(move || {
            let mut toy = Toy::new();
            serve(
                &mut toy,
                &cfg,
                &ServeOptions {
                    lockstep: true,
                    ..ServeOptions::default()
                },
                &|| stop.load(Ordering::Relaxed),
            )
            .unwrap()
        })
    };
    let mut remote = Ros2Hardware::connect(cfg, RobotModel::from_urdf_str(URDF).unwrap()).unwrap();
    assert_eq!(remote.joint_names(), ["j1", "j2"]);
    assert_eq!(remote.cameras()[0].intrinsics.width, 8);
    assert!((remote.cameras()[0].intrinsics.hfov_deg - 60.0).abs() < 1e-9);
    let got = script(&mut remote);
    stop.store(true, Ordering::Relaxed);
    let report = server.join().unwrap();
    assert_eq!(report.commands, 60);
    assert_eq!(report.images, 6);

    let mut local = Toy::new();
    let want = script(&mut local);
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        assert!((g.0 - w.0).abs() < 1e-9, "step {k}: time {} vs {}", g.0, w.0);
        assert_eq!(g.1, w.1, "step {k}: joint positions");
        assert_eq!(g.2, w.2, "step {k}: force");
        assert_eq!(g.3, w.3, "step {k}: image");
    }
}

#[test]
fn a_robot_that_stops_answering_is_an_error_naming_the_topic_and_the_robot_stops_commanding() {
    let cfg = config(domain(1), CommandKind::PositionVelocity);
    let stop = Arc::new(AtomicBool::new(false));
    let server = {
        let (cfg, stop) = (cfg.clone(), stop.clone());
        std::thread::spawn(move || {
            let mut toy = Toy::new();
            serve(
                &mut toy,
                &cfg,
                &ServeOptions {
                    lockstep: true,
                    ..ServeOptions::default()
                },
                &|| stop.load(Ordering::Relaxed),
            )
            .unwrap()
        })
    };
    let mut cfg_robot = cfg.clone();
    cfg_robot.timeout_ms = 300;
    let mut remote = Ros2Hardware::connect(cfg_robot, RobotModel::from_urdf_str(URDF).unwrap()).unwrap();
    remote.set_joint_reference(0, 0.3, 0.0);
    remote.advance(0.002).unwrap();
    stop.store(true, Ordering::Relaxed);
    server.join().unwrap();
    std::thread::sleep(Duration::from_millis(100));
    let e = remote.advance(0.002).unwrap_err().to_string();
    assert!(e.contains("/toy/joint_states"), "{e}");
    let again = remote.advance(0.002).unwrap_err().to_string();
    assert!(again.contains("stopped after an earlier error"), "{again}");
}

#[test]
fn no_robot_on_the_domain_is_a_timeout_naming_the_joint_state_topic() {
    let mut cfg = config(domain(2), CommandKind::Position);
    cfg.timeout_ms = 300;
    let e = Ros2Hardware::connect(cfg, RobotModel::from_urdf_str(URDF).unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("/toy/joint_states") && e.contains("300 ms"), "{e}");
}

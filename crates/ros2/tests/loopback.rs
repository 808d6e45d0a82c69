//! A robot served over ROS 2 in one thread and driven through `Ros2Hardware` in another, on
//! localhost DDS: in lock step the driven robot sees exactly what the same robot shows in-process.

use std::time::Duration;

use control_basis::{ForceTorque, Hardware, Image, Plant, RobotModel};
use pbd_ros2::testing::{ServedToy, TOY_URDF as URDF, ToyRobot as Toy, toy_config as config};
use pbd_ros2::{CommandKind, Ros2Hardware, ServeOptions};

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
    let server = ServedToy::start(
        &cfg,
        ServeOptions {
            lockstep: true,
            ..ServeOptions::default()
        },
    );
    let mut remote = Ros2Hardware::connect(cfg, RobotModel::from_urdf_str(URDF).unwrap()).unwrap();
    assert_eq!(remote.joint_names(), ["j1", "j2"]);
    assert_eq!(remote.cameras()[0].intrinsics.width, 8);
    assert!((remote.cameras()[0].intrinsics.hfov_deg - 60.0).abs() < 1e-9);
    let got = script(&mut remote);
    let report = server.stop().unwrap();
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
    let server = ServedToy::start(
        &cfg,
        ServeOptions {
            lockstep: true,
            ..ServeOptions::default()
        },
    );
    let mut cfg_robot = cfg.clone();
    cfg_robot.timeout_ms = 300;
    let mut remote = Ros2Hardware::connect(cfg_robot, RobotModel::from_urdf_str(URDF).unwrap()).unwrap();
    remote.set_joint_reference(0, 0.3, 0.0);
    remote.advance(0.002).unwrap();
    server.stop().unwrap();
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

#[test]
fn a_teachers_samples_of_an_instant_arrive_with_its_state() {
    let cfg = config(domain(2), CommandKind::JointTrajectory);
    let server = ServedToy::start_with_teacher(
        &cfg,
        ServeOptions {
            lockstep: true,
            ..ServeOptions::default()
        },
    );
    let mut hw = Ros2Hardware::connect(cfg, RobotModel::from_urdf_str(URDF).unwrap()).unwrap();
    for k in 0..40 {
        hw.set_joint_reference(0, 0.01 * k as f64, 0.0);
        hw.advance(0.002).unwrap();
        let t = hw.time_secs();
        let s = hw.teleop().unwrap()[0].clone().expect("a sample");
        // The sample the teacher gave at this instant, not an older one.
        assert!(
            (s.stamp - t).abs() < 1e-9,
            "step {k}: sample at {} for state at {t}",
            s.stamp
        );
        assert_eq!(s.hand, "tip");
        assert!((s.position[1] - 2.0 * s.stamp).abs() < 1e-9 && (s.flexion - s.stamp).abs() < 1e-9);
        assert_eq!(s.orientation, [0.0, 0.0, 0.0, 1.0]);
    }
    server.stop().unwrap();
}

#[test]
fn wrenches_in_their_sensors_frames_are_turned_into_the_worlds_axes() {
    let cfg = config(domain(1), CommandKind::JointTrajectory);
    let server = ServedToy::start(
        &cfg,
        ServeOptions {
            lockstep: true,
            sensor_frames: true,
            ..ServeOptions::default()
        },
    );
    let mut remote = Ros2Hardware::connect(cfg, RobotModel::from_urdf_str(URDF).unwrap()).unwrap();
    let got = script(&mut remote);
    server.stop().unwrap();
    let want = script(&mut Toy::new());
    let mut turned = 0;
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        for i in 0..3 {
            assert!((g.2[i] - w.2[i]).abs() < 1e-12, "step {k}: {:?} vs {:?}", g.2, w.2);
        }
        turned += usize::from(w.2[0].abs() > 1e-3);
    }
    assert!(turned > 10, "the toy's link turned with a force on it: {turned} steps");
}

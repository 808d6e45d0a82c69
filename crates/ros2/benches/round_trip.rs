//! The reference → encoder round trip over ROS 2 on localhost DDS: `Ros2Hardware::advance` sends
//! one motor-unit command and waits for the joint state (and force/torque reading) the served
//! robot publishes after it. Lock step: the served toy robot steps as each command arrives, so the
//! figure is the transport alone (serialisation, DDS, the two waits). Free-running at 500 Hz: the
//! server ticks every 2 ms in real time, and a command waits for the next tick's state.

use control_basis::{Hardware, RobotModel};
use criterion::{Criterion, criterion_group, criterion_main};
use pbd_ros2::testing::{ServedToy, TOY_URDF, toy_config};
use pbd_ros2::{CommandKind, Ros2Hardware, ServeOptions};

fn round_trip(c: &mut Criterion) {
    for (name, lockstep, domain) in [("lockstep", true, 201u16), ("free_500hz", false, 202)] {
        let mut cfg = toy_config(
            domain + (std::process::id() % 10) as u16 * 2,
            CommandKind::JointTrajectory,
        );
        cfg.camera[0].trigger_topic = None;
        let server = ServedToy::start(
            &cfg,
            ServeOptions {
                lockstep,
                camera_rate_hz: 0.0,
                ..ServeOptions::default()
            },
        );
        let mut hw = Ros2Hardware::connect(cfg, RobotModel::from_urdf_str(TOY_URDF).unwrap()).unwrap();
        let mut k = 0u64;
        c.bench_function(&format!("ros2_reference_to_encoder_{name}"), |b| {
            b.iter(|| {
                k += 1;
                hw.set_joint_reference(0, 0.3 * ((k % 100) as f64 / 100.0), 0.0);
                hw.advance(0.002).unwrap();
                std::hint::black_box(hw.joint_positions()[0])
            })
        });
        drop(hw);
        server.stop().expect("the toy was served");
    }
}

criterion_group!(benches, round_trip);
criterion_main!(benches);

//! The Rapier model of Dexter agrees with the URDF kinematics, holds still, and senses forces.

use control_basis::{Chain, ChainBinding};
use dexter_sim::physics::{DexterSim, SimSettings};
use dexter_sim::scene::Scene;

fn empty_scene() -> Scene {
    Scene::builtin("pick-place")
        .expect("builtin scene")
        .with_objects(vec![])
        .expect("empty scene")
}

#[test]
fn bodies_follow_urdf_forward_kinematics() {
    let scene = empty_scene();
    let mut sim = DexterSim::new(
        &scene,
        SimSettings {
            encoder_noise: 0.0,
            ..SimSettings::default()
        },
    )
    .unwrap();
    let n = sim.joint_names().len();
    let mut q = vec![0.0; n];
    for (i, v) in q.iter_mut().enumerate() {
        let (lo, hi, _) = sim.dof_limits(i);
        *v = lo + (hi - lo) * (0.3 + 0.4 * ((i * 7919) % 13) as f64 / 13.0);
    }
    sim.set_configuration(&q).unwrap();
    let mut worst: f64 = 0.0;
    for tip in [
        "left/bhand/palm_surface_link",
        "right/bhand/palm_surface_link",
        "left/bhand/finger_3/tip_link",
        "right/bhand/finger_1/tip_link",
        "left/bhand/finger_2/tip_link",
        "head/left_camera_optical_frame",
    ] {
        let chain = Chain::new(sim.model(), "world", tip).unwrap();
        let binding = ChainBinding::by_name(&chain, sim.joint_names()).unwrap();
        let mut qc = vec![0.0; chain.dof()];
        binding.gather(&q, &mut qc);
        let mut st = chain.new_state();
        st.set_q(&chain, &qc).unwrap();
        control_basis::forward_kinematics(&chain, &mut st);
        let fk = *st.tip_pose();
        let sim_pose = sim.link_pose_by_name(tip).unwrap();
        let d = (fk.translation.vector - sim_pose.translation.vector).norm();
        let a = fk.rotation.angle_to(&sim_pose.rotation);
        println!("{tip}: {d:.2e} m {a:.2e} rad");
        worst = worst.max(d).max(a);
    }
    assert!(worst < 1e-9, "worst {worst}");
    // Encoders read back the configuration.
    for (i, &v) in q.iter().enumerate() {
        assert!(
            (sim.joint_positions()[i] - v).abs() < 1e-9,
            "{}: {} vs {v}",
            sim.joint_names()[i],
            sim.joint_positions()[i]
        );
    }
}

/// Rolling resistance (`SimSettings::rolling_resistance`), which Rapier lacks: a baseball shoved at
/// 0.3 m/s through its centre slides until it rolls at 5/7 of that, then stops after
/// v² (1 + k) / (2 c g) = 16 cm for c = 0.02 and a solid ball (k = 2/5) — a little less with the
/// objects' angular damping (measured 12.6 cm) — and stays on the table; without it the same shove
/// rolls it more than twice as far (59 cm, until angular damping and sleeping stop it).
#[test]
fn a_shoved_ball_rolls_to_rest_against_rolling_resistance() {
    let scene = Scene::builtin("pick-place")
        .expect("builtin scene")
        .with_objects(vec![dexter_sim::scene::ObjectPlacement {
            presentation: "baseball".into(),
            xy: [0.8, 0.55],
            yaw_deg: 0.0,
            z: None,
        }])
        .expect("one ball");
    let roll = |c: f64| {
        let mut sim = DexterSim::new(
            &scene,
            SimSettings {
                rolling_resistance: c,
                placement_jitter: (0.0, 0.0),
                ..SimSettings::default()
            },
        )
        .unwrap();
        for _ in 0..300 {
            sim.step();
        }
        let start = sim.object_state(0).pose.translation.vector;
        let mass = sim.objects()[0].mass;
        // Towards −y, along the table's far edge, past the bins (1.25 m of table ahead).
        let v = nalgebra::Vector3::new(0.0, -0.3, 0.0);
        sim.push_object(0, &(v * mass), &start);
        let mut rest = None;
        for k in 0..8000 {
            sim.step();
            let s = sim.object_state(0);
            if k > 200 && s.linvel.norm() < 1e-3 && sim.object_angvel(0).norm() < 0.05 {
                rest = Some(s.pose.translation.vector);
                break;
            }
        }
        let end = rest.unwrap_or(sim.object_state(0).pose.translation.vector);
        ((end - start).xy().norm(), end.z, rest.is_some())
    };
    let (d, z, stopped) = roll(dexter_sim::physics::ROLLING_RESISTANCE);
    println!("with rolling resistance: {d:.3} m, z {z:.3}, at rest {stopped}");
    assert!(stopped, "still rolling after 8 s ({d:.3} m)");
    assert!(
        (0.08..0.2).contains(&d),
        "rolled {d:.3} m (expected 16 cm or a little less)"
    );
    assert!(z > scene.spec.table.height, "left the table (z {z:.3})");
    let (free, _, _) = roll(0.0);
    println!("without: {free:.3} m");
    assert!(free > 2.0 * d, "without rolling resistance {free:.3} m, with {d:.3} m");
}

#[test]
fn a_nan_or_negative_rolling_resistance_is_refused_by_name() {
    let scene = empty_scene();
    for c in [f64::NAN, -0.1, f64::INFINITY] {
        let Err(e) = DexterSim::new(
            &scene,
            SimSettings {
                rolling_resistance: c,
                ..SimSettings::default()
            },
        ) else {
            panic!("rolling_resistance {c} accepted");
        };
        assert!(e.to_string().contains("rolling_resistance"), "{e}");
    }
}

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

use control_basis::math::{Iso3, Vec3};
use control_basis::{Chain, IkSettings, inverse_kinematics};
use dexter_sim::Arm;
use dexter_sim::control::top_down_orientation;
use dexter_sim::physics::{DexterSim, SimSettings};
use dexter_sim::scene::Scene;
use dexter_sim::task::{park_pose, park_robot};
fn main() {
    let scene = Scene::builtin("pick-place").unwrap();
    let mut sim = DexterSim::new(&scene, SimSettings::default()).unwrap();
    park_robot(&mut sim, 0.75).unwrap();
    for arm in Arm::BOTH {
        let chain = Chain::new(sim.model(), "world", &dexter_sim::control::tool_link(arm)).unwrap();
        let b = control_basis::ChainBinding::by_name(&chain, sim.joint_names()).unwrap();
        let mut q = vec![0.0; 7];
        b.gather(sim.joint_positions(), &mut q);
        println!("{arm} park q = {:.2?}", q);
        for (axis, label) in [
            (Vec3::x(), "x"),
            (-Vec3::x(), "-x"),
            (Vec3::y(), "y"),
            (-Vec3::y(), "-y"),
        ] {
            let rot = top_down_orientation(&axis, &park_pose(arm, 0.75).rotation);
            let target = Iso3::from_parts(nalgebra::Translation3::new(0.55, 0.0, 0.95), rot);
            let s = IkSettings {
                position_tolerance: 5e-4,
                orientation_tolerance: 5e-3,
                restarts: 30,
                seed: 3,
                ..IkSettings::default()
            };
            let sol = inverse_kinematics(&chain, &target, &q, &s).unwrap();
            println!(
                "  axis {label}: conv {} attempts {} err {:.3} q {:.2?}",
                sol.converged,
                sol.attempts,
                sol.position_error,
                sol.q.as_slice()
            );
        }
    }
}

//! Debug probe: one pick-and-place with the object's position printed at every activity change
//! and every 0.1 s during `TRACE_FROM..TRACE_TO` seconds.
use dexter_sim::physics::{DexterSim, SimSettings};
use dexter_sim::pick_place::{PickPlaceRequest, WorldObserver, pick_and_place_in};
use dexter_sim::scene::{ObjectPlacement, Scene};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).cloned().unwrap_or("jif".into());
    let place = args.get(2).cloned().unwrap_or("bin-left".into());
    let seed: u64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(0);
    let from: f64 = std::env::var("TRACE_FROM")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1e9);
    let to: f64 = std::env::var("TRACE_TO")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1e9);
    let base = Scene::builtin("pick-place").expect("scene");
    let scene = base
        .with_objects(vec![ObjectPlacement {
            presentation: name.clone(),
            xy: [0.55, 0.0],
            yaw_deg: 0.0,
            z: None,
        }])
        .expect("scene");
    let mut sim = DexterSim::new(
        &scene,
        SimSettings {
            seed,
            ..SimSettings::default()
        },
    )
    .expect("sim");
    let mut last = String::new();
    let mut next = 0.0;
    let mut cb = |s: &DexterSim, a: &str| {
        let t = s.time();
        if a != last || (t >= from && t <= to && t >= next) {
            next = t + 0.1;
            last = a.to_string();
            let st = s.object_state(0);
            let (f, _, parts) = s.hand_wrench_on_object(dexter_sim::Arm::Left, 0);
            let qd = s.joint_velocities();
            let names = s.joint_names();
            let (wi, wv) = qd
                .iter()
                .enumerate()
                .filter(|(i, _)| names[*i].starts_with("left/") && !names[*i].contains("bhand"))
                .fold((0, 0.0), |a, (i, v)| if v.abs() > a.1 { (i, v.abs()) } else { a });
            let fl: Vec<f64> = [
                "left/bhand/finger_1/med_joint",
                "left/bhand/finger_2/med_joint",
                "left/bhand/finger_3/med_joint",
                "left/bhand/finger_1/prox_joint",
            ]
            .iter()
            .map(|n| s.joint_positions()[s.dof(n).unwrap()])
            .collect();
            let mut tips = [dexter_sim::snapshot::FingertipWrench {
                arm: dexter_sim::Arm::Left,
                finger: 0,
                force: [0.0; 3],
                torque: [0.0; 3],
                in_contact: false,
            }; 6];
            s.fingertip_wrenches(&mut tips);
            println!(
                "   flex {:.3?} tips {:?}",
                fl,
                tips[..3].iter().map(|t| format!("{:.2?}", t.force)).collect::<Vec<_>>()
            );
            let palm = s.link_pose_by_name("left/bhand/palm_surface_link").unwrap();
            println!(
                "t={t:.2} {a:20} obj {:.3?} v {:.3} hand f {:.2?} parts {parts} fastest {} {wv:.2} palm {:.3?} rot {:.3?}",
                st.pose.translation.vector.as_slice(),
                st.linvel.norm(),
                f.as_slice(),
                names[wi],
                palm.translation.vector.as_slice(),
                palm.rotation.scaled_axis().as_slice()
            );
        }
    };
    let req = PickPlaceRequest {
        object: name,
        place,
        arm: None,
    };
    let r = pick_and_place_in(&mut sim, &scene, &req, &mut WorldObserver::new(&mut cb)).expect("run");
    println!("{} {}", r.success, r.outcome);
}

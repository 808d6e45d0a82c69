//! Probe: one pick-and-place per catalog object on the built-in pick-place scene.
use dexter_sim::physics::SimSettings;
use dexter_sim::pick_place::{PickPlaceRequest, pick_and_place};
use dexter_sim::scene::{ObjectPlacement, Scene};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let base = Scene::builtin("pick-place").expect("scene");
    let names: Vec<String> = if args.len() > 1 {
        args[1..].to_vec()
    } else {
        base.catalog
            .presentation_names()
            .iter()
            .map(|s| s.to_string())
            .collect()
    };
    let place = std::env::var("PLACE").unwrap_or("bin-left".into());
    let mut ok = 0;
    for name in &names {
        let scene = base
            .with_objects(vec![ObjectPlacement {
                presentation: name.clone(),
                xy: [0.55, 0.0],
                yaw_deg: 0.0,
                z: None,
            }])
            .expect("scene");
        let req = PickPlaceRequest {
            object: name.clone(),
            place: place.clone(),
            arm: None,
        };
        let seed: u64 = std::env::var("SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(0);
        match pick_and_place(
            &scene,
            &req,
            SimSettings {
                seed,
                ..SimSettings::default()
            },
        ) {
            Ok(r) => {
                if r.success {
                    ok += 1;
                }
                println!(
                    "{name:16} {:5} {:6} lifted={} w={:?} vis={:?} fc={:?} t={:.2}s wall={:.2}s rtf={:.2} {} {:?}",
                    r.success,
                    r.arm.to_string(),
                    r.lifted,
                    r.weighed.map(|(a, b)| (a - b) / b),
                    r.vision_error,
                    r.force_closure,
                    r.sim_time,
                    r.wall_time,
                    r.real_time_factor,
                    r.outcome,
                    r.final_position
                );
            }
            Err(e) => println!("{name:16} error {e}"),
        }
    }
    println!("{ok}/{}", names.len());
}

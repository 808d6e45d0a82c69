//! A teacher names the colour that covers most of an object's surface; the head looks down on the
//! table and sees tops out of proportion. The robot's colour terms of a standing object weigh each
//! pixel by the surface its face stands for (`dexter::watch`, surface colour terms): a peanut-butter
//! jar with a blue lid and a red label is red, a dark soy-sauce bottle with a red cap is black —
//! from the pixels alone the head saw the jar blue and the bottle red (development seeds of
//! `pbd experiment execute`).

use dexter::exec::{NoSink, RobotPlant};
use dexter_sim::hardware::{SimRobot, parked_sim, workspace};
use dexter_sim::physics::SimSettings;
use dexter_sim::scene::Scene;
use schema::percept::COLOR_TERMS;

fn dominant(colors: &[(u8, f64)]) -> &'static str {
    let t = colors.iter().max_by(|a, b| a.1.total_cmp(&b.1)).map_or(0, |c| c.0);
    COLOR_TERMS[usize::from(t)]
}

#[test]
fn standing_objects_are_named_by_the_colour_of_most_of_their_surface() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: renders and simulates; run with cargo test --release");
        return;
    }
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/scenes/surface-colours.toml");
    let text = "version = 1\nname = \"surface-colours\"\ncatalog = \"../objects/household.toml\"\nseed = 4\n\n\
        [table]\nheight = 0.75\ncenter = [0.6, 0.0]\nsize = [0.6, 1.4]\n\n\
        [[objects]]\npresentation = \"jif\"\nxy = [0.62, 0.12]\n\n\
        [[objects]]\npresentation = \"soy_sauce\"\nxy = [0.62, -0.12]\n";
    let scene = Scene::from_toml_str(text, path).unwrap();
    let calibration = dexter_sim::calibrate::workcell_calibration(&scene).unwrap();
    let mut sim = parked_sim(&scene, SimSettings::default()).unwrap();
    let truth: Vec<[f64; 2]> = (0..sim.objects().len())
        .map(|i| {
            let p = sim.object_state(i).pose.translation.vector;
            [p.x, p.y]
        })
        .collect();
    let ws = workspace(&scene);
    let library = schema::Library::builtin();
    let mut sink = NoSink;
    let mut hw = SimRobot::new(&mut sim, &scene, 4).unwrap();
    let mut plant = RobotPlant::new(&mut hw, &ws, calibration, &library, &mut sink).unwrap();
    let segments = dexter::task::look_over_table(&mut plant).unwrap();
    for (name, at, colour) in [("jif", truth[0], "red"), ("soy_sauce", truth[1], "black")] {
        let s = segments
            .iter()
            .find(|s| (s.centroid[0] - at[0]).hypot(s.centroid[1] - at[1]) < 0.05)
            .unwrap_or_else(|| panic!("{name} not seen: {segments:?}"));
        let model = s.extent.as_ref().map(|e| e.model.as_str());
        assert_eq!(
            dominant(&s.colors),
            colour,
            "{name}: colour terms {:?} (extent {model:?})",
            s.colors
        );
    }
}

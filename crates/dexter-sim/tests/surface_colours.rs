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

/// The robot's look over the table of the scene `text` (as if read from `path`), parked, with the
/// workcell's calibration; and where each object stands (x, y: the world's truth).
fn look_over_table(text: &str, path: &str) -> (Vec<schema::SegmentPercept>, Vec<[f64; 2]>) {
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
    (dexter::task::look_over_table(&mut plant).unwrap(), truth)
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
    let (segments, truth) = look_over_table(text, path);
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

/// Near the robot the chest hides the lower part of an object from the head: the head sees a red
/// coffee can 0.43 m in front of it (its image cut by the body) mostly by its black lid — 91 % —
/// and cannot measure it on the table. The fixed chassis pair, in front of the chest, sees it
/// whole: the robot names it red (development seed 2 of `pbd experiment execute`, scene 35: such
/// cans were left alone as not red).
#[test]
fn an_object_beside_the_chest_is_named_from_the_chassis_pair() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: renders and simulates; run with cargo test --release");
        return;
    }
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/scenes/near-chest.toml");
    let text = "version = 1\nname = \"near-chest\"\ncatalog = \"../objects/household.toml\"\nseed = 4\n\n\
        [table]\nheight = 0.75\ncenter = [0.6, 0.0]\nsize = [0.6, 1.4]\n\n\
        [[objects]]\npresentation = \"red_coffee\"\nxy = [0.433, 0.059]\nyaw_deg = 216.0\n";
    let (segments, _) = look_over_table(text, path);
    assert_eq!(segments.len(), 1, "one can, one segment: {segments:?}");
    assert_eq!(
        dominant(&segments[0].colors),
        "red",
        "colour terms {:?}",
        segments[0].colors
    );
}

/// The head sees a coffee can 0.43 m in front of the robot over its chest, which hides the can's
/// lower part: it measures nothing on the table (its triangulated centroid lies 6.5 cm beyond the
/// can), and the hand, closing there, pushed the can away (development seed 1 of
/// `pbd experiment execute`, scene 21, whose three objects these are). The fixed chassis pair
/// sees it from in front of the chest — whole in its right camera, cut by the border of its left
/// one: the robot locates it from that one whole view, within 2.5 cm.
#[test]
fn an_object_beside_the_chest_is_located_from_the_chassis_pair() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: renders and simulates; run with cargo test --release");
        return;
    }
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/scenes/near-chest.toml");
    let text = "version = 1\nname = \"near-chest\"\ncatalog = \"../objects/household.toml\"\nseed = 4\n\n\
        [table]\nheight = 0.75\ncenter = [0.6, 0.0]\nsize = [0.6, 1.4]\n\n\
        [[objects]]\npresentation = \"red_coffee\"\nxy = [0.428, -0.146]\nyaw_deg = 233.0\n\n\
        [[objects]]\npresentation = \"jif-1\"\nxy = [0.560, -0.200]\nyaw_deg = 285.0\n\n\
        [[objects]]\npresentation = \"jif-1\"\nxy = [0.741, -0.001]\nyaw_deg = 332.0\n";
    let (segments, truth) = look_over_table(text, path);
    let at = truth[0];
    let can = segments
        .iter()
        .find(|s| (s.centroid[0] - at[0]).hypot(s.centroid[1] - at[1]) < 0.08)
        .unwrap_or_else(|| panic!("the can not seen: {segments:?}"));
    let e = can.extent.as_ref().expect("an extent");
    let off = (e.center[0] - at[0]).hypot(e.center[1] - at[1]);
    assert!(
        e.model != "coarse" && off < 0.025,
        "measured {:.3} m from where it stands: {e:?}",
        off
    );
}

/// The shares of the colour terms in `counts`.
fn shares(counts: &[u32; 10]) -> [f64; 10] {
    let n = f64::from(counts.iter().sum::<u32>().max(1));
    counts.map(|c| f64::from(c) / n)
}

/// Renders `shape` at `pose` with `colors` alone on the table (the robot's stereo settings, the
/// table's plane known) and returns its measured extent model and its colour-term shares by pixels
/// and by surface (`dexter::vision::color::surface_color_terms`).
fn pixel_and_surface_shares(
    shape: &dexter_sim::scene::Shape,
    pose: control_basis::math::Iso3,
    colors: &[dexter_sim::scene::ColorPatch],
) -> (String, [f64; 10], Option<[f64; 10]>) {
    use dexter::vision::stereo::Side;
    use dexter::vision::{SegmentConfig, StereoConfig};
    use dexter_sim::scene::{CameraSpec, LightSpec};
    use dexter_sim::vision::fixtures::{TABLE_FIXATION, TABLE_TOP, head_cameras, table_and_bins};
    use dexter_sim::vision::{ItemLabel, RenderItem, StereoVision};

    let spec = CameraSpec::default();
    let cams = head_cameras(&spec, nalgebra::Vector3::from(TABLE_FIXATION)).unwrap();
    let config = StereoConfig::on_table(TABLE_TOP, spec.pixel_noise);
    let mut sv = StereoVision::with_config(
        &spec,
        &LightSpec::default(),
        3,
        SegmentConfig::for_noise(spec.pixel_noise),
        config,
    )
    .unwrap();
    let mut scene = table_and_bins();
    sv.capture_background(&cams, &scene).unwrap();
    scene.push(RenderItem::from_catalog(shape, pose, colors, ItemLabel::Object(0)));
    let blobs = sv.perceive(&cams, &scene).unwrap();
    let blob = blobs
        .iter()
        .max_by_key(|b| b.left.map_or(0, |s| s.features.pixel_count))
        .expect("the object is seen");
    let seg = blob.left.expect("seen by the left camera");
    let extent = dexter::skills::extent_of(blob, &cams, TABLE_TOP).expect("measured on the table");
    let surface = dexter::vision::color::surface_color_terms(
        &seg,
        sv.segmenter(Side::Left),
        sv.renderer(Side::Left).image(),
        &cams.left,
        &extent,
        TABLE_TOP,
    );
    (
        extent.model,
        shares(&seg.features.color_terms),
        surface.as_ref().map(shares),
    )
}

const WHITE: [f64; 3] = [40.0, 0.04, 0.96];
const BLUE: [f64; 3] = [220.0, 0.85, 0.75];
const RED: [f64; 3] = [2.0, 0.85, 0.80];
const BLUE_TERM: usize = 7;
const RED_TERM: usize = 3;

#[test]
fn a_white_ball_with_a_blue_cap_is_mostly_white_by_surface_though_the_head_sees_mostly_blue() {
    use dexter_sim::scene::{ColorPatch, Shape};
    let ball = Shape::Sphere { radius: 0.03 };
    let colors = [
        ColorPatch {
            hsv: WHITE,
            fraction: 0.75,
        },
        ColorPatch {
            hsv: BLUE,
            fraction: 0.25,
        },
    ];
    for (x, y) in [(0.6, 0.05), (0.5, -0.12), (0.72, 0.15)] {
        let pose = dexter_sim::vision::fixtures::resting_pose(&ball, x, y, 0.3);
        let (model, pixels, surface) = pixel_and_surface_shares(&ball, pose, &colors);
        let surface = surface.unwrap_or_else(|| panic!("({x}, {y}): no surface colours for a {model} extent"));
        assert_eq!(model, "round", "({x}, {y})");
        assert!(
            pixels[BLUE_TERM] > 0.45,
            "({x}, {y}): the head sees the cap large: {pixels:?}"
        );
        assert!(
            (0.12..0.38).contains(&surface[BLUE_TERM]),
            "({x}, {y}): the cap is a quarter of the ball's surface: {surface:?} (pixels {pixels:?})"
        );
    }
}

#[test]
fn a_lying_capsule_is_weighed_band_by_band_along_its_axis() {
    use control_basis::math::{Iso3, Rot3};
    use dexter_sim::scene::{ColorPatch, Shape};
    let capsule = Shape::Capsule {
        radius: 0.03,
        height: 0.08,
    };
    let colors = [
        ColorPatch {
            hsv: RED,
            fraction: 0.3,
        },
        ColorPatch {
            hsv: WHITE,
            fraction: 0.7,
        },
    ];
    for (x, y, yaw) in [(0.6, 0.05, 0.2), (0.55, -0.1, 0.6), (0.7, 0.12, -0.4)] {
        let pose = Iso3::from_parts(
            nalgebra::Translation3::new(x, y, dexter_sim::vision::fixtures::TABLE_TOP + 0.03 + 1e-4),
            Rot3::from_axis_angle(&nalgebra::Vector3::z_axis(), yaw)
                * Rot3::from_axis_angle(&nalgebra::Vector3::x_axis(), std::f64::consts::FRAC_PI_2),
        );
        let (model, pixels, surface) = pixel_and_surface_shares(&capsule, pose, &colors);
        let surface = surface.unwrap_or_else(|| panic!("({x}, {y}): no surface colours for a {model} extent"));
        assert_eq!(model, "lying", "({x}, {y})");
        assert!(
            (0.18..0.42).contains(&surface[RED_TERM]),
            "({x}, {y}): red is 30 % of the capsule's length: {surface:?} (pixels {pixels:?})"
        );
    }
}

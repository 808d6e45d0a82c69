//! The robot's eyes see only what a camera sees (issue 35): backgrounds predicted from calibration
//! views of the empty workcell, the self-mask drawn from the robot's own model at its encoder
//! readings. Checked against the world's truth (the renderer's labels), which never reaches the
//! robot: the self-mask covers every pixel the robot's body covers and little more; the objects of
//! a scene are found, once each, from several head poses, with no phantom segment.

use control_basis::Hardware;
use control_basis::math::Vec3;
use dexter::eyes::{Eyes, Pair, SearchTrack};
use dexter::vision::Side;
use dexter_sim::hardware::{SimRobot, parked_sim};
use dexter_sim::physics::SimSettings;
use dexter_sim::scene::Scene;

/// Looks at `at`, waits for the head, perceives; returns (self-mask vs truth: covered, missed,
/// extra pixels of the left camera) and the triangulated centroids of the blobs that are not cut
/// off by the image border or the robot's body (the ones that may start a track).
fn look(hw: &mut SimRobot<'_>, eyes: &mut Eyes, at: Vec3) -> ((usize, usize, usize), Vec<Vec3>) {
    let head = SearchTrack::new(hw).unwrap();
    let mut body = dexter::body::Body::new();
    head.look_at(hw, &mut body, &at).unwrap();
    hw.advance(0.8).unwrap();
    let blobs: Vec<Vec3> = eyes
        .perceive(hw, Pair::Head)
        .unwrap()
        .iter()
        .filter(|b| !b.left.is_some_and(|s| s.cut_off()) && !b.right.is_some_and(|s| s.cut_off()))
        .filter_map(|b| b.centroid)
        .collect();
    let mask = eyes.self_masks(Pair::Head).0.to_vec();
    let mut truth = Vec::new();
    hw.sim_cameras().true_self_mask(0, &mut truth);
    let count = |f: &dyn Fn(bool, bool) -> bool| mask.iter().zip(&truth).filter(|(a, b)| f(**a, **b)).count();
    (
        (count(&|a, b| a && b), count(&|a, b| !a && b), count(&|a, b| a && !b)),
        blobs,
    )
}

#[test]
fn self_mask_from_the_model_covers_the_body_and_objects_are_seen_once() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: renders and simulates; run with cargo test --release");
        return;
    }
    let scene = Scene::builtin("sorting").unwrap();
    let table_z = scene.spec.table.height;
    let calibration = dexter_sim::calibrate::workcell_calibration(&scene).unwrap();
    assert!(
        calibration.view_count() >= 10,
        "{} calibration views",
        calibration.view_count()
    );
    let mut sim = parked_sim(&scene, SimSettings::default()).unwrap();
    let mut hw = SimRobot::new(&mut sim, &scene, 3).unwrap();
    let mut eyes = Eyes::new(&hw, table_z, calibration).unwrap();
    let objects: Vec<Vec3> = (0..hw.sim().objects().len())
        .map(|i| hw.sim().object_state(i).pose.translation.vector)
        .collect();
    let (mut covered, mut missed, mut extra) = (0, 0, 0);
    for at in [
        Vec3::new(0.55, 0.0, table_z + 0.03),
        Vec3::new(0.6, 0.25, table_z + 0.03),
        Vec3::new(0.6, -0.25, table_z + 0.03),
        Vec3::new(0.7, 0.0, table_z + 0.03),
    ] {
        let ((c, m, e), blobs) = look(&mut hw, &mut eyes, at);
        covered += c;
        missed += m;
        extra += e;
        // Every whole triangulated blob is an object (within 4 cm), no two blobs are one object.
        let mut owner = vec![0usize; objects.len()];
        for b in &blobs {
            let (d, i) = objects
                .iter()
                .enumerate()
                .map(|(i, o)| ((o - b).xy().norm(), i))
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .unwrap();
            assert!(
                d < 0.04,
                "looking at {at:?}: a phantom blob at {b:?} ({d:.3} m from the nearest object)"
            );
            owner[i] += 1;
        }
        assert!(
            owner.iter().all(|&n| n <= 1),
            "looking at {at:?}: an object seen twice {owner:?}"
        );
        assert!(!blobs.is_empty(), "looking at {at:?}: nothing seen");
        let seg = eyes.pipeline(Pair::Head).segmenter(Side::Left);
        assert!(seg.background().is_some());
    }
    // The body's pixels: all masked but for quantisation at the edges (≤ 0.5 %), and the mask no
    // more than 30 % larger than the body (the one-pixel dilation and the 2 mm margin at 10 cm).
    assert!(covered > 1000, "the robot's body should be in view: {covered} px");
    assert!(
        missed * 200 <= covered,
        "body pixels left unmasked: {missed} of {}",
        covered + missed
    );
    assert!(
        extra * 10 <= covered * 3,
        "mask beyond the body: {extra} px for {covered}"
    );
}

#[test]
fn the_calibration_is_the_same_for_every_run_in_a_workcell() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: renders and simulates; run with cargo test --release");
        return;
    }
    let a = Scene::builtin("sorting").unwrap();
    let mut b = a.clone();
    b.spec.seed += 17;
    b.spec.objects.truncate(1);
    b.resolved.truncate(1);
    let (ca, cb) = (
        dexter_sim::calibrate::workcell_calibration(&a).unwrap(),
        dexter_sim::calibrate::workcell_calibration(&b).unwrap(),
    );
    assert!(
        std::sync::Arc::ptr_eq(&ca, &cb),
        "same table and places, same calibration"
    );
    let direct = dexter_sim::calibrate::calibrate(&a, &Default::default(), 5).unwrap();
    assert_eq!(direct.view_count(), ca.view_count());
}

/// The execute experiment's workcell (the table and bins of `sorting-demo`, the household catalog)
/// with `objects` (`[[objects]]` tables).
fn workcell(name: &str, objects: &str) -> Scene {
    let text = format!(
        r#"
version = 1
name = "{name}"
catalog = "household.toml"
seed = 5
[table]
height = 0.75
center = [0.6, 0.0]
size = [0.6, 1.4]
[[places]]
name = "bin-left"
center = [0.55, 0.45]
size = [0.2, 0.25]
wall_height = 0.06
[[places]]
name = "bin-right"
center = [0.55, -0.45]
size = [0.2, 0.25]
wall_height = 0.06
{objects}"#
    );
    let assets = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../assets/objects/{name}.toml"));
    Scene::from_toml_str(&text, &assets).unwrap()
}

/// Lying things at the table's far corners (development seed 6, execute scenes 13 and 36: a spice
/// jar and a can of peas on their sides, beyond the bins' far ends) are located where they lie:
/// their centroid disparity is off by 1–2 pixels (a cap segmented in one camera, not the other),
/// which triangulated them 7–9 cm nearer the cameras, and a phantom row took their place. The
/// support-plane estimate of a lying thing, checked against its bottom edges, puts them within 2 cm.
#[test]
fn lying_things_at_the_far_corners_are_located_where_they_lie() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: renders and simulates; run with cargo test --release");
        return;
    }
    let scene = workcell(
        "far-corners",
        r#"
[[objects]]
presentation = "blue_spice-1"
xy = [0.778, -0.380]
yaw_deg = 200
[[objects]]
presentation = "peas_can-1"
xy = [0.771, 0.380]
yaw_deg = 209
"#,
    );
    let table_z = scene.spec.table.height;
    let calibration = dexter_sim::calibrate::workcell_calibration(&scene).unwrap();
    let mut sim = parked_sim(&scene, SimSettings::default()).unwrap();
    let mut hw = SimRobot::new(&mut sim, &scene, 1).unwrap();
    let mut eyes = Eyes::new(&hw, table_z, calibration).unwrap();
    for i in 0..2 {
        let truth = hw.sim().object_state(i).pose.translation.vector;
        let head = SearchTrack::new(&hw).unwrap();
        let mut body = dexter::body::Body::new();
        head.look_at(&mut hw, &mut body, &truth).unwrap();
        hw.advance(0.8).unwrap();
        let nearest = eyes
            .perceive(&mut hw, Pair::Head)
            .unwrap()
            .iter()
            .filter_map(|b| b.centroid)
            .map(|c| (c - truth).xy().norm())
            .fold(f64::INFINITY, f64::min);
        assert!(
            nearest < 0.02,
            "object {i} at {truth:?}: the nearest blob is {nearest:.3} m from it"
        );
    }
}

/// A can lying 17 cm behind a box standing on its side, nearly in line with the cameras, is one
/// component in both images; split by colour (green can, orange box) the two parts lie 17 cm apart
/// in range, so they are two objects, each located within 4 cm (before, one coarse track between
/// them: the can was never seen; development seed 1, execute scene 20). The split is a setting,
/// off by default (`StereoConfig::split_occluding`).
#[test]
fn two_objects_one_behind_the_other_are_seen_as_two() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: renders and simulates; run with cargo test --release");
        return;
    }
    let scene = workcell(
        "one-behind-the-other",
        r#"
[[objects]]
presentation = "peas_can-1"
xy = [0.697, 0.165]
yaw_deg = 125
[[objects]]
presentation = "tide-1"
xy = [0.534, 0.178]
yaw_deg = 86
"#,
    );
    let table_z = scene.spec.table.height;
    let calibration = dexter_sim::calibrate::workcell_calibration(&scene).unwrap();
    let mut sim = parked_sim(&scene, SimSettings::default()).unwrap();
    let mut hw = SimRobot::new(&mut sim, &scene, 1).unwrap();
    let mut eyes = Eyes::new(&hw, table_z, calibration).unwrap();
    let mut config = *eyes.pipeline(Pair::Head).config();
    config.split_occluding = true;
    eyes.pipeline_mut(Pair::Head).set_config(config);
    let truth: Vec<_> = (0..2)
        .map(|i| hw.sim().object_state(i).pose.translation.vector)
        .collect();
    let head = SearchTrack::new(&hw).unwrap();
    let mut body = dexter::body::Body::new();
    head.look_at(&mut hw, &mut body, &(0.5 * (truth[0] + truth[1])))
        .unwrap();
    hw.advance(0.8).unwrap();
    let blobs: Vec<_> = eyes
        .perceive(&mut hw, Pair::Head)
        .unwrap()
        .iter()
        .filter_map(|b| b.centroid)
        .collect();
    for (i, t) in truth.iter().enumerate() {
        let nearest = blobs.iter().map(|c| (c - t).xy().norm()).fold(f64::INFINITY, f64::min);
        assert!(
            nearest < 0.04,
            "object {i} at {t:?}: the nearest blob is {nearest:.3} m from it ({blobs:?})"
        );
    }
}

/// Looks at the middle of the scene's objects from the parked robot, with the depth split on
/// (`StereoConfig::split_by_depth`), and returns the objects' true positions and every
/// triangulated blob centroid.
fn blobs_seen_from_parked(scene: &Scene) -> (Vec<Vec3>, Vec<Vec3>) {
    let table_z = scene.spec.table.height;
    let calibration = dexter_sim::calibrate::workcell_calibration(scene).unwrap();
    let mut sim = parked_sim(scene, SimSettings::default()).unwrap();
    let mut hw = SimRobot::new(&mut sim, scene, 1).unwrap();
    let mut eyes = Eyes::new(&hw, table_z, calibration).unwrap();
    let mut config = *eyes.pipeline(Pair::Head).config();
    config.split_by_depth = true;
    eyes.pipeline_mut(Pair::Head).set_config(config);
    let truth: Vec<Vec3> = (0..scene.spec.objects.len())
        .map(|i| hw.sim().object_state(i).pose.translation.vector)
        .collect();
    let middle = truth.iter().fold(Vec3::zeros(), |a, t| a + t) / truth.len() as f64;
    let head = SearchTrack::new(&hw).unwrap();
    let mut body = dexter::body::Body::new();
    head.look_at(&mut hw, &mut body, &middle).unwrap();
    hw.advance(0.8).unwrap();
    let blobs = eyes
        .perceive(&mut hw, Pair::Head)
        .unwrap()
        .iter()
        .filter_map(|b| b.centroid)
        .collect();
    (truth, blobs)
}

/// A coffee can standing 13 cm in front of a peanut-butter jar lying on its side, both mostly red,
/// is one component in both images; where the silhouettes' edges step back in range the pair is
/// split (`StereoPipeline::split_by_depth`, a setting, off by default), and each object is located within
/// 4 cm, with no third blob (before, one coarse track 20 cm tall between them: the jar was never
/// seen, and the grasp planned on the merged centroid closed on nothing; development seed 1,
/// execute scene 21).
#[test]
fn a_can_in_front_of_a_jar_of_its_colour_is_seen_as_two_by_depth() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: renders and simulates; run with cargo test --release");
        return;
    }
    let scene = workcell(
        "can-before-jar",
        r#"
[[objects]]
presentation = "red_coffee"
xy = [0.428, -0.146]
yaw_deg = 233
[[objects]]
presentation = "jif-1"
xy = [0.560, -0.200]
yaw_deg = 285
"#,
    );
    let (truth, blobs) = blobs_seen_from_parked(&scene);
    for (i, t) in truth.iter().enumerate() {
        let nearest = blobs.iter().map(|c| (c - t).xy().norm()).fold(f64::INFINITY, f64::min);
        assert!(
            nearest < 0.04,
            "object {i} at {t:?}: the nearest blob is {nearest:.3} m from it ({blobs:?})"
        );
    }
    let near_one = |c: &Vec3| truth.iter().any(|t| (c - t).xy().norm() < 0.08);
    assert_eq!(
        blobs.iter().filter(|c| near_one(c)).count(),
        2,
        "one blob per object: {blobs:?}"
    );
}

/// A 14 cm carton lying along the line of sight recedes over its rows smoothly, with no step: it
/// stays one blob, where it lies.
#[test]
fn a_carton_lying_along_the_line_of_sight_stays_one() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: renders and simulates; run with cargo test --release");
        return;
    }
    for (x, yaw) in [(0.62, 90.0), (0.50, 90.0), (0.72, 75.0)] {
        let scene = workcell(
            "carton-end-on",
            &format!(
                r#"
[[objects]]
presentation = "orange_juice-1"
xy = [{x}, 0.0]
yaw_deg = {yaw}
"#
            ),
        );
        let (truth, blobs) = blobs_seen_from_parked(&scene);
        let near: Vec<f64> = blobs.iter().map(|c| (c - truth[0]).xy().norm()).collect();
        assert_eq!(near.len(), 1, "carton at x = {x}, yaw {yaw}: blobs {blobs:?}");
        assert!(near[0] < 0.04, "carton at x = {x}, yaw {yaw}: {:.3} m off", near[0]);
    }
}

//! The robot's skills one at a time on one simulation (what `pbd.Sim` steps through from Python):
//! Search-Track, Reach ◁ Grasp + lift, transport, place — judged at the end by the world's truth.

use pbd::dexter_sim::hardware::park_robot;
use pbd::dexter_sim::physics::{DexterSim, SimSettings};
use pbd::dexter_sim::scene::Scene;
use pbd::sim::ArmChoice;
use pbd::skills::SkillSession;

fn never() -> bool {
    false
}

#[test]
fn skills_one_by_one_pick_and_place_an_object() {
    let scene = Scene::builtin("pick-place").unwrap();
    let mut sim = DexterSim::new(&scene, SimSettings::default()).unwrap();
    let table_z = scene.spec.table.height;
    park_robot(&mut sim, table_z).unwrap();
    for _ in 0..200 {
        sim.step();
    }
    let mut s = SkillSession::new(7);

    // Skills that need an earlier one refuse with a message, and change nothing.
    let e = s.grasp(&mut sim, &scene, ArmChoice::Auto, None, &never).unwrap_err();
    assert!(e.to_string().contains("locate first"), "{e}");
    let e = s.place(&mut sim, &scene, &never).unwrap_err();
    assert!(e.to_string().contains("holds nothing"), "{e}");

    let obj = sim.object(&scene.spec.objects[0].presentation).unwrap();
    let hint = scene.resolved[sim.objects()[obj].scene_index].pose.translation.vector;
    let percept = s.perceive(&mut sim, &scene, &never).unwrap();
    assert!(!percept.segments.is_empty(), "the head sees the object");

    let located = s.locate(&mut sim, &scene, [hint.x, hint.y, hint.z], &never).unwrap();
    assert!(located.ok, "{located}");
    let truth = sim.object_state(obj).pose.translation.vector;
    let c = located.centroid.unwrap();
    let err = ((c[0] - truth.x).powi(2) + (c[1] - truth.y).powi(2)).sqrt();
    assert!(err < 0.03, "located {err:.3} m from the truth");

    let place = scene.spec.places[0].clone();
    let grasped = s
        .grasp(&mut sim, &scene, ArmChoice::Auto, Some(&place.name), &never)
        .unwrap();
    assert!(grasped.ok, "{grasped}");
    assert!(grasped.rose.unwrap() > 0.07, "{grasped:?}");
    let weight = sim.objects()[obj].mass * sim.settings().gravity;
    let weighed = grasped.weighed.unwrap();
    assert!(
        (weighed - weight).abs() < 0.5 * weight,
        "weighed {weighed:.2} N, truth {weight:.2} N"
    );
    assert_eq!(s.holding(), grasped.arm);

    let e = s.transport(&mut sim, &scene, "no-such-place", &never).unwrap_err();
    assert!(format!("{e:#}").contains("no-such-place"), "{e:#}");
    let carried = s.transport(&mut sim, &scene, &place.name, &never).unwrap();
    assert!(carried.ok, "{carried}");
    let placed = s.place(&mut sim, &scene, &never).unwrap();
    assert!(placed.ok, "{placed}");
    assert_eq!(s.holding(), None);
    for _ in 0..500 {
        sim.step();
    }
    let p = sim.object_state(obj).pose.translation.vector;
    assert!(
        (p.x - place.center[0]).abs() <= place.size[0] / 2.0 && (p.y - place.center[1]).abs() <= place.size[1] / 2.0,
        "object at ({:.3}, {:.3}), place {} at {:?}",
        p.x,
        p.y,
        place.name,
        place.center
    );
}

#[test]
fn a_stop_request_interrupts_a_skill() {
    let scene = Scene::builtin("pick-place").unwrap();
    let mut sim = DexterSim::new(&scene, SimSettings::default()).unwrap();
    park_robot(&mut sim, scene.spec.table.height).unwrap();
    let mut s = SkillSession::new(1);
    let e = s.locate(&mut sim, &scene, [0.5, 0.0, 0.8], &|| true).unwrap_err();
    assert!(format!("{e:#}").to_lowercase().contains("interrupt"), "{e:#}");
}

//! A stereo pair captured at once (`Hardware::capture_many`: the simulator renders the second view on
//! a thread of its own outside a parallel batch) gives the images of two captures one after the
//! other, bit for bit; a mismatched request is an error, not a panic.

use control_basis::Hardware;
use control_basis::hardware::Image;
use dexter_sim::hardware::{SimRobot, parked_sim};
use dexter_sim::physics::SimSettings;
use dexter_sim::scene::Scene;

/// The head pair of `scene` after `steps` ticks, captured (a) as a pair, (b) one by one, on
/// identical worlds with identical camera noise seeds.
fn both_ways(scene: &Scene, cameras: [usize; 2]) -> ([Image; 2], [Image; 2]) {
    let mut sim_a = parked_sim(scene, SimSettings::default()).unwrap();
    let mut sim_b = parked_sim(scene, SimSettings::default()).unwrap();
    let mut a = SimRobot::new(&mut sim_a, scene, 7).unwrap();
    let mut b = SimRobot::new(&mut sim_b, scene, 7).unwrap();
    let mut pair = [Image::default(), Image::default()];
    let mut single = [Image::default(), Image::default()];
    for _ in 0..3 {
        a.advance(0.005).unwrap();
        b.advance(0.005).unwrap();
        a.capture_many(&cameras, &mut pair).unwrap();
        for (k, image) in cameras.iter().zip(single.iter_mut()) {
            b.capture(*k, image).unwrap();
        }
    }
    (pair, single)
}

#[test]
fn a_pair_captured_at_once_is_the_two_captures_bit_for_bit() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: renders; run with cargo test --release");
        return;
    }
    let scene = Scene::builtin("sorting").unwrap();
    for cameras in [[0, 1], [1, 0], [2, 3]] {
        let (pair, single) = both_ways(&scene, cameras);
        for k in 0..2 {
            assert!(!pair[k].rgb.is_empty(), "camera {} rendered", cameras[k]);
            assert_eq!(pair[k], single[k], "camera {} of {cameras:?}", cameras[k]);
        }
        assert_ne!(pair[0], pair[1], "two views, not one twice ({cameras:?})");
    }
}

#[test]
fn a_mismatched_or_unknown_capture_is_an_error() {
    let scene = Scene::builtin("sorting").unwrap();
    let mut sim = parked_sim(&scene, SimSettings::default()).unwrap();
    let mut hw = SimRobot::new(&mut sim, &scene, 7).unwrap();
    let mut one = [Image::default()];
    let e = hw.capture_many(&[0, 1], &mut one).unwrap_err();
    assert!(e.to_string().contains("2 cameras asked for into 1 images"), "{e}");
    let mut two = [Image::default(), Image::default()];
    let e = hw.capture_many(&[0, 99], &mut two).unwrap_err();
    assert!(e.to_string().contains("no camera 99"), "{e}");
}

//! Injected physical faults, pinned scenes (development seed 1; issue 35): per kind, three scenes
//! in which the fault fires, the robot notices it from its own sensors, takes the expected
//! contingency, and the object still ends in its place (the world's evaluator, by the truth).
//!
//! - drop: the holding hand's fingers are opened by the world during the carry; the schema's
//!   `drop` → `regrasp` contingency runs and the object is grasped again where it fell;
//! - bump: the object is pushed as the hand arrives above it; the grasp closes on nothing and the
//!   robot reaches and grasps again, or the tracker sees the object moved before the hand closes
//!   and the grasp goes to where it lies now;
//! - blocked arm: a post appears in the reaching arm's path; the reach does not converge and ψ
//!   binds the other arm (directly, or through a hand-over) — the response only (see the blocked
//!   arm's test).
//!
//! About a minute in release on two cores (nine short scenes, the three kinds in parallel).

use dexter_sim::fault::{FaultKind, FaultTrial, fault_trial};
use dexter_sim::scene::Scene;

/// The development seed the scenes were chosen from.
const SEED: u64 = 1;

fn trial(kind: FaultKind, i: usize) -> FaultTrial {
    let base = Scene::builtin("pick-place").unwrap();
    let library = schema::Library::builtin();
    let t = fault_trial(&base, "pick-place", &library, kind, SEED, i).unwrap();
    eprintln!("{}", serde_json::to_string(&t).unwrap());
    t
}

/// Scene `i` of `kind`: the fault fired as `detail` says, the executive responded as `expected`
/// says, and the object ended in its place.
fn check(kind: FaultKind, i: usize, detail: &str, expected: impl Fn(&FaultTrial) -> bool) {
    let t = trial(kind, i);
    assert!(t.fired, "{kind} scene {i}: the fault never fired: {t:?}");
    assert!(
        t.fault.contains(detail),
        "{kind} scene {i}: the fault did something else: {t:?}"
    );
    assert!(expected(&t), "{kind} scene {i}: not the expected response: {t:?}");
    assert!(t.success && t.recovered, "{kind} scene {i}: not in its place: {t:?}");
}

#[test]
fn a_dropped_object_is_grasped_again_and_placed() {
    for i in [0, 1, 2] {
        check(FaultKind::Drop, i, "fingers opened", |t| {
            t.response == "re_grasp" && t.contingencies.iter().any(|c| c == "regrasp")
        });
    }
}

#[test]
fn a_bumped_object_is_reached_and_grasped_again_and_placed() {
    for i in [5, 6, 9] {
        // Either the grasp closed on nothing and the robot grasped again, or the tracker saw the
        // object moved before the hand closed and the reach went to where it lies now.
        check(FaultKind::Bump, i, "pushed", |t| {
            t.response == "re_grasp" || t.response == "none"
        });
    }
}

/// Blocked arm: the response only. The object ends in its place in 1 of seed 1's first 10 scenes
/// (a hand-over every time; the long one that succeeds takes 220 s simulated): after the other arm
/// takes the object, the executive places without a hold after a failed carry to the handoff spot,
/// or its monitors miss a converged reach at the handoff spot (robot-side classes of issue 35,
/// item 3). When those are fixed, assert the recovery here too.
#[test]
fn a_blocked_arm_gives_way_to_the_other_arm() {
    for i in [0, 2, 3] {
        let t = trial(FaultKind::BlockedArm, i);
        assert!(t.fired, "scene {i}: the fault never fired: {t:?}");
        assert!(t.fault.contains("post"), "scene {i}: {t:?}");
        // The fault's account names the arm whose path the post stands in: the one that reached
        // first, and then the other arm took over (directly or through a hand-over).
        let blocked = if t.fault.contains("left arm's path") {
            "left"
        } else {
            "right"
        };
        assert_eq!(t.arms.first().map(String::as_str), Some(blocked), "scene {i}: {t:?}");
        assert!(
            t.contingencies.iter().any(|c| c == "other_arm" || c == "hand_over"),
            "scene {i}: ψ did not rebind: {t:?}"
        );
        assert!(
            t.arms.iter().any(|a| a != blocked),
            "scene {i}: the other arm never moved: {t:?}"
        );
    }
}

//! Injected physical faults, pinned scenes (development seed 1; issue 35): per kind, three scenes
//! in which the fault fires, the robot notices it from its own sensors, takes the expected
//! contingency, and the object still ends in its place (the world's evaluator, by the truth).
//!
//! - drop: the holding hand's fingers are opened by the world during the carry; the schema's
//!   `drop` → `regrasp` contingency runs and the object is grasped again where it fell;
//! - bump: the object is pushed as the hand arrives above it; the grasp closes on nothing and the
//!   robot reaches and grasps again, or the tracker sees the object moved before the hand closes
//!   and the grasp goes to where it lies now;
//! - blocked arm: a post appears in the reaching arm's path; the reach does not converge, the arm
//!   tries once more with its way planned round the post, and when that stops too ψ binds the
//!   other arm (directly, or through a hand-over).
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

/// Blocked arm: the post stops the reaching arm; the same arm tries once more, its way planned round
/// the post it sees now, and gets the object there (scenes 2 and 6) — or stops again, and the other
/// arm takes the object and, the bins being on the blocked arm's side, hands it over on a spot both
/// arms reach (scene 8); the object ends in its place. Seed 1's first 12 scenes: 5 recovered with
/// the other arm alone (scenes 2, 6, 8, 10, 11); with the second try round the post, the same five,
/// 2, 6 and 11 by the blocked arm itself.
#[test]
fn a_blocked_arm_goes_round_the_post_or_gives_way_to_the_other_arm() {
    let blocked_arm = |t: &FaultTrial| {
        // The fault's account names the arm whose path the post stands in.
        if t.fault.contains("left arm's path") {
            "left"
        } else {
            "right"
        }
    };
    for i in [2, 6] {
        check(FaultKind::BlockedArm, i, "post", |t| {
            let blocked = blocked_arm(t);
            t.response == "re_grasp" && t.arms.len() >= 2 && t.arms.iter().all(|a| a == blocked)
        });
    }
    check(FaultKind::BlockedArm, 8, "post", |t| {
        // The arm that reached first was the blocked one; after its second stop the other arm
        // took over through a hand-over.
        let blocked = blocked_arm(t);
        t.arms.first().map(String::as_str) == Some(blocked)
            && t.arms.get(1).map(String::as_str) == Some(blocked)
            && t.contingencies.iter().any(|c| c == "hand_over")
            && t.arms.iter().any(|a| a != blocked)
    });
}

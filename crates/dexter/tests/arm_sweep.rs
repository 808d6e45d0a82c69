//! Whole-arm ways round a tall thing (`dexter::skills::plan_way`, `dexter::sweep`), on the robot's
//! own model: the kinematic plant of `examples/kinematic_pick.rs` supplies the model, and the arm
//! stands at its parked pose.

use crate::example;

use control_basis::math::Vec3;
use dexter::Arm;
use dexter::control::ReachControl;
use dexter::route::Obstacle;
use dexter::skills::{ROUTE_CLEARANCE, SWEEP_MARGIN, Way, park_pose, plan_way};
use dexter::sweep::{HAND_LENGTH, arm_clearance};

const TABLE_Z: f64 = 0.75;

/// The right arm at its parked pose (an IK solution) and its reach controller.
fn parked_right() -> (ReachControl, Vec<f64>) {
    let hw = example::ScriptedDexter::new().expect("the kinematic plant");
    let mut reach = ReachControl::new(&hw, Arm::Right).expect("reach");
    let q = reach
        .solve_ik(&hw, &park_pose(Arm::Right, TABLE_Z), 3)
        .expect("ik")
        .expect("the parked pose is reachable");
    (reach, q.as_slice().to_vec())
}

/// A 50 cm post across the way from the right arm's parked palm (0.42, −0.32) to above (0.55,
/// 0.05): 22 cm wide, its long side across that way, 18 cm from the palm.
fn post() -> Obstacle {
    Obstacle {
        center: [0.49, -0.15],
        major_axis: [0.95, -0.31],
        half: [0.11, 0.03],
        top: TABLE_Z + 0.5,
    }
}

#[test]
fn the_straight_way_through_a_post_is_refused_for_one_that_keeps_the_whole_arm_clear() {
    let (mut reach, q0) = parked_right();
    let mut goal = park_pose(Arm::Right, TABLE_Z);
    goal.translation.vector = Vec3::new(0.55, 0.05, TABLE_Z + 0.3);
    // Nothing to avoid: no way is planned (the caller moves straight).
    assert!(plan_way(&reach, &q0, &goal, ROUTE_CLEARANCE, HAND_LENGTH).is_none());
    reach.avoid = vec![post()];
    // The straight way's rollout puts the arm into the post.
    let chain = reach.chain().clone();
    let straight = reach.sweep(&q0, &[goal], 4.0, &mut |s| {
        arm_clearance(&chain, s, &[post()], f64::NEG_INFINITY, HAND_LENGTH)
    });
    assert!(straight.reached, "{straight:?}");
    assert!(straight.clearance < 0.0, "{straight:?}");
    let way = plan_way(&reach, &q0, &goal, ROUTE_CLEARANCE, HAND_LENGTH).expect("a way");
    assert_ne!(way.way, Way::Straight, "{way:?}");
    assert!(way.clear && way.clearance >= SWEEP_MARGIN, "{way:?}");
    assert_eq!(
        way.poses.last().map(|p| p.translation.vector),
        Some(goal.translation.vector)
    );
    // The same post far off the way: the straight way is clear.
    reach.avoid = vec![Obstacle {
        center: [0.8, -0.5],
        ..post()
    }];
    let way = plan_way(&reach, &q0, &goal, ROUTE_CLEARANCE, HAND_LENGTH).expect("a way");
    assert_eq!(way.way, Way::Straight, "{way:?}");
    assert!(way.clear, "{way:?}");
}

#[test]
fn an_arm_is_measured_against_a_post_at_its_elbow_and_clear_of_one_across_the_table() {
    let (reach, q0) = parked_right();
    let chain = reach.chain().clone();
    let mut state = chain.new_state();
    state.set_q(&chain, &q0).unwrap();
    control_basis::forward_kinematics(&chain, &mut state);
    // The elbow: the third distinct origin of the moving links.
    let elbow = state
        .link_poses()
        .iter()
        .zip(chain.links())
        .filter(|(_, l)| l.after.is_some())
        .map(|(p, _)| p.translation.vector)
        .fold(Vec::<Vec3>::new(), |mut v, p| {
            if v.last().is_none_or(|l| (p - l).norm() > 0.02) {
                v.push(p);
            }
            v
        })[1];
    let at_elbow = Obstacle {
        center: [elbow.x, elbow.y],
        major_axis: [1.0, 0.0],
        half: [0.05, 0.05],
        top: elbow.z + 0.1,
    };
    assert!(arm_clearance(&chain, &state, &[at_elbow], f64::NEG_INFINITY, HAND_LENGTH) < 0.0);
    let across = Obstacle {
        center: [0.6, 0.4],
        ..at_elbow
    };
    let c = arm_clearance(&chain, &state, &[across], f64::NEG_INFINITY, HAND_LENGTH);
    assert!(c > 0.2, "{c}");
}

//! Touch (Reach-And-Touch's last action): a guarded descent of the fingertips onto the object
//! until they press it ([`touch_object`]).

use control_basis::Hardware;
use control_basis::math::Iso3;
use schema::{Failure, FailureCause};

use super::*;
use crate::control::{FLEX_CLOSED, HandControl, ReachControl};

/// How fast (m/s) the palm descends to touch ([`touch_object`]): a fingertip meeting the object
/// stops it within a few millimetres.
pub(super) const TOUCH_DESCENT_SPEED: f64 = 0.03;

/// How far (m) below where a fingertip met the object the palm's reference stays after a touch's
/// descent.
pub(super) const TOUCH_DESCENT_PRESS: f64 = 0.003;

/// How fast (rad/s) the fingers close to touch ([`touch_object`]): slow enough that the first
/// finger to meet the object stops on it before the others arrive.
pub(super) const TOUCH_FLEX_SPEED: f64 = 0.4;
/// How far (rad) past the flexion at first contact the touching fingers' reference stays, so that
/// the finger rests on the object with a light force.
pub(super) const TOUCH_PRESS: f64 = 0.10;

/// Touch (the Reach-And-Touch schema's last action): from where the reach stopped — clear above the
/// object, `down` the grasp pose to descend to (slowly, [`TOUCH_DESCENT_SPEED`]; a fingertip that
/// meets the object's top on the way ends the touch there) — or from the grasp pose, close the
/// fingers slowly until a fingertip meets the object, and hold them there: contact without an
/// opposing grasp, the Touch predicate.
/// Fingers that met it from both sides (a squeeze) open again until one side lets go. Fails if no
/// fingertip met anything by the time the hand is closed.
pub fn touch_object(
    hw: &mut dyn Hardware,
    reach: &mut ReachControl,
    hand: &HandControl,
    down: Option<&Iso3>,
    obs: &mut Observer<'_>,
) -> Result<(), Failure> {
    let arm = reach.arm();
    obs.activity = "touch";
    let mut buf = Vec::new();
    let dt = 1.0 / CONTROL_HZ;
    if let Some(goal) = down {
        let speed = reach.max_speed;
        reach.max_speed = TOUCH_DESCENT_SPEED;
        reach.set_goal(hw, *goal);
        let met = run_until(hw, reach, obs, 4.0, |h, r| {
            TouchState::of(&hand_fingertips(h, arm, &mut buf)).loaded > 0 || r.at_goal(h, 0.004, 0.03)
        });
        reach.max_speed = speed;
        // Stop where the fingertip met it, the reference a little below so that it keeps resting
        // on the object with a light force (the fingertip touching at the end is the goal).
        let mut here = reach.tool_pose(hw);
        here.translation.vector.z -= TOUCH_DESCENT_PRESS;
        reach.set_goal(hw, here);
        idle(hw, obs, 0.2);
        if met && TouchState::of(&hand_fingertips(hw, arm, &mut buf)).loaded > 0 {
            return Ok(());
        }
    }
    let start = hand.flexion(hw);
    let mut flex = start.iter().copied().fold(f64::INFINITY, f64::min);
    let met = run_until(hw, reach, obs, 4.0, |h, _| {
        let touch = TouchState::of(&hand_fingertips(h, arm, &mut buf));
        if touch.loaded > 0 {
            return true;
        }
        flex = (flex + TOUCH_FLEX_SPEED * dt).min(FLEX_CLOSED);
        hand.set(h, flex, 0.0);
        false
    });
    if !met {
        return Err(Failure::new(
            FailureCause::NoGrasp,
            "no fingertip met the object (the hand closed on nothing)",
        ));
    }
    // Hold the fingers where they met it, the reference a little past the contact so that the
    // finger keeps resting on it.
    flex = (flex + TOUCH_PRESS).min(FLEX_CLOSED);
    hand.set(hw, flex, 0.0);
    idle(hw, obs, 0.3);
    for _ in 0..10 {
        if !TouchState::of(&hand_fingertips(hw, arm, &mut buf)).opposed {
            break;
        }
        flex -= 0.05;
        hand.set(hw, flex, 0.0);
        idle(hw, obs, 0.1);
    }
    let touch = TouchState::of(&hand_fingertips(hw, arm, &mut buf));
    if touch.loaded == 0 {
        // Open again to where the hand started, for another try from the same pose.
        hand.set(hw, start.iter().copied().fold(f64::INFINITY, f64::min), 0.0);
        idle(hw, obs, 0.3);
        return Err(Failure::new(
            FailureCause::Moved,
            "the fingertip lost the object after it met it (it moved away)",
        ));
    }
    Ok(())
}

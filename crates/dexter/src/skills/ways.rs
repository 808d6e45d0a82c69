//! Ways for the palm round the tall things the robot has seen, weighed for the whole arm
//! ([`plan_way`]: straight, round, round at the things' tops, or over them).

use control_basis::Hardware;
use control_basis::math::{Iso3, Vec3};

use super::*;
use crate::control::ReachControl;

/// How far (m) the palm's way keeps from a tall thing's footprint ([`crate::route`]): the
/// spread fingers' reach about the palm (about 10 cm) and a margin for the thing's measured place.
pub const ROUTE_CLEARANCE: f64 = 0.15;

/// How far (m) the whole arm must keep from a tall thing on a way [`plan_way`] takes without
/// further ado: the thing's measured footprint is a centimetre or two off.
pub const SWEEP_MARGIN: f64 = 0.03;

/// How high (m) above a tall thing's measured top the hand's lowest point passes on the way over it.
pub(super) const OVER_CLEARANCE: f64 = 0.08;

/// A tall thing within this horizontal distance (m) of the straight way counts for the height of
/// the way over ([`Way::Over`]).
pub(super) const OVER_NEAR: f64 = 0.3;

/// The ways [`plan_way`] weighs, in order of preference.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Way {
    /// Straight to the goal.
    Straight,
    /// Round the tall things' footprints ([`crate::route`]) at the goal's height.
    Round,
    /// The same way round with the palm raised to the tall things' tops (the forearm above them),
    /// then down to the goal.
    RoundHigh,
    /// Up over the highest tall thing, across, and down to the goal (an empty hand only).
    Over,
}

/// The way [`plan_way`] chose.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedWay {
    /// Which of the ways.
    pub way: Way,
    /// The tool poses to pass through, ending with the goal.
    pub poses: Vec<Iso3>,
    /// The least whole-arm clearance (m) on it in the rollout (NaN: not rolled out).
    pub clearance: f64,
    /// Whether it keeps [`SWEEP_MARGIN`] (or, for an arm already nearer than that, comes no nearer).
    pub clear: bool,
}

/// The way for the palm of `reach` (in the configuration `q0`, chain order) to `goal` that keeps
/// the whole arm clearest of the tall things in [`ReachControl::avoid`]: each of [`Way`]'s is
/// rolled out on the robot's own model ([`ReachControl::sweep`], [`crate::sweep::arm_clearance`],
/// the hand reaching `below` under the palm surface); the first in order that keeps
/// [`SWEEP_MARGIN`] (or, for an arm already nearer than that, comes no nearer) is taken, else the
/// one that keeps most. The palm's own way round keeps `clearance` from the footprints. When no
/// way reaches the goal in the rollout: the palm's way round, if any. `None` without tall things.
pub fn plan_way(reach: &ReachControl, q0: &[f64], goal: &Iso3, clearance: f64, below: f64) -> Option<PlannedWay> {
    if reach.avoid.is_empty() {
        return None;
    }
    let mut state = reach.chain().new_state();
    state.set_q(reach.chain(), q0).ok()?;
    control_basis::forward_kinematics(reach.chain(), &mut state);
    let palm = state.tip_pose().translation.vector;
    // An arm already nearer a thing than the margin (stopped against the post it was reaching
    // round) is held only to come no nearer than it is.
    let start = crate::sweep::arm_clearance(reach.chain(), &state, &reach.avoid, f64::NEG_INFINITY, below);
    let margin = SWEEP_MARGIN.min(start - 0.005);
    let g = goal.translation.vector;
    let at = |x: f64, y: f64, z: f64| {
        let mut p = *goal;
        p.translation.vector = Vec3::new(x, y, z);
        p
    };
    // The straight way only when the palm's own way keeps `clearance` too (it holds the fingers'
    // spread and a held object's radius, which the arm's capsules do not).
    let mut ways: Vec<(Way, Vec<Iso3>)> = Vec::new();
    if crate::route::clear_of([palm.x, palm.y], [g.x, g.y], &reach.avoid, clearance) {
        ways.push((Way::Straight, vec![*goal]));
    }
    // The tall things near the straight way (a coarse blob's top, guessed from its centroid, can be
    // high; one far off does not matter).
    let top = reach
        .avoid
        .iter()
        .filter(|o| !crate::route::clear_of([palm.x, palm.y], [g.x, g.y], std::slice::from_ref(*o), OVER_NEAR))
        .map(|o| o.top)
        .fold(f64::NEG_INFINITY, f64::max);
    if let Some(round) =
        crate::route::route_within([palm.x, palm.y], [g.x, g.y], &reach.avoid, clearance, reach.way_region)
        && round.len() > 1
    {
        ways.push((Way::Round, round.iter().map(|c| at(c[0], c[1], g.z)).collect()));
        // The same way with the palm as high as the things' tops: the hand passes beside them,
        // the forearm (which rises from the palm towards the elbow) above them.
        let z = top.max(g.z);
        if top.is_finite() && z > g.z + 0.02 {
            let mut poses = vec![at(palm.x, palm.y, z.max(palm.z))];
            poses.extend(round[..round.len() - 1].iter().map(|c| at(c[0], c[1], z)));
            poses.push(at(g.x, g.y, z));
            poses.push(*goal);
            ways.push((Way::RoundHigh, poses));
        }
    }
    // Over, only with an empty hand: a held object lifted that high slips (the hand tilts as the
    // arm nears the top of its workspace; development seed 2, blocked arm, scenes 15 and 22: the
    // receiving hand's carry over the post dropped the object from 0.6 m above the table).
    if top.is_finite() && below <= crate::sweep::HAND_LENGTH {
        let z = top + below.max(crate::sweep::HAND_LENGTH) + OVER_CLEARANCE;
        if z > g.z.max(palm.z) {
            ways.push((Way::Over, vec![at(palm.x, palm.y, z), at(g.x, g.y, z), *goal]));
        }
    }
    let mut chosen: Option<PlannedWay> = None;
    let mut round = None;
    for (way, poses) in ways {
        let sweep = reach.sweep(q0, &poses, 5.0, &mut |s| {
            crate::sweep::arm_clearance(reach.chain(), s, &reach.avoid, f64::NEG_INFINITY, below)
        });
        tracing::trace!(
            "{way:?} way {:?}: {sweep:?}",
            poses
                .iter()
                .map(|p| p.translation.vector.as_slice().to_vec())
                .collect::<Vec<_>>()
        );
        if way == Way::Round {
            round = Some(poses.clone());
        }
        if !sweep.reached {
            continue;
        }
        let clear = sweep.clearance >= margin;
        if clear || chosen.as_ref().is_none_or(|c| sweep.clearance > c.clearance) {
            chosen = Some(PlannedWay {
                way,
                poses,
                clearance: sweep.clearance,
                clear,
            });
        }
        if clear {
            break;
        }
    }
    chosen.or_else(|| {
        round.map(|poses| PlannedWay {
            way: Way::Round,
            poses,
            clearance: f64::NAN,
            clear: false,
        })
    })
}

/// Moves the palm towards `goal` (not to `goal` itself: the caller's own move ends there) by the
/// way [`plan_way`] chooses. `stop` ends the move early (a carried object lost). Does nothing when
/// that is the straight way or there is none. Each via point gets a few seconds; one not reached
/// (out of the arm's reach) is passed on from where the palm is.
pub(super) fn go_around(
    hw: &mut dyn Hardware,
    reach: &mut ReachControl,
    obs: &mut Observer<'_>,
    goal: &Iso3,
    clearance: f64,
    below: f64,
    stop: &mut dyn FnMut(&mut dyn Hardware, &mut ReachControl) -> bool,
) {
    let q0 = reach.chain_configuration(hw);
    let Some(planned) = plan_way(reach, q0.as_slice(), goal, clearance, below) else {
        return;
    };
    tracing::debug!(
        "way to {:?} round {:?}: {planned:?}",
        goal.translation.vector.as_slice(),
        reach.avoid
    );
    for pose in &planned.poses[..planned.poses.len() - 1] {
        reach.set_goal(hw, *pose);
        let mut stopped = false;
        run_until(hw, reach, obs, 4.0, |h, r| {
            stopped = stop(h, r);
            stopped || r.at_goal(h, 0.03, 0.1)
        });
        if stopped {
            return;
        }
    }
}

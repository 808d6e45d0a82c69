//! Whole-arm clearance from the tall things seen on the table, on the robot's own model.
//!
//! A way round a post planned for the palm alone ([`crate::route`]) can still put the forearm or
//! the elbow through it: an arm reaching round a post's end from beside it sweeps its forearm
//! across the post. Here the arm is a chain of capsules between the origins of its moving links
//! (shoulder, elbow, wrist, palm) and a hand capsule below the palm surface (the pre-shaped fingers,
//! and a held object under them), and each tall thing a box: its measured footprint
//! ([`Obstacle`]) from the table up to its measured top. [`arm_clearance`] is the least distance
//! between the two in one configuration; [`crate::control::ReachControl::sweep`] rolls the reach
//! out kinematically along a candidate way and keeps the least clearance met. Everything here is
//! the robot's: its kinematic model at joint angles it chose, and what its cameras measured.

use control_basis::math::Vec3;
use control_basis::{Chain, ChainState};

use crate::route::Obstacle;

/// Radius (m) of the capsules between the arm's link origins: the WAM's upper arm and forearm are
/// tubes of about 5 cm radius, and their motors and the elbow stand a little proud of them.
pub const ARM_RADIUS: f64 = 0.06;

/// How far (m) the hand reaches below the palm surface (the pre-shaped fingers).
pub const HAND_LENGTH: f64 = 0.10;

/// Radius (m) of the hand's capsule: the spread fingers about the palm's axis.
pub const HAND_RADIUS: f64 = 0.07;

/// Spacing (m) of the points a capsule's axis is sampled at against a box.
const SAMPLE: f64 = 0.02;

/// Distance (m) from `p` to the box standing on `floor` (z) under the footprint of `o` up to its
/// top; 0 inside.
pub fn distance_to_box(p: &Vec3, o: &Obstacle, floor: f64) -> f64 {
    let (dx, dy) = (p.x - o.center[0], p.y - o.center[1]);
    let [ax, ay] = o.major_axis;
    let along = (dx * ax + dy * ay).abs() - o.half[0];
    let across = (-dx * ay + dy * ax).abs() - o.half[1];
    let up = if p.z > o.top {
        p.z - o.top
    } else if p.z < floor {
        floor - p.z
    } else {
        0.0
    };
    let (a, b) = (along.max(0.0), across.max(0.0));
    (a * a + b * b + up * up).sqrt()
}

/// Least distance (m) from the segment `a`–`b` (sampled every [`SAMPLE`]) to the boxes.
fn segment_distance(a: &Vec3, b: &Vec3, boxes: &[Obstacle], floor: f64) -> f64 {
    let n = ((b - a).norm() / SAMPLE).ceil().max(1.0) as usize;
    let mut best = f64::INFINITY;
    for i in 0..=n {
        let p = a + (b - a) * (i as f64 / n as f64);
        for o in boxes {
            best = best.min(distance_to_box(&p, o, floor));
        }
    }
    best
}

/// How far (m) the arm of `chain`, in the configuration of `state` (after its forward kinematics),
/// keeps from the boxes: the least distance between the capsules (link origins of the moving links
/// in chain order, then the palm surface, radius [`ARM_RADIUS`]; then the hand, radius
/// [`HAND_RADIUS`], reaching `below` (at least [`HAND_LENGTH`]: the fingers, and a held object's
/// bottom) along the palm's approach axis) and the boxes standing on `floor` (`f64::NEG_INFINITY`: from below the table).
/// Negative: they overlap by that much. Infinite without boxes.
pub fn arm_clearance(chain: &Chain, state: &ChainState, boxes: &[Obstacle], floor: f64, below: f64) -> f64 {
    if boxes.is_empty() {
        return f64::INFINITY;
    }
    let mut best = f64::INFINITY;
    let mut last: Option<Vec3> = None;
    for (link, pose) in chain.links().iter().zip(state.link_poses()) {
        if link.after.is_none() {
            continue;
        }
        let p = pose.translation.vector;
        match last {
            Some(a) if (p - a).norm() < SAMPLE => {}
            Some(a) => {
                best = best.min(segment_distance(&a, &p, boxes, floor) - ARM_RADIUS);
                last = Some(p);
            }
            None => last = Some(p),
        }
    }
    let tip = state.tip_pose();
    let palm = tip.translation.vector;
    if let Some(a) = last {
        best = best.min(segment_distance(&a, &palm, boxes, floor) - ARM_RADIUS);
    }
    let approach = tip.rotation * Vec3::z();
    // The capsule's rounded end reaches `below`, not a radius past it.
    let end = palm + approach * (below.max(HAND_LENGTH) - HAND_RADIUS).max(0.0);
    best.min(segment_distance(&palm, &end, boxes, floor) - HAND_RADIUS)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn post() -> Obstacle {
        Obstacle {
            center: [0.5, 0.0],
            major_axis: [0.0, 1.0],
            half: [0.11, 0.03],
            top: 1.25,
        }
    }

    #[test]
    fn a_point_measures_its_distance_to_the_post_as_a_box() {
        let o = post();
        // Beside its long face, at mid height.
        assert!((distance_to_box(&Vec3::new(0.6, 0.0, 1.0), &o, 0.75) - 0.07).abs() < 1e-12);
        // Beyond its end, along the major axis.
        assert!((distance_to_box(&Vec3::new(0.5, 0.2, 1.0), &o, 0.75) - 0.09).abs() < 1e-12);
        // Above its top: only the height counts.
        assert!((distance_to_box(&Vec3::new(0.5, 0.05, 1.4), &o, 0.75) - 0.15).abs() < 1e-12);
        // Diagonally off a top corner.
        let d = distance_to_box(&Vec3::new(0.56, 0.14, 1.29), &o, 0.75);
        assert!(
            (d - (0.03f64.powi(2) * 2.0 + 0.04f64.powi(2)).sqrt()).abs() < 1e-12,
            "{d}"
        );
        assert_eq!(distance_to_box(&Vec3::new(0.5, 0.1, 1.0), &o, 0.75), 0.0);
    }

    #[test]
    fn a_segment_through_the_post_meets_it_and_one_beside_it_does_not() {
        let o = post();
        let through = segment_distance(&Vec3::new(0.3, 0.0, 1.0), &Vec3::new(0.7, 0.0, 1.0), &[o], 0.75);
        assert_eq!(through, 0.0);
        let beside = segment_distance(&Vec3::new(0.3, 0.3, 1.0), &Vec3::new(0.7, 0.3, 1.0), &[o], 0.75);
        assert!((beside - 0.19).abs() < 1e-9, "{beside}");
    }
}

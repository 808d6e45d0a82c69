//! Effector assignment (5.31)–(5.32): given the place chosen by the feature model, which arm(s)
//! execute Pick-And-Place.
//!
//! p(τ | a, r) is uniform over the arms whose workspace holds the reference r and zero elsewhere,
//! times an optional prior p(τ) (an arm preference). For Pick-And-Place the reach-grasp needs an
//! arm that reaches the object and the place action one that reaches the place; (5.32) picks the
//! most probable arm for both. When no single arm reaches both, the schema's hand-to-hand transfer
//! contingency splits the work: a pick arm, a place arm and a hand-off location both reach.

use serde::Serialize;

/// What one arm can reach, and its prior preference p(τ) (> 0; equal priors = maximum likelihood).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ArmReach {
    /// Arm name (`left`, `right`).
    pub arm: String,
    /// Its workspace holds the object (the reach-grasp reference).
    pub reaches_object: bool,
    /// Its workspace holds the place.
    pub reaches_place: bool,
    /// Prior preference (ties broken by order).
    pub prior: f64,
}

/// A candidate hand-off location and the arms that reach it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Handoff {
    /// Position (m, world).
    pub position: [f64; 3],
    /// Arms whose workspace holds it.
    pub arms: Vec<String>,
}

/// Why nothing can do the task.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Unreachable {
    /// No arm reaches the object.
    Object,
    /// No arm reaches the place.
    Place,
    /// Different arms reach object and place, but no hand-off location is reachable by a pair.
    NoHandoff,
}

/// The assignment of effector resources for one Pick-And-Place.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum EffectorAssignment {
    /// One arm picks and places.
    Single {
        /// The arm.
        arm: String,
    },
    /// Pick with one arm, hand over at `handoff`, place with the other.
    Transfer {
        /// Arm that grasps the object.
        pick_arm: String,
        /// Arm that takes it over and places it.
        place_arm: String,
        /// Hand-off position (m, world), reached by both.
        handoff: [f64; 3],
    },
    /// Nothing can do it.
    Unreachable {
        /// Why.
        reason: Unreachable,
    },
}

/// Assigns arms (5.31)–(5.32): the single arm of highest prior reaching object and place; else
/// the transfer pair (pick arm ≠ place arm) of highest prior product with the first hand-off location
/// both reach; else why it is unreachable. Pure and deterministic (ties: first in `arms` order).
/// Arms with a prior that is not finite and > 0 are never chosen.
pub fn assign_effectors(arms: &[ArmReach], handoffs: &[Handoff]) -> EffectorAssignment {
    let usable = |a: &&ArmReach| a.prior.is_finite() && a.prior > 0.0;
    let best = |it: &mut dyn Iterator<Item = (f64, EffectorAssignment)>| {
        it.fold(None::<(f64, EffectorAssignment)>, |b, (p, a)| match b {
            Some((bp, ba)) if bp >= p => Some((bp, ba)),
            _ => Some((p, a)),
        })
    };
    let mut singles = arms
        .iter()
        .filter(usable)
        .filter(|a| a.reaches_object && a.reaches_place)
        .map(|a| (a.prior, EffectorAssignment::Single { arm: a.arm.clone() }));
    if let Some((_, a)) = best(&mut singles) {
        return a;
    }
    if !arms.iter().filter(usable).any(|a| a.reaches_object) {
        return EffectorAssignment::Unreachable {
            reason: Unreachable::Object,
        };
    }
    if !arms.iter().filter(usable).any(|a| a.reaches_place) {
        return EffectorAssignment::Unreachable {
            reason: Unreachable::Place,
        };
    }
    let mut pairs = arms.iter().filter(usable).filter(|a| a.reaches_object).flat_map(|p| {
        arms.iter()
            .filter(usable)
            .filter(move |q| q.reaches_place && q.arm != p.arm)
            .filter_map(move |q| {
                handoffs
                    .iter()
                    .find(|h| h.arms.contains(&p.arm) && h.arms.contains(&q.arm))
                    .map(|h| {
                        (
                            p.prior * q.prior,
                            EffectorAssignment::Transfer {
                                pick_arm: p.arm.clone(),
                                place_arm: q.arm.clone(),
                                handoff: h.position,
                            },
                        )
                    })
            })
    });
    match best(&mut pairs) {
        Some((_, a)) => a,
        None => EffectorAssignment::Unreachable {
            reason: Unreachable::NoHandoff,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arm(name: &str, object: bool, place: bool) -> ArmReach {
        ArmReach {
            arm: name.into(),
            reaches_object: object,
            reaches_place: place,
            prior: 1.0,
        }
    }

    fn middle() -> Vec<Handoff> {
        vec![Handoff {
            position: [0.5, 0.0, 1.0],
            arms: vec!["left".into(), "right".into()],
        }]
    }

    #[test]
    fn one_arm_when_it_reaches_both() {
        let a = assign_effectors(&[arm("left", true, false), arm("right", true, true)], &middle());
        assert_eq!(a, EffectorAssignment::Single { arm: "right".into() });
        // Ties go to the first arm; a prior breaks them.
        let mut arms = vec![arm("left", true, true), arm("right", true, true)];
        assert_eq!(
            assign_effectors(&arms, &[]),
            EffectorAssignment::Single { arm: "left".into() }
        );
        arms[1].prior = 2.0;
        assert_eq!(
            assign_effectors(&arms, &[]),
            EffectorAssignment::Single { arm: "right".into() }
        );
    }

    #[test]
    fn transfer_when_pick_and_place_need_different_arms() {
        let a = assign_effectors(&[arm("left", false, true), arm("right", true, false)], &middle());
        assert_eq!(
            a,
            EffectorAssignment::Transfer {
                pick_arm: "right".into(),
                place_arm: "left".into(),
                handoff: [0.5, 0.0, 1.0]
            }
        );
    }

    #[test]
    fn unreachable_reasons() {
        let u = |r| EffectorAssignment::Unreachable { reason: r };
        assert_eq!(
            assign_effectors(&[arm("left", false, true), arm("right", false, true)], &middle()),
            u(Unreachable::Object)
        );
        assert_eq!(
            assign_effectors(&[arm("left", true, false), arm("right", true, false)], &middle()),
            u(Unreachable::Place)
        );
        assert_eq!(
            assign_effectors(&[arm("left", false, true), arm("right", true, false)], &[]),
            u(Unreachable::NoHandoff)
        );
        assert_eq!(assign_effectors(&[], &[]), u(Unreachable::Object));
    }
}

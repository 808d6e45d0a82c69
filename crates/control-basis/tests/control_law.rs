//! The control law (3.4), null-space composition (3.5–3.7) and the closed loop on a kinematic plant.

use crate::common;

use control_basis::{
    Chain, ControlStack, Controller, FeedbackElement, KinematicPlant, ManipulabilityRows, MotorUnits, Operator, Plant,
    Potential, Predicate, Reference, Sensor, StackSettings, forward_kinematics, jacobian, math::Iso3,
};
use nalgebra::DVector;

fn tip(chain: &Chain) -> usize {
    chain.links().len() - 1
}

fn no_vel_scaling() -> StackSettings {
    StackSettings {
        respect_velocity_limits: false,
        clamp_position_limits: false,
        ..Default::default()
    }
}

fn pose_at(chain: &Chain, q: &[f64]) -> Iso3 {
    let mut s = chain.new_state();
    s.set_q(chain, q).unwrap();
    forward_kinematics(chain, &mut s);
    *s.tip_pose()
}

fn manipulability_at(chain: &Chain, q: &[f64]) -> f64 {
    let mut s = chain.new_state();
    s.set_q(chain, q).unwrap();
    forward_kinematics(chain, &mut s);
    jacobian(chain, &mut s);
    let j = s.jacobian();
    (j * j.transpose()).determinant().sqrt()
}

#[test]
fn manipulability_gradient_matches_finite_differences() {
    let chain = common::wam_chain();
    let mut r = common::rng(11);
    for rows in [ManipulabilityRows::Full, ManipulabilityRows::Position] {
        for _ in 0..50 {
            let q = common::random_q(&chain, &mut r, 0.95);
            let m = Controller::manipulability(&chain, rows, 1.0).unwrap();
            let mut stack = ControlStack::new(&chain, vec![m], no_vel_scaling()).unwrap();
            let mut s = chain.new_state();
            s.set_q(&chain, &q).unwrap();
            stack.tick(&chain, &mut s, &[], 0.01);
            let grad = &stack.buffers()[0].error; // ∇φ_M = −∇w
            let w = |q: &[f64]| {
                let mut s = chain.new_state();
                s.set_q(&chain, q).unwrap();
                forward_kinematics(&chain, &mut s);
                jacobian(&chain, &mut s);
                let j = s.jacobian().rows(0, rows.count()).into_owned();
                (&j * j.transpose()).determinant().sqrt()
            };
            let h = 1e-6;
            for k in 0..7 {
                let mut qp = q.clone();
                let mut qm = q.clone();
                qp[k] += h;
                qm[k] -= h;
                let fd = (w(&qp) - w(&qm)) / (2.0 * h);
                assert!(
                    (-grad[k] - fd).abs() < 1e-7,
                    "rows {rows:?} k {k}: {} vs {fd}",
                    -grad[k]
                );
            }
        }
    }
}

/// A manipulability level under a reach on the same tip rows takes w and B = A⁻¹J from the reach's own
/// Cholesky factor; the result must equal the potential computed on its own.
#[test]
fn manipulability_from_the_reach_factor_equals_the_standalone_potential() {
    let chain = common::wam_chain();
    let n = chain.dof();
    let mut r = common::rng(17);
    for (rows, reach) in [
        (
            ManipulabilityRows::Full,
            Controller::reach_pose(&chain, tip(&chain), 5.0).unwrap(),
        ),
        (
            ManipulabilityRows::Position,
            Controller::reach_position(&chain, tip(&chain), 5.0).unwrap(),
        ),
    ] {
        let manip = Controller::manipulability(&chain, rows, 1.0).unwrap();
        let mut stack = ControlStack::new(&chain, vec![reach, manip.clone()], no_vel_scaling()).unwrap();
        let mut alone = ControlStack::new(&chain, vec![manip], no_vel_scaling()).unwrap();
        let mut s = chain.new_state();
        for _ in 0..200 {
            let q = common::random_q(&chain, &mut r, 0.95);
            let target = pose_at(&chain, &common::random_q(&chain, &mut r, 0.9));
            let reference = match rows {
                ManipulabilityRows::Full => Reference::Pose(target),
                ManipulabilityRows::Position => Reference::Position(target.translation.vector),
            };
            stack.set_reference(&chain, 0, reference).unwrap();
            s.set_q(&chain, &q).unwrap();
            stack.tick(&chain, &mut s, &[], 0.01);
            s.set_q(&chain, &q).unwrap();
            alone.tick(&chain, &mut s, &[], 0.01);
            let (phi, phi0) = (stack.potentials()[1].unwrap(), alone.potentials()[0].unwrap());
            assert!(
                (phi - phi0).abs() <= 1e-9 * phi0.abs().max(1e-3),
                "{rows:?}: φ {phi} vs {phi0}"
            );
            let (e, e0) = (&stack.buffers()[1].error, &alone.buffers()[0].error);
            let scale = e0.rows(0, n).amax().max(1e-6);
            for k in 0..n {
                assert!(
                    (e[k] - e0[k]).abs() <= 1e-9 * scale,
                    "{rows:?} joint {k}: {} vs {}",
                    e[k],
                    e0[k]
                );
            }
            assert_eq!(stack.predicate(1), alone.predicate(0));
        }
        // The shared path ran (the undamped solves: most random configurations).
        assert!(
            stack.shared_factor_count() >= 100,
            "{rows:?}: shared {} of 200",
            stack.shared_factor_count()
        );
        assert_eq!(alone.shared_factor_count(), 0);
    }
}

#[test]
fn inferior_objectives_do_not_move_superior_ones() {
    let chain = common::wam_chain();
    let n = chain.dof();
    let mut r = common::rng(3);
    let mut worst: f64 = 0.0;
    for case in 0..500 {
        let q = common::random_q(&chain, &mut r, 0.95);
        let target = pose_at(&chain, &common::random_q(&chain, &mut r, 0.9));
        // Two to four ranked controllers: position reach, orientation reach, manipulability, joint limits.
        let position = Controller::new(
            "position",
            FeedbackElement {
                sensor: Sensor::LinkPosition { link: tip(&chain) },
                operator: Operator::Identity,
            },
            Potential::Quadratic {
                orientation_weight: 1.0,
            },
            MotorUnits::all(n),
            3.0,
        )
        .unwrap();
        let orientation = Controller::new(
            "orientation",
            FeedbackElement {
                sensor: Sensor::LinkOrientation { link: tip(&chain) },
                operator: Operator::Identity,
            },
            Potential::Quadratic {
                orientation_weight: 1.0,
            },
            MotorUnits::all(n),
            2.0,
        )
        .unwrap();
        let manip = Controller::manipulability(&chain, ManipulabilityRows::Full, 5.0).unwrap();
        let limits = Controller::joint_limits(&chain, 1.0).unwrap();
        let mut ctrls = vec![position, orientation, manip, limits];
        ctrls.truncate(2 + case % 3);
        let levels = ctrls.len();
        let mut stack = ControlStack::new(&chain, ctrls, no_vel_scaling()).unwrap();
        stack
            .set_reference(&chain, 0, Reference::Position(target.translation.vector))
            .unwrap();
        stack
            .set_reference(&chain, 1, Reference::Orientation(target.rotation))
            .unwrap();
        let mut s = chain.new_state();
        s.set_q(&chain, &q).unwrap();
        let du = stack.tick(&chain, &mut s, &[], 0.01).clone();
        // J₁ Δu_total = J₁ Δu₁, and for level 2: [J₁; J₂] unaffected by levels ≥ 3.
        let j1 = stack.buffers()[0].jacobian.rows(0, 3).into_owned();
        let d1 = &j1 * &du - &j1 * &stack.level_steps()[0];
        worst = worst.max(d1.amax());
        if levels > 2 {
            let j2 = stack.buffers()[1].jacobian.rows(0, 3).into_owned();
            let upto2 = {
                // Δu of the first two levels alone.
                let mut s2 = chain.new_state();
                s2.set_q(&chain, &q).unwrap();
                let mut st2 = ControlStack::new(&chain, stack.controllers()[..2].to_vec(), no_vel_scaling()).unwrap();
                st2.set_reference(&chain, 0, Reference::Position(target.translation.vector))
                    .unwrap();
                st2.set_reference(&chain, 1, Reference::Orientation(target.rotation))
                    .unwrap();
                st2.tick(&chain, &mut s2, &[], 0.01).clone()
            };
            worst = worst.max((&j2 * (&du - &upto2)).amax());
            worst = worst.max((&j1 * (&du - &upto2)).amax());
        }
    }
    assert!(worst < 1e-9, "superior motion changed by {worst:e}");
}

#[test]
fn manipulability_under_reach_raises_manipulability_without_moving_the_hand() {
    let chain = common::wam_chain();
    let mut r = common::rng(5);
    let mut raised = 0;
    let mut movable = 0;
    let cases = 100;
    for _ in 0..cases {
        let q0 = common::random_q(&chain, &mut r, 0.7);
        let hold = pose_at(&chain, &q0);
        let reach = Controller::reach_pose(&chain, tip(&chain), 5.0).unwrap();
        let manip = Controller::manipulability(&chain, ManipulabilityRows::Full, 20.0).unwrap();
        let mut stack = ControlStack::new(&chain, vec![reach, manip], StackSettings::default()).unwrap();
        stack.set_reference(&chain, 0, Reference::Pose(hold)).unwrap();
        let mut s = chain.new_state();
        s.set_q(&chain, &q0).unwrap();
        let w0 = manipulability_at(&chain, &q0);
        let mut q = DVector::from_column_slice(&q0);
        let mut max_drift: f64 = 0.0;
        let mut null_share = None;
        for _ in 0..300 {
            s.q_mut().copy_from(&q);
            stack.tick(&chain, &mut s, &[], 0.01);
            // The first tick tells how much of the manipulability gradient lies in the reach's null
            // space: at a local maximum of w along the self-motion nothing can be gained.
            null_share.get_or_insert_with(|| {
                let projected = (stack.delta_u() - &stack.level_steps()[0]).norm();
                projected / stack.level_steps()[1].norm().max(1e-300)
            });
            q += stack.delta_u();
            let p = pose_at(&chain, q.as_slice());
            max_drift = max_drift.max((p.translation.vector - hold.translation.vector).norm());
            max_drift = max_drift.max(0.2 * (p.rotation * hold.rotation.inverse()).angle());
        }
        let w1 = manipulability_at(&chain, q.as_slice());
        assert!(max_drift < 1e-3, "hand moved {max_drift} m");
        assert!(w1 >= w0 - 1e-9, "manipulability fell from {w0} to {w1}");
        if null_share.unwrap() > 0.05 {
            movable += 1;
            if w1 > w0 * 1.001 {
                raised += 1;
            }
        }
    }
    eprintln!("manipulability raised in {raised}/{movable} cases with a null-space gradient");
    assert!(movable >= cases / 4);
    assert!(raised == movable, "raised manipulability in only {raised}/{movable}");
}

/// Reach on a kinematic plant until the reach predicate is 1 or `max_ticks` pass.
///
/// The behaviour: solve the target for a configuration within the limits (the control law iterated on a
/// virtual chain, seeded restarts); if one exists, servo the joints to it with a configuration-space
/// φ_U controller while a Cartesian reach *monitor* reports P(Reach); if none exists, run the Cartesian
/// reach controller itself, which ends quiescent at the closest pose it can hold.
fn run_reach(chain: &Chain, q0: &[f64], target: &Iso3, max_ticks: usize) -> (Predicate, f64, f64, f64, Vec<Predicate>) {
    let dt = 0.01;
    let settings = StackSettings::default();
    let ik = control_basis::inverse_kinematics(chain, target, q0, &control_basis::IkSettings::default()).unwrap();
    let reach = Controller::reach_pose(chain, tip(chain), 5.0).unwrap();
    let mut monitor = control_basis::Monitor::new(reach.clone(), chain, settings.predicate, 0).unwrap();
    let mut stack = if ik.converged {
        let joint_reach = Controller::configuration(chain, 5.0).unwrap();
        let mut st = ControlStack::new(chain, vec![joint_reach], settings).unwrap();
        st.set_reference(chain, 0, Reference::Configuration(ik.q.clone()))
            .unwrap();
        st
    } else {
        let mut st = ControlStack::new(chain, vec![reach], settings).unwrap();
        st.set_reference(chain, 0, Reference::Pose(*target)).unwrap();
        st
    };
    let mut plant = KinematicPlant::for_chain(chain, q0).unwrap();
    let mut s = chain.new_state();
    let mut q = vec![0.0; chain.dof()];
    let mut u = vec![0.0; chain.dof()];
    let mut history = Vec::new();
    for _ in 0..max_ticks {
        plant.read_joint_positions(&mut q);
        s.set_q(chain, &q).unwrap();
        let m = monitor.observe(chain, &mut s, &[], &Reference::Pose(*target), dt);
        stack.tick(chain, &mut s, &[], dt);
        let du = stack.delta_u();
        // The behaviour's goal (3.20): the acting controller and the reach monitor both quiescent.
        let z = [stack.predicate(0), m];
        let p = control_basis::behaviour_predicate(&z, |z| z.iter().all(|p| *p == Predicate::Converged));
        for k in 0..q.len() {
            u[k] = q[k] + du[k];
        }
        if history.last() != Some(&p) {
            history.push(p);
        }
        if p == Predicate::Converged {
            break;
        }
        plant.command(&u).unwrap();
        plant.step(dt).unwrap();
    }
    let pose = pose_at(chain, plant.true_positions());
    let ep = (pose.translation.vector - target.translation.vector).norm();
    let er = (pose.rotation * target.rotation.inverse()).angle();
    (
        *history.last().unwrap(),
        ep,
        er,
        monitor.potential().unwrap_or(f64::NAN),
        history,
    )
}

#[test]
fn closed_loop_reach_converges_in_at_least_99_percent_of_1000_cases() {
    let chain = common::wam_chain();
    let mut r = common::rng(2011);
    let cases = 1000;
    let mut ok = 0;
    let mut worst_ok_pos: f64 = 0.0;
    for _ in 0..cases {
        let q0 = common::random_q(&chain, &mut r, 0.9);
        let target = pose_at(&chain, &common::random_q(&chain, &mut r, 0.9));
        let (p, ep, er, _, _) = run_reach(&chain, &q0, &target, 3000);
        if p == Predicate::Converged && ep < 1e-3 && er < 0.01 {
            ok += 1;
            worst_ok_pos = worst_ok_pos.max(ep);
        }
    }
    eprintln!("reach: {ok}/{cases} converged to 1 mm / 0.01 rad (worst position error {worst_ok_pos:e} m)");
    assert!(ok * 100 >= cases * 99, "only {ok}/{cases}");
}

#[test]
fn unreachable_target_ends_quiescent_at_nonzero_potential() {
    let chain = common::wam_chain();
    let mut r = common::rng(17);
    for _ in 0..20 {
        let q0 = common::random_q(&chain, &mut r, 0.8);
        // 3 m away: beyond the 1.2 m reach.
        let mut target = pose_at(&chain, &q0);
        target.translation.vector = nalgebra::Vector3::new(2.0, 1.5, 1.8);
        let (p, ep, _, phi, history) = run_reach(&chain, &q0, &target, 5000);
        assert_eq!(p, Predicate::Converged, "history {history:?}");
        assert!(ep > 1.0 && phi > 0.1, "ep {ep} phi {phi}");
        assert_eq!(history.first(), Some(&Predicate::Converging));
        assert!(history.iter().all(|p| p.is_finite_state()));
    }
}

trait FiniteState {
    fn is_finite_state(&self) -> bool;
}
impl FiniteState for Predicate {
    fn is_finite_state(&self) -> bool {
        matches!(self, Predicate::Converging | Predicate::Converged)
    }
}

#[test]
fn undefined_reference_gives_null_predicate_and_no_motion() {
    let chain = common::wam_chain();
    let reach = Controller::reach_pose(&chain, tip(&chain), 5.0).unwrap();
    let mut stack = ControlStack::new(&chain, vec![reach], StackSettings::default()).unwrap();
    assert_eq!(stack.predicate(0), Predicate::Unknown);
    let mut s = chain.new_state();
    let du = stack.tick(&chain, &mut s, &[], 0.01).clone();
    assert_eq!(stack.predicate(0), Predicate::NoReference);
    assert_eq!(du.amax(), 0.0);
}

#[test]
fn stretched_out_arm_gives_bounded_joint_steps() {
    let chain = common::wam_chain();
    // q = 0: the arm points straight up, J₁ and J₃ align, J loses rank.
    let q0 = vec![0.0; 7];
    let mut s = chain.new_state();
    s.set_q(&chain, &q0).unwrap();
    for (target, settings) in [
        (nalgebra::Vector3::new(0.0, 0.0, 3.0), no_vel_scaling()),
        (nalgebra::Vector3::new(0.01, 0.0, 2.0), no_vel_scaling()),
        (nalgebra::Vector3::new(0.3, 0.2, 2.5), StackSettings::default()),
    ] {
        let position = Controller::new(
            "position",
            FeedbackElement {
                sensor: Sensor::LinkPosition { link: tip(&chain) },
                operator: Operator::Identity,
            },
            Potential::Quadratic {
                orientation_weight: 1.0,
            },
            MotorUnits::all(7),
            5.0,
        )
        .unwrap();
        let mut stack = ControlStack::new(&chain, vec![position], settings).unwrap();
        stack.set_reference(&chain, 0, Reference::Position(target)).unwrap();
        let du = stack.tick(&chain, &mut s, &[], 0.01).clone();
        let e = stack.buffers()[0].error.rows(0, 3).norm();
        // DLS bound: |J†_λ e| ≤ |e| / (2 λ_max); times κ dt.
        let bound = 5.0 * 0.01 * e / (2.0 * 0.05);
        assert!(du.iter().all(|v| v.is_finite()));
        assert!(du.norm() <= bound + 1e-12, "|du| {} > {bound}", du.norm());
        assert!(
            stack.dls_info()[0].lambda_sq > 0.0,
            "damping engaged at the singularity"
        );
        if settings.respect_velocity_limits {
            assert!(du.amax() <= 2.0 * 0.01 + 1e-12);
        }
    }
}

#[test]
fn reference_of_wrong_kind_is_rejected() {
    let chain = common::wam_chain();
    let reach = Controller::reach_pose(&chain, tip(&chain), 5.0).unwrap();
    let mut stack = ControlStack::new(&chain, vec![reach], StackSettings::default()).unwrap();
    assert!(
        stack
            .set_reference(&chain, 0, Reference::Position(nalgebra::Vector3::zeros()))
            .is_err()
    );
    assert!(stack.set_reference(&chain, 3, Reference::Undefined).is_err());
    let mut bad = Iso3::identity();
    bad.translation.vector.x = f64::NAN;
    assert!(stack.set_reference(&chain, 0, Reference::Pose(bad)).is_err());
    assert!(Controller::reach_pose(&chain, tip(&chain), f64::NAN).is_err());
    let wrong = Controller::new(
        "bad",
        FeedbackElement {
            sensor: Sensor::ContactLoads,
            operator: Operator::Identity,
        },
        Potential::Manipulability {
            rows: ManipulabilityRows::Full,
        },
        MotorUnits::all(7),
        1.0,
    );
    assert!(wrong.is_err());
}

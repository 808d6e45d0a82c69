//! The QP composition ([`QpComposer`]) against its acceptance criteria: joint limits hold in every step of
//! 1,000 random runs, it agrees with the pseudoinverse law when no limit is active, the scaled / stuck
//! statuses come out where they should, and malformed input is an `Err`.
//!
//! Run with `--nocapture` to see the figures (steps with an active limit, worst violation, worst
//! disagreement).

use control_basis::{
    CbError, Chain, ChainState, ControlStack, Controller, FeedbackElement, ManipulabilityRows, MotorUnits, Operator,
    Potential, QpComposer, QpSettings, QpStatus, Reference, RobotModel, Sensor, StackSettings, forward_kinematics,
};
use nalgebra::{DVector, Vector3};
use rand::RngExt;

/// A Barrett WAM 7-DOF written from the published kinematics (joint origins as in the jhu-lcsr
/// `barrett_model` URDF, which equal the standard DH table a = [0, 0, 0.045, −0.045, 0, 0, 0],
/// α = [−π/2, π/2, −π/2, π/2, −π/2, π/2, 0], d = [0, 0, 0.55, 0, 0.3, 0, 0.06] with the base 0.346 m
/// below DH frame 0); limits from `reference/wam7/kinematics.json`, velocity limits 2 rad/s.
/// `wam_matches_the_pinocchio_reference` checks it against `tests/data/wam7_kinematics.json`.
const WAM_URDF: &str = r#"<robot name="wam">
  <link name="base_link"/><link name="shoulder_yaw_link"/><link name="shoulder_pitch_link"/>
  <link name="upper_arm_link"/><link name="forearm_link"/><link name="wrist_yaw_link"/>
  <link name="wrist_pitch_link"/><link name="wrist_palm_link"/>
  <joint name="base_yaw_joint" type="revolute"><parent link="base_link"/><child link="shoulder_yaw_link"/>
    <origin xyz="0 0 0.346" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2.6" upper="2.6" effort="60" velocity="2.0"/></joint>
  <joint name="shoulder_pitch_joint" type="revolute"><parent link="shoulder_yaw_link"/><child link="shoulder_pitch_link"/>
    <origin xyz="0 0 0" rpy="-1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1.985" upper="1.985" effort="60" velocity="2.0"/></joint>
  <joint name="shoulder_yaw_joint" type="revolute"><parent link="shoulder_pitch_link"/><child link="upper_arm_link"/>
    <origin xyz="0 0 0" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2.8" upper="2.8" effort="45" velocity="2.0"/></joint>
  <joint name="elbow_pitch_joint" type="revolute"><parent link="upper_arm_link"/><child link="forearm_link"/>
    <origin xyz="0.045 0 0.55" rpy="-1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-0.9" upper="3.141592653589793" effort="30" velocity="2.0"/></joint>
  <joint name="wrist_yaw_joint" type="revolute"><parent link="forearm_link"/><child link="wrist_yaw_link"/>
    <origin xyz="-0.045 -0.3 0" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-4.55" upper="1.25" effort="10" velocity="2.0"/></joint>
  <joint name="wrist_pitch_joint" type="revolute"><parent link="wrist_yaw_link"/><child link="wrist_pitch_link"/>
    <origin xyz="0 0 0" rpy="-1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1.5707" upper="1.5707" effort="10" velocity="2.0"/></joint>
  <joint name="palm_yaw_joint" type="revolute"><parent link="wrist_pitch_link"/><child link="wrist_palm_link"/>
    <origin xyz="0 0 0" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3.0" upper="3.0" effort="10" velocity="2.0"/></joint>
</robot>"#;

const DT: f64 = 0.01;

fn wam() -> Chain {
    let model = RobotModel::from_urdf_str(WAM_URDF).unwrap();
    Chain::new(&model, "base_link", "wrist_palm_link").unwrap()
}

/// Planar arm in the xy plane: revolute joints about z with the given link lengths, limits ±1 rad and
/// 2 rad/s. The tip is the last link's end.
fn planar(lengths: &[f64]) -> Chain {
    let mut urdf = String::from(r#"<robot name="planar"><link name="l0"/>"#);
    for (i, _) in lengths.iter().enumerate() {
        urdf += &format!(r#"<link name="l{}"/>"#, i + 1);
    }
    urdf += r#"<link name="tip"/>"#;
    let mut offset = 0.0;
    for (i, length) in lengths.iter().enumerate() {
        urdf += &format!(
            r#"<joint name="j{i}" type="revolute"><parent link="l{i}"/><child link="l{}"/>
               <origin xyz="{offset} 0 0"/><axis xyz="0 0 1"/>
               <limit lower="-1" upper="1" effort="1" velocity="2"/></joint>"#,
            i + 1
        );
        offset = *length;
    }
    urdf += &format!(
        r#"<joint name="jt" type="fixed"><parent link="l{}"/><child link="tip"/><origin xyz="{offset} 0 0"/></joint></robot>"#,
        lengths.len()
    );
    let model = RobotModel::from_urdf_str(&urdf).unwrap();
    Chain::new(&model, "l0", "tip").unwrap()
}

/// Stack settings for the QP: the pseudoinverse law without the stack's own position-limit clamping.
fn unclamped() -> StackSettings {
    StackSettings {
        clamp_position_limits: false,
        ..StackSettings::default()
    }
}

fn tip(chain: &Chain) -> usize {
    chain.links().len() - 1
}

fn reach_position(chain: &Chain, gain: f64) -> Controller {
    Controller::new(
        "reach_position",
        FeedbackElement {
            sensor: Sensor::LinkPosition { link: tip(chain) },
            operator: Operator::Identity,
        },
        Potential::Quadratic {
            orientation_weight: 1.0,
        },
        MotorUnits::all(chain.dof()),
        gain,
    )
    .unwrap()
}

fn joint_target(chain: &Chain, gain: f64) -> Controller {
    Controller::new(
        "joint_target",
        FeedbackElement {
            sensor: Sensor::JointPositions,
            operator: Operator::Identity,
        },
        Potential::Quadratic {
            orientation_weight: 1.0,
        },
        MotorUnits::all(chain.dof()),
        gain,
    )
    .unwrap()
}

/// Reach (pose of the tip) ◁ manipulability: the stack of the random runs.
fn reach_with_manipulability(chain: &Chain, respect_velocity_limits: bool) -> ControlStack {
    let reach = Controller::reach_pose(chain, tip(chain), 5.0).unwrap();
    let manip = Controller::manipulability(chain, ManipulabilityRows::Position, 1.0).unwrap();
    let settings = StackSettings {
        respect_velocity_limits,
        ..unclamped()
    };
    ControlStack::new(chain, vec![reach, manip], settings).unwrap()
}

fn pose_at(chain: &Chain, q: &[f64]) -> nalgebra::Isometry3<f64> {
    let mut s = chain.new_state();
    s.set_q(chain, q).unwrap();
    forward_kinematics(chain, &mut s);
    s.link_poses()[tip(chain)]
}

fn uniform_q(chain: &Chain, rng: &mut bayes::rng::Generator, margin_fraction: f64) -> Vec<f64> {
    chain
        .dofs()
        .iter()
        .map(|d| {
            let (lo, hi) = (d.limits.lower, d.limits.upper);
            let m = margin_fraction * (hi - lo);
            rng.random_range(lo + m..hi - m)
        })
        .collect()
}

/// ‖J₁ Δu − α J₁ Δu_ref‖ / ‖J₁ Δu_ref‖ for the first level of `stack` (0 when it asks for no motion).
fn direction_error(stack: &ControlStack, du: &DVector<f64>, reference: &DVector<f64>, alpha: f64) -> f64 {
    let buf = &stack.buffers()[0];
    let j = buf.jacobian.rows(0, buf.rows);
    let d1 = j * reference;
    if d1.norm() < 1e-12 {
        return 0.0;
    }
    (j * du - &d1 * alpha).norm() / d1.norm()
}

#[test]
fn wam_matches_the_pinocchio_reference() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/wam7_kinematics.json");
    let text = std::fs::read_to_string(path).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let chain = wam();
    let f64s =
        |v: &serde_json::Value| -> Vec<f64> { v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect() };
    let mut worst: f64 = 0.0;
    for case in v["cases"].as_array().unwrap() {
        let pose = pose_at(&chain, &f64s(&case["q"]));
        let expect = f64s(&case["tip_position"]);
        for (got, want) in pose.translation.vector.iter().zip(&expect) {
            worst = worst.max((got - want).abs());
        }
    }
    assert!(worst < 1e-9, "inline WAM deviates from the reference by {worst:e} m");
}

/// Acceptance: "QP composition respects joint limits in every step of 1,000 random runs".
#[test]
fn qp_composition_respects_joint_limits_in_every_step_of_1000_random_runs() {
    // 1,000 runs either way. An unoptimised Clarabel is ~25x slower, so the debug build runs 5 ticks per
    // run (about 20 s); `cargo test --release` runs 200 (about 35 s).
    let runs = 1000;
    let ticks = if cfg!(debug_assertions) { 5 } else { 200 };
    let chain = wam();
    let n = chain.dof();
    let mut rng = bayes::rng::seeded(2011);
    let mut state = chain.new_state();
    let mut stack = reach_with_manipulability(&chain, false);
    let mut qp = QpComposer::new(&chain, QpSettings::default()).unwrap();
    let mut du = DVector::zeros(n);

    let (mut steps, mut solved, mut ref_violates_position, mut position_active, mut velocity_active) = (0, 0, 0, 0, 0);
    let (mut found, mut scaled, mut stuck, mut failed, mut fallback) = (0, 0, 0, 0, 0);
    let mut worst_position: f64 = 0.0;
    let mut worst_velocity: f64 = 0.0;
    let mut worst_direction: f64 = 0.0;
    let mut worst_uniform_gap: f64 = 0.0;
    let mut max_iterations = 0;
    let start = std::time::Instant::now();
    for run in 0..runs {
        // Start near the limits: each joint within 0.05 rad of one of its limits with probability 0.3
        // (exactly at it in one run out of ten), else uniform.
        let at_limit = run % 10 == 0;
        let q0: Vec<f64> = chain
            .dofs()
            .iter()
            .map(|d| {
                let (lo, hi) = (d.limits.lower, d.limits.upper);
                let offset = if at_limit { 0.0 } else { rng.random_range(0.0..0.05) };
                match rng.random_range(0.0..1.0) {
                    u if u < 0.15 => lo + offset,
                    u if u < 0.3 => hi - offset,
                    _ => rng.random_range(lo..hi),
                }
            })
            .collect();
        state.set_q(&chain, &q0).unwrap();
        let target = pose_at(&chain, &uniform_q(&chain, &mut rng, 0.0));
        stack.reset_predicates();
        stack.set_reference(&chain, 0, Reference::Pose(target)).unwrap();
        for _ in 0..ticks {
            stack.tick(&chain, &mut state, &[], DT);
            let report = qp.solve(&chain, &state, &stack, DT, &mut du).unwrap();
            steps += 1;
            max_iterations = max_iterations.max(report.iterations);
            if report.solves > 0 {
                solved += 1;
            }
            if report.fallback {
                fallback += 1;
            }
            match report.status {
                QpStatus::Found => found += 1,
                QpStatus::Scaled { .. } => scaled += 1,
                QpStatus::Stuck => stuck += 1,
                QpStatus::Infeasible | QpStatus::NotConverged => failed += 1,
            }
            let reference = qp.reference().clone();
            let q = state.q().clone();
            let (mut pos_act, mut vel_act, mut ref_viol, mut position_binds_somewhere) = (false, false, false, false);
            let mut worst_ratio: f64 = 0.0;
            for (i, d) in chain.dofs().iter().enumerate() {
                let l = d.limits;
                let reach = l.velocity * DT;
                worst_velocity = worst_velocity.max(du[i].abs() - reach);
                let next = q[i] + du[i];
                worst_position = worst_position.max(next - l.upper).max(l.lower - next);
                assert!(
                    du[i].abs() <= reach + 1e-9 && next <= l.upper + 1e-9 && next >= l.lower - 1e-9,
                    "run {run}: joint {i} q {} + Δu {} leaves [{}, {}] or exceeds {reach}",
                    q[i],
                    du[i],
                    l.lower,
                    l.upper
                );
                let ref_next = q[i] + reference[i];
                ref_viol |= ref_next > l.upper || ref_next < l.lower;
                pos_act |= (next - l.upper).abs() < 1e-12 || (next - l.lower).abs() < 1e-12;
                vel_act |= (du[i].abs() - reach).abs() < 1e-12;
                position_binds_somewhere |= l.upper - q[i] < 1.5 * reach || q[i] - l.lower < 1.5 * reach;
                worst_ratio = worst_ratio.max(reference[i].abs() / reach);
            }
            ref_violates_position += ref_viol as usize;
            position_active += pos_act as usize;
            velocity_active += vel_act as usize;
            if report.solves > 0 {
                worst_direction = worst_direction.max(direction_error(&stack, &du, &reference, report.alpha));
            }
            // Far from position limits the stack's uniform velocity scaling is one feasible answer, so the
            // QP's α can only be larger (its extra freedom is the null space of the superior task).
            if !position_binds_somewhere && worst_ratio > 1.0 {
                worst_uniform_gap = worst_uniform_gap.max(1.0 / worst_ratio - report.alpha);
            }
            *state.q_mut() += &du;
        }
    }
    let secs = start.elapsed().as_secs_f64();
    eprintln!(
        "{runs} runs x {ticks} ticks = {steps} steps in {secs:.1} s: solver called in {solved}, pseudoinverse step \
         would leave the position range in {ref_violates_position}, a position limit active in {position_active}, \
         a velocity limit active in {velocity_active}; Found {found}, Scaled {scaled}, Stuck {stuck}, failed \
         {failed}, fallback {fallback}; worst position violation {worst_position:e}, worst velocity excess \
         {worst_velocity:e}, worst relative direction error of the superior task {worst_direction:e}, worst \
         shortfall of α below the uniform scaling {worst_uniform_gap:e}, max iterations {max_iterations}"
    );
    assert!(worst_position <= 1e-9 && worst_velocity <= 1e-9);
    assert!(
        position_active > steps / 100,
        "limits must actually bind ({position_active} of {steps} steps)"
    );
    assert_eq!(failed, 0);
    assert!(
        worst_direction < 1e-6,
        "superior task direction error {worst_direction:e}"
    );
    assert!(
        worst_uniform_gap < 1e-6,
        "α below the uniform velocity scaling by {worst_uniform_gap:e}"
    );
}

/// Acceptance: "agrees with the pseudoinverse law to 1e-6 when no limit is active" — through the solver
/// (`skip_when_feasible = false`) and through the shortcut.
#[test]
fn qp_agrees_with_the_pseudoinverse_law_when_no_limit_is_active() {
    let chain = wam();
    let n = chain.dof();
    let mut rng = bayes::rng::seeded(7);
    let mut state = chain.new_state();
    let mut stack = reach_with_manipulability(&chain, true);
    let forced = QpSettings {
        skip_when_feasible: false,
        ..QpSettings::default()
    };
    let mut through_solver = QpComposer::new(&chain, forced).unwrap();
    let mut shortcut = QpComposer::new(&chain, QpSettings::default()).unwrap();
    let (mut du, mut du_short) = (DVector::zeros(n), DVector::zeros(n));
    let mut worst: f64 = 0.0;
    let mut worst_alpha: f64 = 0.0;
    let mut largest_step: f64 = 0.0;
    let cases = 300;
    for _ in 0..cases {
        let q = uniform_q(&chain, &mut rng, 0.2);
        let near: Vec<f64> = q.iter().map(|v| v + rng.random_range(-0.05..0.05)).collect();
        state.set_q(&chain, &q).unwrap();
        stack.reset_predicates();
        stack
            .set_reference(&chain, 0, Reference::Pose(pose_at(&chain, &near)))
            .unwrap();
        let pinv = stack.tick(&chain, &mut state, &[], DT).clone();
        let report = through_solver.solve(&chain, &state, &stack, DT, &mut du).unwrap();
        // No bound is active: the pseudoinverse step is strictly inside every bound.
        let (lo, hi) = through_solver.bounds();
        for i in 0..n {
            assert!(
                lo[i] < pinv[i] && pinv[i] < hi[i],
                "the case must leave every limit inactive"
            );
        }
        assert_eq!(
            pinv,
            *through_solver.reference(),
            "Δu_ref must be the stack's step bit for bit"
        );
        assert_eq!(report.status, QpStatus::Found);
        assert_eq!(report.solves, 2);
        worst = worst.max((&du - &pinv).amax());
        worst_alpha = worst_alpha.max(1.0 - report.alpha);
        largest_step = largest_step.max(pinv.amax());

        let report = shortcut.solve(&chain, &state, &stack, DT, &mut du_short).unwrap();
        assert_eq!((report.status, report.solves, report.alpha), (QpStatus::Found, 0, 1.0));
        assert_eq!(du_short, pinv);
    }
    eprintln!(
        "{cases} cases, steps up to {largest_step:.2e} rad: worst |Δu_qp − Δu_pinv|∞ = {worst:e}, worst 1 − α = {worst_alpha:e}"
    );
    assert!(worst <= 1e-6, "QP disagrees with the pseudoinverse law by {worst:e}");
    assert!(worst_alpha <= 1e-8);
}

/// A non-redundant arm (two joints, planar position task of rank 2) must scale the whole step: with
/// joint 0 at its upper limit and the task asking to turn it further the answer is Stuck; 0.001 rad below
/// the limit it is Scaled with α = 0.001 / Δu_ref₀, landing exactly on the limit.
#[test]
fn joint_at_its_limit_pushed_further_is_stuck_and_near_it_is_scaled() {
    let chain = planar(&[1.0, 0.5]);
    let mut state = chain.new_state();
    let mut stack = ControlStack::new(&chain, vec![reach_position(&chain, 20.0)], unclamped()).unwrap();
    let mut qp = QpComposer::new(&chain, QpSettings::default()).unwrap();
    let mut du = DVector::zeros(2);
    for (q0, expect_stuck) in [(1.0, true), (0.999, false)] {
        // Target: the tip turned about the base by a further 0.02 rad (a nearly pure joint-0 motion).
        state.set_q(&chain, &[q0, 0.5]).unwrap();
        let target = pose_at(&chain, &[q0 + 0.02, 0.5]).translation.vector;
        stack.set_reference(&chain, 0, Reference::Position(target)).unwrap();
        stack.tick(&chain, &mut state, &[], DT);
        let report = qp.solve(&chain, &state, &stack, DT, &mut du).unwrap();
        let reference = qp.reference().clone();
        assert!(
            reference[0] > 2.0 * (1.0 - q0),
            "the law must push joint 0 through its limit: {reference}"
        );
        if expect_stuck {
            assert_eq!(report.status, QpStatus::Stuck, "{report:?}");
            assert!(report.alpha <= 1e-6 && du.amax() < 1e-9, "{report:?} {du}");
        } else {
            let expect = (1.0 - q0) / reference[0];
            match report.status {
                QpStatus::Scaled { alpha } => {
                    assert!((alpha - expect).abs() < 1e-7, "α {alpha} vs {expect}")
                }
                other => panic!("expected Scaled, got {other:?}"),
            }
            assert!((q0 + du[0] - 1.0).abs() < 1e-9, "joint 0 must stop on its limit");
            assert!(
                (&du - &reference * expect).amax() < 1e-9,
                "the step keeps the law's direction"
            );
        }
    }
}

/// With a redundant joint the QP does better than scaling: joint 0 is held at its limit and the other
/// two realise the whole task motion (Found, though Δu ≠ Δu_ref).
#[test]
fn redundancy_absorbs_a_binding_limit() {
    let chain = planar(&[1.0, 0.8, 0.5]);
    let mut state = chain.new_state();
    let mut stack = ControlStack::new(&chain, vec![reach_position(&chain, 5.0)], unclamped()).unwrap();
    let mut qp = QpComposer::new(&chain, QpSettings::default()).unwrap();
    let mut du = DVector::zeros(3);
    state.set_q(&chain, &[1.0, 0.4, 0.3]).unwrap();
    // A small tip motion the pseudoinverse spreads over all joints, including joint 0 upwards.
    let target = pose_at(&chain, &[1.01, 0.41, 0.3]).translation.vector;
    stack.set_reference(&chain, 0, Reference::Position(target)).unwrap();
    stack.tick(&chain, &mut state, &[], DT);
    let report = qp.solve(&chain, &state, &stack, DT, &mut du).unwrap();
    assert!(qp.reference()[0] > 0.0, "the law must push joint 0 through its limit");
    assert_eq!(report.status, QpStatus::Found, "{report:?}");
    assert_eq!(report.solves, 2);
    assert!(du[0] <= 1e-12, "joint 0 stays at its limit: Δu₀ = {}", du[0]);
    let err = direction_error(&stack, &du, qp.reference(), 1.0);
    assert!(
        err < 1e-7,
        "the task motion is realised in full (relative error {err:e})"
    );
}

/// The superior task asks for no motion (its reference is the current pose) while an inferior level pulls
/// joint 0 through its limit: the QP must hold the superior task (d₁ = 0 means "do not move it") and the
/// joint's limit together, which on a 7-DOF arm with a 6-row task leaves no motion at all.
#[test]
fn idle_superior_task_is_held_while_an_inferior_level_meets_a_limit() {
    let chain = wam();
    let n = chain.dof();
    let mut state = chain.new_state();
    let q = [2.6, 0.5, 0.3, 1.2, -0.4, 0.6, 0.2];
    state.set_q(&chain, &q).unwrap();
    let reach = Controller::reach_pose(&chain, tip(&chain), 5.0).unwrap();
    let mut stack = ControlStack::new(&chain, vec![reach, joint_target(&chain, 2.0)], unclamped()).unwrap();
    stack
        .set_reference(&chain, 0, Reference::Pose(pose_at(&chain, &q)))
        .unwrap();
    let mut pulled = q;
    pulled[0] = 3.0;
    stack
        .set_reference(&chain, 1, Reference::Configuration(DVector::from_row_slice(&pulled)))
        .unwrap();
    stack.tick(&chain, &mut state, &[], DT);
    let mut qp = QpComposer::new(&chain, QpSettings::default()).unwrap();
    let mut du = DVector::zeros(n);
    let report = qp.solve(&chain, &state, &stack, DT, &mut du).unwrap();
    assert!(
        qp.reference()[0] > 0.0,
        "the inferior level must push joint 0 through its limit"
    );
    assert_eq!(
        (report.status, report.alpha, report.solves),
        (QpStatus::Found, 1.0, 1),
        "{report:?}"
    );
    assert!(
        du.amax() < 1e-7,
        "the only null-space motion would cross the limit or move away: {du}"
    );
}

/// A joint already beyond its limit may stay or move back, never further out, and the step is feasible.
#[test]
fn joint_outside_its_range_never_moves_further_out() {
    let chain = planar(&[1.0, 0.5]);
    let mut state = chain.new_state();
    let mut stack = ControlStack::new(&chain, vec![reach_position(&chain, 5.0)], unclamped()).unwrap();
    let mut qp = QpComposer::new(&chain, QpSettings::default()).unwrap();
    let mut du = DVector::zeros(2);
    for (target_q0, expect_back) in [(1.35, false), (0.0, true)] {
        state.set_q(&chain, &[1.3, 0.2]).unwrap();
        let target = pose_at(&chain, &[target_q0, 0.2]).translation.vector;
        stack.set_reference(&chain, 0, Reference::Position(target)).unwrap();
        for _ in 0..50 {
            let before = state.q()[0];
            stack.tick(&chain, &mut state, &[], DT);
            let report = qp.solve(&chain, &state, &stack, DT, &mut du).unwrap();
            assert!(!matches!(report.status, QpStatus::Infeasible | QpStatus::NotConverged));
            assert!(du[0] <= 1e-12 && du[0] >= -0.02 - 1e-12, "Δu₀ = {}", du[0]);
            *state.q_mut() += &du;
            assert!(state.q()[0] <= before + 1e-12);
        }
        if expect_back {
            assert!(
                state.q()[0] < 1.0,
                "pulled inwards the joint comes back ({})",
                state.q()[0]
            );
        } else {
            assert!(
                (state.q()[0] - 1.3).abs() < 1e-9,
                "pushed outwards the joint stays ({})",
                state.q()[0]
            );
        }
    }
}

/// Acceptance: malformed input gives `Err`, not a panic.
#[test]
fn malformed_input_is_an_error() {
    let chain = wam();
    let other = planar(&[1.0, 0.5]);
    let mut state = chain.new_state();
    let mut stack = reach_with_manipulability(&chain, true);
    stack
        .set_reference(&chain, 0, Reference::Pose(pose_at(&chain, &[0.3; 7])))
        .unwrap();
    stack.tick(&chain, &mut state, &[], DT);
    let mut qp = QpComposer::new(&chain, QpSettings::default()).unwrap();
    let mut du = DVector::zeros(7);

    let short_state: ChainState = other.new_state();
    let err = qp.solve(&chain, &short_state, &stack, DT, &mut du).unwrap_err();
    assert!(
        matches!(
            err,
            CbError::DimensionMismatch {
                expected: 7,
                got: 2,
                ..
            }
        ),
        "{err}"
    );

    let mut short_out = DVector::zeros(3);
    assert!(matches!(
        qp.solve(&chain, &state, &stack, DT, &mut short_out),
        Err(CbError::DimensionMismatch { .. })
    ));
    assert!(matches!(
        qp.solve(&other, &state, &stack, DT, &mut du),
        Err(CbError::DimensionMismatch { .. })
    ));
    for dt in [0.0, -0.01, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            qp.solve(&chain, &state, &stack, dt, &mut du),
            Err(CbError::InvalidParameter { name: "dt_secs", .. })
        ));
    }
    let mut other_stack = ControlStack::new(&other, vec![reach_position(&other, 1.0)], unclamped()).unwrap();
    other_stack
        .set_reference(&other, 0, Reference::Position(Vector3::new(1.0, 0.2, 0.0)))
        .unwrap();
    let mut other_state = other.new_state();
    other_stack.tick(&other, &mut other_state, &[], DT);
    assert!(matches!(
        qp.solve(&chain, &state, &other_stack, DT, &mut du),
        Err(CbError::DimensionMismatch { .. })
    ));
    let clamping = ControlStack::new(&chain, stack.controllers().to_vec(), StackSettings::default()).unwrap();
    assert!(matches!(
        qp.solve(&chain, &state, &clamping, DT, &mut du),
        Err(CbError::InvalidParameter {
            name: "clamp_position_limits",
            ..
        })
    ));
    let mut bad = state.clone();
    bad.q_mut()[3] = f64::NAN;
    assert!(matches!(
        qp.solve(&chain, &bad, &stack, DT, &mut du),
        Err(CbError::NotFinite { .. })
    ));

    for settings in [
        QpSettings {
            tolerance: 0.0,
            ..QpSettings::default()
        },
        QpSettings {
            max_iterations: 0,
            ..QpSettings::default()
        },
        QpSettings {
            stuck_alpha: f64::NAN,
            ..QpSettings::default()
        },
    ] {
        assert!(matches!(
            QpComposer::new(&chain, settings),
            Err(CbError::InvalidParameter { .. })
        ));
    }
    // Still usable after the errors.
    assert!(qp.solve(&chain, &state, &stack, DT, &mut du).is_ok());
}

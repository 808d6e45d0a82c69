//! The control tick: FK + Jacobian + damped pseudoinverse + one null-space level, per arm and for the
//! whole of Dexter (both arms, both hands, the head).
//!
//! The `wam_*_distinct_q` cases time what the Pinocchio peer times (`../shared/reference/peers/`,
//! `bench_pinocchio_cpp.cpp`; run side by side by `benches/peers/arm_tick.sh`): every call takes the
//! next of 1024 configurations drawn uniformly within the joint limits (and a 6-D error with entries
//! of about 0.01), made before timing, so neither the branch predictor nor the DLS warm start sees the
//! same problem twice in a row.
//! - `wam_fk_jacobian_dls_distinct_q`: FK + tip Jacobian (6×7) + one damped least-squares step
//!   Jᵀ (J Jᵀ + λ² I)⁻¹ e — Pinocchio's `fk_plus_frame_jacobian` plus Eigen's `dls_step_eigen` (fixed-size
//!   6×6 LDLT, constant λ = 0.05). Ours also estimates σ_min for the adaptive damping, which the peer
//!   does not.
//! - `wam_dls_only_distinct_j`: the DLS step alone on the 1024 Jacobians (Eigen's `dls_step_eigen`).
//! - `wam_tick_reach_manipulability_distinct_q`: the whole [`ControlStack`] tick, reach ◁ manipulability
//!   (pose error, DLS, manipulability gradient, exact null-space projection, limits, predicates).

use control_basis::{
    Chain, ControlStack, Controller, DampedLeastSquares, DlsSettings, FeedbackElement, ManipulabilityRows, MotorUnits,
    Operator, Potential, Reference, RobotModel, Sensor, StackSettings, forward_kinematics, jacobian,
};
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::DVector;
use std::hint::black_box;

const DEXTER: &str = include_str!("../../../assets/dexter.urdf");

fn arm_stack(chain: &Chain) -> ControlStack {
    let tip = chain.links().len() - 1;
    let reach = Controller::reach_pose(chain, tip, 5.0).unwrap();
    let manip = Controller::manipulability(chain, ManipulabilityRows::Full, 10.0).unwrap();
    let mut stack = ControlStack::new(chain, vec![reach, manip], StackSettings::default()).unwrap();
    let mut s = chain.new_state();
    let q: Vec<f64> = (0..chain.dof()).map(|i| 0.3 + 0.1 * i as f64).collect();
    s.set_q(chain, &q).unwrap();
    forward_kinematics(chain, &mut s);
    let mut target = *s.tip_pose();
    target.translation.vector.x += 0.1;
    stack.set_reference(chain, 0, Reference::Pose(target)).unwrap();
    stack
}

fn config_stack(chain: &Chain) -> ControlStack {
    let c = Controller::configuration(chain, 5.0).unwrap();
    let mut stack = ControlStack::new(chain, vec![c], StackSettings::default()).unwrap();
    stack
        .set_reference(
            chain,
            0,
            Reference::Configuration(DVector::from_element(chain.dof(), 0.5)),
        )
        .unwrap();
    stack
}

fn gaze_stack(chain: &Chain) -> ControlStack {
    let tip = chain.links().len() - 1;
    let track = Controller::new(
        "track",
        FeedbackElement {
            sensor: Sensor::LinkOrientation { link: tip },
            operator: Operator::LowPass {
                time_constant_secs: 0.05,
            },
        },
        Potential::Quadratic {
            orientation_weight: 1.0,
        },
        MotorUnits::all(chain.dof()),
        5.0,
    )
    .unwrap();
    let mut stack = ControlStack::new(chain, vec![track], StackSettings::default()).unwrap();
    stack
        .set_reference(
            chain,
            0,
            Reference::Orientation(nalgebra::UnitQuaternion::from_euler_angles(0.1, 0.4, 0.2)),
        )
        .unwrap();
    stack
}

fn bench(c: &mut Criterion) {
    let model = RobotModel::from_urdf_str(DEXTER).unwrap();
    let arm = Chain::new(&model, "left/base_link", "left/wrist_palm_link").unwrap();
    let mut s = arm.new_state();
    s.set_q(&arm, &[0.3, -0.4, 0.5, 1.2, -0.3, 0.4, 0.2]).unwrap();

    c.bench_function("fk_jacobian_wam", |b| {
        b.iter(|| {
            forward_kinematics(&arm, &mut s);
            jacobian(&arm, &mut s);
            black_box(s.jacobian()[(0, 0)])
        })
    });

    // 1024 configurations within the joint limits and 6-D errors, made before timing (splitmix64).
    let mut seed = 1u64;
    let mut uniform = move || {
        seed = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = seed;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let qs: Vec<Vec<f64>> = (0..1024)
        .map(|_| {
            arm.dofs()
                .iter()
                .map(|d| d.limits.lower + (d.limits.upper - d.limits.lower) * uniform())
                .collect()
        })
        .collect();
    let es: Vec<[f64; 6]> = (0..1024)
        .map(|_| std::array::from_fn(|_| 0.02 * (uniform() - 0.5)))
        .collect();
    let mut dls = DampedLeastSquares::new(6, DlsSettings::default());
    let mut out = vec![0.0; arm.dof()];
    let mut i = 0usize;
    let mut s2 = arm.new_state();
    c.bench_function("wam_fk_jacobian_dls_distinct_q", |b| {
        b.iter(|| {
            i = (i + 1) & 1023;
            s2.q_mut().as_mut_slice().copy_from_slice(&qs[i]);
            forward_kinematics(&arm, &mut s2);
            jacobian(&arm, &mut s2);
            dls.solve(s2.jacobian(), &es[i], &mut out);
            black_box(out[0])
        })
    });

    // The DLS step alone on those 1024 Jacobians (Eigen's `dls_step_eigen` times this on 1000).
    let js: Vec<_> = qs
        .iter()
        .map(|q| {
            s2.q_mut().as_mut_slice().copy_from_slice(q);
            forward_kinematics(&arm, &mut s2);
            jacobian(&arm, &mut s2);
            s2.jacobian().clone()
        })
        .collect();
    c.bench_function("wam_dls_only_distinct_j", |b| {
        b.iter(|| {
            i = (i + 1) & 1023;
            dls.solve(&js[i], &es[i], &mut out);
            black_box(out[0])
        })
    });

    let mut stack = arm_stack(&arm);
    let mut i = 0usize;
    c.bench_function("wam_tick_reach_manipulability_distinct_q", |b| {
        b.iter(|| {
            i = (i + 1) & 1023;
            s2.q_mut().as_mut_slice().copy_from_slice(&qs[i]);
            black_box(stack.tick(&arm, &mut s2, &[], 0.002)[0])
        })
    });

    let mut stack = arm_stack(&arm);
    c.bench_function("arm_tick_reach_with_manipulability_nullspace", |b| {
        b.iter(|| black_box(stack.tick(&arm, &mut s, &[], 0.002)[0]))
    });

    let reach_only = {
        let tip = arm.links().len() - 1;
        let mut st = ControlStack::new(
            &arm,
            vec![Controller::reach_pose(&arm, tip, 5.0).unwrap()],
            StackSettings::default(),
        )
        .unwrap();
        st.set_reference(&arm, 0, Reference::Pose(*s.tip_pose())).unwrap();
        st
    };
    let mut reach_only = reach_only;
    c.bench_function("arm_tick_reach_only", |b| {
        b.iter(|| black_box(reach_only.tick(&arm, &mut s, &[], 0.002)[0]))
    });

    // Whole robot: two arms (reach ◁ manipulability), six finger chains, two head-camera chains.
    let mut chains: Vec<(Chain, ControlStack, control_basis::ChainState)> = Vec::new();
    for side in ["left", "right"] {
        let ch = Chain::new(&model, &format!("{side}/base_link"), &format!("{side}/wrist_palm_link")).unwrap();
        let st = arm_stack(&ch);
        let mut state = ch.new_state();
        state.set_q(&ch, &[0.3, -0.4, 0.5, 1.2, -0.3, 0.4, 0.2]).unwrap();
        chains.push((ch, st, state));
        for f in 1..=3 {
            let ch = Chain::new(
                &model,
                &format!("{side}/bhand/palm_link"),
                &format!("{side}/bhand/finger_{f}/tip_link"),
            )
            .unwrap();
            let st = config_stack(&ch);
            let state = ch.new_state();
            chains.push((ch, st, state));
        }
    }
    for cam in ["left", "right"] {
        let ch = Chain::new(&model, "head/base_link", &format!("head/{cam}_camera_optical_frame")).unwrap();
        let st = gaze_stack(&ch);
        let state = ch.new_state();
        chains.push((ch, st, state));
    }
    c.bench_function("dexter_tick_both_arms_hands_head", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for (ch, st, state) in chains.iter_mut() {
                acc += st.tick(ch, state, &[], 0.002)[0];
            }
            black_box(acc)
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);

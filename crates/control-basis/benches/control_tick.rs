//! The control tick: FK + Jacobian + damped pseudoinverse + one null-space level, per arm and for the
//! whole of Dexter (both arms, both hands, the head).

use control_basis::{
    Chain, ControlStack, Controller, FeedbackElement, ManipulabilityRows, MotorUnits, Operator, Potential, Reference,
    RobotModel, Sensor, StackSettings, forward_kinematics, jacobian,
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

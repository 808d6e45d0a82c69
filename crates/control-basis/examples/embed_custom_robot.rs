//! Embedding control-basis in your own robot.
//!
//! 1. Load *your* URDF (a path on the command line, or the small 3-link arm below).
//! 2. Implement [`Plant`] for your robot (here: motor units with a first-order lag, standing in for your
//!    driver — replace `command`/`step`/`read_joint_positions` with calls to your hardware or simulator).
//! 3. Compose two controllers, reach ◁-superior to manipulability (M ◁ R, seed eq. 3.17), and run the loop
//!    until the convergence predicate P(R) (3.18) reaches 1.
//!
//! Run: `cargo run --release -p control-basis --example embed_custom_robot [-- my_robot.urdf BASE TIP]`

use control_basis::{
    CbError, Chain, ChainBinding, ControlStack, Controller, ManipulabilityRows, Plant, Predicate, Reference,
    RobotModel, StackSettings, forward_kinematics, predicate::format_vector,
};

const PLANAR_ARM: &str = r#"<robot name="planar3">
  <link name="base"/><link name="upper"/><link name="fore"/><link name="hand"/><link name="tool"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/><axis xyz="0 0 1"/>
    <limit lower="-2.5" upper="2.5" effort="20" velocity="1.5"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/><origin xyz="0.4 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2.5" upper="2.5" effort="20" velocity="1.5"/></joint>
  <joint name="wrist" type="revolute"><parent link="fore"/><child link="hand"/><origin xyz="0.3 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2.5" upper="2.5" effort="10" velocity="2.0"/></joint>
  <joint name="tool_mount" type="fixed"><parent link="hand"/><child link="tool"/><origin xyz="0.1 0 0"/></joint>
</robot>"#;

/// Your robot. Its motor units track position setpoints with a time constant, like a servo drive.
struct MyRobot {
    names: Vec<String>,
    q: Vec<f64>,
    setpoint: Vec<f64>,
    time_constant_secs: f64,
    t: f64,
}

impl Plant for MyRobot {
    fn joint_names(&self) -> &[String] {
        &self.names
    }
    fn read_joint_positions(&self, q: &mut [f64]) {
        q.copy_from_slice(&self.q);
    }
    fn command(&mut self, references: &[f64]) -> Result<(), CbError> {
        if references.len() != self.setpoint.len() {
            return Err(CbError::DimensionMismatch {
                what: "MyRobot setpoints".into(),
                expected: self.setpoint.len(),
                got: references.len(),
            });
        }
        self.setpoint.copy_from_slice(references);
        Ok(())
    }
    fn step(&mut self, dt_secs: f64) -> Result<(), CbError> {
        let a = dt_secs / (self.time_constant_secs + dt_secs);
        for (q, s) in self.q.iter_mut().zip(&self.setpoint) {
            *q += a * (s - *q);
        }
        self.t += dt_secs;
        Ok(())
    }
    fn time_secs(&self) -> f64 {
        self.t
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (model, base, tip) = match args.as_slice() {
        [path, base, tip] => (RobotModel::from_urdf_file(path)?, base.clone(), tip.clone()),
        [] => (
            RobotModel::from_urdf_str(PLANAR_ARM)?,
            "base".to_string(),
            "tool".to_string(),
        ),
        _ => return Err("usage: embed_custom_robot [URDF BASE TIP]".into()),
    };
    let chain = Chain::new(&model, &base, &tip)?;
    println!("chain {base} -> {tip}: {} DOF ({})", chain.dof(), names(&chain));

    // The plant exposes all of the robot's actuated joints; the binding maps chain variables onto them.
    let plant_names: Vec<String> = model.actuated_joints().map(|j| j.name.clone()).collect();
    let binding = ChainBinding::by_name(&chain, &plant_names)?;
    let start: Vec<f64> = plant_names.iter().map(|_| 0.3).collect();
    let mut robot = MyRobot {
        names: plant_names.clone(),
        setpoint: start.clone(),
        q: start,
        time_constant_secs: 0.02,
        t: 0.0,
    };

    // Target: where the tool would be at another configuration, so it is reachable.
    let mut state = chain.new_state();
    let goal_q: Vec<f64> = (0..chain.dof()).map(|i| if i % 2 == 0 { 0.9 } else { -0.7 }).collect();
    state.set_q(&chain, &goal_q)?;
    forward_kinematics(&chain, &mut state);
    let target = state.tip_pose().translation.vector;

    // Two controllers, ranked: position reach R superior, manipulability M in its null space (M ◁ R).
    let tool = chain.links().len() - 1;
    let reach = Controller::new(
        "reach",
        control_basis::FeedbackElement {
            sensor: control_basis::Sensor::LinkPosition { link: tool },
            operator: control_basis::Operator::Identity,
        },
        control_basis::Potential::Quadratic {
            orientation_weight: 1.0,
        },
        control_basis::MotorUnits::all(chain.dof()),
        4.0,
    )?;
    let manip = Controller::manipulability(&chain, ManipulabilityRows::Position, 2.0)?;
    let mut stack = ControlStack::new(&chain, vec![reach, manip], StackSettings::default())?;
    stack.set_reference(&chain, 0, Reference::Position(target))?;

    let dt = 0.01;
    let mut q_plant = vec![0.0; robot.dof()];
    let mut q_chain = vec![0.0; chain.dof()];
    let mut z = [Predicate::Unknown; 2];
    let mut last = String::new();
    for tick in 0..2000 {
        robot.read_joint_positions(&mut q_plant);
        binding.gather(&q_plant, &mut q_chain);
        state.set_q(&chain, &q_chain)?;
        let du = stack.tick(&chain, &mut state, &[], dt);
        // Motor-unit references u_τ = q + Δu (3.4), sent to the chain's joints only.
        let mut u = q_plant.clone();
        for (i, d) in du.iter().enumerate() {
            u[binding.plant_index(i)] = q_chain[i] + d;
        }
        robot.command(&u)?;
        robot.step(dt)?;
        stack.predicates_into(&mut z);
        let shown = format_vector(&z);
        if shown != last {
            println!(
                "t = {:5.2} s  z = [P(R) P(M)] = {shown}  φ_R = {:.3e}",
                robot.time_secs(),
                stack.potentials()[0].unwrap_or(f64::NAN)
            );
            last = shown;
        }
        if z[0] == Predicate::Converged {
            println!("reach converged after {} ticks", tick + 1);
            break;
        }
    }
    forward_kinematics(&chain, &mut state);
    let err = (state.tip_pose().translation.vector - target).norm();
    println!("tool error {:.3} mm", err * 1e3);
    Ok(())
}

fn names(chain: &Chain) -> String {
    chain
        .dofs()
        .iter()
        .map(|d| d.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

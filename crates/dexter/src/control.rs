//! Control-basis controllers bound to Dexter's motor units: Reach (φ_U on the palm pose with
//! Manipulability subordinate, (3.17)), the hand's motor units, and the Grasp predicate.
//!
//! Each controller runs at the control rate on the encoder readings and writes motor references
//! (`q_ref = q + Δq`, `q̇_ref = Δq / Δt`) through [`Hardware::set_joint_reference`]: the motor units
//! (PD setpoint controllers, simulated or real) then track them.

use control_basis::math::{Iso3, Rot3, Vec3};
use control_basis::{
    Chain, ChainBinding, ChainState, ControlStack, Controller, Hardware, IkSettings, ManipulabilityRows, Predicate,
    Reference, StackSettings, inverse_kinematics,
};
use nalgebra::DVector;

use crate::arm::Arm;
use crate::error::RobotError;

/// The tool frame that Reach servoes: the centre of the palm surface, z = approach direction.
pub fn tool_link(arm: Arm) -> String {
    format!("{}/bhand/palm_surface_link", arm.prefix())
}

/// Reach with Manipulability subordinate, C_M ◁ C_R (3.17), for one arm, in the world frame.
///
/// The reference is a pose of the tool frame. A reference generator (the operator ω of the feedback
/// element in the seed's terms) moves the commanded pose towards the goal at bounded linear and
/// angular speed, so that large motions follow a straight line in Cartesian space.
#[derive(Debug)]
pub struct ReachControl {
    arm: Arm,
    chain: Chain,
    state: ChainState,
    stack: ControlStack,
    /// Configuration servo used for large motions (after IK): no local minima, no limit traps.
    joint_stack: ControlStack,
    /// `Some((q_goal, q_commanded))` while servoing in configuration space.
    joint_goal: Option<(DVector<f64>, DVector<f64>)>,
    /// Joint speed limit of the configuration reference (rad/s).
    pub max_joint_speed: f64,
    /// Joint acceleration limit of the configuration reference (rad/s²).
    pub max_joint_acceleration: f64,
    joint_speed: f64,
    binding: ChainBinding,
    q_chain: Vec<f64>,
    goal: Iso3,
    commanded: Iso3,
    /// Linear speed limit of the reference (m/s).
    pub max_speed: f64,
    /// Angular speed limit of the reference (rad/s).
    pub max_angular_speed: f64,
    /// Linear acceleration limit of the reference (m/s²).
    pub max_acceleration: f64,
    /// Current speed of the reference (m/s).
    speed: f64,
    active: bool,
    /// Things the palm must go around, not over (tall things seen on the table): the approach to
    /// a grasp and the carry to a place take a way around them ([`crate::route`]). Set by whoever
    /// binds the reach (the executive, from what it sees).
    pub avoid: Vec<crate::route::Obstacle>,
    /// Where the ways around [`ReachControl::avoid`] may pass, as (min x, min y), (max x, max y)
    /// (m, world): the table top. A way round a tall thing over the robot's own body had the carried
    /// object knocked from the hand. `None`: anywhere.
    pub way_region: Option<[[f64; 2]; 2]>,
}

impl ReachControl {
    /// Builds the controller for `arm` of `hw`.
    pub fn new(hw: &dyn Hardware, arm: Arm) -> Result<Self, RobotError> {
        let chain = Chain::new(hw.model(), "world", &tool_link(arm))?;
        let tip = chain.links().len() - 1;
        let reach = Controller::reach_pose(&chain, tip, 6.0)?;
        let manip = Controller::manipulability(&chain, ManipulabilityRows::Full, 0.5)?;
        let settings = StackSettings {
            clamp_position_limits: true,
            ..StackSettings::default()
        };
        let stack = ControlStack::new(&chain, vec![reach, manip], settings)?;
        let joint_stack = ControlStack::new(&chain, vec![Controller::configuration(&chain, 8.0)?], settings)?;
        let binding = ChainBinding::by_name(&chain, hw.joint_names())?;
        let state = chain.new_state();
        let n = chain.dof();
        let mut rc = ReachControl {
            arm,
            chain,
            state,
            stack,
            joint_stack,
            joint_goal: None,
            max_joint_speed: 1.0,
            max_joint_acceleration: 2.0,
            joint_speed: 0.0,
            binding,
            q_chain: vec![0.0; n],
            goal: Iso3::identity(),
            commanded: Iso3::identity(),
            max_speed: 0.3,
            max_angular_speed: 1.2,
            max_acceleration: 0.6,
            speed: 0.0,
            active: false,
            avoid: Vec::new(),
            way_region: None,
        };
        let pose = rc.tool_pose(hw);
        rc.goal = pose;
        rc.commanded = pose;
        Ok(rc)
    }

    /// The arm.
    pub fn arm(&self) -> Arm {
        self.arm
    }

    /// The kinematic chain (world → tool).
    pub fn chain(&self) -> &Chain {
        &self.chain
    }

    /// The tool pose computed from the encoders.
    pub fn tool_pose(&mut self, hw: &dyn Hardware) -> Iso3 {
        self.binding.gather(hw.joint_positions(), &mut self.q_chain);
        if self.state.set_q(&self.chain, &self.q_chain).is_ok() {
            control_basis::forward_kinematics(&self.chain, &mut self.state);
        }
        *self.state.tip_pose()
    }

    /// The arm's configuration (chain order) from the encoders.
    pub fn chain_configuration(&mut self, hw: &dyn Hardware) -> DVector<f64> {
        self.binding.gather(hw.joint_positions(), &mut self.q_chain);
        DVector::from_column_slice(&self.q_chain)
    }

    /// Sets the goal; the commanded reference starts from the current tool pose and moves along a
    /// straight line (Cartesian Reach ◁ Manipulability).
    pub fn set_goal(&mut self, hw: &dyn Hardware, goal: Iso3) {
        self.commanded = self.tool_pose(hw);
        self.speed = 0.0;
        self.goal = goal;
        self.active = true;
        self.joint_goal = None;
        self.stack.reset_predicates();
    }

    /// Moves the goal without restarting the reference: the commanded pose keeps its speed and
    /// follows the new goal within the speed and acceleration limits. For a goal that moves every tick
    /// (teleoperation: the operator's hand pose streamed at glove rate).
    pub fn track(&mut self, hw: &dyn Hardware, goal: Iso3) {
        if !self.active || self.joint_goal.is_some() {
            self.commanded = self.tool_pose(hw);
            self.speed = 0.0;
            self.joint_goal = None;
            self.active = true;
        }
        self.goal = goal;
    }

    /// Solves IK for `goal` from the current configuration and servoes there in configuration space
    /// (the Reach goal, transformed into the configuration space once). For large motions: a
    /// configuration servo has no local minima or joint-limit traps. Returns `false` (and does
    /// nothing) if IK finds no configuration within the limits.
    pub fn set_goal_via_ik(&mut self, hw: &dyn Hardware, goal: Iso3, seed: u64) -> Result<bool, RobotError> {
        let Some(q_goal) = self.solve_ik(hw, &goal, seed)? else {
            return Ok(false);
        };
        self.goal = goal;
        self.active = true;
        let q_now = DVector::from_column_slice(&self.q_chain);
        self.joint_goal = Some((q_goal, q_now));
        self.joint_speed = 0.0;
        self.joint_stack.reset_predicates();
        Ok(true)
    }

    /// An IK solution for `goal` within the joint limits, nearest the current configuration among
    /// the attempts, or `None`.
    pub fn solve_ik(&mut self, hw: &dyn Hardware, goal: &Iso3, seed: u64) -> Result<Option<DVector<f64>>, RobotError> {
        self.tool_pose(hw);
        let settings = IkSettings {
            position_tolerance: 5e-4,
            orientation_tolerance: 5e-3,
            restarts: 30,
            seed,
            ..IkSettings::default()
        };
        let sol = inverse_kinematics(&self.chain, goal, &self.q_chain, &settings)?;
        Ok(sol.converged.then_some(sol.q))
    }

    /// The goal.
    pub fn goal(&self) -> Iso3 {
        self.goal
    }

    /// Stops servoing: the motor references stay where they are.
    pub fn release(&mut self) {
        self.active = false;
    }

    /// Whether the controller is engaged.
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// One control tick of `dt` seconds: advance the reference, run the stack, write motor references.
    pub fn tick(&mut self, hw: &mut dyn Hardware, dt: f64) {
        if !self.active {
            return;
        }
        if let Some((q_goal, q_cmd)) = self.joint_goal.as_mut() {
            // Configuration reference generator: bounded joint speed, all joints arrive together.
            // Trapezoidal profile on the leading joint; all joints arrive together.
            let worst = (0..q_goal.len())
                .map(|i| (q_goal[i] - q_cmd[i]).abs())
                .fold(0.0, f64::max);
            let braking = (2.0 * self.max_joint_acceleration * worst).sqrt();
            self.joint_speed = (self.joint_speed + self.max_joint_acceleration * dt)
                .min(self.max_joint_speed)
                .min(braking);
            let step = self.joint_speed * dt;
            if worst > step && worst > 1e-12 {
                let f = step / worst;
                for i in 0..q_goal.len() {
                    q_cmd[i] += (q_goal[i] - q_cmd[i]) * f;
                }
            } else {
                q_cmd.copy_from(q_goal);
                self.joint_speed = 0.0;
            }
            let _ = self
                .joint_stack
                .set_configuration_reference(&self.chain, 0, q_cmd.as_slice());
            self.binding.gather(hw.joint_positions(), &mut self.q_chain);
            if self.state.set_q(&self.chain, &self.q_chain).is_err() {
                return;
            }
            let du = self.joint_stack.tick(&self.chain, &mut self.state, &[], dt);
            for i in 0..self.q_chain.len() {
                let j = self.binding.plant_index(i);
                hw.set_joint_reference(j, self.q_chain[i] + du[i], du[i] / dt);
            }
            return;
        }
        // Reference generator: move `commanded` towards `goal` with a trapezoidal speed profile
        // (bounded speed and acceleration), so that a held object is not shaken out of the hand.
        let limits = self.limits();
        advance_reference(&mut self.commanded, &mut self.speed, &self.goal, limits, dt);
        let _ = self
            .stack
            .set_reference(&self.chain, 0, Reference::Pose(self.commanded));
        let _ = self.stack.set_reference(&self.chain, 1, Reference::Undefined);
        self.binding.gather(hw.joint_positions(), &mut self.q_chain);
        if self.state.set_q(&self.chain, &self.q_chain).is_err() {
            return;
        }
        let du = self.stack.tick(&self.chain, &mut self.state, &[], dt);
        for i in 0..self.q_chain.len() {
            let j = self.binding.plant_index(i);
            hw.set_joint_reference(j, self.q_chain[i] + du[i], du[i] / dt);
        }
    }

    /// The reference generator's limits: linear speed, linear acceleration, angular speed.
    fn limits(&self) -> [f64; 3] {
        [self.max_speed, self.max_acceleration, self.max_angular_speed]
    }

    /// A kinematic rollout of the Cartesian reach (the same reference generator and control stack as
    /// [`ReachControl::tick`], on the robot's own model) from configuration `q0` (chain order) through
    /// the tool poses of `way` in turn, each for at most `seconds` (a via point counts as passed
    /// within 3 cm, the last pose as reached within 1.5 cm), the motor units assumed to track their
    /// references. `clearance` measures each
    /// configuration passed through (e.g. [`crate::sweep::arm_clearance`]); the sweep keeps the
    /// least. Nothing is commanded. A robot-side plan check: which way round a tall thing the whole
    /// arm, not only the palm, can take.
    pub fn sweep(
        &self,
        q0: &[f64],
        way: &[Iso3],
        seconds: f64,
        clearance: &mut dyn FnMut(&ChainState) -> f64,
    ) -> Sweep {
        const DT: f64 = 0.02;
        let mut out = Sweep {
            clearance: f64::INFINITY,
            reached: true,
            error: 0.0,
        };
        let mut state = self.state.clone();
        let mut stack = self.stack.clone();
        stack.reset_predicates();
        let mut q = q0.to_vec();
        if state.set_q(&self.chain, &q).is_err() {
            out.reached = false;
            return out;
        }
        control_basis::forward_kinematics(&self.chain, &mut state);
        let mut commanded = *state.tip_pose();
        let limits = self.limits();
        for (i, goal) in way.iter().enumerate() {
            // A via point counts as passed within 3 cm (as [`crate::skills`] moves through them),
            // the goal within 1.5 cm.
            let tolerance = if i + 1 < way.len() { 0.03 } else { 0.015 };
            let mut speed = 0.0;
            let mut reached = false;
            for _ in 0..(seconds / DT).ceil() as usize {
                advance_reference(&mut commanded, &mut speed, goal, limits, DT);
                let _ = stack.set_reference(&self.chain, 0, Reference::Pose(commanded));
                let _ = stack.set_reference(&self.chain, 1, Reference::Undefined);
                if state.set_q(&self.chain, &q).is_err() {
                    break;
                }
                let du = stack.tick(&self.chain, &mut state, &[], DT);
                for (qi, d) in q.iter_mut().zip(du.iter()) {
                    *qi += d;
                }
                // `tick` left the forward kinematics of the configuration before the step.
                out.clearance = out.clearance.min(clearance(&state));
                let error = (state.tip_pose().translation.vector - goal.translation.vector).norm();
                if commanded.translation.vector == goal.translation.vector && error < tolerance {
                    reached = true;
                    break;
                }
            }
            if !reached {
                out.reached = false;
                out.error = (state.tip_pose().translation.vector - goal.translation.vector).norm();
                return out;
            }
        }
        out
    }

    /// Distance (m) and angle (rad) between the measured tool pose and the goal.
    pub fn goal_error(&mut self, hw: &dyn Hardware) -> (f64, f64) {
        let pose = self.tool_pose(hw);
        let d = (pose.translation.vector - self.goal.translation.vector).norm();
        let a = pose.rotation.angle_to(&self.goal.rotation);
        (d, a)
    }

    /// Whether the reference has reached the goal and the tool is within `tol` (m, rad) of it.
    pub fn at_goal(&mut self, hw: &dyn Hardware, tol_pos: f64, tol_rot: f64) -> bool {
        let reference_done = match &self.joint_goal {
            Some((q_goal, q_cmd)) => (q_goal - q_cmd).amax() < 1e-12,
            None => {
                (self.commanded.translation.vector - self.goal.translation.vector).norm() < 1e-9
                    && self.commanded.rotation.angle_to(&self.goal.rotation) < 1e-9
            }
        };
        let (d, a) = self.goal_error(hw);
        reference_done && d < tol_pos && a < tol_rot
    }

    /// Convergence predicate of the Reach controller (3.18).
    pub fn predicate(&self) -> Predicate {
        self.stack.predicate(0)
    }
}

/// What a [`ReachControl::sweep`] found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sweep {
    /// The least clearance (m) of the configurations passed through.
    pub clearance: f64,
    /// Whether every pose of the way was reached.
    pub reached: bool,
    /// How far (m) the tool stayed from the first pose it did not reach (0 when all were).
    pub error: f64,
}

/// One tick of the Cartesian reference generator: moves `commanded` towards `goal` with a
/// trapezoidal speed profile (`limits`: linear speed, linear acceleration, angular speed; `speed` the
/// reference's current linear speed).
fn advance_reference(commanded: &mut Iso3, speed: &mut f64, goal: &Iso3, limits: [f64; 3], dt: f64) {
    let [max_speed, max_acceleration, max_angular_speed] = limits;
    let dp = goal.translation.vector - commanded.translation.vector;
    let dist = dp.norm();
    let braking = (2.0 * max_acceleration * dist).sqrt();
    *speed = (*speed + max_acceleration * dt).min(max_speed).min(braking);
    let step = *speed * dt;
    if dist > step && dist > 1e-9 {
        commanded.translation.vector += dp * (step / dist);
    } else {
        commanded.translation.vector = goal.translation.vector;
        *speed = 0.0;
    }
    let angle = commanded.rotation.rotation_to(&goal.rotation).angle();
    let astep = max_angular_speed * dt;
    commanded.rotation = if angle > astep {
        commanded.rotation.slerp(&goal.rotation, astep / angle)
    } else {
        goal.rotation
    };
}

/// The BarrettHand's motor units: spread and the three flexion joints.
#[derive(Debug, Clone)]
pub struct HandControl {
    arm: Arm,
    spread: usize,
    flex: [usize; 3],
}

/// Flexion (rad) of the medial joints at which the hand counts as fully closed.
pub const FLEX_CLOSED: f64 = 2.4;

impl HandControl {
    /// The hand of `arm`.
    pub fn new(hw: &dyn Hardware, arm: Arm) -> Result<Self, RobotError> {
        let p = arm.prefix();
        Ok(HandControl {
            arm,
            spread: hw.dof_index(&format!("{p}/bhand/finger_1/prox_joint"))?,
            flex: [
                hw.dof_index(&format!("{p}/bhand/finger_1/med_joint"))?,
                hw.dof_index(&format!("{p}/bhand/finger_2/med_joint"))?,
                hw.dof_index(&format!("{p}/bhand/finger_3/med_joint"))?,
            ],
        })
    }

    /// The arm.
    pub fn arm(&self) -> Arm {
        self.arm
    }

    /// Sets all three flexion references and the spread.
    pub fn set(&self, hw: &mut dyn Hardware, flex: f64, spread: f64) {
        for &f in &self.flex {
            hw.set_joint_reference(f, flex, 0.0);
        }
        hw.set_joint_reference(self.spread, spread, 0.0);
    }

    /// Measured flexion of the three fingers.
    pub fn flexion(&self, hw: &dyn Hardware) -> [f64; 3] {
        let q = hw.joint_positions();
        [q[self.flex[0]], q[self.flex[1]], q[self.flex[2]]]
    }

    /// Largest flexion speed (rad/s).
    pub fn max_flex_speed(&self, hw: &dyn Hardware) -> f64 {
        let qd = hw.joint_velocities();
        self.flex.iter().map(|&f| qd[f].abs()).fold(0.0, f64::max)
    }
}

/// A top-down grasp pose: the palm surface above the object's centre, palm normal down, the
/// fingers closing along `axis` (a horizontal unit vector), F3 on the side of +axis or −axis,
/// whichever turns the hand less from `current`.
pub fn top_down_orientation(axis: &Vec3, current: &Rot3) -> Rot3 {
    let z = -Vec3::z();
    let mut best = Rot3::identity();
    let mut best_angle = f64::INFINITY;
    for s in [1.0, -1.0] {
        let y = (axis * s).normalize();
        let x = y.cross(&z);
        let m = nalgebra::Matrix3::from_columns(&[x, y, z]);
        let r = Rot3::from_matrix(&m);
        let a = r.angle_to(current);
        if a < best_angle {
            best_angle = a;
            best = r;
        }
    }
    best
}

//! Teleoperation on the robot's side (§4.3.1): one glove sample per hand ([`HandCommand`]: the palm
//! pose and the mean finger flexion) and the [`TeleopDriver`] that makes Dexter's hands follow it —
//! Reach ◁ Manipulability tracks the commanded palm pose, the hand's motor units take the flexion, as a
//! teleoperation system maps a glove onto the robot. Where the samples come from (a glove stream, a
//! scripted teacher in the simulator, ROS 2 topics) is the caller's; [`crate::teach`] watches the
//! demonstration they drive.

use control_basis::Hardware;
use control_basis::math::Iso3;
use nalgebra::{Quaternion, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

use crate::arm::Arm;
use crate::control::{HandControl, ReachControl};
use crate::error::RobotError;

/// One glove sample for one hand.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HandCommand {
    /// Time (s).
    pub t: f64,
    /// Which hand.
    pub hand: Arm,
    /// Palm-surface position (m, world).
    pub position: [f64; 3],
    /// Palm-surface orientation, unit quaternion `[x, y, z, w]`.
    pub orientation: [f64; 4],
    /// Mean finger flexion (rad).
    pub flexion: f64,
}

impl HandCommand {
    /// A command from a pose.
    pub fn new(t: f64, hand: Arm, pose: &Iso3, flexion: f64) -> HandCommand {
        let q = pose.rotation.quaternion();
        let p = pose.translation.vector;
        HandCommand {
            t,
            hand,
            position: [p.x, p.y, p.z],
            orientation: [q.i, q.j, q.k, q.w],
            flexion,
        }
    }

    /// The commanded palm pose.
    pub fn pose(&self) -> Iso3 {
        let [x, y, z, w] = self.orientation;
        let q = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
        Iso3::from_parts(
            Translation3::new(self.position[0], self.position[1], self.position[2]),
            q,
        )
    }
}

/// Drives Dexter's hands from hand commands: Reach ◁ Manipulability tracks the commanded palm pose,
/// the hand's motor units take the flexion (a real teleoperation system maps the glove this way).
#[derive(Debug)]
pub struct TeleopDriver {
    reach: [ReachControl; 2],
    hand: [HandControl; 2],
}

impl TeleopDriver {
    /// A driver for both arms of `hw`.
    pub fn new(hw: &dyn Hardware) -> Result<TeleopDriver, RobotError> {
        Ok(TeleopDriver {
            reach: [ReachControl::new(hw, Arm::Left)?, ReachControl::new(hw, Arm::Right)?],
            hand: [HandControl::new(hw, Arm::Left)?, HandControl::new(hw, Arm::Right)?],
        })
    }

    /// One control tick: every hand with a command tracks it.
    pub fn tick(&mut self, hw: &mut dyn Hardware, commands: &[Option<HandCommand>; 2], dt: f64) {
        for (k, command) in commands.iter().enumerate() {
            if let Some(c) = command {
                self.reach[k].track(hw, c.pose());
                self.hand[k].set(hw, c.flexion, 0.0);
            }
            self.reach[k].tick(hw, dt);
        }
    }

    /// The measured palm pose of `arm`.
    pub fn palm_pose(&mut self, hw: &dyn Hardware, arm: Arm) -> Iso3 {
        self.reach[arm.index()].tool_pose(hw)
    }

    /// Mean measured flexion of `arm`'s fingers.
    pub fn flexion(&self, hw: &dyn Hardware, arm: Arm) -> f64 {
        let f = self.hand[arm.index()].flexion(hw);
        (f[0] + f[1] + f[2]) / 3.0
    }
}

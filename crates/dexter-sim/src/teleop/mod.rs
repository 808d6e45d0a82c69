//! Teleoperation (§4.3.1): the teacher's hand poses and finger flexion, streamed at glove rate, drive
//! Dexter's hands. A stream comes from a file (real glove or mocap data, CSV or JSON lines) or from
//! the scripted, human-like [`Teacher`].
//!
//! ## File formats
//! One sample per line, per hand; time in seconds from the start (non-decreasing per hand), the palm
//! surface pose in the robot's world frame (m, unit quaternion x y z w) and the mean finger flexion
//! (rad, 0 open … 2.4 closed).
//!
//! CSV, with this header line exactly:
//! ```text
//! t,hand,x,y,z,qx,qy,qz,qw,flexion
//! 0.000,right,0.42,-0.32,0.95,1,0,0,0,0.3
//! ```
//! JSON lines:
//! ```text
//! {"t":0.0,"hand":"right","position":[0.42,-0.32,0.95],"orientation":[1,0,0,0],"flexion":0.3}
//! ```
//! Between samples the command is held (a zero-order hold, as a glove delivers it).
//!
//! `stream.rs` holds the streams (the samples, the two file formats, their checks, playback),
//! `teacher.rs` the scripted teacher; this file the [`TeleopDriver`] that turns hand commands into
//! Dexter's motion.

use control_basis::Hardware;
use control_basis::math::Iso3;
use dexter::control::{HandControl, ReachControl};

use crate::error::SimError;
use crate::snapshot::Arm;

mod stream;
mod teacher;

pub use stream::{CSV_HEADER, HandCommand, MAX_SAMPLE_GAP_SECS, MAX_STREAM_SECS, Replay, TeleopStream};
pub use teacher::{TeachTask, Teacher};

/// Drives Dexter's hands from hand commands: Reach ◁ Manipulability tracks the commanded palm pose,
/// the hand's motor units take the flexion (a real teleoperation system maps the glove this way).
#[derive(Debug)]
pub struct TeleopDriver {
    reach: [ReachControl; 2],
    hand: [HandControl; 2],
}

impl TeleopDriver {
    /// A driver for both arms of `sim`.
    pub fn new(hw: &dyn Hardware) -> Result<TeleopDriver, SimError> {
        let r = crate::error::from_robot;
        Ok(TeleopDriver {
            reach: [
                ReachControl::new(hw, Arm::Left).map_err(r)?,
                ReachControl::new(hw, Arm::Right).map_err(r)?,
            ],
            hand: [
                HandControl::new(hw, Arm::Left).map_err(r)?,
                HandControl::new(hw, Arm::Right).map_err(r)?,
            ],
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

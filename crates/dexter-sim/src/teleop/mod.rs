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
//! `teacher.rs` the scripted teacher. The [`TeleopDriver`] that turns hand commands into Dexter's
//! motion is the robot's (`dexter::teleop`).

mod stream;
mod teacher;

pub use stream::{CSV_HEADER, HandCommand, MAX_SAMPLE_GAP_SECS, MAX_STREAM_SECS, Replay, TeleopStream};
pub use teacher::{TeachTask, Teacher};

/// Dexter's hands driven from hand commands: the robot's own (moved to `dexter::teleop`).
pub use dexter::teleop::TeleopDriver;

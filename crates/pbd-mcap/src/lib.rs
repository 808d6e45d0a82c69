//! # pbd-mcap: MCAP logs of simulator runs, for Foxglove and for pbd's own tools
//!
//! A demonstration or an execution is recorded as one MCAP file that opens in Foxglove: the robot's
//! link frames and the objects move in the 3D panel (`/tf`), the table, bins and objects are drawn
//! (`/scene`), the cameras show in image panels, text events in the log panel, and joint states and
//! fingertip wrenches can be plotted. Foxglove's well-known messages are Protobuf (the `foxglove`
//! crate's typed schemas), pbd's own JSON with a JSON Schema, so they are also easy to read back
//! from Python or `jq`.
//!
//! | topic                        | schema                        | written by                          |
//! |------------------------------|-------------------------------|-------------------------------------|
//! | `/tf`                        | `foxglove.FrameTransforms`    | [`McapLog::log_snapshot`]           |
//! | `/joint_states`              | `pbd.JointState`              | [`McapLog::log_snapshot`]           |
//! | `/fingertips`                | `pbd.FingertipWrenches`       | [`McapLog::log_snapshot`]           |
//! | `/fingertips/arrows`         | `foxglove.SceneUpdate`        | [`McapLog::log_snapshot`]           |
//! | `/activity`                  | `pbd.Activity`                | [`McapLog::log_snapshot`], on change |
//! | `/robot`                     | `foxglove.SceneUpdate`        | [`McapLog::log_robot`]              |
//! | `/scene`                     | `foxglove.SceneUpdate`        | [`McapLog::log_scene`]              |
//! | `/grasp/candidates`          | `foxglove.SceneUpdate`        | [`McapLog::log_pre_grasps`]         |
//! | `/log`                       | `foxglove.Log`                | [`McapLog::log_text`]               |
//! | `/camera/<name>/image`       | `foxglove.CompressedImage` (JPEG or PNG) or `foxglove.RawImage` (rgb8) | [`McapLog::log_camera_image`] |
//! | `/camera/<name>/calibration` | `foxglove.CameraCalibration`  | [`McapLog::log_camera_image`]       |
//!
//! In the ROS 2 encoding ([`Encoding::Ros2`], `pbd record --encoding ros2`) every channel is CDR with a
//! `ros2msg` schema instead, as rosbag2 writes it (the types and topics: [`ros2`]).
//!
//! Frames: `world` is the fixed frame; each robot link is published relative to its parent link
//! (`parent_from_child = world_from_parent⁻¹ · world_from_child`), each object as
//! `world → object/<name>`. A message's log time is the simulated time in nanoseconds. A frame is
//! written when it moved by more than [`McapLogOptions::tf_tolerance_m`] /
//! [`McapLogOptions::tf_tolerance_rad`], and every frame at least every
//! [`McapLogOptions::tf_keyframe_secs`] of log time (a keyframe), so that the parked arm and the
//! resting objects cost nothing between keyframes and a reader who seeks still finds every frame.
//!
//! ## Crash safety
//!
//! The file is written in place, never renamed, and stays readable if the process dies: messages go
//! into zstd chunks that are built in memory and written whole, and the file is flushed to the
//! operating system after each chunk. A chunk is closed when it holds [`McapLogOptions::chunk_bytes`]
//! of uncompressed data or has been open for [`McapLogOptions::max_chunk_age`] of wall-clock time,
//! whichever comes first, so a crash loses at most that much. [`McapLog::finish`] writes the summary
//! (indexes, statistics) that makes seeking fast; a file without one is still read in full by
//! Foxglove and by [`read_summary`], which reports it as recovered.

#![warn(missing_docs)]

mod grasps;
mod messages;
mod robot;
pub mod ros2;
mod scene;
mod schemas;

pub mod live;
mod read;
mod repair;
mod scan;
mod topics;
mod video;
mod writer;

pub use grasps::PreGraspMarker;
pub use read::*;
pub use repair::*;
pub use robot::{ARROW_M_PER_N, ARROW_MAX_LENGTH, ARROW_MIN_FORCE};
pub use scan::*;
pub use topics::*;
pub use writer::*;

#[cfg(test)]
mod tests;

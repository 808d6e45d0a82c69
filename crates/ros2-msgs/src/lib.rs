//! The ROS 2 messages pbd speaks over DDS (`pbd-ros2`) and writes into recordings (`pbd-mcap`'s
//! ROS 2 encoding), with no ROS installation:
//!
//! - [`msg`]: the messages as serde structs in their definitions' field order;
//! - [`definitions`]: their `.msg` texts, concatenated with the types they use as rosbag2 stores
//!   them (`ros2msg` schemas);
//! - [`cdr`]: encoding and decoding as ROS 2 sends them (CDR with its encapsulation header).
#![warn(missing_docs)]

pub mod cdr;
pub mod definitions;
pub mod msg;

pub use cdr::{CdrError, decode, encode, encode_into};

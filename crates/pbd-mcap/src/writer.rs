//! Writing a log: [`McapLog`], its options, Foxglove's Protobuf messages and pbd's JSON ones, in
//! crash-safe zstd chunks.

use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use crate::messages::{self, FrameTree, TfPolicy, Time, time_ns};
use crate::topics::*;
use crate::{PreGraspMarker, grasps, robot, scene, schemas};
use anyhow::{Context, Result, ensure};
use dexter_sim::scene::Scene;
use dexter_sim::snapshot::{Snapshot, SnapshotHeader};
use foxglove::messages as fm;
use mcap::records::{MessageHeader, Metadata};
use mcap::write::NoSeek;
use mcap::{Attachment, Compression, WriteOptions, Writer};
use serde::Serialize;

/// How camera images are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ImageFormat {
    /// `foxglove.CompressedVideo` (ROS 2: `foxglove_msgs/CompressedVideo`), H.264 (constrained
    /// baseline, OpenH264) at this constant quantiser (0–51, lower is better): one video stream per
    /// camera, a keyframe with its SPS and PPS every [`H264_KEYFRAME_INTERVAL`] frames (where
    /// Foxglove can seek to, and where a reader of a file cut short starts again), no B frames. The
    /// smallest by far: the head cameras' 160×120 frames are about 0.7 kB each at 26 against 4.6 kB
    /// as JPEG 85, because most of a frame is the frame before.
    H264 {
        /// Quantisation parameter, 0–51.
        qp: u8,
    },
    /// `foxglove.CompressedImage`, baseline JPEG of this quality (1–100): every frame on its own;
    /// the cameras' pixel noise is what JPEG discards first.
    Jpeg {
        /// Quality, 1–100.
        quality: u8,
    },
    /// `foxglove.CompressedImage`, lossless PNG.
    Png,
    /// `foxglove.RawImage`, `rgb8`: every byte as the robot saw it.
    Raw,
}

/// [`ImageFormat::H264`]: frames from one keyframe to the next (the video's group of pictures).
pub const H264_KEYFRAME_INTERVAL: u32 = 10;

impl ImageFormat {
    /// JPEG at its default quality (85).
    pub const JPEG: Self = Self::Jpeg { quality: 85 };
    /// H.264 at its default quantiser (26, OpenH264's own default).
    pub const H264: Self = Self::H264 { qp: 26 };
}

impl Default for ImageFormat {
    /// H.264 ([`ImageFormat::H264`]).
    fn default() -> Self {
        Self::H264
    }
}

impl std::str::FromStr for ImageFormat {
    type Err = anyhow::Error;

    /// `h264`, `h264:QP` (quantiser 0–51), `jpeg`, `jpeg:Q` (quality 1–100), `png` or `raw`.
    fn from_str(s: &str) -> Result<Self> {
        let unknown = || {
            anyhow::anyhow!(
                "unknown image format `{s}`: use h264, h264:QP (0-51), jpeg, jpeg:QUALITY (1-100), png or raw"
            )
        };
        match s {
            "h264" => Ok(Self::H264),
            "jpeg" | "jpg" => Ok(Self::JPEG),
            "png" => Ok(Self::Png),
            "raw" => Ok(Self::Raw),
            _ => {
                if let Some(qp) = s.strip_prefix("h264:") {
                    return qp
                        .parse::<u8>()
                        .ok()
                        .filter(|qp| *qp <= 51)
                        .map(|qp| Self::H264 { qp })
                        .ok_or_else(unknown);
                }
                let q = s
                    .strip_prefix("jpeg:")
                    .or_else(|| s.strip_prefix("jpg:"))
                    .and_then(|q| q.parse::<u8>().ok())
                    .filter(|q| (1..=100).contains(q));
                q.map(|quality| Self::Jpeg { quality }).ok_or_else(unknown)
            }
        }
    }
}

impl std::fmt::Display for ImageFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::H264 { qp } => write!(f, "h264:{qp}"),
            Self::Jpeg { quality } => write!(f, "jpeg:{quality}"),
            Self::Png => f.write_str("png"),
            Self::Raw => f.write_str("raw"),
        }
    }
}

/// How a log's messages are encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Encoding {
    /// Foxglove's well-known messages in Protobuf (the `foxglove` crate's typed schemas), pbd's own
    /// in JSON with JSON Schemas: what Foxglove reads best.
    #[default]
    Foxglove,
    /// ROS 2: every channel CDR with a `ros2msg` schema, profile `ros2` — what rosbag2 writes, so
    /// that `ros2 bag`, `rosbags` and Foxglove read it (the types: [`crate::ros2`]).
    Ros2,
}

impl std::str::FromStr for Encoding {
    type Err = anyhow::Error;

    /// `foxglove` (also `json`, the name of pbd's own part) or `ros2` (also `cdr`).
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "foxglove" | "json" | "protobuf" => Ok(Self::Foxglove),
            "ros2" | "cdr" => Ok(Self::Ros2),
            _ => anyhow::bail!("unknown log encoding `{s}`: use foxglove or ros2"),
        }
    }
}

impl std::fmt::Display for Encoding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Foxglove => "foxglove",
            Self::Ros2 => "ros2",
        })
    }
}

/// What a channel carries (its schema in either [`Encoding`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Tf,
    Scene,
    Log,
    JointState,
    Fingertips,
    Activity,
    RawImage,
    CompressedImage,
    CompressedVideo,
    Calibration,
}

/// A camera as [`McapLog::log_camera_image`] needs it: its name (the topics), its optical frame
/// in `/tf` (+z forward, +x right, +y down) and its pinhole calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraView<'a> {
    /// Topic name: `/camera/<name>/image`.
    pub name: &'a str,
    /// The optical frame's link (the image's `frame_id`).
    pub frame_id: &'a str,
    /// Focal lengths (px).
    pub focal: [f64; 2],
    /// Principal point (px).
    pub principal: [f64; 2],
}

/// Uncompressed size of a message record besides its data: opcode (1), record length (8), channel
/// id (2), sequence (4), log time (8), publish time (8).
const MESSAGE_RECORD_OVERHEAD: usize = 31;

/// Severity of a [`McapLog::log_text`] event (the `foxglove.LogLevel` values).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LogLevel {
    /// Detail for debugging.
    Debug = 1,
    /// Normal progress.
    Info = 2,
    /// Something unexpected that the run survives.
    Warning = 3,
    /// Something failed.
    Error = 4,
    /// The run cannot go on.
    Fatal = 5,
}

/// How a log is chunked; the defaults suit recordings of a few MB/s.
#[derive(Debug, Clone, PartialEq)]
pub struct McapLogOptions {
    /// A chunk is compressed and written once it holds this many uncompressed bytes.
    pub chunk_bytes: usize,
    /// … or once it has been open this long (wall clock), so that a slow stream is saved too.
    pub max_chunk_age: Duration,
    /// zstd level; 0 is zstd's default (3). Level 1 was both faster and smaller than 3 on
    /// snapshot logs (70 vs 94 µs CPU and 2.06 vs 2.26 kB per 60-link snapshot).
    pub zstd_level: u32,
    /// How camera images are stored.
    pub image_format: ImageFormat,
    /// How messages are encoded (Foxglove's Protobuf and pbd's JSON, or ROS 2's CDR).
    pub encoding: Encoding,
    /// Every `/tf` frame is written at least this often (s of log time); 0 writes every frame of
    /// every snapshot.
    pub tf_keyframe_secs: f64,
    /// Between keyframes a frame is written when it moved more than this (m) …
    pub tf_tolerance_m: f64,
    /// … or turned more than this (rad) since it was last written.
    pub tf_tolerance_rad: f64,
}

impl Default for McapLogOptions {
    fn default() -> Self {
        Self {
            // Protobuf made Foxglove's messages about half their JSON size; 512 KiB keeps a chunk
            // (what a crash can lose) about as long in time as 1 MiB of JSON did.
            chunk_bytes: 512 << 10,
            max_chunk_age: Duration::from_secs(2),
            zstd_level: 1,
            image_format: ImageFormat::default(),
            encoding: Encoding::default(),
            // 50 µm and 0.1 mrad are below a pixel of the 3D panel at arm's length.
            tf_keyframe_secs: 1.0,
            tf_tolerance_m: 5e-5,
            tf_tolerance_rad: 1e-4,
        }
    }
}

impl McapLogOptions {
    pub(crate) fn tf_policy(&self) -> TfPolicy {
        let keyframe = if self.tf_keyframe_secs > 0.0 {
            time_ns(self.tf_keyframe_secs)
        } else {
            0
        };
        TfPolicy {
            keyframe_ns: keyframe,
            tolerance_m: if keyframe == 0 { -1.0 } else { self.tf_tolerance_m },
            tolerance_rad: if keyframe == 0 { -1.0 } else { self.tf_tolerance_rad },
        }
    }
}

/// What [`McapLog::finish`] wrote.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriteStats {
    /// Messages on all channels.
    pub messages: u64,
    /// Chunks.
    pub chunks: u32,
    /// File size (bytes).
    pub bytes: u64,
}

type McapWriter = Writer<NoSeek<BufWriter<File>>>;

/// Channel ids of the fixed topics.
#[derive(Debug, Clone, Copy, Default)]
struct Channels {
    tf: u16,
    scene: u16,
    log: u16,
    joint_states: u16,
    /// `/fingertips` (pbd's JSON; in ROS 2 one `WrenchStamped` topic per sensor instead).
    fingertips: u16,
    activity: u16,
    robot: u16,
    arrows: u16,
    /// `/joint_references` (ROS 2 only: the motor references, which pbd's JSON joint state holds).
    references: Option<u16>,
}

/// A channel as declared: what a live view needs to declare it too.
#[derive(Debug, Clone)]
struct ChannelInfo {
    id: u16,
    topic: String,
    schema_name: String,
    /// `jsonschema` (pbd's own messages) or `protobuf` (Foxglove's).
    schema_encoding: &'static str,
    schema: Vec<u8>,
    /// `json` or `protobuf`.
    message_encoding: &'static str,
}

/// The schema of a Foxglove message type of the `foxglove` crate (Protobuf descriptors).
fn foxglove_schema<T: foxglove::Encode>() -> Result<foxglove::Schema> {
    T::get_schema().context("a foxglove message type without a schema")
}

/// The fingertip arrows: sensor ids, their tip links in the frame tree, the arrows of this
/// snapshot, and whether the last message drew any.
#[derive(Debug, Clone, Default)]
struct Arrows {
    ids: Vec<String>,
    links: Vec<Option<usize>>,
    arrows: Vec<Option<messages::ArrowPrimitive>>,
    shown: bool,
}

/// An MCAP log being written. Create with [`McapLog::create`], end with [`McapLog::finish`]
/// (dropping it also finishes, but cannot report errors).
pub struct McapLog {
    path: PathBuf,
    /// `None` only once finished.
    writer: Option<McapWriter>,
    options: McapLogOptions,
    channels: Channels,
    /// Each camera's channels (image, calibration), by name.
    cameras: HashMap<String, (u16, u16)>,
    /// Each camera's video stream ([`ImageFormat::H264`]), by name.
    videos: HashMap<String, crate::video::H264Stream>,
    /// Schema ids by name.
    schema_ids: HashMap<String, u16>,
    /// ROS 2: each fingertip sensor's `WrenchStamped` channel, parallel to the snapshot's readings.
    wrench_channels: Vec<u16>,
    tf_policy: TfPolicy,
    arrows: Arrows,
    /// Reused encoded-image buffer.
    image: Vec<u8>,
    /// Every channel declared so far.
    declared: Vec<ChannelInfo>,
    /// Where messages are streamed too, and its channel for each of ours (by id).
    live: Option<crate::live::LiveView>,
    live_channels: Vec<Option<std::sync::Arc<foxglove::RawChannel>>>,
    /// Channels of [`McapLog::log_json`], by topic.
    json_channels: HashMap<String, u16>,
    /// Resolved from the last snapshot header.
    frame_tree: Option<FrameTree>,
    last_activity: Option<String>,
    /// Reused JSON buffer.
    json: Vec<u8>,
    pub(crate) sequence: u32,
    /// When the open chunk got its first message, and its uncompressed size so far.
    open_chunk: Option<(Instant, usize)>,
    /// Latest log time written (ns), the log time of attachments.
    last_time_ns: u64,
}

impl std::fmt::Debug for McapLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapLog")
            .field("path", &self.path)
            .field("finished", &self.writer.is_none())
            .field("options", &self.options)
            .field("cameras", &self.cameras.keys().collect::<Vec<_>>())
            .field("messages", &self.sequence)
            .finish_non_exhaustive()
    }
}

fn write_context(path: &Path) -> String {
    format!("cannot write MCAP log {}", path.display())
}

impl McapLog {
    /// Creates (or truncates) `path` with the default [`McapLogOptions`].
    pub fn create(path: impl AsRef<Path>) -> Result<Self> {
        Self::create_with(path, McapLogOptions::default())
    }

    /// Creates (or truncates) `path`. The header, schemas and channels are on disk when this returns.
    pub fn create_with(path: impl AsRef<Path>, options: McapLogOptions) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let file = File::create(&path).with_context(|| format!("cannot create MCAP log {}", path.display()))?;
        let write_options = WriteOptions::new()
            .compression(Some(Compression::Zstd))
            .compression_level(options.zstd_level)
            // One thread: chunks are small and the simulator needs the other core.
            .compression_threads(0)
            // rosbag2's profile: what ROS 2 readers check before reading on.
            .profile(if options.encoding == Encoding::Ros2 { "ros2" } else { "" })
            .library(concat!("pbd ", env!("CARGO_PKG_VERSION")))
            // Chunks are closed by `McapLog` (size or age) and then flushed; mcap's own size limit
            // would close them without flushing.
            .chunk_size(None)
            // Build each chunk in memory and write it whole: the file never holds a chunk header
            // that still waits for its length.
            .disable_seeking(true);
        let writer = Writer::with_options(NoSeek::new(BufWriter::with_capacity(1 << 16, file)), write_options)
            .with_context(|| write_context(&path))?;
        let tf_policy = options.tf_policy();
        let mut log = Self {
            path,
            writer: Some(writer),
            options,
            channels: Channels::default(),
            cameras: HashMap::new(),
            videos: HashMap::new(),
            schema_ids: HashMap::new(),
            wrench_channels: Vec::new(),
            tf_policy,
            arrows: Arrows::default(),
            image: Vec::new(),
            declared: Vec::new(),
            live: None,
            live_channels: Vec::new(),
            json_channels: HashMap::new(),
            frame_tree: None,
            last_activity: None,
            json: Vec::with_capacity(1 << 14),
            sequence: 0,
            open_chunk: None,
            last_time_ns: 0,
        };
        let ros2 = log.options.encoding == Encoding::Ros2;
        log.channels = Channels {
            tf: log.add_channel(TOPIC_TF, Kind::Tf)?,
            scene: log.add_channel(TOPIC_SCENE, Kind::Scene)?,
            log: log.add_channel(TOPIC_LOG, Kind::Log)?,
            joint_states: log.add_channel(TOPIC_JOINT_STATES, Kind::JointState)?,
            fingertips: if ros2 {
                0
            } else {
                log.add_channel(TOPIC_FINGERTIPS, Kind::Fingertips)?
            },
            activity: log.add_channel(TOPIC_ACTIVITY, Kind::Activity)?,
            robot: log.add_channel(TOPIC_ROBOT, Kind::Scene)?,
            arrows: log.add_channel(TOPIC_FINGERTIP_ARROWS, Kind::Scene)?,
            references: if ros2 {
                Some(log.add_channel(TOPIC_JOINT_REFERENCES, Kind::JointState)?)
            } else {
                None
            },
        };
        log.flush()?;
        Ok(log)
    }

    /// The schema (name, schema encoding, data) and message encoding of a channel of `kind`.
    fn channel_type(&self, kind: Kind) -> Result<(String, &'static str, Vec<u8>, &'static str)> {
        if self.options.encoding == Encoding::Ros2 {
            let name = match kind {
                Kind::Tf => "tf2_msgs/msg/TFMessage",
                Kind::Scene => "visualization_msgs/msg/MarkerArray",
                Kind::Log => "rcl_interfaces/msg/Log",
                Kind::JointState => "sensor_msgs/msg/JointState",
                Kind::Fingertips => "geometry_msgs/msg/WrenchStamped",
                Kind::Activity => "std_msgs/msg/String",
                Kind::RawImage => "sensor_msgs/msg/Image",
                Kind::CompressedImage => "sensor_msgs/msg/CompressedImage",
                Kind::CompressedVideo => "foxglove_msgs/msg/CompressedVideo",
                Kind::Calibration => "sensor_msgs/msg/CameraInfo",
            };
            return Ok((name.to_owned(), "ros2msg", crate::ros2::schema(name)?, "cdr"));
        }
        let fox = |s: foxglove::Schema| (s.name, "protobuf", s.data.into_owned(), "protobuf");
        let json = |name: &str, schema: serde_json::Value| -> Result<_> {
            Ok((name.to_owned(), "jsonschema", serde_json::to_vec(&schema)?, "json"))
        };
        Ok(match kind {
            Kind::Tf => fox(foxglove_schema::<fm::FrameTransforms>()?),
            Kind::Scene => fox(foxglove_schema::<fm::SceneUpdate>()?),
            Kind::Log => fox(foxglove_schema::<fm::Log>()?),
            Kind::RawImage => fox(foxglove_schema::<fm::RawImage>()?),
            Kind::CompressedImage => fox(foxglove_schema::<fm::CompressedImage>()?),
            Kind::CompressedVideo => fox(foxglove_schema::<fm::CompressedVideo>()?),
            Kind::Calibration => fox(foxglove_schema::<fm::CameraCalibration>()?),
            Kind::JointState => json("pbd.JointState", schemas::joint_state())?,
            Kind::Fingertips => json("pbd.FingertipWrenches", schemas::fingertip_wrenches())?,
            Kind::Activity => json("pbd.Activity", schemas::activity())?,
        })
    }

    /// Declares a channel on `topic` for messages of `kind` (its schema once per log).
    fn add_channel(&mut self, topic: &str, kind: Kind) -> Result<u16> {
        let (name, schema_encoding, schema, message_encoding) = self.channel_type(kind)?;
        self.add_channel_with(topic, name, schema_encoding, schema, message_encoding)
    }

    fn add_channel_with(
        &mut self,
        topic: &str,
        schema_name: String,
        schema_encoding: &'static str,
        schema: Vec<u8>,
        message_encoding: &'static str,
    ) -> Result<u16> {
        let writer = self.writer.as_mut().context("the MCAP log is finished")?;
        let id = (|| -> Result<u16> {
            let schema_id = match self.schema_ids.get(&schema_name) {
                Some(&id) => id,
                None => {
                    let id = writer.add_schema(&schema_name, schema_encoding, &schema)?;
                    self.schema_ids.insert(schema_name.clone(), id);
                    id
                }
            };
            Ok(writer.add_channel(schema_id, topic, message_encoding, &BTreeMap::new())?)
        })()
        .with_context(|| write_context(&self.path))?;
        self.declare(ChannelInfo {
            id,
            topic: topic.to_owned(),
            schema_name,
            schema_encoding,
            schema,
            message_encoding,
        })?;
        Ok(id)
    }

    /// Encodes one of Foxglove's messages into the buffer in the log's encoding.
    fn encode_fox<M: prost::Message + 'static>(&mut self, m: &M) -> Result<()> {
        encode_message(&mut self.json, self.options.encoding, m)
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Streams every message from now on to `live` as well (its clients see the same channels,
    /// schemas and messages as the file).
    pub fn stream_to(&mut self, live: crate::live::LiveView) -> Result<()> {
        self.live = Some(live);
        self.live_channels.clear();
        for info in self.declared.clone() {
            self.declare_live(&info)?;
        }
        Ok(())
    }

    /// Notes a new channel (and declares it to the live view).
    fn declare(&mut self, info: ChannelInfo) -> Result<()> {
        self.declare_live(&info)?;
        self.declared.push(info);
        Ok(())
    }

    fn declare_live(&mut self, info: &ChannelInfo) -> Result<()> {
        let Some(live) = &self.live else { return Ok(()) };
        let channel = live.channel(
            &info.topic,
            &info.schema_name,
            info.schema_encoding,
            &info.schema,
            info.message_encoding,
        )?;
        let i = usize::from(info.id);
        if self.live_channels.len() <= i {
            self.live_channels.resize(i + 1, None);
        }
        self.live_channels[i] = Some(channel);
        Ok(())
    }

    /// Logs one simulator snapshot: `/tf` (the links and objects that moved, all of them at a
    /// keyframe), `/joint_states`, `/fingertips`, `/fingertips/arrows` (while any sensor reads a
    /// force, and once more when none does), and `/activity` when the activity text differs from
    /// the last one logged.
    ///
    /// `header` must describe `snap` (same joint, link and object counts); it may change between
    /// calls (the frame tree is re-resolved when it does).
    pub fn log_snapshot(&mut self, header: &SnapshotHeader, snap: &Snapshot) -> Result<()> {
        let joints = header.joint_names.len();
        ensure!(
            snap.q.len() == joints && snap.qd.len() == joints && snap.q_ref.len() == joints,
            "snapshot at t = {} s has {}/{}/{} joint values (q/qd/q_ref) for {joints} joint names",
            snap.time,
            snap.q.len(),
            snap.qd.len(),
            snap.q_ref.len()
        );
        ensure!(
            snap.link_poses.len() == header.link_names.len() && header.link_parents.len() == header.link_names.len(),
            "snapshot at t = {} s has {} link poses and {} link parents for {} link names",
            snap.time,
            snap.link_poses.len(),
            header.link_parents.len(),
            header.link_names.len()
        );
        ensure!(
            snap.objects.len() == header.object_names.len(),
            "snapshot at t = {} s has {} objects for {} object names",
            snap.time,
            snap.objects.len(),
            header.object_names.len()
        );
        if !self.frame_tree.as_ref().is_some_and(|tree| tree.matches(header)) {
            let tree = FrameTree::new(header);
            self.arrows.links.clear();
            self.arrows.ids.clear();
            self.frame_tree = Some(tree);
        }
        let log_time = time_ns(snap.time);
        let timestamp = Time::from_ns(log_time);

        if let Some(tree) = &mut self.frame_tree
            && tree.update(log_time, &snap.link_poses, &snap.objects, &self.tf_policy) > 0
        {
            tree.encode_transforms(timestamp, &mut self.json);
            if self.options.encoding == Encoding::Ros2 {
                let transforms =
                    <fm::FrameTransforms as prost::Message>::decode(self.json.as_slice()).context("re-reading /tf")?;
                self.encode_fox(&transforms)?;
            }
            self.write_buffer(self.channels.tf, log_time)?;
        }

        if let Some(references) = self.channels.references {
            // ROS 2: sensor_msgs/JointState for the encoders and for the motor references, and
            // one WrenchStamped per fingertip sensor (world-aligned, at the tip link).
            let stamp = ros2_time(timestamp);
            for (channel, position, velocity) in [
                (self.channels.joint_states, &snap.q, snap.qd.clone()),
                (references, &snap.q_ref, Vec::new()),
            ] {
                let m = pbd_ros2_msgs::msg::JointState {
                    header: pbd_ros2_msgs::msg::Header {
                        stamp,
                        frame_id: String::new(),
                    },
                    name: header.joint_names.clone(),
                    position: position.clone(),
                    velocity,
                    effort: Vec::new(),
                };
                pbd_ros2_msgs::encode_into(&mut self.json, &m)?;
                self.write_buffer(channel, log_time)?;
            }
            if self.wrench_channels.len() != snap.fingertips.len() {
                self.wrench_channels.clear();
                for id in robot::fingertip_ids(&snap.fingertips) {
                    let topic = format!("/{}", id.replacen("fingertip/", "fingertips/", 1));
                    let c = self.add_channel(&topic, Kind::Fingertips)?;
                    self.wrench_channels.push(c);
                }
            }
            for (f, k) in snap.fingertips.iter().zip(0..) {
                let m = pbd_ros2_msgs::msg::WrenchStamped {
                    header: pbd_ros2_msgs::msg::Header {
                        stamp,
                        frame_id: messages::WORLD_FRAME.to_owned(),
                    },
                    wrench: pbd_ros2_msgs::msg::Wrench {
                        force: pbd_ros2_msgs::msg::Vector3::from_array(f.force),
                        torque: pbd_ros2_msgs::msg::Vector3::from_array(f.torque),
                    },
                };
                pbd_ros2_msgs::encode_into(&mut self.json, &m)?;
                self.write_buffer(self.wrench_channels[k], log_time)?;
            }
        } else {
            let msg = messages::JointState {
                timestamp,
                name: &header.joint_names,
                position: messages::Rounded(&snap.q),
                velocity: messages::Rounded(&snap.qd),
                position_ref: messages::Rounded(&snap.q_ref),
            };
            encode(&mut self.json, &msg)?;
            self.write_buffer(self.channels.joint_states, log_time)?;

            encode(
                &mut self.json,
                &messages::FingertipWrenches {
                    timestamp,
                    fingertips: &snap.fingertips,
                },
            )?;
            self.write_buffer(self.channels.fingertips, log_time)?;
        }
        self.log_arrows(snap, timestamp, log_time)?;

        if self.last_activity.as_deref() != Some(snap.activity.as_str()) {
            if self.options.encoding == Encoding::Ros2 {
                let m = pbd_ros2_msgs::msg::StringMsg {
                    data: snap.activity.clone(),
                };
                pbd_ros2_msgs::encode_into(&mut self.json, &m)?;
            } else {
                encode(
                    &mut self.json,
                    &messages::Activity {
                        timestamp,
                        text: &snap.activity,
                    },
                )?;
            }
            self.write_buffer(self.channels.activity, log_time)?;
            let last = self.last_activity.get_or_insert_with(String::new);
            last.clear();
            last.push_str(&snap.activity);
        }
        Ok(())
    }

    /// The fingertip readings as arrows at their tip links (see [`robot`]).
    fn log_arrows(&mut self, snap: &Snapshot, timestamp: Time, log_time: u64) -> Result<()> {
        let a = &mut self.arrows;
        if a.ids.len() != snap.fingertips.len() {
            a.ids = robot::fingertip_ids(&snap.fingertips);
            a.links.clear();
        }
        if a.links.len() != snap.fingertips.len() {
            let tree = self.frame_tree.as_ref();
            a.links = snap
                .fingertips
                .iter()
                .map(|f| tree.and_then(|t| t.link(&robot::tip_link(f))))
                .collect();
        }
        a.arrows.clear();
        for (f, link) in snap.fingertips.iter().zip(&a.links) {
            let arrow = link
                .and_then(|l| snap.link_poses.get(l))
                .and_then(|pose| robot::force_arrow(&pose.translation.vector, f.force, f.in_contact));
            a.arrows.push(arrow);
        }
        let any = a.arrows.iter().any(Option::is_some);
        if !(any || a.shown) {
            return Ok(());
        }
        a.shown = any;
        let update = robot::arrow_update(timestamp, &a.ids, &a.arrows);
        self.encode_fox(&update)?;
        self.write_buffer(self.channels.arrows, log_time)
    }

    /// Logs the robot on `/robot`: each link's URDF visuals as an entity locked to the link's
    /// frame, so that the arms, hands and head move with `/tf`. Replaces everything logged on
    /// `/robot` before.
    pub fn log_robot(&mut self, model: &control_basis::RobotModel, time_secs: f64) -> Result<()> {
        let log_time = time_ns(time_secs);
        let update = robot::robot_update(model, Time::from_ns(log_time));
        self.encode_fox(&update.proto())?;
        self.write_buffer(self.channels.robot, log_time)
    }

    /// Draws pre-grasp candidates on `/grasp/candidates` (approach arrows ending at each palm
    /// pose, coloured by rank; see [`PreGraspMarker`]). Replaces every candidate drawn before.
    pub fn log_pre_grasps(&mut self, time_secs: f64, markers: &[PreGraspMarker]) -> Result<()> {
        let log_time = time_ns(time_secs);
        let update = grasps::pre_grasp_update(markers, Time::from_ns(log_time));
        self.log_foxglove(TOPIC_GRASP_CANDIDATES, time_secs, &update.proto())
    }

    /// Logs the scene on `/scene`: the table and places in `world`, each object in its frame
    /// `object/<name>` (names from `header.object_names`, parallel to `scene.resolved`). Replaces
    /// everything logged on `/scene` before; call again after objects appear or disappear.
    pub fn log_scene(&mut self, scene: &Scene, header: &SnapshotHeader, time_secs: f64) -> Result<()> {
        let log_time = time_ns(time_secs);
        let update = scene::scene_update(scene, header, Time::from_ns(log_time))?;
        self.encode_fox(&update.proto())?;
        self.write_buffer(self.channels.scene, log_time)
    }

    /// Logs a text event on `/log` (node name `pbd`).
    pub fn log_text(&mut self, time_secs: f64, level: LogLevel, message: &str) -> Result<()> {
        self.log_record(time_secs, level, "pbd", message, "", 0)
    }

    /// Logs a diagnostic on `/log`: its source (`name`, e.g. the module `dexter::exec`), and the
    /// file and line that emitted it (empty and 0 when unknown).
    pub fn log_record(
        &mut self,
        time_secs: f64,
        level: LogLevel,
        name: &str,
        message: &str,
        file: &str,
        line: u32,
    ) -> Result<()> {
        let log_time = time_ns(time_secs);
        let msg = messages::log(Time::from_ns(log_time), level as u8, message, name, file, line);
        self.encode_fox(&msg)?;
        self.write_buffer(self.channels.log, log_time)
    }

    /// Logs an RGB image (`rgb8`, rows top to bottom, `width * height * 3` bytes) on
    /// `/camera/<camera_name>/image` in the log's [`ImageFormat`], with `frame_id` = `camera_name`
    /// and no calibration. Prefer [`McapLog::log_camera_image`], which places the image in 3D.
    pub fn log_image(&mut self, time_secs: f64, camera_name: &str, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
        self.write_image(time_secs, camera_name, camera_name, None, width, height, rgb)
    }

    /// Logs a camera image (`rgb8`, rows top to bottom, `width * height * 3` bytes) on
    /// `/camera/<name>/image` in the log's [`ImageFormat`], and the camera's pinhole calibration on
    /// `/camera/<name>/calibration` (both in the optical frame `camera.frame_id`), so that Foxglove
    /// shows the image in an image panel and projects it in the 3D panel.
    pub fn log_camera_image(
        &mut self,
        time_secs: f64,
        camera: &CameraView<'_>,
        width: u32,
        height: u32,
        rgb: &[u8],
    ) -> Result<()> {
        self.write_image(
            time_secs,
            camera.name,
            camera.frame_id,
            Some(camera),
            width,
            height,
            rgb,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn write_image(
        &mut self,
        time_secs: f64,
        camera_name: &str,
        frame_id: &str,
        calibration: Option<&CameraView<'_>>,
        width: u32,
        height: u32,
        rgb: &[u8],
    ) -> Result<()> {
        let step = width.checked_mul(3).context("image too wide")?;
        let expected = (step as usize)
            .checked_mul(height as usize)
            .context("image too large")?;
        ensure!(
            rgb.len() == expected,
            "camera {camera_name}: a {width}×{height} rgb8 image has {expected} bytes, got {}",
            rgb.len()
        );
        let format = self.options.image_format;
        let (image_channel, calibration_channel) = match self.cameras.get(camera_name) {
            Some(&channels) => channels,
            None => {
                let (image_topic, calibration_topic) = camera_topics(self.options.encoding, camera_name, format);
                let kind = match format {
                    ImageFormat::Raw => Kind::RawImage,
                    ImageFormat::H264 { .. } => Kind::CompressedVideo,
                    _ => Kind::CompressedImage,
                };
                let channels = (
                    self.add_channel(&image_topic, kind)?,
                    self.add_channel(&calibration_topic, Kind::Calibration)?,
                );
                self.cameras.insert(camera_name.to_owned(), channels);
                channels
            }
        };
        let log_time = time_ns(time_secs);
        let timestamp = Time::from_ns(log_time);
        let data: &[u8] = match format {
            ImageFormat::Raw => rgb,
            ImageFormat::H264 { qp } => {
                let stream = match self.videos.entry(camera_name.to_owned()) {
                    std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
                    std::collections::hash_map::Entry::Vacant(e) => e.insert(
                        crate::video::H264Stream::new(width, height, qp, H264_KEYFRAME_INTERVAL)
                            .with_context(|| format!("camera {camera_name}"))?,
                    ),
                };
                ensure!(
                    stream.size() == (width as usize, height as usize),
                    "camera {camera_name}: a {width}×{height} image in a video of {}×{} frames",
                    stream.size().0,
                    stream.size().1
                );
                if !stream
                    .encode(rgb, &mut self.image)
                    .with_context(|| format!("camera {camera_name}"))?
                {
                    return Ok(());
                }
                &self.image
            }
            ImageFormat::Jpeg { quality } => {
                self.image.clear();
                jpeg_encoder::Encoder::new(&mut self.image, quality.clamp(1, 100))
                    .encode(
                        rgb,
                        u16::try_from(width).context("image too wide for JPEG")?,
                        u16::try_from(height).context("image too high for JPEG")?,
                        jpeg_encoder::ColorType::Rgb,
                    )
                    .with_context(|| format!("camera {camera_name}: JPEG encoding"))?;
                &self.image
            }
            ImageFormat::Png => {
                self.image.clear();
                let mut encoder = png::Encoder::new(&mut self.image, width, height);
                encoder.set_color(png::ColorType::Rgb);
                encoder.set_depth(png::BitDepth::Eight);
                encoder.set_compression(png::Compression::Fast);
                encoder
                    .write_header()
                    .and_then(|mut w| w.write_image_data(rgb))
                    .with_context(|| format!("camera {camera_name}: PNG encoding"))?;
                &self.image
            }
        };
        let data = foxglove::bytes::Bytes::copy_from_slice(data);
        match format {
            ImageFormat::Raw => self.encode_fox(&fm::RawImage {
                timestamp: Some(timestamp.proto()),
                frame_id: frame_id.to_owned(),
                width,
                height,
                encoding: "rgb8".into(),
                step,
                data,
            })?,
            ImageFormat::H264 { .. } => self.encode_fox(&fm::CompressedVideo {
                timestamp: Some(timestamp.proto()),
                frame_id: frame_id.to_owned(),
                data,
                format: "h264".into(),
            })?,
            ImageFormat::Jpeg { .. } | ImageFormat::Png => self.encode_fox(&fm::CompressedImage {
                timestamp: Some(timestamp.proto()),
                frame_id: frame_id.to_owned(),
                data,
                format: if format == ImageFormat::Png { "png" } else { "jpeg" }.into(),
            })?,
        }
        self.write_buffer(image_channel, log_time)?;
        if let Some(c) = calibration {
            let calibration = messages::pinhole_calibration(timestamp, frame_id, width, height, c.focal, c.principal);
            self.encode_fox(&calibration)?;
            self.write_buffer(calibration_channel, log_time)?;
        }
        Ok(())
    }

    /// Logs any serialisable message as JSON on `topic`, whose channel (with schema `schema_name` and
    /// the JSON Schema `schema`) is created on first use.
    pub fn log_json<T: Serialize>(
        &mut self,
        topic: &str,
        schema_name: &str,
        schema: &serde_json::Value,
        time_secs: f64,
        msg: &T,
    ) -> Result<()> {
        let ros2 = self.options.encoding == Encoding::Ros2;
        let channel = match self.json_channels.get(topic) {
            Some(&c) => c,
            None => {
                let c = if ros2 {
                    let name = crate::ros2::pbd_type(schema_name);
                    self.add_channel_with(topic, name.to_owned(), "ros2msg", crate::ros2::schema(name)?, "cdr")?
                } else {
                    self.add_channel_with(
                        topic,
                        schema_name.to_owned(),
                        "jsonschema",
                        serde_json::to_vec(schema)?,
                        "json",
                    )?
                };
                self.json_channels.insert(topic.to_owned(), c);
                c
            }
        };
        if ros2 {
            // Through the JSON of the other encoding, numbers rounded alike: both encodings of a
            // demonstration infer the same.
            encode(&mut self.json, msg)?;
            let value: serde_json::Value =
                serde_json::from_slice(&self.json).context("cannot serialise a log message")?;
            crate::ros2::encode_pbd(&mut self.json, schema_name, value)?;
        } else {
            encode(&mut self.json, msg)?;
        }
        self.write_buffer(channel, time_ns(time_secs))
    }

    /// Logs a Foxglove message (Protobuf) on `topic`, whose channel is created on first use.
    pub fn log_foxglove<T: foxglove::Encode + prost::Message + 'static>(
        &mut self,
        topic: &str,
        time_secs: f64,
        msg: &T,
    ) -> Result<()> {
        let channel = match self.json_channels.get(topic) {
            Some(&c) => c,
            None => {
                let (name, schema_encoding, schema, message_encoding) = if self.options.encoding == Encoding::Ros2 {
                    let name = ros2_type_of::<T>()?;
                    (name.to_owned(), "ros2msg", crate::ros2::schema(name)?, "cdr")
                } else {
                    let schema = foxglove_schema::<T>()?;
                    (schema.name, "protobuf", schema.data.into_owned(), "protobuf")
                };
                let c = self.add_channel_with(topic, name, schema_encoding, schema, message_encoding)?;
                self.json_channels.insert(topic.to_owned(), c);
                c
            }
        };
        self.encode_fox(msg)?;
        self.write_buffer(channel, time_ns(time_secs))
    }

    /// Stores a file in the log (e.g. the URDF as `dexter.urdf`, `application/xml`). Closes the open
    /// chunk.
    pub fn attach(&mut self, name: &str, media_type: &str, bytes: &[u8]) -> Result<()> {
        let create_time = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(0));
        let attachment = Attachment {
            log_time: self.last_time_ns,
            create_time,
            name: name.to_owned(),
            media_type: media_type.to_owned(),
            data: Cow::Borrowed(bytes),
        };
        let writer = self.writer.as_mut().context("the MCAP log is finished")?;
        writer
            .attach(&attachment)
            .with_context(|| format!("attaching {name}: {}", write_context(&self.path)))?;
        self.flush()
    }

    /// Stores a named set of key–value pairs (e.g. `run`: scene, seed, git commit). Closes the open
    /// chunk.
    pub fn metadata(&mut self, name: &str, metadata: BTreeMap<String, String>) -> Result<()> {
        let writer = self.writer.as_mut().context("the MCAP log is finished")?;
        writer
            .write_metadata(&Metadata {
                name: name.to_owned(),
                metadata,
            })
            .with_context(|| format!("writing metadata {name}: {}", write_context(&self.path)))?;
        self.flush()
    }

    /// Closes the open chunk, writes it and flushes the file to the operating system. Called
    /// automatically by size and age; call it yourself after an event that must survive a crash.
    pub fn flush(&mut self) -> Result<()> {
        let writer = self.writer.as_mut().context("the MCAP log is finished")?;
        writer.flush().with_context(|| write_context(&self.path))?;
        self.open_chunk = None;
        Ok(())
    }

    /// Writes the last chunk and the summary section and closes the file.
    pub fn finish(mut self) -> Result<WriteStats> {
        let writer = self.writer.take().context("the MCAP log is finished")?;
        finish_writer(writer).with_context(|| write_context(&self.path))
    }

    /// Writes `self.json` as one message and closes the chunk if it is full or old.
    fn write_buffer(&mut self, channel_id: u16, log_time: u64) -> Result<()> {
        let writer = self.writer.as_mut().context("the MCAP log is finished")?;
        let header = MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time,
            publish_time: log_time,
        };
        writer
            .write_to_known_channel(&header, &self.json)
            .with_context(|| write_context(&self.path))?;
        if let Some(live) = &self.live
            && let Some(Some(channel)) = self.live_channels.get(usize::from(channel_id))
        {
            live.publish(channel, log_time, &self.json);
        }
        self.sequence = self.sequence.wrapping_add(1);
        self.last_time_ns = self.last_time_ns.max(log_time);
        let (opened, bytes) = self.open_chunk.get_or_insert_with(|| (Instant::now(), 0));
        *bytes += self.json.len() + MESSAGE_RECORD_OVERHEAD;
        if *bytes >= self.options.chunk_bytes || opened.elapsed() >= self.options.max_chunk_age {
            self.flush()?;
        }
        Ok(())
    }
}

impl Drop for McapLog {
    /// Finishes the file if [`McapLog::finish`] was not called (e.g. while unwinding from a panic).
    fn drop(&mut self) {
        if let Some(writer) = self.writer.take() {
            // Nothing to report an error to; the chunks already written stay readable.
            let _ = finish_writer(writer);
        }
    }
}

fn finish_writer(mut writer: McapWriter) -> Result<WriteStats> {
    let summary = writer.finish()?;
    let mut out = writer.into_inner().into_inner();
    out.flush()?;
    let file = out.into_inner().map_err(|e| e.into_error())?;
    let bytes = file.metadata()?.len();
    let stats = summary.stats.unwrap_or_default();
    Ok(WriteStats {
        messages: stats.message_count,
        chunks: stats.chunk_count,
        bytes,
    })
}

/// The topics of a camera's image and calibration: pbd's (`/camera/<name>/image`,
/// `/camera/<name>/calibration`), or in ROS 2 image_transport's (`…/image` raw,
/// `…/image/compressed`, `…/camera_info`).
fn camera_topics(encoding: Encoding, name: &str, format: ImageFormat) -> (String, String) {
    match encoding {
        Encoding::Foxglove => (camera_topic(name), calibration_topic(name)),
        Encoding::Ros2 => (
            match format {
                ImageFormat::Raw => camera_topic(name),
                // Not image_transport's `compressed`: a CompressedImage subscriber would refuse it.
                ImageFormat::H264 { .. } => format!("{}/h264", camera_topic(name)),
                _ => format!("{}/compressed", camera_topic(name)),
            },
            format!("/camera/{name}/camera_info"),
        ),
    }
}

/// A Foxglove timestamp of ours as `builtin_interfaces/Time`.
fn ros2_time(t: Time) -> pbd_ros2_msgs::msg::Time {
    pbd_ros2_msgs::msg::Time {
        sec: i32::try_from(t.sec).unwrap_or(i32::MAX),
        nanosec: t.nsec,
    }
}

/// A Foxglove message's stamp as `builtin_interfaces/Time` (zero when it has none).
fn stamp_of(t: Option<foxglove::messages::Timestamp>) -> pbd_ros2_msgs::msg::Time {
    ros2_time(t.map_or(Time::from_ns(0), |t| Time {
        sec: t.sec(),
        nsec: t.nsec(),
    }))
}

/// The ROS 2 type a Foxglove message type is written as.
fn ros2_type_of<M: 'static>() -> Result<&'static str> {
    use std::any::TypeId;
    let t = TypeId::of::<M>();
    Ok(if t == TypeId::of::<fm::FrameTransforms>() {
        "tf2_msgs/msg/TFMessage"
    } else if t == TypeId::of::<fm::SceneUpdate>() {
        "visualization_msgs/msg/MarkerArray"
    } else if t == TypeId::of::<fm::Log>() {
        "rcl_interfaces/msg/Log"
    } else if t == TypeId::of::<fm::RawImage>() {
        "sensor_msgs/msg/Image"
    } else if t == TypeId::of::<fm::CompressedImage>() {
        "sensor_msgs/msg/CompressedImage"
    } else if t == TypeId::of::<fm::CompressedVideo>() {
        "foxglove_msgs/msg/CompressedVideo"
    } else if t == TypeId::of::<fm::CameraCalibration>() {
        "sensor_msgs/msg/CameraInfo"
    } else {
        anyhow::bail!(
            "{} has no ROS 2 counterpart in pbd's ROS 2 encoding",
            std::any::type_name::<M>()
        )
    })
}

/// Encodes one of Foxglove's messages into `buf` (cleared first): Protobuf, or its ROS 2
/// counterpart in CDR ([`crate::ros2`]).
fn encode_message<M: prost::Message + 'static>(buf: &mut Vec<u8>, encoding: Encoding, m: &M) -> Result<()> {
    use pbd_ros2_msgs::{encode_into, msg};
    if encoding == Encoding::Foxglove {
        return encode_proto(buf, m);
    }
    let any = m as &dyn std::any::Any;
    let cdr = if let Some(m) = any.downcast_ref::<fm::FrameTransforms>() {
        encode_into(buf, &crate::ros2::tf(m))
    } else if let Some(m) = any.downcast_ref::<fm::SceneUpdate>() {
        encode_into(buf, &crate::ros2::markers(m))
    } else if let Some(m) = any.downcast_ref::<fm::Log>() {
        encode_into(buf, &crate::ros2::log(m))
    } else if let Some(m) = any.downcast_ref::<fm::CameraCalibration>() {
        encode_into(buf, &crate::ros2::camera_info(m))
    } else if let Some(m) = any.downcast_ref::<fm::RawImage>() {
        encode_into(
            buf,
            &msg::Image {
                header: msg::Header {
                    stamp: stamp_of(m.timestamp),
                    frame_id: m.frame_id.clone(),
                },
                height: m.height,
                width: m.width,
                encoding: m.encoding.clone(),
                is_bigendian: 0,
                step: m.step,
                data: m.data.to_vec(),
            },
        )
    } else if let Some(m) = any.downcast_ref::<fm::CompressedVideo>() {
        encode_into(
            buf,
            &msg::CompressedVideo {
                timestamp: stamp_of(m.timestamp),
                frame_id: m.frame_id.clone(),
                data: m.data.to_vec(),
                format: m.format.clone(),
            },
        )
    } else if let Some(m) = any.downcast_ref::<fm::CompressedImage>() {
        encode_into(
            buf,
            &msg::CompressedImage {
                header: msg::Header {
                    stamp: stamp_of(m.timestamp),
                    frame_id: m.frame_id.clone(),
                },
                format: m.format.clone(),
                data: m.data.to_vec(),
            },
        )
    } else {
        anyhow::bail!(
            "{} has no ROS 2 counterpart in pbd's ROS 2 encoding",
            std::any::type_name::<M>()
        )
    };
    cdr.context("CDR encoding")
}

/// Encodes a Protobuf message into `buf` (cleared first).
pub(crate) fn encode_proto<M: prost::Message>(buf: &mut Vec<u8>, msg: &M) -> Result<()> {
    buf.clear();
    msg.encode(buf).context("Protobuf encoding")
}

/// Serialises `msg` as JSON into the cleared buffer, every number to the precision of
/// [`messages::round_json`].
pub(crate) fn encode<T: Serialize>(buf: &mut Vec<u8>, msg: &T) -> Result<()> {
    buf.clear();
    let mut ser = serde_json::Serializer::with_formatter(&mut *buf, RoundedFormatter);
    msg.serialize(&mut ser).context("cannot serialise a log message")
}

/// serde_json's compact output with every floating-point number rounded by
/// [`messages::round_json`]: shortest decimals that compress (a double's last digits are noise to
/// zstd; rounding pbd's own messages made `pbd demo`'s recording 14 % smaller).
struct RoundedFormatter;

impl serde_json::ser::Formatter for RoundedFormatter {
    fn write_f64<W: ?Sized + Write>(&mut self, writer: &mut W, value: f64) -> std::io::Result<()> {
        serde_json::ser::CompactFormatter.write_f64(writer, messages::round_json(value))
    }

    fn write_f32<W: ?Sized + Write>(&mut self, writer: &mut W, value: f32) -> std::io::Result<()> {
        serde_json::ser::CompactFormatter.write_f64(writer, messages::round_json(f64::from(value)))
    }
}

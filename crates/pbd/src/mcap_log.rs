//! # MCAP logs of simulator runs, for Foxglove and for pbd's own tools
//!
//! A demonstration or an execution is recorded as one MCAP file that opens in Foxglove: the robot's
//! link frames and the objects move in the 3D panel (`/tf`), the table, bins and objects are drawn
//! (`/scene`), the cameras show in image panels, text events in the log panel, and joint states and
//! fingertip wrenches can be plotted. Every message is JSON with a JSON Schema, so the file is also
//! easy to read back from Python or `jq`.
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

use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result, ensure};
use dexter_sim::scene::Scene;
use dexter_sim::snapshot::{Snapshot, SnapshotHeader};
use foxglove::messages as fm;
use mcap::records::{MessageHeader, Metadata, Record};
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::write::NoSeek;
use mcap::{Attachment, Compression, WriteOptions, Writer};
use serde::Serialize;

mod grasps;
mod messages;
mod scene;
mod schemas;

mod robot;

pub use grasps::PreGraspMarker;
pub use robot::{ARROW_M_PER_N, ARROW_MAX_LENGTH, ARROW_MIN_FORCE};

use messages::{FrameTree, TfPolicy, Time, time_ns};

/// Robot links and objects (`foxglove.FrameTransforms`).
pub const TOPIC_TF: &str = "/tf";
/// Table, places and objects (`foxglove.SceneUpdate`).
pub const TOPIC_SCENE: &str = "/scene";
/// Text events (`foxglove.Log`).
pub const TOPIC_LOG: &str = "/log";
/// Joint encoders, velocities and setpoints (`pbd.JointState`).
pub const TOPIC_JOINT_STATES: &str = "/joint_states";
/// Fingertip force/torque sensors (`pbd.FingertipWrenches`).
pub const TOPIC_FINGERTIPS: &str = "/fingertips";
/// The task layer's activity text (`pbd.Activity`).
pub const TOPIC_ACTIVITY: &str = "/activity";
/// The robot's links drawn from its URDF visuals (`foxglove.SceneUpdate`).
pub const TOPIC_ROBOT: &str = "/robot";
/// Fingertip forces as arrows (`foxglove.SceneUpdate`).
pub const TOPIC_FINGERTIP_ARROWS: &str = "/fingertips/arrows";
/// Pre-grasp candidates of a grasp run (`foxglove.SceneUpdate`).
pub const TOPIC_GRASP_CANDIDATES: &str = "/grasp/candidates";

/// The Foxglove layout for pbd's logs (`assets/foxglove/pbd-layout.json`): the robot, scene and
/// fingertip arrows in 3D, the left head camera, the schema state and ln B10 as plots, fingertip
/// forces, the decisions and the log. Import it in Foxglove with Layouts → Import from file.
pub const FOXGLOVE_LAYOUT: &str = include_str!("../../../assets/foxglove/pbd-layout.json");

/// Where a schema stands, with its monitor observation (`pbd.SchemaState`): the inferred state
/// of a demonstration (`pbd infer`'s companion log) or the executive's during an execution.
pub const TOPIC_SCHEMA_STATE: &str = "/pbd/schema_state";
/// The robot's decision per seen segment: relevance, place, arms (`pbd.Decision`).
pub const TOPIC_DECISION: &str = "/pbd/decision";

/// The JSON Schema of [`TOPIC_SCHEMA_STATE`] for a library with these action names.
pub fn schema_state_schema(action_names: &[&str]) -> serde_json::Value {
    schemas::schema_state(action_names)
}

/// Simulated time `t` (s) as a Foxglove `time` (`{sec, nsec}`), for messages written with
/// [`McapLog::log_json`].
pub fn foxglove_time(t: f64) -> serde_json::Value {
    serde_json::to_value(Time::from_ns(time_ns(t))).unwrap_or(serde_json::Value::Null)
}

/// The JSON Schema of [`TOPIC_DECISION`].
pub fn decision_schema() -> serde_json::Value {
    schemas::decision()
}

/// The topic of a camera's images (`foxglove.CompressedImage` or `foxglove.RawImage`).
pub fn camera_topic(camera_name: &str) -> String {
    format!("/camera/{camera_name}/image")
}

/// The topic of a camera's calibration (`foxglove.CameraCalibration`).
pub fn calibration_topic(camera_name: &str) -> String {
    format!("/camera/{camera_name}/calibration")
}

/// How camera images are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ImageFormat {
    /// `foxglove.CompressedImage`, baseline JPEG of this quality (1–100): the smallest; the cameras'
    /// pixel noise is what JPEG discards first.
    Jpeg {
        /// Quality, 1–100.
        quality: u8,
    },
    /// `foxglove.CompressedImage`, lossless PNG.
    Png,
    /// `foxglove.RawImage`, `rgb8`: every byte as the robot saw it.
    Raw,
}

impl Default for ImageFormat {
    fn default() -> Self {
        Self::Jpeg { quality: 85 }
    }
}

impl std::str::FromStr for ImageFormat {
    type Err = anyhow::Error;

    /// `jpeg`, `jpeg:Q` (quality 1–100), `png` or `raw`.
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "jpeg" | "jpg" => Ok(Self::default()),
            "png" => Ok(Self::Png),
            "raw" => Ok(Self::Raw),
            _ => {
                let q = s
                    .strip_prefix("jpeg:")
                    .or_else(|| s.strip_prefix("jpg:"))
                    .and_then(|q| q.parse::<u8>().ok())
                    .filter(|q| (1..=100).contains(q));
                q.map(|quality| Self::Jpeg { quality }).ok_or_else(|| {
                    anyhow::anyhow!("unknown image format `{s}`: use jpeg, jpeg:QUALITY (1-100), png or raw")
                })
            }
        }
    }
}

impl std::fmt::Display for ImageFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Jpeg { quality } => write!(f, "jpeg:{quality}"),
            Self::Png => f.write_str("png"),
            Self::Raw => f.write_str("raw"),
        }
    }
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
            // 50 µm and 0.1 mrad are below a pixel of the 3D panel at arm's length.
            tf_keyframe_secs: 1.0,
            tf_tolerance_m: 5e-5,
            tf_tolerance_rad: 1e-4,
        }
    }
}

impl McapLogOptions {
    fn tf_policy(&self) -> TfPolicy {
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
#[derive(Debug, Clone, Copy)]
struct Channels {
    tf: u16,
    scene: u16,
    log: u16,
    joint_states: u16,
    fingertips: u16,
    activity: u16,
    robot: u16,
    arrows: u16,
}

/// Schema ids of the camera topics, and each camera's channels (image, calibration).
#[derive(Debug, Clone)]
struct CameraChannels {
    /// Schema ids and texts.
    raw: (u16, foxglove::Schema),
    compressed: (u16, foxglove::Schema),
    calibration: (u16, foxglove::Schema),
    by_name: HashMap<String, (u16, u16)>,
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
    cameras: CameraChannels,
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
    sequence: u32,
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
            .field("cameras", &self.cameras.by_name.keys().collect::<Vec<_>>())
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
            .profile("")
            .library(concat!("pbd ", env!("CARGO_PKG_VERSION")))
            // Chunks are closed by `McapLog` (size or age) and then flushed; mcap's own size limit
            // would close them without flushing.
            .chunk_size(None)
            // Build each chunk in memory and write it whole: the file never holds a chunk header
            // that still waits for its length.
            .disable_seeking(true);
        let mut writer = Writer::with_options(NoSeek::new(BufWriter::with_capacity(1 << 16, file)), write_options)
            .with_context(|| write_context(&path))?;

        let mut declared: Vec<ChannelInfo> = Vec::new();
        let mut declared_fox: Vec<ChannelInfo> = Vec::new();
        // pbd's own messages: JSON with a JSON Schema.
        let mut add_json =
            |writer: &mut McapWriter, topic: &str, schema_name: &str, schema: serde_json::Value| -> Result<u16> {
                let data = serde_json::to_vec(&schema)?;
                let schema_id = writer.add_schema(schema_name, "jsonschema", &data)?;
                let id = writer.add_channel(schema_id, topic, "json", &BTreeMap::new())?;
                declared.push(ChannelInfo {
                    id,
                    topic: topic.to_owned(),
                    schema_name: schema_name.to_owned(),
                    schema_encoding: "jsonschema",
                    schema: data,
                    message_encoding: "json",
                });
                Ok(id)
            };
        let channels = (|| -> Result<Channels> {
            // Foxglove's: Protobuf, one schema per type.
            let mut schema_ids: HashMap<String, u16> = HashMap::new();
            let mut fox =
                |writer: &mut McapWriter, topic: &str, schema: foxglove::Schema| -> Result<(u16, ChannelInfo)> {
                    let schema_id = match schema_ids.get(&schema.name) {
                        Some(&id) => id,
                        None => {
                            let id = writer.add_schema(&schema.name, &schema.encoding, &schema.data)?;
                            schema_ids.insert(schema.name.clone(), id);
                            id
                        }
                    };
                    let id = writer.add_channel(schema_id, topic, "protobuf", &BTreeMap::new())?;
                    Ok((
                        id,
                        ChannelInfo {
                            id,
                            topic: topic.to_owned(),
                            schema_name: schema.name,
                            schema_encoding: "protobuf",
                            schema: schema.data.into_owned(),
                            message_encoding: "protobuf",
                        },
                    ))
                };
            let mut fox_channel = |writer: &mut McapWriter, topic: &str, schema: foxglove::Schema| -> Result<u16> {
                let (id, info) = fox(writer, topic, schema)?;
                declared_fox.push(info);
                Ok(id)
            };
            let w = &mut writer;
            Ok(Channels {
                tf: fox_channel(w, TOPIC_TF, foxglove_schema::<fm::FrameTransforms>()?)?,
                scene: fox_channel(w, TOPIC_SCENE, foxglove_schema::<fm::SceneUpdate>()?)?,
                log: fox_channel(w, TOPIC_LOG, foxglove_schema::<fm::Log>()?)?,
                joint_states: add_json(w, TOPIC_JOINT_STATES, "pbd.JointState", schemas::joint_state())?,
                fingertips: add_json(
                    w,
                    TOPIC_FINGERTIPS,
                    "pbd.FingertipWrenches",
                    schemas::fingertip_wrenches(),
                )?,
                activity: add_json(w, TOPIC_ACTIVITY, "pbd.Activity", schemas::activity())?,
                robot: fox_channel(w, TOPIC_ROBOT, foxglove_schema::<fm::SceneUpdate>()?)?,
                arrows: fox_channel(w, TOPIC_FINGERTIP_ARROWS, foxglove_schema::<fm::SceneUpdate>()?)?,
            })
        })()
        .with_context(|| write_context(&path))?;
        declared.append(&mut declared_fox);
        declared.sort_by_key(|c| c.id);
        let cameras = (|| -> Result<CameraChannels> {
            let mut schema = |s: foxglove::Schema| -> Result<(u16, foxglove::Schema)> {
                Ok((writer.add_schema(&s.name, &s.encoding, &s.data)?, s))
            };
            Ok(CameraChannels {
                raw: schema(foxglove_schema::<fm::RawImage>()?)?,
                compressed: schema(foxglove_schema::<fm::CompressedImage>()?)?,
                calibration: schema(foxglove_schema::<fm::CameraCalibration>()?)?,
                by_name: HashMap::new(),
            })
        })()
        .with_context(|| write_context(&path))?;
        writer.flush().with_context(|| write_context(&path))?;

        let tf_policy = options.tf_policy();
        Ok(Self {
            path,
            writer: Some(writer),
            options,
            channels,
            cameras,
            tf_policy,
            arrows: Arrows::default(),
            image: Vec::new(),
            declared,
            live: None,
            live_channels: Vec::new(),
            json_channels: HashMap::new(),
            frame_tree: None,
            last_activity: None,
            json: Vec::with_capacity(1 << 14),
            sequence: 0,
            open_chunk: None,
            last_time_ns: 0,
        })
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
            self.write_buffer(self.channels.tf, log_time)?;
        }

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
        self.log_arrows(snap, timestamp, log_time)?;

        if self.last_activity.as_deref() != Some(snap.activity.as_str()) {
            encode(
                &mut self.json,
                &messages::Activity {
                    timestamp,
                    text: &snap.activity,
                },
            )?;
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
        encode_proto(&mut self.json, &robot::arrow_update(timestamp, &a.ids, &a.arrows))?;
        self.write_buffer(self.channels.arrows, log_time)
    }

    /// Logs the robot on `/robot`: each link's URDF visuals as an entity locked to the link's
    /// frame, so that the arms, hands and head move with `/tf`. Replaces everything logged on
    /// `/robot` before.
    pub fn log_robot(&mut self, model: &control_basis::RobotModel, time_secs: f64) -> Result<()> {
        let log_time = time_ns(time_secs);
        let update = robot::robot_update(model, Time::from_ns(log_time));
        encode_proto(&mut self.json, &update.proto())?;
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
        encode_proto(&mut self.json, &update.proto())?;
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
        encode_proto(&mut self.json, &msg)?;
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
        let (image_channel, calibration_channel) = match self.cameras.by_name.get(camera_name) {
            Some(&channels) => channels,
            None => {
                let writer = self.writer.as_mut().context("the MCAP log is finished")?;
                let schema = match format {
                    ImageFormat::Raw => &self.cameras.raw,
                    _ => &self.cameras.compressed,
                };
                let channels = writer
                    .add_channel(schema.0, &camera_topic(camera_name), "protobuf", &BTreeMap::new())
                    .and_then(|image| {
                        let calibration = writer.add_channel(
                            self.cameras.calibration.0,
                            &calibration_topic(camera_name),
                            "protobuf",
                            &BTreeMap::new(),
                        )?;
                        Ok((image, calibration))
                    })
                    .with_context(|| write_context(&self.path))?;
                self.cameras.by_name.insert(camera_name.to_owned(), channels);
                let image_schema = match format {
                    ImageFormat::Raw => &self.cameras.raw.1,
                    _ => &self.cameras.compressed.1,
                };
                let info = |id: u16, topic: String, schema: &foxglove::Schema| ChannelInfo {
                    id,
                    topic,
                    schema_name: schema.name.clone(),
                    schema_encoding: "protobuf",
                    schema: schema.data.to_vec(),
                    message_encoding: "protobuf",
                };
                let infos = [
                    info(channels.0, camera_topic(camera_name), image_schema),
                    info(channels.1, calibration_topic(camera_name), &self.cameras.calibration.1),
                ];
                for info in infos {
                    self.declare(info)?;
                }
                channels
            }
        };
        let log_time = time_ns(time_secs);
        let timestamp = Time::from_ns(log_time);
        let data: &[u8] = match format {
            ImageFormat::Raw => rgb,
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
            ImageFormat::Raw => encode_proto(
                &mut self.json,
                &fm::RawImage {
                    timestamp: Some(timestamp.proto()),
                    frame_id: frame_id.to_owned(),
                    width,
                    height,
                    encoding: "rgb8".into(),
                    step,
                    data,
                },
            )?,
            ImageFormat::Jpeg { .. } | ImageFormat::Png => encode_proto(
                &mut self.json,
                &fm::CompressedImage {
                    timestamp: Some(timestamp.proto()),
                    frame_id: frame_id.to_owned(),
                    data,
                    format: if format == ImageFormat::Png { "png" } else { "jpeg" }.into(),
                },
            )?,
        }
        self.write_buffer(image_channel, log_time)?;
        if let Some(c) = calibration {
            encode_proto(
                &mut self.json,
                &messages::pinhole_calibration(timestamp, frame_id, width, height, c.focal, c.principal),
            )?;
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
        let channel = match self.json_channels.get(topic) {
            Some(&c) => c,
            None => {
                let writer = self.writer.as_mut().context("the MCAP log is finished")?;
                let data = serde_json::to_vec(schema)?;
                let c = writer
                    .add_schema(schema_name, "jsonschema", &data)
                    .and_then(|id| writer.add_channel(id, topic, "json", &BTreeMap::new()))
                    .with_context(|| write_context(&self.path))?;
                self.json_channels.insert(topic.to_owned(), c);
                self.declare(ChannelInfo {
                    id: c,
                    topic: topic.to_owned(),
                    schema_name: schema_name.to_owned(),
                    schema_encoding: "jsonschema",
                    schema: data,
                    message_encoding: "json",
                })?;
                c
            }
        };
        encode(&mut self.json, msg)?;
        self.write_buffer(channel, time_ns(time_secs))
    }

    /// Logs a Foxglove message (Protobuf) on `topic`, whose channel is created on first use.
    pub fn log_foxglove<T: foxglove::Encode + prost::Message>(
        &mut self,
        topic: &str,
        time_secs: f64,
        msg: &T,
    ) -> Result<()> {
        let channel = match self.json_channels.get(topic) {
            Some(&c) => c,
            None => {
                let schema = foxglove_schema::<T>()?;
                let writer = self.writer.as_mut().context("the MCAP log is finished")?;
                let c = writer
                    .add_schema(&schema.name, &schema.encoding, &schema.data)
                    .and_then(|id| writer.add_channel(id, topic, "protobuf", &BTreeMap::new()))
                    .with_context(|| write_context(&self.path))?;
                self.json_channels.insert(topic.to_owned(), c);
                self.declare(ChannelInfo {
                    id: c,
                    topic: topic.to_owned(),
                    schema_name: schema.name,
                    schema_encoding: "protobuf",
                    schema: schema.data.into_owned(),
                    message_encoding: "protobuf",
                })?;
                c
            }
        };
        encode_proto(&mut self.json, msg)?;
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

/// Serialises `msg` into the cleared buffer.
/// One message of a pbd log as JSON, whatever its encoding: pbd's own (`json`) as written, and
/// Foxglove's (`protobuf`, by schema name) decoded with the `foxglove` crate's types and shown with
/// that crate's field names (Foxglove's, lower-cased: a calibration's `K` is `k`; bytes as base64,
/// enums by name) — what the tests read, and what a script can print.
pub fn message_json(schema_name: &str, message_encoding: &str, data: &[u8]) -> Result<serde_json::Value> {
    fn decode<T: prost::Message + Default + Serialize>(data: &[u8]) -> Result<serde_json::Value> {
        Ok(serde_json::to_value(T::decode(data)?)?)
    }
    match message_encoding {
        "json" => Ok(serde_json::from_slice(data)?),
        "protobuf" => match schema_name {
            "foxglove.FrameTransforms" => decode::<fm::FrameTransforms>(data),
            "foxglove.SceneUpdate" => decode::<fm::SceneUpdate>(data),
            "foxglove.Log" => decode::<fm::Log>(data),
            "foxglove.CompressedImage" => decode::<fm::CompressedImage>(data),
            "foxglove.RawImage" => decode::<fm::RawImage>(data),
            "foxglove.CameraCalibration" => decode::<fm::CameraCalibration>(data),
            other => anyhow::bail!("Protobuf schema `{other}` is not one pbd writes"),
        },
        other => anyhow::bail!("message encoding `{other}` is not one pbd writes"),
    }
}

/// Encodes a Protobuf message into `buf` (cleared first).
fn encode_proto<M: prost::Message>(buf: &mut Vec<u8>, msg: &M) -> Result<()> {
    buf.clear();
    msg.encode(buf).context("Protobuf encoding")
}

fn encode<T: Serialize>(buf: &mut Vec<u8>, msg: &T) -> Result<()> {
    buf.clear();
    serde_json::to_writer(&mut *buf, msg).context("cannot serialise a log message")
}

// ---------------------------------------------------------------------------------------------
// Reading

/// What an MCAP file holds, from reading it start to end (see [`read_summary`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Summary {
    /// File size (bytes).
    pub file_bytes: u64,
    /// Whether the file ended properly.
    pub status: FileStatus,
    /// Every channel seen, by topic.
    pub channels: Vec<ChannelSummary>,
    /// Messages read, all channels.
    pub message_count: u64,
    /// Log times of the first and last message (ns), if any.
    pub time_range_ns: Option<(u64, u64)>,
    /// Attachment names, in file order.
    pub attachments: Vec<String>,
    /// Metadata record names, in file order.
    pub metadata: Vec<String>,
    /// Disagreements between what was read and the file's own records: chunk headers whose times are
    /// not those of their messages, chunk indexes and a statistics record that disagree with them.
    pub issues: Vec<String>,
    /// Damaged chunks that were skipped (their CRC or compression failed); everything else was read.
    pub skipped_chunks: Vec<String>,
}

impl Summary {
    /// The channel on `topic`.
    pub fn channel(&self, topic: &str) -> Option<&ChannelSummary> {
        self.channels.iter().find(|c| c.topic == topic)
    }

    /// Messages on `topic` (0 if there is no such channel).
    pub fn count(&self, topic: &str) -> u64 {
        self.channel(topic).map_or(0, |c| c.message_count)
    }

    /// Time from the first to the last message (s).
    pub fn duration_secs(&self) -> f64 {
        self.time_range_ns.map_or(0.0, |(a, b)| (b - a) as f64 * 1e-9)
    }
}

/// How an MCAP file ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FileStatus {
    /// Read to the end magic without error: the writer finished it.
    Complete,
    /// Cut short or damaged (the writer crashed, or the disk filled): everything before the first
    /// bad record was read, and `messages` messages were recovered.
    Recovered {
        /// Messages recovered.
        messages: u64,
        /// What stopped the reader.
        reason: String,
    },
    /// Not one well-formed recording: its first record is not a header, or bytes follow its end
    /// magic (two recordings concatenated, data appended). Everything up to the end magic was read;
    /// [`read_recording`] refuses such a file, [`read_summary`] reports it.
    Malformed {
        /// What is wrong, with the byte offset.
        reason: String,
    },
}

/// One channel of a [`Summary`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelSummary {
    /// Topic.
    pub topic: String,
    /// Schema name (`foxglove.FrameTransforms`, …), empty if none.
    pub schema_name: String,
    /// Message encoding (`json`).
    pub message_encoding: String,
    /// Messages read.
    pub message_count: u64,
    /// Log times of its first and last message (ns), if any.
    pub time_range_ns: Option<(u64, u64)>,
}

/// Largest record the reader accepts (a corrupt length must not allocate gigabytes).
const READ_RECORD_LIMIT: usize = 1 << 30;

/// Reads the MCAP file at `path` start to end, validating chunk CRCs, and counts messages per
/// channel. A file that was cut short (a crashed writer) is not an error: its readable part is
/// summarised and [`Summary::status`] says [`FileStatus::Recovered`]. Errors are for files that
/// cannot be opened or read, or are not MCAP at all.
pub fn read_summary(path: impl AsRef<Path>) -> Result<Summary> {
    summarise(Source::File(path.as_ref()))
}

/// [`read_summary`] of an MCAP file held in memory (`bytes` is the whole file); errors name it
/// `<memory>`. For fuzzing and for callers that already hold the bytes.
pub fn read_summary_bytes(bytes: &[u8]) -> Result<Summary> {
    summarise(Source::Bytes(bytes))
}

/// Where [`scan`] reads an MCAP file from.
#[derive(Debug, Clone, Copy)]
enum Source<'a> {
    File(&'a Path),
    Bytes(&'a [u8]),
}

impl Source<'_> {
    /// The name errors give the input.
    fn name(&self) -> String {
        match self {
            Source::File(path) => path.display().to_string(),
            Source::Bytes(_) => "<memory>".to_owned(),
        }
    }
}

fn summarise(source: Source<'_>) -> Result<Summary> {
    let mut schemas: HashMap<u16, String> = HashMap::new();
    // channel id -> index into `channels`
    let mut channel_index: HashMap<u16, usize> = HashMap::new();
    let mut channels: Vec<ChannelSummary> = Vec::new();
    let mut summary = Summary {
        file_bytes: 0,
        status: FileStatus::Complete,
        channels: Vec::new(),
        message_count: 0,
        time_range_ns: None,
        attachments: Vec::new(),
        metadata: Vec::new(),
        issues: Vec::new(),
        skipped_chunks: Vec::new(),
    };
    let mut stats = None;
    let scanned = scan(source, &mut |record| match record {
        Record::Schema { header, .. } => {
            schemas.insert(header.id, header.name);
        }
        Record::Channel(c) => {
            let schema_name = schemas.get(&c.schema_id).cloned().unwrap_or_default();
            // Channels are repeated in the summary section.
            if let std::collections::hash_map::Entry::Vacant(e) = channel_index.entry(c.id) {
                e.insert(channels.len());
                channels.push(ChannelSummary {
                    topic: c.topic,
                    schema_name,
                    message_encoding: c.message_encoding,
                    message_count: 0,
                    time_range_ns: None,
                });
            }
        }
        Record::Message { header, .. } => {
            let i = *channel_index.entry(header.channel_id).or_insert_with(|| {
                channels.push(ChannelSummary {
                    topic: format!("<unknown channel {}>", header.channel_id),
                    schema_name: String::new(),
                    message_encoding: String::new(),
                    message_count: 0,
                    time_range_ns: None,
                });
                channels.len() - 1
            });
            let t = header.log_time;
            let c = &mut channels[i];
            c.message_count += 1;
            c.time_range_ns = Some(c.time_range_ns.map_or((t, t), |(a, b)| (a.min(t), b.max(t))));
            summary.message_count += 1;
            summary.time_range_ns = Some(summary.time_range_ns.map_or((t, t), |(a, b)| (a.min(t), b.max(t))));
        }
        Record::Attachment { header, .. } => summary.attachments.push(header.name),
        Record::Metadata(m) => summary.metadata.push(m.name),
        Record::Statistics(s) => stats = Some(s),
        _ => {}
    })?;
    summary.file_bytes = scanned.file_bytes;
    summary.skipped_chunks = scanned.skipped;
    summary.issues = scanned.issues;
    summary.status = match scanned.status {
        FileStatus::Recovered { reason, .. } => FileStatus::Recovered {
            messages: summary.message_count,
            reason,
        },
        s => s,
    };
    if let Some(stats) = stats
        && summary.skipped_chunks.is_empty()
    {
        if stats.message_count != summary.message_count {
            summary.issues.push(format!(
                "the statistics record counts {} messages, {} were read",
                stats.message_count, summary.message_count
            ));
        }
        for (id, &count) in &stats.channel_message_counts {
            let read = channel_index.get(id).map_or(0, |&i| channels[i].message_count);
            if read != count {
                let topic = channel_index.get(id).map_or("?", |&i| channels[i].topic.as_str());
                summary
                    .issues
                    .push(format!("channel {id} ({topic}): statistics count {count}, {read} read"));
            }
        }
    }
    channels.sort_by(|a, b| a.topic.cmp(&b.topic));
    summary.channels = channels;
    Ok(summary)
}

/// What [`scan`] found besides the records it handed on.
#[derive(Debug)]
struct Scanned {
    /// File size (bytes).
    file_bytes: u64,
    /// How the file ended (`Recovered` carries 0 messages; callers count their own).
    status: FileStatus,
    /// Damaged chunks, skipped.
    skipped: Vec<String>,
    /// Disagreements between chunk headers, the messages inside the chunks, the chunk indexes and
    /// the statistics record (a seeking reader trusts these and would miss or misplace messages).
    issues: Vec<String>,
}

/// Reads every record of the MCAP file at `path` in file order and hands each to `visit`. Chunks are
/// checked one by one (decompression and CRC): a damaged chunk is skipped and described in
/// [`Scanned::skipped`], and reading goes on with the next one. A file whose first record is not a
/// header, or with bytes after its end magic (two recordings concatenated), is
/// [`FileStatus::Malformed`]. Errors: the file cannot be read, or not one record could be parsed
/// (not MCAP).
fn scan(source: Source<'_>, visit: &mut dyn FnMut(Record<'_>)) -> Result<Scanned> {
    match source {
        Source::File(path) => {
            let context = || format!("cannot read MCAP log {}", path.display());
            let mut file = bayes::input::open_input(path).with_context(context)?;
            let file_bytes = file.metadata().with_context(context)?.len();
            scan_from(&mut file, file_bytes, &source.name(), visit)
        }
        Source::Bytes(bytes) => scan_from(
            &mut std::io::Cursor::new(bytes),
            bytes.len() as u64,
            &source.name(),
            visit,
        ),
    }
}

/// A log time (ns) as seconds, exactly.
fn secs(ns: u64) -> String {
    format!("{}.{:09} s", ns / 1_000_000_000, ns % 1_000_000_000)
}

/// A chunk as read: where it starts, the times its header declares, and the log times of the
/// messages found inside (`None`: no messages, or the chunk was damaged).
struct ChunkSeen {
    number: usize,
    declared: (u64, u64),
    actual: Option<(u64, u64)>,
    damaged: bool,
}

fn scan_from<R: Read + std::io::Seek>(
    file: &mut R,
    file_bytes: u64,
    name: &str,
    visit: &mut dyn FnMut(Record<'_>),
) -> Result<Scanned> {
    let context = || format!("cannot read MCAP log {name}");
    // Chunks are handed to us whole, so that one bad chunk costs its own messages only; the data
    // section CRC would fail for any bad chunk, so the chunks' own CRCs are the check.
    let options = LinearReaderOptions::default()
        .with_emit_chunks(true)
        .with_validate_data_section_crc(false)
        .with_validate_summary_section_crc(true)
        // No record is longer than the file: a corrupt length fails here, before a buffer is grown.
        .with_record_length_limit(READ_RECORD_LIMIT.min(usize::try_from(file_bytes).unwrap_or(usize::MAX)));
    let mut reader = LinearReader::new_with_options(options);
    let mut records_read = 0_u64;
    // Bytes handed to the reader so far. It asks for exactly the bytes it needs next, so this is
    // the offset just past the record it yields (and past the end magic once it is done).
    let mut position = 0_u64;
    // The opcode of the first record, right after the 8-byte magic.
    let mut first_opcode = None;
    let mut chunks: BTreeMap<u64, ChunkSeen> = BTreeMap::new();
    let mut chunk_indexes = Vec::new();
    let mut stats = None;
    // Log times of the messages outside chunks.
    let mut loose: Option<(u64, u64)> = None;
    let mut skipped = Vec::new();
    let mut stop = None;
    while let Some(event) = reader.next_event() {
        let (record, offset) = match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let buf = reader.insert(need);
                let n = file.read(buf).with_context(context)?;
                if position <= 8 && position + n as u64 > 8 {
                    first_opcode = Some(buf[(8 - position) as usize]);
                }
                position += n as u64;
                reader.notify_read(n);
                continue;
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                // The opcode (1) and length (8) come before the body.
                let offset = position.saturating_sub(9 + data.len() as u64);
                (parse_record(opcode, data), offset)
            }
            Err(e) => (Err(e), position),
        };
        match record {
            Ok(Record::Chunk { header, data }) => {
                records_read += 1;
                let number = chunks.len() + 1;
                let mut seen = ChunkSeen {
                    number,
                    declared: (header.message_start_time, header.message_end_time),
                    actual: None,
                    damaged: false,
                };
                match visit_chunk(&header, &data, visit) {
                    Ok(times) => seen.actual = times,
                    Err(why) => {
                        seen.damaged = true;
                        skipped.push(format!(
                            "chunk {number} at offset {offset} (messages logged {:.3}–{:.3} s): {why}; skipped",
                            header.message_start_time as f64 * 1e-9,
                            header.message_end_time as f64 * 1e-9
                        ));
                    }
                }
                chunks.insert(offset, seen);
            }
            Ok(record) => {
                records_read += 1;
                match &record {
                    Record::Message { header, .. } => loose = Some(widen(loose, header.log_time)),
                    Record::ChunkIndex(i) => chunk_indexes.push(i.clone()),
                    Record::Statistics(s) => stats = Some(s.clone()),
                    _ => {}
                }
                visit(record);
            }
            Err(e) => {
                stop = Some(e);
                break;
            }
        }
    }
    let not_a_header = first_opcode
        .filter(|&op| op != mcap::records::op::HEADER)
        .map(|op| format!("the first record, at offset 8, has opcode {op:#04x} where a header record (0x01) must be"));
    if records_read == 0
        && let Some(e) = &stop
    {
        let why = match &not_a_header {
            Some(header) => format!("{header} ({})", describe(e)),
            None => describe(e),
        };
        return Err(anyhow::anyhow!("{why}")).with_context(|| format!("{name} is not an MCAP file"));
    }
    // A complete file ends with the magic right after its footer: bytes after it are not part of
    // the recording (an append, a second recording) and make the file malformed; they are never read.
    let mut malformed: Vec<String> = not_a_header.into_iter().collect();
    if stop.is_none() && position < file_bytes {
        use std::io::SeekFrom;
        let mut next = [0u8; 8];
        file.seek(SeekFrom::Start(position)).with_context(context)?;
        let n = file.read(&mut next).with_context(context)?;
        let guess = if next[..n] == mcap::MAGIC[..] {
            "two recordings concatenated?"
        } else {
            "data appended by another tool?"
        };
        malformed.push(format!(
            "{} bytes after the end of the recording at offset {position} (after the footer and its end magic): {guess}",
            file_bytes - position
        ));
    }
    let issues = chunk_time_issues(&chunks, &chunk_indexes, stats.as_ref(), loose);
    let truncated = stop.map(|e| match e {
        // Also reported at a record boundary: the reader wants a footer.
        mcap::McapError::UnexpectedEof => "the file ends before its footer (the writer did not finish)".to_owned(),
        // The length limit is the file size: the last record was cut short.
        mcap::McapError::RecordTooLarge { len, .. } if len > file_bytes => {
            format!("the file ends before its footer (a record of {len} bytes runs past its end)")
        }
        e => describe(&e),
    });
    let status = match (malformed.is_empty(), truncated) {
        (true, None) => FileStatus::Complete,
        (true, Some(reason)) => FileStatus::Recovered { messages: 0, reason },
        (false, truncated) => FileStatus::Malformed {
            reason: malformed.into_iter().chain(truncated).collect::<Vec<_>>().join("; "),
        },
    };
    Ok(Scanned {
        file_bytes,
        status,
        skipped,
        issues,
    })
}

/// Chunk times that disagree: a chunk header's [start, end] with the log times of the messages
/// inside it, a chunk index with the chunk it points at, the statistics record with the messages
/// of the file (`loose`: those outside chunks). Damaged chunks are not judged.
fn chunk_time_issues(
    chunks: &BTreeMap<u64, ChunkSeen>,
    indexes: &[mcap::records::ChunkIndex],
    stats: Option<&mcap::records::Statistics>,
    loose: Option<(u64, u64)>,
) -> Vec<String> {
    let mut issues = Vec::new();
    for (offset, c) in chunks {
        if let Some((first, last)) = c.actual
            && c.declared != (first, last)
        {
            issues.push(format!(
                "chunk {} at offset {offset} declares messages logged {}–{}, its messages are logged {}–{}",
                c.number,
                secs(c.declared.0),
                secs(c.declared.1),
                secs(first),
                secs(last)
            ));
        }
    }
    for (i, index) in indexes.iter().enumerate() {
        let offset = index.chunk_start_offset;
        match chunks.get(&offset) {
            None => issues.push(format!(
                "chunk index {} points at offset {offset}, where no chunk begins",
                i + 1
            )),
            Some(c) if !c.damaged && (index.message_start_time, index.message_end_time) != c.declared => {
                issues.push(format!(
                    "chunk index {} says chunk {} at offset {offset} holds messages logged {}–{}, its header says {}–{}",
                    i + 1,
                    c.number,
                    secs(index.message_start_time),
                    secs(index.message_end_time),
                    secs(c.declared.0),
                    secs(c.declared.1)
                ));
            }
            Some(_) => {}
        }
    }
    if !indexes.is_empty() && indexes.len() != chunks.len() {
        issues.push(format!(
            "the summary indexes {} chunks, the file holds {}",
            indexes.len(),
            chunks.len()
        ));
    }
    if let Some(stats) = stats
        && chunks.values().all(|c| !c.damaged)
    {
        if stats.chunk_count as usize != chunks.len() {
            issues.push(format!(
                "the statistics record counts {} chunks, the file holds {}",
                stats.chunk_count,
                chunks.len()
            ));
        }
        let actual = chunks
            .values()
            .filter_map(|c| c.actual)
            .chain(loose)
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
        if let Some((first, last)) = actual
            && (stats.message_start_time, stats.message_end_time) != (first, last)
        {
            issues.push(format!(
                "the statistics record says messages are logged {}–{}, the file holds messages logged {}–{}",
                secs(stats.message_start_time),
                secs(stats.message_end_time),
                secs(first),
                secs(last)
            ));
        }
    }
    issues
}

/// `mcap::parse_record` after [`check_lengths`]: the crate reserves a string's or a byte array's
/// declared length before reading it, so a corrupt 4-byte length once asked for 4 GB.
fn parse_record(opcode: u8, body: &[u8]) -> std::result::Result<Record<'_>, mcap::McapError> {
    check_lengths(opcode, body)
        .map_err(|why| mcap::McapError::Io(std::io::Error::new(std::io::ErrorKind::InvalidData, why)))?;
    mcap::parse_record(opcode, body)
}

/// An MCAP error as a reason: our own length errors (an `Io` of kind `InvalidData`) with their text.
fn describe(e: &mcap::McapError) -> String {
    match e {
        mcap::McapError::Io(io) if io.kind() == std::io::ErrorKind::InvalidData => io.to_string(),
        e => e.to_string(),
    }
}

/// Checks that every length prefix in a record body (strings, byte arrays, maps, and the strings
/// inside string maps) fits in the body, following the record layouts of the MCAP specification.
/// Unknown opcodes are not checked (the crate keeps their bodies as they are).
fn check_lengths(opcode: u8, body: &[u8]) -> std::result::Result<(), String> {
    #[derive(Clone, Copy)]
    enum F {
        /// A fixed-size integer of this many bytes.
        Int(usize),
        /// A string or byte array with a u32 length.
        Bytes32,
        /// A byte array with a u64 length.
        Bytes64,
        /// A map or array with a u32 byte length, of fixed-size entries.
        Table,
        /// A map<string, string> with a u32 byte length.
        StringMap,
    }
    use F::*;
    let (record, fields): (&str, &[(&str, F)]) = match opcode {
        0x01 => ("header", &[("profile", Bytes32), ("library", Bytes32)]),
        0x03 => (
            "schema",
            &[
                ("id", Int(2)),
                ("name", Bytes32),
                ("encoding", Bytes32),
                ("data", Bytes32),
            ],
        ),
        0x04 => (
            "channel",
            &[
                ("id", Int(2)),
                ("schema_id", Int(2)),
                ("topic", Bytes32),
                ("message_encoding", Bytes32),
                ("metadata", StringMap),
            ],
        ),
        0x06 => (
            "chunk",
            &[
                ("message_start_time", Int(8)),
                ("message_end_time", Int(8)),
                ("uncompressed_size", Int(8)),
                ("uncompressed_crc", Int(4)),
                ("compression", Bytes32),
                ("records", Bytes64),
            ],
        ),
        0x07 => ("message index", &[("channel_id", Int(2)), ("records", Table)]),
        0x08 => (
            "chunk index",
            &[
                ("times", Int(16)),
                ("chunk_start_offset", Int(8)),
                ("chunk_length", Int(8)),
                ("message_index_offsets", Table),
                ("message_index_length", Int(8)),
                ("compression", Bytes32),
                ("sizes", Int(16)),
            ],
        ),
        0x09 => (
            "attachment",
            &[
                ("times", Int(16)),
                ("name", Bytes32),
                ("media_type", Bytes32),
                ("data", Bytes64),
                ("crc", Int(4)),
            ],
        ),
        0x0A => (
            "attachment index",
            &[
                ("offsets and times", Int(40)),
                ("name", Bytes32),
                ("media_type", Bytes32),
            ],
        ),
        0x0B => (
            "statistics",
            &[
                ("counts", Int(26)),
                ("times", Int(16)),
                ("channel_message_counts", Table),
            ],
        ),
        0x0C => ("metadata", &[("name", Bytes32), ("metadata", StringMap)]),
        0x0D => ("metadata index", &[("offset and length", Int(16)), ("name", Bytes32)]),
        _ => return Ok(()),
    };
    let mut rest = body;
    let take = |rest: &mut &[u8], n: u64, field: &str| -> std::result::Result<(), String> {
        match usize::try_from(n).ok().filter(|&n| n <= rest.len()) {
            Some(n) => {
                *rest = &rest[n..];
                Ok(())
            }
            None => Err(format!(
                "{record} record: field `{field}` claims {n} bytes, {} are left in the record",
                rest.len()
            )),
        }
    };
    let read_len = |rest: &mut &[u8], width: usize, field: &str| -> std::result::Result<u64, String> {
        if rest.len() < width {
            return Err(format!("{record} record: field `{field}` is cut short"));
        }
        let mut b = [0u8; 8];
        b[..width].copy_from_slice(&rest[..width]);
        *rest = &rest[width..];
        Ok(u64::from_le_bytes(b))
    };
    for &(field, kind) in fields {
        match kind {
            Int(n) => take(&mut rest, n as u64, field)?,
            Bytes32 | Table => {
                let n = read_len(&mut rest, 4, field)?;
                take(&mut rest, n, field)?;
            }
            Bytes64 => {
                let n = read_len(&mut rest, 8, field)?;
                take(&mut rest, n, field)?;
            }
            StringMap => {
                let n = read_len(&mut rest, 4, field)?;
                let mut map = rest;
                take(&mut map, n, field)?;
                let mut entries = &rest[..rest.len() - map.len()];
                rest = map;
                while !entries.is_empty() {
                    for part in ["key", "value"] {
                        let n = read_len(&mut entries, 4, &format!("{field} {part}"))?;
                        take(&mut entries, n, &format!("{field} {part}"))?;
                    }
                }
            }
        }
    }
    Ok(())
}

/// Decompresses one chunk, checks its CRC and hands its records to `visit`; nothing is visited when
/// the chunk is damaged. Returns the log times of the first and last message inside (`None`: none).
fn visit_chunk(
    header: &mcap::records::ChunkHeader,
    data: &[u8],
    visit: &mut dyn FnMut(Record<'_>),
) -> std::result::Result<Option<(u64, u64)>, String> {
    let size = usize::try_from(header.uncompressed_size)
        .ok()
        .filter(|&n| n <= READ_RECORD_LIMIT)
        .ok_or_else(|| format!("uncompressed size {} is too large", header.uncompressed_size))?;
    let owned;
    let bytes: &[u8] = match header.compression.as_str() {
        "" => data,
        "zstd" => {
            owned = zstd::bulk::decompress(data, size).map_err(|e| format!("zstd: {e}"))?;
            &owned
        }
        "lz4" => {
            let mut out = Vec::with_capacity(size);
            lz4::Decoder::new(data)
                .and_then(|mut d| std::io::copy(&mut d, &mut out))
                .map_err(|e| format!("lz4: {e}"))?;
            owned = out;
            &owned
        }
        other => return Err(format!("unknown compression `{other}`")),
    };
    if bytes.len() != size {
        return Err(format!(
            "{} bytes after decompression, the header says {size}",
            bytes.len()
        ));
    }
    if header.uncompressed_crc != 0 {
        let crc = crc32fast::hash(bytes);
        if crc != header.uncompressed_crc {
            return Err(format!(
                "CRC {crc:#010x} does not match the header's {:#010x}",
                header.uncompressed_crc
            ));
        }
    }
    // Parse everything first: a chunk whose records do not parse is skipped whole.
    let mut records = Vec::new();
    let mut rest = bytes;
    while !rest.is_empty() {
        if rest.len() < 9 {
            return Err("a record header is cut short".into());
        }
        let opcode = rest[0];
        let mut len_bytes = [0u8; 8];
        len_bytes.copy_from_slice(&rest[1..9]);
        let len = usize::try_from(u64::from_le_bytes(len_bytes)).unwrap_or(usize::MAX);
        let body = rest
            .get(9..9usize.saturating_add(len))
            .ok_or_else(|| "a record runs past the chunk's end".to_string())?;
        records.push(parse_record(opcode, body).map_err(|e| describe(&e))?);
        rest = &rest[9 + len..];
    }
    let mut times = None;
    for r in records {
        if let Record::Message { header, .. } = &r {
            times = Some(widen(times, header.log_time));
        }
        visit(r);
    }
    Ok(times)
}

/// `range` widened to hold `t`.
fn widen(range: Option<(u64, u64)>, t: u64) -> (u64, u64) {
    range.map_or((t, t), |(a, b)| (a.min(t), b.max(t)))
}

/// Rewrites every readable record of `path` (schemas, channels, messages, attachments, metadata) into
/// a new, complete MCAP file at `out`; returns the number of messages written. For a file cut short.
pub fn repair(path: impl AsRef<Path>, out: impl AsRef<Path>) -> Result<u64> {
    let (path, out) = (path.as_ref(), out.as_ref());
    ensure!(path != out, "--repair must name a new file, not {}", path.display());
    crate::files::refuse_inputs_as_outputs(&[path], &[out])?;
    // Written beside the target and renamed at the end: never a half-written repair.
    let tmp = crate::files::temporary_beside(out)?;
    let file = File::create(&tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
    let mut writer = Writer::with_options(
        BufWriter::new(file),
        WriteOptions::new().compression(Some(Compression::Zstd)).profile(""),
    )?;
    let mut schema_ids: HashMap<u16, u16> = HashMap::new();
    let mut channel_ids: HashMap<u16, u16> = HashMap::new();
    let mut count = 0u64;
    let mut failure: Option<anyhow::Error> = None;
    let scanned = scan(Source::File(path), &mut |record| {
        if failure.is_some() {
            return;
        }
        let r: Result<()> = (|| {
            match record {
                Record::Schema { header, data } => {
                    if let std::collections::hash_map::Entry::Vacant(e) = schema_ids.entry(header.id) {
                        e.insert(writer.add_schema(&header.name, &header.encoding, &data)?);
                    }
                }
                Record::Channel(c) => {
                    if let std::collections::hash_map::Entry::Vacant(e) = channel_ids.entry(c.id) {
                        let schema = schema_ids.get(&c.schema_id).copied().unwrap_or(0);
                        e.insert(writer.add_channel(schema, &c.topic, &c.message_encoding, &c.metadata)?);
                    }
                }
                Record::Message { header, data } => {
                    if let Some(&channel_id) = channel_ids.get(&header.channel_id) {
                        writer.write_to_known_channel(&MessageHeader { channel_id, ..header }, &data)?;
                        count += 1;
                    }
                }
                Record::Attachment { header, data, .. } => {
                    writer.attach(&Attachment {
                        log_time: header.log_time,
                        create_time: header.create_time,
                        name: header.name,
                        media_type: header.media_type,
                        data,
                    })?;
                }
                Record::Metadata(m) => writer.write_metadata(&m)?,
                _ => {}
            }
            Ok(())
        })();
        if let Err(e) = r {
            failure = Some(e);
        }
    });
    let finished = match (scanned, failure) {
        (Err(e), _) => Err(e),
        (Ok(_), Some(e)) => Err(e.context(format!("cannot write {}", out.display()))),
        (Ok(_), None) => writer
            .finish()
            .map(|_| ())
            .with_context(|| format!("cannot write {}", out.display())),
    };
    if let Err(e) = finished {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    std::fs::rename(&tmp, out).with_context(|| format!("cannot write {}", out.display()))?;
    Ok(count)
}

/// Messages of some topics read back from a log, with its metadata and attachments.
#[derive(Debug, Clone, Default)]
pub struct Recording {
    /// (topic, log time ns, payload) in file order: JSON on pbd's own topics, Protobuf on
    /// Foxglove's (JSON in recordings before 2026-11-29; [`message_json`] reads either).
    pub messages: Vec<(String, u64, Vec<u8>)>,
    /// Metadata records by name.
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    /// Attachments by name.
    pub attachments: BTreeMap<String, Vec<u8>>,
    /// How the file ended.
    pub status: Option<FileStatus>,
    /// Damaged chunks that were skipped (see [`Summary::skipped_chunks`]).
    pub skipped_chunks: Vec<String>,
    /// Channels on a wanted topic that were skipped because pbd did not write them: neither JSON
    /// with a JSON Schema nor Protobuf with a `foxglove.*` schema (ROS 2 messages…).
    pub foreign_channels: Vec<String>,
}

impl Recording {
    /// Payloads on `topic`, with their log times (ns).
    pub fn topic<'a>(&'a self, topic: &'a str) -> impl Iterator<Item = (u64, &'a [u8])> + 'a {
        self.messages
            .iter()
            .filter(move |(t, _, _)| t == topic)
            .map(|(_, time, data)| (*time, data.as_slice()))
    }
}

/// Reads the messages on `topics` (all topics if empty), the metadata and the attachments of the
/// MCAP file at `path`. A file cut short keeps everything up to its last complete chunk;
/// [`Recording::status`] says so.
pub fn read_recording(path: impl AsRef<Path>, topics: &[&str]) -> Result<Recording> {
    record_of(Source::File(path.as_ref()), topics)
}

/// [`read_recording`] of an MCAP file held in memory (`bytes` is the whole file); errors name it
/// `<memory>`.
pub fn read_recording_bytes(bytes: &[u8], topics: &[&str]) -> Result<Recording> {
    record_of(Source::Bytes(bytes), topics)
}

fn record_of(source: Source<'_>, topics: &[&str]) -> Result<Recording> {
    let mut wanted: HashMap<u16, String> = HashMap::new();
    let mut schemas: HashMap<u16, (String, String)> = HashMap::new();
    let mut rec = Recording::default();
    let scanned = scan(source, &mut |record| match record {
        Record::Schema { header, .. } => {
            schemas.insert(header.id, (header.name, header.encoding));
        }
        Record::Channel(c) if topics.is_empty() || topics.contains(&c.topic.as_str()) => {
            // pbd's own messages are JSON with a JSON Schema (or none), Foxglove's well-known ones
            // Protobuf (JSON before 2026-11-29): both are read (decode with [`message_json`]);
            // anything else is not ours.
            let schema = schemas.get(&c.schema_id);
            let foreign_schema = c.schema_id != 0 && schema.is_none_or(|(_, enc)| enc != "jsonschema");
            let foxglove_proto =
                c.message_encoding == "protobuf" && schema.is_some_and(|(name, _)| name.starts_with("foxglove."));
            if (c.message_encoding == "json" && !foreign_schema) || foxglove_proto {
                wanted.insert(c.id, c.topic);
            } else {
                let what = match schema {
                    Some((name, enc)) => format!("schema `{name}` ({enc})"),
                    None if c.schema_id != 0 => format!("unknown schema id {}", c.schema_id),
                    None => "no schema".into(),
                };
                let note = format!(
                    "channel {} on {} has message encoding `{}` and {what}; pbd reads the JSON and Foxglove Protobuf channels it writes — skipped",
                    c.id, c.topic, c.message_encoding
                );
                if !rec.foreign_channels.contains(&note) {
                    rec.foreign_channels.push(note);
                }
            }
        }
        Record::Message { header, data } => {
            if let Some(topic) = wanted.get(&header.channel_id) {
                rec.messages.push((topic.clone(), header.log_time, data.into_owned()));
            }
        }
        Record::Metadata(m) => {
            rec.metadata.insert(m.name, m.metadata);
        }
        Record::Attachment { header, data, .. } => {
            rec.attachments.insert(header.name, data.into_owned());
        }
        _ => {}
    })?;
    if let FileStatus::Malformed { reason } = &scanned.status {
        anyhow::bail!("{}: {reason}; `pbd doctor` says more", source.name());
    }
    let count = rec.messages.len() as u64;
    rec.skipped_chunks = scanned.skipped;
    rec.status = Some(match scanned.status {
        FileStatus::Recovered { reason, .. } => FileStatus::Recovered {
            messages: count,
            reason,
        },
        s => s,
    });
    Ok(rec)
}

#[cfg(test)]
mod tests;

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

/// Serialises `msg` as JSON into the cleared buffer.
/// Encodes a Protobuf message into `buf` (cleared first).
pub(crate) fn encode_proto<M: prost::Message>(buf: &mut Vec<u8>, msg: &M) -> Result<()> {
    buf.clear();
    msg.encode(buf).context("Protobuf encoding")
}

pub(crate) fn encode<T: Serialize>(buf: &mut Vec<u8>, msg: &T) -> Result<()> {
    buf.clear();
    serde_json::to_writer(&mut *buf, msg).context("cannot serialise a log message")
}

//! The JSON messages of a pbd log, as borrowed serde structs serialised straight into a reused buffer.
//!
//! Field names are the Foxglove ones (see `schemas.rs`); nothing here allocates per message except
//! the scene update, which is written rarely.

use control_basis::math::Iso3;
use dexter_sim::snapshot::{FingertipWrench, ObjectState, SnapshotHeader};
use serde::Serialize;
use serde::ser::{SerializeSeq, SerializeStruct, Serializer};

/// The fixed frame everything hangs from.
pub(super) const WORLD_FRAME: &str = "world";

/// Prefix of an object's frame and scene-entity id: `object/<name>`.
pub(super) const OBJECT_PREFIX: &str = "object/";

const NS_PER_SEC: u64 = 1_000_000_000;

/// Simulated time (s) as nanoseconds, the MCAP `log_time`. Negative and NaN times map to 0.
pub(super) fn time_ns(time_secs: f64) -> u64 {
    if time_secs > 0.0 {
        // `as` saturates at u64::MAX (584 years).
        (time_secs * 1e9).round() as u64
    } else {
        0
    }
}

/// Foxglove `time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub(super) struct Time {
    pub sec: u32,
    pub nsec: u32,
}

impl Time {
    pub fn from_ns(ns: u64) -> Self {
        Self {
            sec: u32::try_from(ns / NS_PER_SEC).unwrap_or(u32::MAX),
            nsec: (ns % NS_PER_SEC) as u32,
        }
    }
}

/// Foxglove `duration`; zero means "forever" for an entity lifetime.
#[derive(Debug, Clone, Copy, Serialize)]
pub(super) struct DurationMsg {
    pub sec: i32,
    pub nsec: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub(super) struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

impl From<[f64; 3]> for Vector3 {
    fn from([x, y, z]: [f64; 3]) -> Self {
        Self { x, y, z }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub(super) struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Quaternion {
    const IDENTITY: Self = Self {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    };
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub(super) struct Pose {
    pub position: Vector3,
    pub orientation: Quaternion,
}

impl Pose {
    /// The pose of an isometry.
    pub fn of(iso: &Iso3) -> Self {
        let (position, orientation) = split(iso);
        Self { position, orientation }
    }

    /// A pure translation.
    pub fn at(x: f64, y: f64, z: f64) -> Self {
        Self {
            position: Vector3 { x, y, z },
            orientation: Quaternion::IDENTITY,
        }
    }
}

/// Position and orientation of an isometry.
pub(super) fn split(iso: &Iso3) -> (Vector3, Quaternion) {
    let t = &iso.translation.vector;
    let q = iso.rotation.quaternion();
    (
        Vector3 { x: t.x, y: t.y, z: t.z },
        Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        },
    )
}

/// Foxglove `Color`, components in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub(super) struct Color {
    pub r: f64,
    pub g: f64,
    pub b: f64,
    pub a: f64,
}

impl Color {
    /// From `[h_deg, s, v]` (h in degrees, wrapped; s and v clamped to [0, 1]).
    pub fn from_hsv(hsv: [f64; 3], a: f64) -> Self {
        let [r, g, b] = dexter_sim::vision::color::hsv_to_rgb(hsv);
        Self { r, g, b, a }
    }
}

/// How a link's transform is published.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum ParentFrame {
    /// The link *is* the root frame (`world`): nothing to publish.
    Root,
    /// Published as `world → link` with the link's world pose (a root not called `world`, or a parent
    /// that is not one of the links).
    World,
    /// Published relative to this link (index into the link list).
    Link(usize),
}

/// The frame tree of a [`SnapshotHeader`], resolved once and reused while the header is unchanged,
/// with the transforms published last: a frame is written again only when it moved by more than
/// the tolerance or at a keyframe (every frame, so that a reader who seeks finds them all).
#[derive(Debug, Clone)]
pub(super) struct FrameTree {
    link_names: Vec<String>,
    link_parents: Vec<Option<String>>,
    object_names: Vec<String>,
    parents: Vec<ParentFrame>,
    /// `object/<name>` for each object.
    object_frames: Vec<String>,
    /// Parent-from-child of every link, then world-from-object of every object, this snapshot.
    current: Vec<Iso3>,
    /// What was last published for each frame.
    published: Vec<Option<Iso3>>,
    /// Whether each frame is written this snapshot.
    publish: Vec<bool>,
    /// Log time (ns) of the last keyframe.
    last_keyframe: Option<u64>,
}

/// When a transform is written again.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct TfPolicy {
    /// Every frame is written at least this often (ns of log time); 0 = every snapshot.
    pub keyframe_ns: u64,
    /// A frame that moved more than this (m) is written.
    pub tolerance_m: f64,
    /// … or turned more than this (rad).
    pub tolerance_rad: f64,
}

impl FrameTree {
    pub fn new(header: &SnapshotHeader) -> Self {
        let index_of = |name: &str| header.link_names.iter().position(|n| n == name);
        let parents = header
            .link_names
            .iter()
            .zip(&header.link_parents)
            .map(|(name, parent)| match parent {
                None if name == WORLD_FRAME => ParentFrame::Root,
                None => ParentFrame::World,
                Some(p) => index_of(p).map_or(ParentFrame::World, ParentFrame::Link),
            })
            .collect();
        let frames = header.link_names.len() + header.object_names.len();
        Self {
            link_names: header.link_names.clone(),
            link_parents: header.link_parents.clone(),
            object_names: header.object_names.clone(),
            parents,
            object_frames: header.object_names.iter().map(|n| object_frame(n)).collect(),
            current: vec![Iso3::identity(); frames],
            published: vec![None; frames],
            publish: vec![false; frames],
            last_keyframe: None,
        }
    }

    /// Whether this tree was built from an equal header (a few dozen short string compares).
    pub fn matches(&self, header: &SnapshotHeader) -> bool {
        self.link_names == header.link_names
            && self.link_parents == header.link_parents
            && self.object_names == header.object_names
    }

    /// Index of the link called `name`.
    pub fn link(&self, name: &str) -> Option<usize> {
        self.link_names.iter().position(|n| n == name)
    }

    /// Computes this snapshot's transforms and chooses the frames to write (see [`TfPolicy`]);
    /// returns how many. `link_poses` and `objects` are in the tree's order.
    pub fn update(&mut self, log_time: u64, link_poses: &[Iso3], objects: &[ObjectState], policy: &TfPolicy) -> usize {
        let keyframe = match self.last_keyframe {
            None => true,
            Some(t) => log_time < t || log_time - t >= policy.keyframe_ns,
        };
        if keyframe {
            self.last_keyframe = Some(log_time);
        }
        let links = self.link_names.len();
        for (i, parent) in self.parents.iter().enumerate() {
            let world_from_child = &link_poses[i];
            self.current[i] = match *parent {
                ParentFrame::Root | ParentFrame::World => *world_from_child,
                // child_in_parent = world_from_parent⁻¹ · world_from_child
                ParentFrame::Link(p) => link_poses[p].inv_mul(world_from_child),
            };
            self.publish[i] = *parent != ParentFrame::Root;
        }
        for (k, o) in objects.iter().enumerate() {
            self.current[links + k] = o.pose;
            self.publish[links + k] = true;
        }
        let mut n = 0;
        for ((publish, current), published) in self.publish.iter_mut().zip(&self.current).zip(&mut self.published) {
            if !*publish {
                continue;
            }
            let moved = match published {
                None => true,
                Some(last) => {
                    (current.translation.vector - last.translation.vector).norm() > policy.tolerance_m
                        || current.rotation.angle_to(&last.rotation) > policy.tolerance_rad
                }
            };
            *publish = keyframe || moved;
            if *publish {
                *published = Some(*current);
                n += 1;
            }
        }
        n
    }
}

/// `object/<name>`.
pub(super) fn object_frame(name: &str) -> String {
    format!("{OBJECT_PREFIX}{name}")
}

/// One `foxglove.FrameTransform`; translation and quaternion are rounded to 6 decimals.
#[derive(Debug, Serialize)]
pub(super) struct FrameTransform<'a> {
    pub timestamp: Time,
    pub parent_frame_id: &'a str,
    pub child_frame_id: &'a str,
    pub translation: Vector3,
    pub rotation: Quaternion,
}

impl<'a> FrameTransform<'a> {
    fn new(timestamp: Time, parent_frame_id: &'a str, child_frame_id: &'a str, parent_from_child: &Iso3) -> Self {
        let (t, q) = split(parent_from_child);
        // 1 µm and ~2 µrad are far below what the simulator resolves; short numbers halve the
        // file and the compression time (18 → 13 kB of JSON for 65 transforms, 4.2 → 2.3 kB zstd).
        let translation = Vector3 {
            x: round6(t.x),
            y: round6(t.y),
            z: round6(t.z),
        };
        let rotation = Quaternion {
            x: round6(q.x),
            y: round6(q.y),
            z: round6(q.z),
            w: round6(q.w),
        };
        Self {
            timestamp,
            parent_frame_id,
            child_frame_id,
            translation,
            rotation,
        }
    }
}

/// `x` rounded to 6 decimals (non-finite values unchanged).
pub(super) fn round6(x: f64) -> f64 {
    (x * 1e6).round() / 1e6
}

/// `foxglove.FrameTransforms` for the frames [`FrameTree::update`] chose: links (parent → child)
/// and objects (`world → object/<name>`).
#[derive(Debug)]
pub(super) struct FrameTransforms<'a> {
    pub timestamp: Time,
    pub tree: &'a FrameTree,
}

impl Serialize for FrameTransforms<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut s = serializer.serialize_struct("FrameTransforms", 1)?;
        s.serialize_field("transforms", &TransformList(self))?;
        s.end()
    }
}

struct TransformList<'a>(&'a FrameTransforms<'a>);

impl Serialize for TransformList<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let m = self.0;
        let tree = m.tree;
        let links = tree.link_names.len();
        let mut seq = serializer.serialize_seq(None)?;
        for (i, parent) in tree.parents.iter().enumerate() {
            if !tree.publish[i] {
                continue;
            }
            let parent_name = match *parent {
                ParentFrame::Root => continue,
                ParentFrame::World => WORLD_FRAME,
                ParentFrame::Link(p) => tree.link_names[p].as_str(),
            };
            let child = tree.link_names[i].as_str();
            seq.serialize_element(&FrameTransform::new(m.timestamp, parent_name, child, &tree.current[i]))?;
        }
        for (k, frame) in tree.object_frames.iter().enumerate() {
            if tree.publish[links + k] {
                seq.serialize_element(&FrameTransform::new(
                    m.timestamp,
                    WORLD_FRAME,
                    frame,
                    &tree.current[links + k],
                ))?;
            }
        }
        seq.end()
    }
}

/// Serialises a slice of numbers rounded to 6 decimals.
#[derive(Debug)]
pub(super) struct Rounded<'a>(pub &'a [f64]);

impl Serialize for Rounded<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut seq = serializer.serialize_seq(Some(self.0.len()))?;
        for &x in self.0 {
            seq.serialize_element(&round6(x))?;
        }
        seq.end()
    }
}

/// `pbd.JointState`.
#[derive(Debug, Serialize)]
pub(super) struct JointState<'a> {
    pub timestamp: Time,
    pub name: &'a [String],
    pub position: Rounded<'a>,
    pub velocity: Rounded<'a>,
    pub position_ref: Rounded<'a>,
}

/// `pbd.FingertipWrenches`.
#[derive(Debug, Serialize)]
pub(super) struct FingertipWrenches<'a> {
    pub timestamp: Time,
    #[serde(serialize_with = "serialize_fingertips")]
    pub fingertips: &'a [FingertipWrench],
}

fn serialize_fingertips<S: Serializer>(fingertips: &&[FingertipWrench], serializer: S) -> Result<S::Ok, S::Error> {
    #[derive(Serialize)]
    struct Wrench {
        arm: dexter_sim::Arm,
        finger: u8,
        force: Vector3,
        torque: Vector3,
        in_contact: bool,
    }
    let mut seq = serializer.serialize_seq(Some(fingertips.len()))?;
    for f in fingertips.iter() {
        seq.serialize_element(&Wrench {
            arm: f.arm,
            finger: f.finger,
            force: f.force.into(),
            torque: f.torque.into(),
            in_contact: f.in_contact,
        })?;
    }
    seq.end()
}

/// `pbd.Activity`.
#[derive(Debug, Serialize)]
pub(super) struct Activity<'a> {
    pub timestamp: Time,
    pub text: &'a str,
}

/// `foxglove.Log`.
#[derive(Debug, Serialize)]
pub(super) struct Log<'a> {
    pub timestamp: Time,
    pub level: u8,
    pub message: &'a str,
    pub name: &'a str,
    pub file: &'a str,
    pub line: u32,
}

/// `foxglove.RawImage`; `data` is already base64.
#[derive(Debug, Serialize)]
pub(super) struct RawImage<'a> {
    pub timestamp: Time,
    pub frame_id: &'a str,
    pub width: u32,
    pub height: u32,
    pub encoding: &'a str,
    pub step: u32,
    pub data: &'a str,
}

/// `foxglove.CompressedImage`; `data` is already base64.
#[derive(Debug, Serialize)]
pub(super) struct CompressedImage<'a> {
    pub timestamp: Time,
    pub frame_id: &'a str,
    pub data: &'a str,
    pub format: &'a str,
}

/// `foxglove.CameraCalibration` of an undistorted pinhole camera.
#[derive(Debug, Serialize)]
pub(super) struct CameraCalibration<'a> {
    pub timestamp: Time,
    pub frame_id: &'a str,
    pub width: u32,
    pub height: u32,
    pub distortion_model: &'a str,
    #[serde(rename = "D")]
    pub d: [f64; 0],
    #[serde(rename = "K")]
    pub k: [f64; 9],
    #[serde(rename = "R")]
    pub r: [f64; 9],
    #[serde(rename = "P")]
    pub p: [f64; 12],
}

impl<'a> CameraCalibration<'a> {
    /// From the focal lengths and principal point (px).
    pub fn pinhole(timestamp: Time, frame_id: &'a str, width: u32, height: u32, f: [f64; 2], c: [f64; 2]) -> Self {
        let [fx, fy] = f;
        let [cx, cy] = c;
        Self {
            timestamp,
            frame_id,
            width,
            height,
            distortion_model: "plumb_bob",
            d: [],
            k: [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
            r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            p: [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
        }
    }
}

/// `foxglove.SceneUpdate`.
#[derive(Debug, Serialize)]
pub(super) struct SceneUpdate {
    pub deletions: Vec<SceneEntityDeletion>,
    pub entities: Vec<SceneEntity>,
}

impl SceneUpdate {
    /// An update that first deletes every entity of its topic (so that entities gone since the
    /// last update disappear), then draws `entities`.
    pub fn replacing_all(timestamp: Time, entities: Vec<SceneEntity>) -> Self {
        Self {
            deletions: vec![SceneEntityDeletion {
                timestamp,
                kind: 1,
                id: String::new(),
            }],
            entities,
        }
    }
}

/// `foxglove.SceneEntityDeletion`; `type` 0 = matching id, 1 = all.
#[derive(Debug, Serialize)]
pub(super) struct SceneEntityDeletion {
    pub timestamp: Time,
    #[serde(rename = "type")]
    pub kind: u8,
    pub id: String,
}

/// `foxglove.SceneEntity`. Primitive kinds pbd does not draw are written as empty lists (Foxglove
/// requires every list).
#[derive(Debug, Serialize)]
pub(super) struct SceneEntity {
    pub timestamp: Time,
    pub frame_id: String,
    pub id: String,
    pub lifetime: DurationMsg,
    pub frame_locked: bool,
    pub metadata: Vec<KeyValuePair>,
    pub arrows: Vec<ArrowPrimitive>,
    pub cubes: Vec<SizedPrimitive>,
    pub spheres: Vec<SizedPrimitive>,
    pub cylinders: Vec<CylinderPrimitive>,
    pub lines: EmptyList,
    pub triangles: EmptyList,
    pub texts: Vec<TextPrimitive>,
    pub models: EmptyList,
}

impl SceneEntity {
    /// An entity with no primitives that lives until replaced.
    pub fn new(timestamp: Time, frame_id: &str, id: String, frame_locked: bool) -> Self {
        Self {
            timestamp,
            frame_id: frame_id.to_owned(),
            id,
            lifetime: DurationMsg { sec: 0, nsec: 0 },
            frame_locked,
            metadata: Vec::new(),
            arrows: Vec::new(),
            cubes: Vec::new(),
            spheres: Vec::new(),
            cylinders: Vec::new(),
            lines: EmptyList,
            triangles: EmptyList,
            texts: Vec::new(),
            models: EmptyList,
        }
    }

    pub fn with_metadata(mut self, pairs: &[(&str, &str)]) -> Self {
        self.metadata = pairs
            .iter()
            .map(|(k, v)| KeyValuePair {
                key: (*k).to_owned(),
                value: (*v).to_owned(),
            })
            .collect();
        self
    }
}

/// Serialises as `[]`.
#[derive(Debug, Clone, Copy)]
pub(super) struct EmptyList;

impl Serialize for EmptyList {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_seq(Some(0))?.end()
    }
}

#[derive(Debug, Serialize)]
pub(super) struct KeyValuePair {
    pub key: String,
    pub value: String,
}

/// `foxglove.CubePrimitive` and `foxglove.SpherePrimitive` (`size` = full extents / diameters).
#[derive(Debug, Clone, Copy, Serialize)]
pub(super) struct SizedPrimitive {
    pub pose: Pose,
    pub size: Vector3,
    pub color: Color,
}

/// `foxglove.ArrowPrimitive`: points along the pose's +x, from its position.
#[derive(Debug, Clone, Copy, Serialize)]
pub(super) struct ArrowPrimitive {
    pub pose: Pose,
    pub shaft_length: f64,
    pub shaft_diameter: f64,
    pub head_length: f64,
    pub head_diameter: f64,
    pub color: Color,
}

/// `foxglove.CylinderPrimitive`, axis along local z.
#[derive(Debug, Clone, Copy, Serialize)]
pub(super) struct CylinderPrimitive {
    pub pose: Pose,
    pub size: Vector3,
    pub bottom_scale: f64,
    pub top_scale: f64,
    pub color: Color,
}

/// `foxglove.TextPrimitive`.
#[derive(Debug, Serialize)]
pub(super) struct TextPrimitive {
    pub pose: Pose,
    pub billboard: bool,
    pub font_size: f64,
    pub scale_invariant: bool,
    pub color: Color,
    pub text: String,
}

//! The messages of a pbd log. Foxglove's well-known topics are the `foxglove` crate's typed
//! Protobuf messages ([`fm`]): the scene builders (`scene.rs`, `robot.rs`, `grasps.rs`) draw with the
//! small value types below and convert once, and `/tf` is encoded frame by frame from templates
//! kept with the frame tree (no allocation per snapshot). pbd's own messages (`pbd.*`) are
//! borrowed serde structs serialised as JSON straight into a reused buffer.

use control_basis::math::Iso3;
use dexter_sim::snapshot::{FingertipWrench, ObjectState, SnapshotHeader};
use foxglove::messages as fm;
use serde::Serialize;
use serde::ser::{SerializeSeq, Serializer};

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
    /// As a Foxglove Protobuf timestamp.
    pub fn proto(self) -> fm::Timestamp {
        fm::Timestamp::new(self.sec, self.nsec)
    }

    pub fn from_ns(ns: u64) -> Self {
        Self {
            sec: u32::try_from(ns / NS_PER_SEC).unwrap_or(u32::MAX),
            nsec: (ns % NS_PER_SEC) as u32,
        }
    }
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
    /// Parent-from-child of every link, then world-from-object of every object, this snapshot.
    current: Vec<Iso3>,
    /// What was last published for each frame.
    published: Vec<Option<Iso3>>,
    /// Whether each frame is written this snapshot.
    publish: Vec<bool>,
    /// Log time (ns) of the last keyframe.
    last_keyframe: Option<u64>,
    /// Per frame, its transform message with the frame names filled in (`None`: the root, never
    /// written).
    templates: Vec<Option<fm::FrameTransform>>,
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
        let parents: Vec<ParentFrame> = header
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
        let template = |parent: &str, child: &str| fm::FrameTransform {
            parent_frame_id: parent.to_owned(),
            child_frame_id: child.to_owned(),
            ..Default::default()
        };
        let object_frames: Vec<String> = header.object_names.iter().map(|n| object_frame(n)).collect();
        let templates = header
            .link_names
            .iter()
            .zip(&parents)
            .map(|(child, parent)| match *parent {
                ParentFrame::Root => None,
                ParentFrame::World => Some(template(WORLD_FRAME, child)),
                ParentFrame::Link(p) => Some(template(&header.link_names[p], child)),
            })
            .chain(object_frames.iter().map(|f| Some(template(WORLD_FRAME, f))))
            .collect();
        Self {
            link_names: header.link_names.clone(),
            link_parents: header.link_parents.clone(),
            object_names: header.object_names.clone(),
            parents,
            current: vec![Iso3::identity(); frames],
            published: vec![None; frames],
            publish: vec![false; frames],
            last_keyframe: None,
            templates,
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

/// `x` rounded to 6 decimals (non-finite values unchanged), for JSON: 1 µm and ~2 µrad are far below
/// what the simulator resolves, and short numbers compress better.
pub(super) fn round6(x: f64) -> f64 {
    (x * 1e6).round() / 1e6
}

/// `x` as pbd's JSON messages carry it: to 6 decimals (1 µm, 1 µrad, 1 µN, 1 µs), and below 1 to 6
/// significant digits (a probability of 1e-9 stays one); non-finite values unchanged (JSON writes
/// them as `null`). A value already rounded to 6 decimals is unchanged, so joint states keep
/// their precision.
pub(crate) fn round_json(x: f64) -> f64 {
    if !x.is_finite() || x == 0.0 {
        return x;
    }
    // Digits after the decimal point: 6, or more for a small number's 6 significant ones.
    let k = 6.max(5 - x.abs().log10().floor() as i32);
    if k > 22 {
        // Below 1e-17: a power of ten that large is not exact; such a number is noise anyway.
        return x;
    }
    let p = 10f64.powi(k);
    let r = (x * p).round() / p;
    if r.is_finite() { r } else { x }
}

/// `x` rounded to a multiple of 2⁻²⁰ (≈ 0.95 µm or µrad; non-finite values unchanged), for binary
/// doubles: the low mantissa bits are then zero, and zstd packs them (rounding to decimals would
/// leave them random: a Protobuf `/tf` compressed 10 % worse than the JSON it replaced).
pub(super) fn round_bits(x: f64) -> f64 {
    const GRID: f64 = (1u64 << 20) as f64;
    (x * GRID).round() / GRID
}

impl FrameTree {
    /// Encodes the frames [`FrameTree::update`] chose as one `foxglove.FrameTransforms` into `buf`
    /// (cleared first): links (parent → child) and objects (`world → object/<name>`), translation
    /// and quaternion rounded to multiples of 2⁻²⁰ ([`round_bits`]). Each transform is encoded from its template as field 1
    /// of the message (Protobuf's repeated field), so nothing is allocated.
    pub fn encode_transforms(&mut self, timestamp: Time, buf: &mut Vec<u8>) {
        buf.clear();
        let timestamp = Some(timestamp.proto());
        for ((t, publish), current) in self.templates.iter_mut().zip(&self.publish).zip(&self.current) {
            let Some(t) = t else { continue };
            if !*publish {
                continue;
            }
            let (v, q) = split(current);
            t.timestamp = timestamp;
            t.translation = Some(fm::Vector3 {
                x: round_bits(v.x),
                y: round_bits(v.y),
                z: round_bits(v.z),
            });
            t.rotation = Some(fm::Quaternion {
                x: round_bits(q.x),
                y: round_bits(q.y),
                z: round_bits(q.z),
                w: round_bits(q.w),
            });
            prost::encoding::message::encode(1, &*t, buf);
        }
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
pub(super) fn log(timestamp: Time, level: u8, message: &str, name: &str, file: &str, line: u32) -> fm::Log {
    fm::Log {
        timestamp: Some(timestamp.proto()),
        level: i32::from(level),
        message: message.to_owned(),
        name: name.to_owned(),
        file: file.to_owned(),
        line,
    }
}

/// `foxglove.CameraCalibration` of an undistorted pinhole camera, from the focal lengths and
/// principal point (px).
pub(super) fn pinhole_calibration(
    timestamp: Time,
    frame_id: &str,
    width: u32,
    height: u32,
    f: [f64; 2],
    c: [f64; 2],
) -> fm::CameraCalibration {
    let [fx, fy] = f;
    let [cx, cy] = c;
    fm::CameraCalibration {
        timestamp: Some(timestamp.proto()),
        frame_id: frame_id.to_owned(),
        width,
        height,
        distortion_model: "plumb_bob".into(),
        d: Vec::new(),
        k: vec![fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
        r: vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: vec![fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
    }
}

/// A scene update as pbd draws it: the entities, after deleting every entity of the topic or not.
#[derive(Debug)]
pub(super) struct SceneUpdate {
    /// Delete everything drawn on the topic before (at this time) first.
    pub replace_all: Option<Time>,
    pub entities: Vec<SceneEntity>,
}

impl SceneUpdate {
    /// An update that first deletes every entity of its topic (so that entities gone since the
    /// last update disappear), then draws `entities`.
    pub fn replacing_all(timestamp: Time, entities: Vec<SceneEntity>) -> Self {
        Self {
            replace_all: Some(timestamp),
            entities,
        }
    }

    /// As a `foxglove.SceneUpdate`.
    pub fn proto(&self) -> fm::SceneUpdate {
        fm::SceneUpdate {
            deletions: self
                .replace_all
                .map(|t| fm::SceneEntityDeletion {
                    timestamp: Some(t.proto()),
                    r#type: fm::scene_entity_deletion::Type::All as i32,
                    id: String::new(),
                })
                .into_iter()
                .collect(),
            entities: self.entities.iter().map(SceneEntity::proto).collect(),
        }
    }
}

/// A `foxglove.SceneEntity` with the primitives pbd draws; it lives until replaced.
#[derive(Debug)]
pub(super) struct SceneEntity {
    pub timestamp: Time,
    pub frame_id: String,
    pub id: String,
    pub frame_locked: bool,
    pub metadata: Vec<(String, String)>,
    pub arrows: Vec<ArrowPrimitive>,
    pub cubes: Vec<SizedPrimitive>,
    pub spheres: Vec<SizedPrimitive>,
    pub cylinders: Vec<CylinderPrimitive>,
    pub texts: Vec<TextPrimitive>,
}

impl SceneEntity {
    /// An entity with no primitives that lives until replaced.
    pub fn new(timestamp: Time, frame_id: &str, id: String, frame_locked: bool) -> Self {
        Self {
            timestamp,
            frame_id: frame_id.to_owned(),
            id,
            frame_locked,
            metadata: Vec::new(),
            arrows: Vec::new(),
            cubes: Vec::new(),
            spheres: Vec::new(),
            cylinders: Vec::new(),
            texts: Vec::new(),
        }
    }

    pub fn with_metadata(mut self, pairs: &[(&str, &str)]) -> Self {
        self.metadata = pairs.iter().map(|(k, v)| ((*k).to_owned(), (*v).to_owned())).collect();
        self
    }

    /// As a `foxglove.SceneEntity` (lifetime zero: forever).
    pub fn proto(&self) -> fm::SceneEntity {
        fm::SceneEntity {
            timestamp: Some(self.timestamp.proto()),
            frame_id: self.frame_id.clone(),
            id: self.id.clone(),
            lifetime: Some(fm::Duration::new(0, 0)),
            frame_locked: self.frame_locked,
            metadata: self
                .metadata
                .iter()
                .map(|(key, value)| fm::KeyValuePair {
                    key: key.clone(),
                    value: value.clone(),
                })
                .collect(),
            arrows: self.arrows.iter().map(ArrowPrimitive::proto).collect(),
            cubes: self
                .cubes
                .iter()
                .map(|c| fm::CubePrimitive {
                    pose: Some(c.pose.proto()),
                    size: Some(c.size.proto()),
                    color: Some(c.color.proto()),
                })
                .collect(),
            spheres: self
                .spheres
                .iter()
                .map(|c| fm::SpherePrimitive {
                    pose: Some(c.pose.proto()),
                    size: Some(c.size.proto()),
                    color: Some(c.color.proto()),
                })
                .collect(),
            cylinders: self
                .cylinders
                .iter()
                .map(|c| fm::CylinderPrimitive {
                    pose: Some(c.pose.proto()),
                    size: Some(c.size.proto()),
                    bottom_scale: c.bottom_scale,
                    top_scale: c.top_scale,
                    color: Some(c.color.proto()),
                })
                .collect(),
            texts: self
                .texts
                .iter()
                .map(|t| fm::TextPrimitive {
                    pose: Some(t.pose.proto()),
                    billboard: t.billboard,
                    font_size: t.font_size,
                    scale_invariant: t.scale_invariant,
                    color: Some(t.color.proto()),
                    text: t.text.clone(),
                })
                .collect(),
            ..Default::default()
        }
    }
}

/// `foxglove.CubePrimitive` and `foxglove.SpherePrimitive` (`size` = full extents / diameters).
#[derive(Debug, Clone, Copy)]
pub(super) struct SizedPrimitive {
    pub pose: Pose,
    pub size: Vector3,
    pub color: Color,
}

/// `foxglove.ArrowPrimitive`: points along the pose's +x, from its position.
#[derive(Debug, Clone, Copy)]
pub(super) struct ArrowPrimitive {
    pub pose: Pose,
    pub shaft_length: f64,
    pub shaft_diameter: f64,
    pub head_length: f64,
    pub head_diameter: f64,
    pub color: Color,
}

impl ArrowPrimitive {
    pub fn proto(&self) -> fm::ArrowPrimitive {
        fm::ArrowPrimitive {
            pose: Some(self.pose.proto()),
            shaft_length: self.shaft_length,
            shaft_diameter: self.shaft_diameter,
            head_length: self.head_length,
            head_diameter: self.head_diameter,
            color: Some(self.color.proto()),
        }
    }
}

/// `foxglove.CylinderPrimitive`, axis along local z.
#[derive(Debug, Clone, Copy)]
pub(super) struct CylinderPrimitive {
    pub pose: Pose,
    pub size: Vector3,
    pub bottom_scale: f64,
    pub top_scale: f64,
    pub color: Color,
}

/// `foxglove.TextPrimitive`.
#[derive(Debug)]
pub(super) struct TextPrimitive {
    pub pose: Pose,
    pub billboard: bool,
    pub font_size: f64,
    pub scale_invariant: bool,
    pub color: Color,
    pub text: String,
}

impl Vector3 {
    pub fn proto(self) -> fm::Vector3 {
        fm::Vector3 {
            x: self.x,
            y: self.y,
            z: self.z,
        }
    }
}

impl Pose {
    pub fn proto(self) -> fm::Pose {
        let q = self.orientation;
        fm::Pose {
            position: Some(self.position.proto()),
            orientation: Some(fm::Quaternion {
                x: q.x,
                y: q.y,
                z: q.z,
                w: q.w,
            }),
        }
    }
}

impl Color {
    pub fn proto(self) -> fm::Color {
        fm::Color {
            r: self.r,
            g: self.g,
            b: self.b,
            a: self.a,
        }
    }
}

#[cfg(test)]
mod round_tests {
    use super::round_json;

    #[test]
    fn json_numbers_keep_six_decimals_and_six_significant_digits_below_one() {
        let cases = [
            (20.00500000000171, "20.005"),
            (11.73167071365145, "11.731671"),
            (0.6963544431786289, "0.696354"),
            (-0.023820822965936767, "-0.0238208"),
            (2.862618, "2.862618"),
            (-4e-6, "-4e-6"),
            (1.234567891e-9, "1.23457e-9"),
            (123456.7890123, "123456.789012"),
            (0.0, "0.0"),
        ];
        for (x, text) in cases {
            assert_eq!(serde_json::to_string(&round_json(x)).unwrap(), text, "{x}");
            assert_eq!(round_json(round_json(x)), round_json(x), "idempotent at {x}");
        }
        assert!(round_json(f64::NAN).is_nan());
        assert_eq!(round_json(f64::INFINITY), f64::INFINITY);
        assert_eq!(round_json(1e-300), 1e-300);
        assert_eq!(round_json(1e300), 1e300);
    }
}

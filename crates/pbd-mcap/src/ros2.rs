//! The ROS 2 encoding of a log ([`crate::Encoding::Ros2`]): every channel CDR with a `ros2msg`
//! schema, in an MCAP file of profile `ros2` — what rosbag2 writes, so that `ros2 bag`, `rosbags`
//! and Foxglove read it.
//!
//! Foxglove's messages become their ROS 2 counterparts (`foxglove.FrameTransforms` →
//! `tf2_msgs/TFMessage`, `foxglove.SceneUpdate` → `visualization_msgs/MarkerArray`, `foxglove.Log` →
//! `rcl_interfaces/Log`, images → `sensor_msgs/Image` or `CompressedImage`, calibrations →
//! `sensor_msgs/CameraInfo`); pbd's own become `pbd_msgs/…` ([`PBD_MSGS`]): a percept, the truth
//! and a hand command field by field, any other as `pbd_msgs/Json` (its pbd schema name and its
//! JSON text). Reading converts `pbd_msgs` back to the JSON pbd writes in its other encoding, so
//! `pbd infer` reads either.

use anyhow::{Context, Result, bail};
use foxglove::messages as fm;
use pbd_ros2_msgs::definitions;
use pbd_ros2_msgs::msg::{self, Header};
use schema::percept::{HandPercept, Percept, PlacePercept, SeenExtent, SegmentPercept};
use serde::{Deserialize, Serialize};

/// The `pbd_msgs` package: pbd's own messages in ROS 2 form.
pub const PBD_MSGS: &[(&str, &str)] = &[
    (
        "pbd_msgs/msg/Percept",
        "float64 t\npbd_msgs/HandPercept[] hands\npbd_msgs/SegmentPercept[] segments\n\
         pbd_msgs/PlacePercept[] places\nfloat64 table_z\nuint32[<=1] gaze\n",
    ),
    (
        "pbd_msgs/msg/HandPercept",
        "string arm\nfloat64[3] palm\nfloat64 palm_speed\nfloat64 flexion\nfloat64[3] finger_force\nfloat64 load\n",
    ),
    (
        "pbd_msgs/msg/SegmentPercept",
        "uint32 id\nfloat64[3] centroid\nbool seen\nuint32[2] pixels\npbd_msgs/Share[] histogram\n\
         float64[4] covariance\npbd_msgs/Share[] colors\npbd_msgs/SeenExtent[<=1] extent\n",
    ),
    ("pbd_msgs/msg/Share", "uint8 index\nfloat64 share\n"),
    (
        "pbd_msgs/msg/SeenExtent",
        "float64 height\nfloat64[2] center\nfloat64[2] major_axis\nfloat64 half_major\nfloat64 half_minor\nstring model\n",
    ),
    (
        "pbd_msgs/msg/PlacePercept",
        "string name\nfloat64[3] center\nfloat64[2] half_extents\n",
    ),
    ("pbd_msgs/msg/Truth", "float64 t\npbd_msgs/ObjectPosition[] objects\n"),
    ("pbd_msgs/msg/ObjectPosition", "string name\nfloat64[3] position\n"),
    (
        "pbd_msgs/msg/HandCommand",
        "float64 t\nstring hand\nfloat64[3] position\nfloat64[4] orientation\nfloat64 flexion\n",
    ),
    ("pbd_msgs/msg/Json", "string schema_name\nstring data\n"),
];

/// The `ros2msg` schema of `type_name` (`package/msg/Type`): its definition and every type it uses.
pub(crate) fn schema(type_name: &str) -> Result<Vec<u8>> {
    definitions::concatenated(type_name, &[definitions::STANDARD, PBD_MSGS])
        .map(String::into_bytes)
        .with_context(|| format!("no ROS 2 definition of {type_name}"))
}

/// The ROS 2 type of pbd's message `schema_name` (`pbd.Percept` → `pbd_msgs/msg/Percept`).
pub(crate) fn pbd_type(schema_name: &str) -> &'static str {
    match schema_name {
        "pbd.Percept" => "pbd_msgs/msg/Percept",
        "pbd.Truth" => "pbd_msgs/msg/Truth",
        "pbd.HandCommand" => "pbd_msgs/msg/HandCommand",
        _ => "pbd_msgs/msg/Json",
    }
}

/// A Foxglove timestamp as `builtin_interfaces/Time`.
fn time(t: Option<fm::Timestamp>) -> msg::Time {
    t.map_or_else(msg::Time::default, |t| msg::Time {
        sec: i32::try_from(t.sec()).unwrap_or(i32::MAX),
        nanosec: t.nsec(),
    })
}

fn header(t: Option<fm::Timestamp>, frame_id: &str) -> Header {
    Header {
        stamp: time(t),
        frame_id: frame_id.to_owned(),
    }
}

fn vector(v: Option<fm::Vector3>) -> msg::Vector3 {
    v.map_or_else(msg::Vector3::default, |v| msg::Vector3 { x: v.x, y: v.y, z: v.z })
}

fn quaternion(q: Option<fm::Quaternion>) -> msg::Quaternion {
    q.map_or_else(msg::Quaternion::default, |q| msg::Quaternion {
        x: q.x,
        y: q.y,
        z: q.z,
        w: q.w,
    })
}

fn pose(p: Option<fm::Pose>) -> msg::Pose {
    let p = p.unwrap_or_default();
    let v = vector(p.position);
    msg::Pose {
        position: msg::Point { x: v.x, y: v.y, z: v.z },
        orientation: quaternion(p.orientation),
    }
}

fn color(c: Option<fm::Color>) -> msg::ColorRgba {
    c.map_or_else(msg::ColorRgba::default, |c| msg::ColorRgba {
        r: c.r as f32,
        g: c.g as f32,
        b: c.b as f32,
        a: c.a as f32,
    })
}

/// `/tf`.
pub(crate) fn tf(m: &fm::FrameTransforms) -> msg::TfMessage {
    msg::TfMessage {
        transforms: m
            .transforms
            .iter()
            .map(|t| msg::TransformStamped {
                header: header(t.timestamp, &t.parent_frame_id),
                child_frame_id: t.child_frame_id.clone(),
                transform: msg::Transform {
                    translation: vector(t.translation),
                    rotation: quaternion(t.rotation),
                },
            })
            .collect(),
    }
}

/// A scene update as markers: a deletion of everything as one `DELETEALL`; each entity's
/// primitives as markers in the namespace of its id (numbered in the order arrows, cubes, spheres,
/// cylinders, texts), in its frame and locked to it as the entity is; an entity with no primitive
/// (an arrow that is gone) as a `DELETE` of its first marker. Lines, triangles and models (which
/// pbd does not draw) are left out.
pub(crate) fn markers(u: &fm::SceneUpdate) -> msg::MarkerArray {
    let mut markers = Vec::new();
    if u.deletions
        .iter()
        .any(|d| d.r#type == fm::scene_entity_deletion::Type::All as i32)
    {
        markers.push(msg::Marker {
            header: header(u.deletions[0].timestamp, ""),
            action: msg::Marker::DELETEALL,
            ..Default::default()
        });
    }
    for e in &u.entities {
        let base = msg::Marker {
            header: header(e.timestamp, &e.frame_id),
            ns: e.id.clone(),
            action: msg::Marker::ADD,
            lifetime: e.lifetime.map_or_else(msg::Duration::default, |d| msg::Duration {
                sec: d.sec(),
                nanosec: d.nsec(),
            }),
            frame_locked: e.frame_locked,
            ..Default::default()
        };
        let mut add = |kind: i32, p: Option<fm::Pose>, scale: msg::Vector3, c: Option<fm::Color>, text: &str| {
            markers.push(msg::Marker {
                id: markers.iter().filter(|m| m.ns == e.id).count() as i32,
                kind,
                pose: pose(p),
                scale,
                color: color(c),
                text: text.to_owned(),
                ..base.clone()
            });
        };
        for a in &e.arrows {
            let scale = msg::Vector3 {
                x: a.shaft_length + a.head_length,
                y: a.shaft_diameter,
                z: a.head_diameter,
            };
            add(msg::Marker::ARROW, a.pose, scale, a.color, "");
        }
        for c in &e.cubes {
            add(msg::Marker::CUBE, c.pose, vector(c.size), c.color, "");
        }
        for s in &e.spheres {
            add(msg::Marker::SPHERE, s.pose, vector(s.size), s.color, "");
        }
        for c in &e.cylinders {
            // A marker cylinder is straight: a cone's wider end.
            let mut size = vector(c.size);
            let s = c.bottom_scale.max(c.top_scale);
            size.x *= s;
            size.y *= s;
            add(msg::Marker::CYLINDER, c.pose, size, c.color, "");
        }
        for t in &e.texts {
            let height = msg::Vector3 {
                z: if t.scale_invariant {
                    t.font_size / 200.0
                } else {
                    t.font_size
                },
                ..Default::default()
            };
            add(msg::Marker::TEXT_VIEW_FACING, t.pose, height, t.color, &t.text);
        }
        if !markers.iter().any(|m| m.ns == e.id) {
            markers.push(msg::Marker {
                action: msg::Marker::DELETE,
                ..base
            });
        }
    }
    msg::MarkerArray { markers }
}

/// `/log` (Foxglove's levels 1–5 as `rcl_interfaces/Log`'s 10–50).
pub(crate) fn log(l: &fm::Log) -> msg::Log {
    msg::Log {
        stamp: time(l.timestamp),
        level: u8::try_from(l.level.clamp(1, 5) * 10).unwrap_or(msg::Log::INFO),
        name: l.name.clone(),
        msg: l.message.clone(),
        file: l.file.clone(),
        function: String::new(),
        line: l.line,
    }
}

/// A pinhole calibration as `sensor_msgs/CameraInfo`.
pub(crate) fn camera_info(c: &fm::CameraCalibration) -> msg::CameraInfo {
    fn fixed<const N: usize>(v: &[f64]) -> [f64; N] {
        let mut out = [0.0; N];
        for (o, x) in out.iter_mut().zip(v) {
            *o = *x;
        }
        out
    }
    msg::CameraInfo {
        header: header(c.timestamp, &c.frame_id),
        height: c.height,
        width: c.width,
        distortion_model: c.distortion_model.clone(),
        d: c.d.clone(),
        k: fixed(&c.k),
        r: fixed(&c.r),
        p: fixed(&c.p),
        ..Default::default()
    }
}

// pbd's own messages, field by field (the structs mirror `schema::percept`'s; destructuring there
// makes a new field a compile error here).

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct PerceptMsg {
    t: f64,
    hands: Vec<HandMsg>,
    segments: Vec<SegmentMsg>,
    places: Vec<PlaceMsg>,
    table_z: f64,
    gaze: Option<u32>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct HandMsg {
    arm: String,
    palm: [f64; 3],
    palm_speed: f64,
    flexion: f64,
    finger_force: [f64; 3],
    load: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct SegmentMsg {
    id: u32,
    centroid: [f64; 3],
    seen: bool,
    pixels: [u32; 2],
    histogram: Vec<(u8, f64)>,
    covariance: [f64; 4],
    colors: Vec<(u8, f64)>,
    extent: Option<ExtentMsg>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct ExtentMsg {
    height: f64,
    center: [f64; 2],
    major_axis: [f64; 2],
    half_major: f64,
    half_minor: f64,
    model: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct PlaceMsg {
    name: String,
    center: [f64; 3],
    half_extents: [f64; 2],
}

impl From<Percept> for PerceptMsg {
    fn from(p: Percept) -> Self {
        let Percept {
            t,
            hands,
            segments,
            places,
            table_z,
            gaze,
        } = p;
        PerceptMsg {
            t,
            hands: hands
                .into_iter()
                .map(|h| {
                    let HandPercept {
                        arm,
                        palm,
                        palm_speed,
                        flexion,
                        finger_force,
                        load,
                    } = h;
                    HandMsg {
                        arm,
                        palm,
                        palm_speed,
                        flexion,
                        finger_force,
                        load,
                    }
                })
                .collect(),
            segments: segments
                .into_iter()
                .map(|s| {
                    let SegmentPercept {
                        id,
                        centroid,
                        seen,
                        pixels,
                        histogram,
                        covariance,
                        colors,
                        extent,
                    } = s;
                    SegmentMsg {
                        id,
                        centroid,
                        seen,
                        pixels,
                        histogram,
                        covariance,
                        colors,
                        extent: extent.map(|e| {
                            let SeenExtent {
                                height,
                                center,
                                major_axis,
                                half_major,
                                half_minor,
                                model,
                            } = e;
                            ExtentMsg {
                                height,
                                center,
                                major_axis,
                                half_major,
                                half_minor,
                                model,
                            }
                        }),
                    }
                })
                .collect(),
            places: places
                .into_iter()
                .map(|p| {
                    let PlacePercept {
                        name,
                        center,
                        half_extents,
                    } = p;
                    PlaceMsg {
                        name,
                        center,
                        half_extents,
                    }
                })
                .collect(),
            table_z,
            gaze,
        }
    }
}

impl From<PerceptMsg> for Percept {
    fn from(m: PerceptMsg) -> Self {
        Percept {
            t: m.t,
            hands: m
                .hands
                .into_iter()
                .map(|h| HandPercept {
                    arm: h.arm,
                    palm: h.palm,
                    palm_speed: h.palm_speed,
                    flexion: h.flexion,
                    finger_force: h.finger_force,
                    load: h.load,
                })
                .collect(),
            segments: m
                .segments
                .into_iter()
                .map(|s| SegmentPercept {
                    id: s.id,
                    centroid: s.centroid,
                    seen: s.seen,
                    pixels: s.pixels,
                    histogram: s.histogram,
                    covariance: s.covariance,
                    colors: s.colors,
                    extent: s.extent.map(|e| SeenExtent {
                        height: e.height,
                        center: e.center,
                        major_axis: e.major_axis,
                        half_major: e.half_major,
                        half_minor: e.half_minor,
                        model: e.model,
                    }),
                })
                .collect(),
            places: m
                .places
                .into_iter()
                .map(|p| PlacePercept {
                    name: p.name,
                    center: p.center,
                    half_extents: p.half_extents,
                })
                .collect(),
            table_z: m.table_z,
            gaze: m.gaze,
        }
    }
}

/// `pbd.Truth`: the objects' true positions, for evaluation (its JSON: `{t, objects: [[name, [x, y, z]], …]}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct TruthMsg {
    t: f64,
    objects: Vec<(String, [f64; 3])>,
}

/// `pbd.HandCommand` (its JSON: `dexter_sim::teleop::HandCommand`'s, the hand as `left`/`right`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct HandCommandMsg {
    t: f64,
    hand: String,
    position: [f64; 3],
    orientation: [f64; 4],
    flexion: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct JsonMsg {
    schema_name: String,
    data: String,
}

/// Encodes pbd's message `schema_name`, given as its JSON value, as its `pbd_msgs` type into `buf`.
pub(crate) fn encode_pbd(buf: &mut Vec<u8>, schema_name: &str, value: serde_json::Value) -> Result<()> {
    let what = || format!("a {schema_name} message in ROS 2 form");
    match pbd_type(schema_name) {
        "pbd_msgs/msg/Percept" => {
            let p: Percept = serde_json::from_value(value).with_context(what)?;
            pbd_ros2_msgs::encode_into(buf, &PerceptMsg::from(p))
        }
        "pbd_msgs/msg/Truth" => {
            pbd_ros2_msgs::encode_into(buf, &serde_json::from_value::<TruthMsg>(value).with_context(what)?)
        }
        "pbd_msgs/msg/HandCommand" => pbd_ros2_msgs::encode_into(
            buf,
            &serde_json::from_value::<HandCommandMsg>(value).with_context(what)?,
        ),
        _ => pbd_ros2_msgs::encode_into(
            buf,
            &JsonMsg {
                schema_name: schema_name.to_owned(),
                data: value.to_string(),
            },
        ),
    }
    .with_context(what)
}

/// The JSON pbd writes in its other encoding for a `pbd_msgs` message (`None`: not a pbd type).
pub(crate) fn pbd_json(type_name: &str, data: &[u8]) -> Result<Option<Vec<u8>>> {
    let json = match type_name {
        "pbd_msgs/msg/Percept" => serde_json::to_vec(&Percept::from(pbd_ros2_msgs::decode::<PerceptMsg>(data)?))?,
        "pbd_msgs/msg/Truth" => serde_json::to_vec(&pbd_ros2_msgs::decode::<TruthMsg>(data)?)?,
        "pbd_msgs/msg/HandCommand" => serde_json::to_vec(&pbd_ros2_msgs::decode::<HandCommandMsg>(data)?)?,
        "pbd_msgs/msg/Json" => pbd_ros2_msgs::decode::<JsonMsg>(data)?.data.into_bytes(),
        _ => return Ok(None),
    };
    Ok(Some(json))
}

/// Any ROS 2 message pbd writes, as JSON (field names of its definition; pbd's own as their JSON).
pub(crate) fn message_json(type_name: &str, data: &[u8]) -> Result<serde_json::Value> {
    fn decode<T: serde::de::DeserializeOwned + Serialize>(data: &[u8]) -> Result<serde_json::Value> {
        Ok(serde_json::to_value(pbd_ros2_msgs::decode::<T>(data)?)?)
    }
    if let Some(json) = pbd_json(type_name, data)? {
        return Ok(serde_json::from_slice(&json)?);
    }
    match type_name {
        "tf2_msgs/msg/TFMessage" => decode::<msg::TfMessage>(data),
        "visualization_msgs/msg/MarkerArray" => decode::<msg::MarkerArray>(data),
        "rcl_interfaces/msg/Log" => decode::<msg::Log>(data),
        "sensor_msgs/msg/JointState" => decode::<msg::JointState>(data),
        "geometry_msgs/msg/WrenchStamped" => decode::<msg::WrenchStamped>(data),
        "sensor_msgs/msg/Image" => decode::<msg::Image>(data),
        "sensor_msgs/msg/CompressedImage" => decode::<msg::CompressedImage>(data),
        "foxglove_msgs/msg/CompressedVideo" => decode::<msg::CompressedVideo>(data),
        "sensor_msgs/msg/CameraInfo" => decode::<msg::CameraInfo>(data),
        "std_msgs/msg/String" => decode::<msg::StringMsg>(data),
        other => bail!("ROS 2 type `{other}` is not one pbd writes"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_type_pbd_writes_has_a_schema() {
        for (name, _) in PBD_MSGS.iter().chain(definitions::STANDARD) {
            assert!(schema(name).is_ok(), "{name}");
        }
    }

    #[test]
    fn a_full_percept_survives_cdr_exactly() {
        let p = Percept {
            t: 1.0 / 3.0,
            hands: vec![HandPercept {
                arm: "left".into(),
                palm: [0.1, -0.2, 0.3],
                palm_speed: 1e-17,
                flexion: 0.7,
                finger_force: [1.0, 2.0, 3.5],
                load: -0.25,
            }],
            segments: vec![
                SegmentPercept {
                    id: 7,
                    centroid: [0.5, 0.25, 0.125],
                    seen: true,
                    pixels: [120, 99],
                    histogram: vec![(3, 0.5), (63, 0.5)],
                    covariance: [1.0, 0.1, 0.1, 2.0],
                    colors: vec![(4, 1.0)],
                    extent: Some(SeenExtent {
                        height: 0.08,
                        center: [0.5, 0.25],
                        major_axis: [0.6, 0.8],
                        half_major: 0.03,
                        half_minor: 0.02,
                        model: "prism".into(),
                    }),
                },
                SegmentPercept {
                    id: 8,
                    centroid: [0.0; 3],
                    seen: false,
                    pixels: [0, 0],
                    histogram: vec![],
                    covariance: [0.0; 4],
                    colors: vec![],
                    extent: None,
                },
            ],
            places: vec![PlacePercept {
                name: "bin_a".into(),
                center: [0.4, 0.3, 0.75],
                half_extents: [0.1, 0.125],
            }],
            table_z: 0.75,
            gaze: Some(7),
        };
        let mut buf = Vec::new();
        encode_pbd(&mut buf, "pbd.Percept", serde_json::to_value(&p).unwrap()).unwrap();
        let json = pbd_json("pbd_msgs/msg/Percept", &buf).unwrap().unwrap();
        assert_eq!(json, serde_json::to_vec(&p).unwrap());
        let none = Percept { gaze: None, ..p };
        encode_pbd(&mut buf, "pbd.Percept", serde_json::to_value(&none).unwrap()).unwrap();
        let back: Percept = serde_json::from_slice(&pbd_json("pbd_msgs/msg/Percept", &buf).unwrap().unwrap()).unwrap();
        assert_eq!(back, none);
    }

    #[test]
    fn other_pbd_messages_travel_as_json() {
        let mut buf = Vec::new();
        let v = serde_json::json!({"t": 1.5, "decision": "bin_a"});
        encode_pbd(&mut buf, "pbd.Decision", v.clone()).unwrap();
        let json = pbd_json("pbd_msgs/msg/Json", &buf).unwrap().unwrap();
        assert_eq!(serde_json::from_slice::<serde_json::Value>(&json).unwrap(), v);
        assert!(encode_pbd(&mut buf, "pbd.Truth", serde_json::json!({"t": "x"})).is_err());
    }

    #[test]
    fn a_scene_update_becomes_markers() {
        let u = fm::SceneUpdate {
            deletions: vec![fm::SceneEntityDeletion {
                timestamp: None,
                r#type: fm::scene_entity_deletion::Type::All as i32,
                id: String::new(),
            }],
            entities: vec![
                fm::SceneEntity {
                    frame_id: "world".into(),
                    id: "table".into(),
                    frame_locked: true,
                    cubes: vec![fm::CubePrimitive {
                        pose: None,
                        size: Some(fm::Vector3 { x: 1.0, y: 2.0, z: 0.1 }),
                        color: Some(fm::Color {
                            r: 0.5,
                            g: 0.5,
                            b: 0.5,
                            a: 1.0,
                        }),
                    }],
                    texts: vec![fm::TextPrimitive {
                        text: "table".into(),
                        font_size: 0.05,
                        ..Default::default()
                    }],
                    ..Default::default()
                },
                fm::SceneEntity {
                    id: "fingertip/left/1".into(),
                    ..Default::default()
                },
            ],
        };
        let m = markers(&u).markers;
        assert_eq!(m.len(), 4);
        assert_eq!(m[0].action, msg::Marker::DELETEALL);
        assert_eq!((m[1].ns.as_str(), m[1].id, m[1].kind), ("table", 0, msg::Marker::CUBE));
        assert_eq!(m[1].scale.y, 2.0);
        assert!(m[1].frame_locked);
        assert_eq!(
            (m[2].id, m[2].kind, m[2].text.as_str()),
            (1, msg::Marker::TEXT_VIEW_FACING, "table")
        );
        assert_eq!(
            (m[3].ns.as_str(), m[3].action),
            ("fingertip/left/1", msg::Marker::DELETE)
        );
        // And the array encodes.
        let bytes = pbd_ros2_msgs::encode(&msg::MarkerArray { markers: m }).unwrap();
        assert_eq!(
            pbd_ros2_msgs::decode::<msg::MarkerArray>(&bytes).unwrap().markers.len(),
            4
        );
    }
}

use super::*;
use std::collections::BTreeMap;
use std::fs::File;
use std::path::PathBuf;

use dexter_sim::scene::Scene;
use dexter_sim::snapshot::{Snapshot, SnapshotHeader};
use std::time::Instant;

use crate::messages::{FrameTree, Time, time_ns};
use crate::scene;
use base64::Engine as _;
use control_basis::math::{Iso3, Vec3};
use dexter_sim::Arm;
use dexter_sim::scene::{Catalog, ResolvedObject, SceneSpec};
use dexter_sim::snapshot::{FingertipWrench, ObjectState};
use serde_json::Value;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A file in the temp directory, removed on drop.
struct TempFile(PathBuf);

impl TempFile {
    fn new(tag: &str) -> Self {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        Self(std::env::temp_dir().join(format!("pbd-mcap-log-{}-{n}-{tag}.mcap", std::process::id())))
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

fn iso(xyz: [f64; 3], rpy: [f64; 3]) -> Iso3 {
    control_basis::math::iso_from_xyz_rpy(xyz, rpy)
}

/// `world` (root) → `base` → `arm`, two joints, one object.
fn header() -> SnapshotHeader {
    SnapshotHeader {
        joint_names: vec!["j1".into(), "j2".into()],
        link_names: vec!["world".into(), "base".into(), "arm".into()],
        link_parents: vec![None, Some("world".into()), Some("base".into())],
        object_names: vec!["jif".into()],
    }
}

fn snapshot(time: f64, activity: &str) -> Snapshot {
    let base = iso([0.0, 0.0, 0.5], [0.0, 0.0, 0.3]);
    let base_from_arm = iso([0.1, 0.2, 0.3], [0.1, -0.2, 0.4 + time]);
    let fingertips = Arm::BOTH
        .iter()
        .flat_map(|&arm| {
            (1..=3).map(move |finger| FingertipWrench {
                arm,
                finger,
                force: [0.1, 0.2, f64::from(finger)],
                torque: [0.0, 0.0, 0.01],
                in_contact: finger == 2,
            })
        })
        .collect();
    Snapshot {
        time,
        q: vec![0.1 * time, -0.2],
        qd: vec![0.1, 0.0],
        q_ref: vec![0.1 * time + 0.01, -0.2],
        link_poses: vec![Iso3::identity(), base, base * base_from_arm],
        objects: vec![ObjectState {
            pose: iso([0.6, 0.1, 0.8], [0.0, 0.0, 1.0]),
            linvel: Vec3::zeros(),
        }],
        fingertips,
        activity: activity.into(),
    }
}

fn scene() -> Scene {
    // Built from JSON so that fields added to the specs later take their defaults here too.
    fn spec<T: serde::de::DeserializeOwned>(v: Value) -> T {
        serde_json::from_value(v).unwrap()
    }
    let catalog: Catalog = spec(serde_json::json!({
        "version": 1,
        "objects": [{
            "name": "jif",
            "shape": { "kind": "cylinder", "radius": 0.04, "height": 0.12 },
            "mass": 0.4,
            "colors": [{ "hsv": [0.0, 0.9, 0.8], "fraction": 0.3 }, { "hsv": [210.0, 0.8, 0.7], "fraction": 0.7 }],
            "color_class": "blue",
            "size_class": "medium"
        }]
    }));
    let scene_spec: SceneSpec = spec(serde_json::json!({
        "version": 1,
        "name": "test",
        "catalog": "builtin:household",
        "table": { "height": 0.75, "center": [0.6, 0.0], "size": [0.8, 1.2] },
        "places": [
            { "name": "bin-a", "center": [0.6, 0.4], "size": [0.2, 0.2], "wall_height": 0.05 },
            { "name": "mark", "center": [0.6, -0.4], "size": [0.1, 0.1], "hsv": [60.0, 1.0, 1.0] }
        ]
    }));
    Scene {
        spec: scene_spec,
        catalog,
        path: PathBuf::new(),
        resolved: vec![ResolvedObject {
            presentation: "jif".into(),
            label: "jif".into(),
            object: 0,
            pose: iso([0.6, 0.1, 0.81], [0.0, 0.0, 0.0]),
        }],
    }
}

/// All messages of `bytes` (a complete file), by topic.
fn messages_by_topic(bytes: &[u8]) -> BTreeMap<String, Vec<(u64, Value)>> {
    let mut out: BTreeMap<String, Vec<(u64, Value)>> = BTreeMap::new();
    for m in mcap::MessageStream::new(bytes).unwrap() {
        let m = m.unwrap();
        let schema = m.channel.schema.as_ref().map_or("", |s| s.name.as_str());
        let json = message_json(schema, &m.channel.message_encoding, &m.data).unwrap();
        out.entry(m.channel.topic.clone()).or_default().push((m.log_time, json));
    }
    out
}

fn keys(v: &Value) -> Vec<&str> {
    let mut k: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    k.sort_unstable();
    k
}

#[test]
fn a_small_log_reads_back_with_its_channels_schemas_and_messages() {
    let tmp = TempFile::new("small");
    let header = header();
    // Every frame in every snapshot, images as they are.
    let options = McapLogOptions {
        image_format: ImageFormat::Raw,
        tf_keyframe_secs: 0.0,
        ..Default::default()
    };
    let mut log = McapLog::create_with(&tmp.0, options).unwrap();
    log.attach("dexter.urdf", "application/xml", b"<robot name=\"dexter\"/>")
        .unwrap();
    log.metadata("run", BTreeMap::from([("scene".to_owned(), "test".to_owned())]))
        .unwrap();
    log.log_scene(&scene(), &header, 0.0).unwrap();
    for i in 0..10 {
        let activity = if i < 4 { "" } else { "reach left → jif" };
        log.log_snapshot(&header, &snapshot(0.05 * f64::from(i), activity))
            .unwrap();
    }
    log.log_text(0.2, LogLevel::Warning, "grasp slipped").unwrap();
    let rgb: Vec<u8> = (0..4 * 3 * 3).map(|i| i as u8).collect();
    log.log_image(0.25, "head_left", 4, 3, &rgb).unwrap();
    let stats = log.finish().unwrap();
    assert_eq!(stats.messages, 10 * 3 + 2 + 1 + 1 + 1);

    let bytes = std::fs::read(&tmp.0).unwrap();
    assert_eq!(stats.bytes, bytes.len() as u64);
    let summary = mcap::Summary::read(&bytes)
        .unwrap()
        .expect("a finished file has a summary");
    let mut found: Vec<(String, String, String, String)> = summary
        .channels
        .values()
        .map(|c| {
            let s = c.schema.as_ref().unwrap();
            (
                c.topic.clone(),
                s.name.clone(),
                s.encoding.clone(),
                c.message_encoding.clone(),
            )
        })
        .collect();
    found.sort();
    let expected = [
        ("/activity", "pbd.Activity"),
        ("/camera/head_left/calibration", "foxglove.CameraCalibration"),
        ("/camera/head_left/image", "foxglove.RawImage"),
        ("/fingertips", "pbd.FingertipWrenches"),
        ("/fingertips/arrows", "foxglove.SceneUpdate"),
        ("/joint_states", "pbd.JointState"),
        ("/log", "foxglove.Log"),
        ("/robot", "foxglove.SceneUpdate"),
        ("/scene", "foxglove.SceneUpdate"),
        ("/tf", "foxglove.FrameTransforms"),
    ]
    .map(|(t, s)| {
        // Foxglove's schemas are Protobuf (the foxglove crate's descriptors), pbd's own JSON.
        let (schema, message) = if s.starts_with("foxglove.") {
            ("protobuf", "protobuf")
        } else {
            ("jsonschema", "json")
        };
        (t.to_owned(), s.to_owned(), schema.to_owned(), message.to_owned())
    });
    assert_eq!(found, expected);
    for schema in summary.schemas.values() {
        if schema.encoding == "jsonschema" {
            let v: Value = serde_json::from_slice(&schema.data).unwrap();
            assert_eq!(v["title"], schema.name.as_str());
        } else {
            assert!(
                !schema.data.is_empty() && schema.name.starts_with("foxglove."),
                "{}",
                schema.name
            );
        }
    }

    let by_topic = messages_by_topic(&bytes);
    let count = |t: &str| by_topic.get(t).map_or(0, Vec::len);
    assert_eq!(count(TOPIC_TF), 10);
    assert_eq!(count(TOPIC_JOINT_STATES), 10);
    assert_eq!(count(TOPIC_FINGERTIPS), 10);
    assert_eq!(count(TOPIC_ACTIVITY), 2, "activity is written when it changes");
    assert_eq!(count(TOPIC_SCENE), 1);
    assert_eq!(count(TOPIC_LOG), 1);

    // Joint states: log time is sim time in ns, timestamp {sec, nsec}, parallel arrays.
    let (t, js) = &by_topic[TOPIC_JOINT_STATES][3];
    assert_eq!(*t, 150_000_000);
    assert_eq!(js["timestamp"], serde_json::json!({ "sec": 0, "nsec": 150_000_000 }));
    assert_eq!(js["name"], serde_json::json!(["j1", "j2"]));
    assert!((js["position"][0].as_f64().unwrap() - 0.015).abs() < 1e-12);
    assert_eq!(js["velocity"].as_array().unwrap().len(), 2);
    assert_eq!(js["position_ref"].as_array().unwrap().len(), 2);

    // Transforms: the root `world` is not published; `arm` is relative to `base`.
    let (_, tf) = &by_topic[TOPIC_TF][2];
    let transforms = tf["transforms"].as_array().unwrap();
    let pairs: Vec<(&str, &str)> = transforms
        .iter()
        .map(|t| {
            (
                t["parent_frame_id"].as_str().unwrap(),
                t["child_frame_id"].as_str().unwrap(),
            )
        })
        .collect();
    assert_eq!(pairs, [("world", "base"), ("base", "arm"), ("world", "object/jif")]);
    let expected_base_from_arm = iso([0.1, 0.2, 0.3], [0.1, -0.2, 0.4 + 0.1]);
    let tr = &transforms[1]["translation"];
    let q = &transforms[1]["rotation"];
    let got = Iso3::from_parts(
        nalgebra::Translation3::new(
            tr["x"].as_f64().unwrap(),
            tr["y"].as_f64().unwrap(),
            tr["z"].as_f64().unwrap(),
        ),
        nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            q["w"].as_f64().unwrap(),
            q["x"].as_f64().unwrap(),
            q["y"].as_f64().unwrap(),
            q["z"].as_f64().unwrap(),
        )),
    );
    let err = got.inv_mul(&expected_base_from_arm);
    // Rounded to 6 decimals.
    assert!(err.translation.vector.norm() < 1e-6 && err.rotation.angle() < 1e-5);

    // Fingertips and activity.
    let (_, ft) = &by_topic[TOPIC_FINGERTIPS][0];
    let tips = ft["fingertips"].as_array().unwrap();
    assert_eq!(tips.len(), 6);
    assert_eq!(keys(&tips[4]), ["arm", "finger", "force", "in_contact", "torque"]);
    assert_eq!(
        (tips[4]["arm"].as_str(), tips[4]["finger"].as_u64()),
        (Some("right"), Some(2))
    );
    assert_eq!(tips[4]["force"]["z"], 2.0);
    assert_eq!(by_topic[TOPIC_ACTIVITY][1].1["text"], "reach left → jif");
    assert_eq!(by_topic[TOPIC_ACTIVITY][1].0, 200_000_000);

    // Log and image.
    let (_, log_msg) = &by_topic[TOPIC_LOG][0];
    assert_eq!(keys(log_msg), ["file", "level", "line", "message", "name", "timestamp"]);
    assert_eq!(log_msg["level"], "WARNING");
    let (_, image) = &by_topic["/camera/head_left/image"][0];
    assert_eq!(
        keys(image),
        ["data", "encoding", "frame_id", "height", "step", "timestamp", "width"]
    );
    assert_eq!(
        (image["encoding"].as_str(), image["step"].as_u64()),
        (Some("rgb8"), Some(12))
    );
    let data = base64::engine::general_purpose::STANDARD
        .decode(image["data"].as_str().unwrap())
        .unwrap();
    assert_eq!(data, rgb);

    // Attachments and metadata.
    let attachment = summary
        .attachment_indexes
        .first()
        .map(|ix| mcap::read::attachment(&bytes, ix).unwrap());
    let attachment = attachment.expect("one attachment");
    assert_eq!(
        (attachment.name.as_str(), attachment.media_type.as_str()),
        ("dexter.urdf", "application/xml")
    );
    assert_eq!(&*attachment.data, b"<robot name=\"dexter\"/>");
    assert_eq!(summary.metadata_indexes.len(), 1);

    // The reader helper agrees.
    let s = read_summary(&tmp.0).unwrap();
    assert_eq!(s.status, FileStatus::Complete);
    assert!(s.issues.is_empty(), "{:?}", s.issues);
    assert_eq!(s.message_count, stats.messages);
    assert_eq!(s.count(TOPIC_TF), 10);
    assert_eq!(s.channel(TOPIC_TF).unwrap().schema_name, "foxglove.FrameTransforms");
    assert_eq!(s.time_range_ns, Some((0, 450_000_000)));
    assert_eq!(s.attachments, ["dexter.urdf"]);
    assert_eq!(s.metadata, ["run"]);
    assert_eq!(s.file_bytes, stats.bytes);
}

#[test]
fn frame_transforms_are_foxglove_protobuf_messages_with_the_chosen_frames() {
    let header = header();
    let mut tree = FrameTree::new(&header);
    let snap = snapshot(1.5, "");
    let policy = McapLogOptions::default().tf_policy();
    assert_eq!(
        tree.update(time_ns(snap.time), &snap.link_poses, &snap.objects, &policy),
        3
    );
    let mut buf = vec![7u8; 3];
    tree.encode_transforms(Time::from_ns(time_ns(snap.time)), &mut buf);
    // Field by field: the frames written from their templates decode as one FrameTransforms.
    let msg = <foxglove::messages::FrameTransforms as prost::Message>::decode(buf.as_slice()).unwrap();
    let pairs: Vec<(&str, &str)> = msg
        .transforms
        .iter()
        .map(|t| (t.parent_frame_id.as_str(), t.child_frame_id.as_str()))
        .collect();
    assert_eq!(pairs, [("world", "base"), ("base", "arm"), ("world", "object/jif")]);
    for t in &msg.transforms {
        assert_eq!(t.timestamp, Some(foxglove::messages::Timestamp::new(1, 500_000_000)));
        let q = t.rotation.unwrap();
        assert!((q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w - 1.0).abs() < 1e-5);
    }
    // As JSON, the Foxglove field names.
    let v = message_json("foxglove.FrameTransforms", "protobuf", &buf).unwrap();
    assert_eq!(
        keys(&v["transforms"][0]),
        [
            "child_frame_id",
            "parent_frame_id",
            "rotation",
            "timestamp",
            "translation"
        ]
    );
}

#[test]
fn scene_entities_have_every_required_field_and_one_primitive_per_colour_band() {
    let header = header();
    let update = scene::scene_update(&scene(), &header, Time::from_ns(0)).unwrap();
    let v = serde_json::to_value(update.proto()).unwrap();
    assert_eq!(keys(&v), ["deletions", "entities"]);
    assert_eq!(v["deletions"][0]["type"], "ALL");
    let required = [
        "arrows",
        "cubes",
        "cylinders",
        "frame_id",
        "frame_locked",
        "id",
        "lifetime",
        "lines",
        "metadata",
        "models",
        "spheres",
        "texts",
        "timestamp",
        "triangles",
    ];
    let entities = v["entities"].as_array().unwrap();
    let ids: Vec<&str> = entities.iter().map(|e| e["id"].as_str().unwrap()).collect();
    assert_eq!(ids, ["table", "place/bin-a", "place/mark", "object/jif"]);
    for e in entities {
        for k in required {
            assert!(e.get(k).is_some(), "{k} in {e}");
        }
    }
    assert_eq!(entities[0]["cubes"].as_array().unwrap().len(), 5, "top and four legs");
    assert_eq!(
        entities[1]["cubes"].as_array().unwrap().len(),
        5,
        "floor and four walls"
    );
    assert_eq!(entities[2]["cubes"].as_array().unwrap().len(), 1, "a flat region");
    let jif = &entities[3];
    assert_eq!(
        (jif["frame_id"].as_str(), jif["frame_locked"].as_bool()),
        (Some("object/jif"), Some(true))
    );
    let bands = jif["cylinders"].as_array().unwrap();
    assert_eq!(bands.len(), 2);
    // Bottom band: 30 % of 0.12 m, red.
    assert!((bands[0]["size"]["z"].as_f64().unwrap() - 0.036).abs() < 1e-12);
    assert!((bands[0]["pose"]["position"]["z"].as_f64().unwrap() - (-0.06 + 0.018)).abs() < 1e-12);
    assert!(bands[0]["color"]["r"].as_f64().unwrap() > 0.7 && bands[0]["color"]["b"].as_f64().unwrap() < 0.1);
    assert_eq!(bands[0]["size"]["x"], 0.08);

    let mut wrong = header.clone();
    wrong.object_names.push("extra".into());
    assert!(scene::scene_update(&scene(), &wrong, Time::from_ns(0)).is_err());
}

#[test]
fn inconsistent_input_is_an_error_not_a_panic() {
    let tmp = TempFile::new("bad-input");
    let header = header();
    let mut log = McapLog::create(&tmp.0).unwrap();
    let mut snap = snapshot(0.0, "");
    snap.link_poses.pop();
    let err = log.log_snapshot(&header, &snap).unwrap_err();
    assert!(format!("{err:#}").contains("link poses"), "{err:#}");
    let err = log.log_image(0.0, "cam", 4, 3, &[0; 35]).unwrap_err();
    assert!(format!("{err:#}").contains("36 bytes"), "{err:#}");
    let err = log
        .log_scene(
            &scene(),
            &SnapshotHeader {
                object_names: vec![],
                ..header
            },
            0.0,
        )
        .unwrap_err();
    assert!(format!("{err:#}").contains("objects"), "{err:#}");
    assert_eq!(log.finish().unwrap().messages, 0);
}

/// Writes `n` snapshots of a 60-link robot; returns the messages written.
fn write_snapshots(log: &mut McapLog, n: usize) -> u64 {
    let (header, snaps) = big_robot(16);
    for i in 0..n {
        let mut snap = snaps[i % snaps.len()].clone();
        snap.time = i as f64 / 100.0;
        log.log_snapshot(&header, &snap).unwrap();
    }
    // tf, joint states and fingertips per snapshot, plus one activity.
    3 * n as u64 + 1
}

/// A chain-and-branches robot with 60 links, 30 joints and 5 objects, and `variants` snapshots
/// of it in different poses (so that compression sees realistic, changing numbers).
fn big_robot(variants: usize) -> (SnapshotHeader, Vec<Snapshot>) {
    let links = 60;
    let link_names: Vec<String> = std::iter::once("world".to_owned())
        .chain((1..links).map(|i| format!("link_{i:02}")))
        .collect();
    let link_parents: Vec<Option<String>> = (0..links)
        .map(|i| {
            if i == 0 {
                None
            } else {
                Some(link_names[(i - 1) / 2].clone())
            }
        })
        .collect();
    let header = SnapshotHeader {
        joint_names: (0..30).map(|i| format!("joint_{i:02}")).collect(),
        link_names,
        link_parents,
        object_names: (0..5).map(|i| format!("object-{i}")).collect(),
    };
    let snaps = (0..variants)
        .map(|k| {
            let s = k as f64 * 0.037;
            let mut snap = snapshot(0.0, "reach left → object-0");
            snap.q = (0..30).map(|j| (s + j as f64).sin()).collect();
            snap.qd = (0..30).map(|j| (s + j as f64).cos()).collect();
            snap.q_ref = snap.q.iter().map(|q| q + 0.001).collect();
            snap.link_poses = (0..links)
                .map(|i| iso([0.01 * i as f64 + s, 0.2 * s.sin(), 0.5], [s, 0.1 * i as f64, -s]))
                .collect();
            snap.objects = (0..5)
                .map(|i| ObjectState {
                    pose: iso([0.5, 0.1 * i as f64, 0.8 + s], [0.0, 0.0, s]),
                    linvel: Vec3::zeros(),
                })
                .collect();
            snap
        })
        .collect();
    (header, snaps)
}

#[test]
fn a_file_cut_at_60_percent_recovers_the_messages_of_its_complete_chunks() {
    let tmp = TempFile::new("full");
    let options = McapLogOptions {
        chunk_bytes: 32 << 10,
        ..McapLogOptions::default()
    };
    let mut log = McapLog::create_with(&tmp.0, options).unwrap();
    let written = write_snapshots(&mut log, 240);
    let stats = log.finish().unwrap();
    assert_eq!(stats.messages, written);
    assert!(stats.chunks >= 10, "{} chunks", stats.chunks);

    let bytes = std::fs::read(&tmp.0).unwrap();
    let cut = TempFile::new("cut");
    std::fs::write(&cut.0, &bytes[..bytes.len() * 6 / 10]).unwrap();

    // mcap's own streaming reader yields the complete chunks' messages, then an error.
    let cut_bytes = std::fs::read(&cut.0).unwrap();
    let mut streamed = 0_u64;
    let mut stream_error = None;
    for m in mcap::MessageStream::new(&cut_bytes).unwrap() {
        match m {
            Ok(m) => {
                let schema = m.channel.schema.as_ref().map_or("", |s| s.name.as_str());
                message_json(schema, &m.channel.message_encoding, &m.data).expect("every recovered message is whole");
                streamed += 1;
            }
            Err(e) => {
                stream_error = Some(e);
                break;
            }
        }
    }
    assert!(stream_error.is_some(), "a cut file must end in an error");

    let s = read_summary(&cut.0).unwrap();
    let FileStatus::Recovered { messages, reason } = &s.status else {
        panic!("not recovered: {s:?}")
    };
    assert_eq!(*messages, s.message_count);
    assert!(!reason.is_empty());
    // 60 % of the file is a bit more of the data section (the summary repeats the ~12 kB of
    // schemas), less the chunk that was cut.
    let share = *messages as f64 / written as f64;
    assert!((0.45..0.7).contains(&share), "recovered {messages} of {written}");
    assert!(
        streamed >= *messages,
        "mcap streamed {streamed}, read_summary counted {messages}"
    );
    // Whole snapshots are in order: no topic is far ahead of another.
    let (tf, js) = (s.count(TOPIC_TF), s.count(TOPIC_JOINT_STATES));
    assert!(tf.abs_diff(js) <= 1, "tf {tf}, joint states {js}");
    let full = read_summary(&tmp.0).unwrap();
    assert_eq!(full.status, FileStatus::Complete);
    assert_eq!(full.message_count, written);
}

/// One flipped byte in one chunk costs that chunk only: the others are read, the file is reported
/// full length with the damaged chunk named, and a repair keeps everything readable.
#[test]
fn a_damaged_chunk_is_skipped_and_the_rest_is_read() {
    let tmp = TempFile::new("damaged");
    let options = McapLogOptions {
        chunk_bytes: 32 << 10,
        ..McapLogOptions::default()
    };
    let mut log = McapLog::create_with(&tmp.0, options).unwrap();
    let written = write_snapshots(&mut log, 240);
    let stats = log.finish().unwrap();
    assert!(stats.chunks >= 10, "{} chunks", stats.chunks);
    let mut bytes = std::fs::read(&tmp.0).unwrap();
    let i = bytes.len() * 3 / 10;
    bytes[i] ^= 0xFF;
    let bad = TempFile::new("damaged-bad");
    std::fs::write(&bad.0, &bytes).unwrap();

    let s = read_summary(&bad.0).unwrap();
    assert_eq!(s.status, FileStatus::Complete, "a full-length file is not cut short");
    assert_eq!(s.skipped_chunks.len(), 1, "{:?}", s.skipped_chunks);
    let lost = written - s.message_count;
    assert!(lost > 0 && lost < written / 5, "lost {lost} of {written}");

    let rec = read_recording(&bad.0, &[]).unwrap();
    assert_eq!(rec.messages.len() as u64, s.message_count);
    assert!(rec.foreign_channels.is_empty(), "{:?}", rec.foreign_channels);
    assert_eq!(rec.skipped_chunks, s.skipped_chunks);

    let fixed = TempFile::new("damaged-fixed");
    assert_eq!(repair(&bad.0, &fixed.0).unwrap(), s.message_count);
    let r = read_summary(&fixed.0).unwrap();
    assert_eq!(
        (r.status, r.skipped_chunks.len(), r.message_count),
        (FileStatus::Complete, 0, s.message_count)
    );
}

#[test]
fn a_crashed_writer_leaves_every_flushed_chunk_on_disk() {
    let tmp = TempFile::new("crash");
    let options = McapLogOptions {
        chunk_bytes: 32 << 10,
        ..McapLogOptions::default()
    };
    let mut log = McapLog::create_with(&tmp.0, options).unwrap();
    write_snapshots(&mut log, 40);
    log.flush().unwrap();
    let flushed = log.sequence as u64;
    // Less than a chunk after the flush, so these stay in memory.
    for i in 0..3 {
        log.log_text(10.0 + f64::from(i), LogLevel::Info, "lost in the crash")
            .unwrap();
    }
    // A crash: no drop, no finish, the buffered writer's contents are never written.
    std::mem::forget(log);
    let s = read_summary(&tmp.0).unwrap();
    let FileStatus::Recovered { reason, .. } = &s.status else {
        panic!("not recovered: {s:?}")
    };
    assert!(reason.contains("before its footer"), "{reason}");
    assert_eq!(s.message_count, flushed);
}

#[test]
fn dropping_an_unfinished_log_finishes_the_file() {
    let tmp = TempFile::new("drop");
    {
        let mut log = McapLog::create(&tmp.0).unwrap();
        log.log_text(0.5, LogLevel::Info, "hello").unwrap();
    }
    let s = read_summary(&tmp.0).unwrap();
    assert_eq!(s.status, FileStatus::Complete);
    assert_eq!(s.count(TOPIC_LOG), 1);
}

#[test]
fn a_file_that_is_not_mcap_is_an_error() {
    let tmp = TempFile::new("not-mcap");
    std::fs::write(&tmp.0, b"hello, world").unwrap();
    let err = read_summary(&tmp.0).unwrap_err();
    assert!(format!("{err:#}").contains("not an MCAP file"), "{err:#}");
    assert!(read_summary(tmp.0.with_extension("missing")).is_err());
}

/// CPU time of this thread (s), from Linux's schedstat: on a shared machine wall time says little.
fn thread_cpu_secs() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    Some(stat.split_whitespace().next()?.parse::<f64>().ok()? * 1e-9)
}

/// `cargo test --release -p pbd-cli mcap_log::tests::throughput -- --ignored --nocapture`
#[test]
#[ignore = "a measurement, run in release"]
fn throughput() {
    let (header, mut snaps) = big_robot(256);
    let tmp = TempFile::new("throughput");
    let mut log = McapLog::create(&tmp.0).unwrap();
    let n = 20_000;
    let (wall, cpu) = (Instant::now(), thread_cpu_secs());
    for i in 0..n {
        let snap = &mut snaps[i % 256];
        snap.time = i as f64 / 100.0;
        log.log_snapshot(&header, snap).unwrap();
    }
    let stats = log.finish().unwrap();
    let wall = wall.elapsed().as_secs_f64();
    let cpu = thread_cpu_secs().zip(cpu).map_or(wall, |(b, a)| b - a);
    let read_cpu = thread_cpu_secs();
    let s = read_summary(&tmp.0).unwrap();
    let read_cpu = thread_cpu_secs().zip(read_cpu).map_or(f64::NAN, |(b, a)| b - a);
    println!(
        "{n} snapshots of {} links, {} joints, {} objects: {:.1} µs CPU/snapshot ({:.0} snapshots/s, {:.0} \
         messages/s; wall {:.1} µs), {} chunks, {:.2} MB ({} B/snapshot); read_summary {:.0} messages/s CPU",
        header.link_names.len(),
        header.joint_names.len(),
        header.object_names.len(),
        cpu / n as f64 * 1e6,
        n as f64 / cpu,
        stats.messages as f64 / cpu,
        wall / n as f64 * 1e6,
        stats.chunks,
        stats.bytes as f64 / 1e6,
        stats.bytes / n as u64,
        s.message_count as f64 / read_cpu,
    );
    // A noisy image (±3 levels, like the simulator's pixel noise) over a smooth gradient.
    let mut seed = 12345_u32;
    let rgb: Vec<u8> = (0..160 * 120 * 3)
        .map(|i| {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            ((i / 480) as u8).wrapping_add((seed >> 29) as u8)
        })
        .collect();
    let tmp = TempFile::new("images");
    let mut log = McapLog::create(&tmp.0).unwrap();
    let cpu = thread_cpu_secs();
    for i in 0..400 {
        log.log_image(f64::from(i) / 40.0, "head_left", 160, 120, &rgb).unwrap();
    }
    let stats = log.finish().unwrap();
    let cpu = thread_cpu_secs().zip(cpu).map_or(f64::NAN, |(b, a)| b - a);
    println!(
        "160×120 rgb8 images: {:.0} µs CPU each, {} B each in the file (57600 B raw)",
        cpu / 400.0 * 1e6,
        stats.bytes / 400
    );
}

/// Channels pbd did not write (protobuf messages, a ROS 2 schema) are skipped with a note, never
/// JSON-parsed; bytes after the footer make the file malformed.
#[test]
fn foreign_channels_are_skipped_and_trailing_bytes_reported() {
    let tmp = TempFile::new("foreign");
    {
        let mut w = mcap::Writer::new(std::io::BufWriter::new(File::create(&tmp.0).unwrap())).unwrap();
        let ros = w
            .add_schema("sensor_msgs/msg/PointCloud2", "ros2msg", b"uint32 height")
            .unwrap();
        let cloud = w.add_channel(ros, "/pbd/percept", "cdr", &BTreeMap::new()).unwrap();
        let json = w.add_channel(0, "/pbd/percept", "json", &BTreeMap::new()).unwrap();
        let proto = w.add_channel(0, "/other", "protobuf", &BTreeMap::new()).unwrap();
        for (channel, data) in [
            (cloud, &b"\x00\x01binary"[..]),
            (json, b"{\"t\":0}"),
            (proto, b"\x08\x01"),
        ] {
            w.write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: channel,
                    sequence: 0,
                    log_time: 1,
                    publish_time: 1,
                },
                data,
            )
            .unwrap();
        }
        w.finish().unwrap();
    }
    let rec = read_recording(&tmp.0, &["/pbd/percept"]).unwrap();
    assert_eq!(rec.messages.len(), 1, "only the JSON channel is read");
    assert_eq!(rec.messages[0].2, b"{\"t\":0}".to_vec());
    assert_eq!(rec.foreign_channels.len(), 1, "{:?}", rec.foreign_channels);
    assert!(
        rec.foreign_channels[0].contains("PointCloud2"),
        "{:?}",
        rec.foreign_channels
    );
    let all = read_recording(&tmp.0, &[]).unwrap();
    assert!(all.foreign_channels.iter().any(|c| c.contains("protobuf")));
    assert!(read_summary(&tmp.0).unwrap().skipped_chunks.is_empty());
    // Data appended after the footer.
    let mut bytes = std::fs::read(&tmp.0).unwrap();
    bytes.extend_from_slice(b"trailing garbage");
    std::fs::write(&tmp.0, &bytes).unwrap();
    let s = read_summary(&tmp.0).unwrap();
    let FileStatus::Malformed { reason } = &s.status else {
        panic!("{:?}", s.status)
    };
    assert!(
        reason.contains(&format!(
            "16 bytes after the end of the recording at offset {}",
            bytes.len() - 16
        )) && reason.contains("after the footer"),
        "{reason}"
    );
    // Refused by the readers of recordings, naming the file.
    let e = format!("{:#}", read_recording(&tmp.0, &[]).unwrap_err());
    assert!(
        e.contains(&tmp.0.display().to_string()) && e.contains("after the end"),
        "{e}"
    );
}

/// The frames written by each `/tf` message, as (parent, child) pairs.
fn tf_pairs(tf: &Value) -> Vec<(String, String)> {
    tf["transforms"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            (
                t["parent_frame_id"].as_str().unwrap().to_owned(),
                t["child_frame_id"].as_str().unwrap().to_owned(),
            )
        })
        .collect()
}

#[test]
fn tf_writes_what_moved_and_everything_at_keyframes() {
    let tmp = TempFile::new("tf-delta");
    let header = header();
    let mut log = McapLog::create(&tmp.0).unwrap();
    // 0.0, 0.1, …, 2.0 s: `arm` turns 0.1 rad per snapshot; `base` and the object rest.
    for i in 0..=20 {
        log.log_snapshot(&header, &snapshot(0.1 * f64::from(i), "")).unwrap();
    }
    // A resting snapshot repeated: nothing moved, no keyframe due, no message.
    log.log_snapshot(&header, &snapshot(2.0, "")).unwrap();
    log.finish().unwrap();
    let by_topic = messages_by_topic(&std::fs::read(&tmp.0).unwrap());
    let tf = &by_topic[TOPIC_TF];
    assert_eq!(tf.len(), 21, "one message per snapshot that moved");
    let all = [("world", "base"), ("base", "arm"), ("world", "object/jif")].map(|(p, c)| (p.to_owned(), c.to_owned()));
    let arm_only = vec![("base".to_owned(), "arm".to_owned())];
    for (i, (t, msg)) in tf.iter().enumerate() {
        // Keyframes every 1 s of log time: at 0, 1 and 2 s.
        let keyframe = i % 10 == 0;
        assert_eq!(*t, time_ns(0.1 * i as f64));
        assert_eq!(
            tf_pairs(msg),
            if keyframe { all.to_vec() } else { arm_only.clone() },
            "message {i}"
        );
    }
    // Joint states are written every snapshot, rounded to 6 decimals.
    let js = &by_topic[TOPIC_JOINT_STATES];
    assert_eq!(js.len(), 22);
    assert_eq!(js[3].1["position"][0], 0.03);
}

#[test]
fn images_are_h264_by_default_with_their_calibration_and_png_is_lossless() {
    let (w, h) = (32u32, 24u32);
    // A smooth gradient with a little noise, as the cameras see the table.
    let rgb: Vec<u8> = (0..w * h)
        .flat_map(|i| {
            let (x, y) = (i % w, i / w);
            [(x * 8) as u8, (y * 10) as u8, ((x * 7 + y * 3) % 256) as u8]
        })
        .collect();
    let view = CameraView {
        name: "head_left",
        frame_id: "head/left_camera_optical_frame",
        focal: [100.0, 101.0],
        principal: [15.5, 11.5],
    };
    assert_eq!(ImageFormat::default(), ImageFormat::H264 { qp: 26 });
    for format in [
        ImageFormat::default(),
        ImageFormat::Png,
        ImageFormat::Jpeg { quality: 50 },
        ImageFormat::JPEG,
    ] {
        let tmp = TempFile::new("images");
        let options = McapLogOptions {
            image_format: format,
            ..Default::default()
        };
        let mut log = McapLog::create_with(&tmp.0, options).unwrap();
        log.log_camera_image(0.5, &view, w, h, &rgb).unwrap();
        assert!(
            log.log_camera_image(0.6, &view, w, h, &rgb[1..]).is_err(),
            "wrong size refused"
        );
        log.finish().unwrap();
        let bytes = std::fs::read(&tmp.0).unwrap();
        let by_topic = messages_by_topic(&bytes);
        let (_, image) = &by_topic["/camera/head_left/image"][0];
        assert_eq!(keys(image), ["data", "format", "frame_id", "timestamp"], "{format}");
        assert_eq!(image["frame_id"], "head/left_camera_optical_frame");
        let data = base64::engine::general_purpose::STANDARD
            .decode(image["data"].as_str().unwrap())
            .unwrap();
        match format {
            ImageFormat::Png => {
                assert_eq!(image["format"], "png");
                let mut reader = png::Decoder::new(std::io::Cursor::new(&data)).read_info().unwrap();
                let mut out = vec![0; reader.output_buffer_size().unwrap()];
                let info = reader.next_frame(&mut out).unwrap();
                assert_eq!((info.width, info.height), (w, h));
                assert_eq!(&out[..info.buffer_size()], &rgb[..], "PNG is lossless");
            }
            ImageFormat::H264 { .. } => {
                assert_eq!(image["format"], "h264");
                assert_eq!(&data[..4], &[0, 0, 0, 1], "Annex B");
                let out = decode_h264(&mut openh264::decoder::Decoder::new().unwrap(), &data, w, h).unwrap();
                // 4:2:0 chroma on a blue channel that wraps every few pixels: the quality of a
                // camera frame is the next test's.
                assert!(psnr(&out, &rgb) > 25.0, "PSNR {:.1} dB", psnr(&out, &rgb));
            }
            _ => {
                assert_eq!(image["format"], "jpeg");
                assert_eq!(&data[..2], &[0xFF, 0xD8], "a JPEG starts with SOI");
                assert!(data.len() < rgb.len(), "{} bytes for {} raw", data.len(), rgb.len());
            }
        }
        let (t, cal) = &by_topic["/camera/head_left/calibration"][0];
        assert_eq!(*t, 500_000_000);
        assert_eq!(cal["frame_id"], "head/left_camera_optical_frame");
        assert_eq!((cal["width"].as_u64(), cal["height"].as_u64()), (Some(32), Some(24)));
        assert_eq!(
            cal["k"],
            serde_json::json!([100.0, 0.0, 15.5, 0.0, 101.0, 11.5, 0.0, 0.0, 1.0])
        );
        assert_eq!(cal["p"].as_array().unwrap().len(), 12);
    }
    assert_eq!(
        "jpeg:70".parse::<ImageFormat>().unwrap(),
        ImageFormat::Jpeg { quality: 70 }
    );
    assert_eq!("png".parse::<ImageFormat>().unwrap(), ImageFormat::Png);
    assert_eq!("h264:30".parse::<ImageFormat>().unwrap(), ImageFormat::H264 { qp: 30 });
    assert_eq!("h264".parse::<ImageFormat>().unwrap().to_string(), "h264:26");
    for bad in ["jpeg:0", "jpeg:101", "gif", "", "h264:52", "h264:", "h265"] {
        assert!(bad.parse::<ImageFormat>().is_err(), "{bad}");
    }
}

/// Decodes one `CompressedVideo` frame to `rgb8` (`None` while the decoder waits for a keyframe).
fn decode_h264(decoder: &mut openh264::decoder::Decoder, data: &[u8], w: u32, h: u32) -> Option<Vec<u8>> {
    use openh264::formats::YUVSource;
    let yuv = decoder.decode(data).ok()??;
    assert_eq!(yuv.dimensions(), (w as usize, h as usize));
    let mut out = vec![0; (w * h * 3) as usize];
    yuv.write_rgb8(&mut out);
    Some(out)
}

fn psnr(a: &[u8], b: &[u8]) -> f64 {
    let mse = a
        .iter()
        .zip(b)
        .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2))
        .sum::<f64>()
        / a.len() as f64;
    10.0 * (255.0f64.powi(2) / mse.max(1e-12)).log10()
}

/// A camera's frames as H.264: every frame one message that decodes in order; every keyframe
/// (each [`H264_KEYFRAME_INTERVAL`]-th frame) carries what a fresh decoder needs, so that a
/// viewer seeks to it and a reader of a file cut short starts again there; the same frames give
/// the same bytes; a moving scene costs a fraction of JPEG's bytes at a PSNR as good.
#[test]
fn h264_frames_decode_in_order_and_from_every_keyframe() {
    let (w, h) = (160u32, 120u32);
    // A noisy table with a block sliding across it: most of a frame is the frame before.
    let frame = |k: u32| -> Vec<u8> {
        let mut seed = 12_345u32.wrapping_add(k.wrapping_mul(7919));
        (0..w * h)
            .flat_map(|i| {
                let (x, y) = (i % w, i / w);
                let block = (40..70).contains(&y) && (k * 3..k * 3 + 25).contains(&x);
                let base = if block {
                    [200u32, 40, 30]
                } else {
                    [120 + y / 4, 100 + x / 8, 80]
                };
                base.map(|c| {
                    seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    (c + (seed >> 29)).min(255) as u8
                })
            })
            .collect()
    };
    let frames: Vec<Vec<u8>> = (0..25).map(frame).collect();
    let write = |format: ImageFormat| -> (Vec<serde_json::Value>, u64) {
        let tmp = TempFile::new("video");
        let options = McapLogOptions {
            image_format: format,
            ..Default::default()
        };
        let mut log = McapLog::create_with(&tmp.0, options).unwrap();
        for (k, f) in frames.iter().enumerate() {
            log.log_image(k as f64 * 0.1, "head_left", w, h, f).unwrap();
        }
        log.finish().unwrap();
        let bytes = std::fs::read(&tmp.0).unwrap();
        let data = messages_by_topic(&bytes)["/camera/head_left/image"]
            .iter()
            .map(|(_, m)| m.clone())
            .collect();
        (data, bytes.len() as u64)
    };
    let (video, video_bytes) = write(ImageFormat::default());
    let (jpeg, jpeg_bytes) = write(ImageFormat::JPEG);
    assert_eq!(video.len(), frames.len(), "one message per frame");
    assert_eq!(write(ImageFormat::default()).0, video, "deterministic");
    let data: Vec<Vec<u8>> = video
        .iter()
        .map(|m| {
            base64::engine::general_purpose::STANDARD
                .decode(m["data"].as_str().unwrap())
                .unwrap()
        })
        .collect();
    let mut decoder = openh264::decoder::Decoder::new().unwrap();
    let mut worst = f64::INFINITY;
    for (k, d) in data.iter().enumerate() {
        let out = decode_h264(&mut decoder, d, w, h).unwrap_or_else(|| panic!("frame {k} did not decode"));
        worst = worst.min(psnr(&out, &frames[k]));
    }
    let jpeg_psnr = jpeg
        .iter()
        .zip(&frames)
        .map(|(m, f)| {
            let d = base64::engine::general_purpose::STANDARD
                .decode(m["data"].as_str().unwrap())
                .unwrap();
            let mut dec = jpeg_decoder::Decoder::new(std::io::Cursor::new(d));
            psnr(&dec.decode().unwrap(), f)
        })
        .fold(f64::INFINITY, f64::min);
    println!(
        "25 frames 160×120: H.264 {video_bytes} B, worst PSNR {worst:.1} dB; JPEG 85 {jpeg_bytes} B, worst {jpeg_psnr:.1} dB"
    );
    assert!(worst > 30.0, "worst PSNR {worst:.1} dB");
    assert!(
        video_bytes * 2 < jpeg_bytes,
        "video {video_bytes} B, JPEG {jpeg_bytes} B"
    );
    let k = H264_KEYFRAME_INTERVAL as usize;
    for start in [k, 2 * k] {
        let mut fresh = openh264::decoder::Decoder::new().unwrap();
        for (j, d) in data.iter().enumerate().skip(start) {
            let out = decode_h264(&mut fresh, d, w, h).unwrap_or_else(|| panic!("frame {j} after keyframe {start}"));
            assert!(psnr(&out, &frames[j]) > 30.0);
        }
    }
    let mut fresh = openh264::decoder::Decoder::new().unwrap();
    assert!(
        decode_h264(&mut fresh, &data[k + 1], w, h).is_none(),
        "a frame between keyframes needs the ones before it"
    );
}

#[test]
fn the_robot_is_drawn_and_fingertip_forces_are_arrows_at_the_tips() {
    let model = control_basis::RobotModel::from_urdf_str(dexter_sim::physics::DEXTER_URDF).unwrap();
    // The robot's links, plus the tip links the fingertip sensors sit on.
    let links: Vec<String> = model.links.iter().map(|l| l.name.clone()).collect();
    let header = SnapshotHeader {
        joint_names: vec![],
        link_parents: vec![None; links.len()],
        link_names: links.clone(),
        object_names: vec![],
    };
    let tip = links.iter().position(|l| l == "right/bhand/finger_2/tip_link").unwrap();
    let snap = |time: f64, force: f64| {
        let mut link_poses = vec![Iso3::identity(); links.len()];
        link_poses[tip] = iso([0.5, -0.2, 0.9], [0.0, 0.0, 0.0]);
        let fingertips = Arm::BOTH
            .iter()
            .flat_map(|&arm| {
                (1..=3).map(move |finger| FingertipWrench {
                    arm,
                    finger,
                    force: if arm == Arm::Right && finger == 2 {
                        [0.0, force, 0.0]
                    } else {
                        [0.0; 3]
                    },
                    torque: [0.0; 3],
                    in_contact: force > 0.0,
                })
            })
            .collect();
        Snapshot {
            time,
            q: vec![],
            qd: vec![],
            q_ref: vec![],
            link_poses,
            objects: vec![],
            fingertips,
            activity: String::new(),
        }
    };
    let tmp = TempFile::new("robot");
    let mut log = McapLog::create(&tmp.0).unwrap();
    log.log_robot(&model, 0.0).unwrap();
    // No force, 4 N, 4 N, then none twice: arrows while touching and one message to clear them.
    for (i, f) in [0.0, 4.0, 4.0, 0.0, 0.0].into_iter().enumerate() {
        log.log_snapshot(&header, &snap(0.1 * i as f64, f)).unwrap();
    }
    log.finish().unwrap();
    let by_topic = messages_by_topic(&std::fs::read(&tmp.0).unwrap());

    let robot = &by_topic[TOPIC_ROBOT];
    assert_eq!(robot.len(), 1);
    let entities = robot[0].1["entities"].as_array().unwrap();
    assert!(entities.len() > 40);
    for e in entities {
        let frame = e["frame_id"].as_str().unwrap();
        assert!(links.iter().any(|l| l == frame), "{frame} is a link frame");
        assert_eq!(e["frame_locked"], true);
    }

    let arrows = &by_topic[TOPIC_FINGERTIP_ARROWS];
    assert_eq!(arrows.len(), 3, "two with an arrow, one that clears it");
    let drawn = |m: &Value| -> Vec<String> {
        m["entities"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|e| !e["arrows"].as_array().unwrap().is_empty())
            .map(|e| e["id"].as_str().unwrap().to_owned())
            .collect()
    };
    assert_eq!(drawn(&arrows[0].1), ["fingertip/right/2"]);
    assert!(drawn(&arrows[2].1).is_empty());
    let e = &arrows[0].1["entities"][4];
    assert_eq!(e["frame_id"], "world");
    let a = &e["arrows"][0];
    // On the 2⁻²⁰ grid (≈ 1 µm), as `/tf` is.
    let p = &a["pose"]["position"];
    for (axis, want) in [("x", 0.5), ("y", -0.2), ("z", 0.9)] {
        assert!((p[axis].as_f64().unwrap() - want).abs() < 1e-6, "{p}");
    }
    let length = a["shaft_length"].as_f64().unwrap() + a["head_length"].as_f64().unwrap();
    assert!((length - 4.0 * ARROW_M_PER_N).abs() < 1e-6);
}

/// A record whose string length says 4 GB once made the `mcap` crate reserve 4 GB before reading
/// it (found by `cargo fuzz run mcap_reader`): the lengths are checked against the record first.
#[test]
fn huge_string_lengths_are_refused_before_any_allocation() {
    let record = |opcode: u8, body: &[u8]| {
        let mut r = vec![opcode];
        r.extend_from_slice(&(body.len() as u64).to_le_bytes());
        r.extend_from_slice(body);
        r
    };
    // A header whose profile claims 0xF3000000 bytes: not one record parses, so not MCAP.
    let mut bytes = mcap::MAGIC.to_vec();
    bytes.extend(record(0x01, &[0x00, 0x00, 0x00, 0xF3, 0, 0, 0, 0]));
    let e = format!("{:#}", read_summary_bytes(&bytes).unwrap_err());
    assert!(
        e.contains("header record: field `profile` claims 4076863488 bytes"),
        "{e}"
    );
    // A valid header, then metadata whose map entry claims 4 GB: the file is read up to it.
    let mut bytes = mcap::MAGIC.to_vec();
    bytes.extend(record(0x01, &[0; 8]));
    let mut metadata = vec![1, 0, 0, 0, b'm'];
    metadata.extend_from_slice(&8u32.to_le_bytes());
    metadata.extend_from_slice(&[0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0, 0]);
    bytes.extend(record(0x0C, &metadata));
    let s = read_summary_bytes(&bytes).unwrap();
    match s.status {
        FileStatus::Recovered { reason, .. } => {
            assert!(
                reason.contains("metadata record: field `metadata key` claims"),
                "{reason}"
            )
        }
        other => panic!("{other:?}"),
    }
    let r = read_recording_bytes(&bytes, &[]).unwrap();
    assert!(r.metadata.is_empty());
}

#[test]
fn a_ros2_log_is_cdr_with_ros2msg_schemas_throughout_and_reads_back() {
    use pbd_ros2_msgs::msg;
    let header = header();
    let percept = schema::percept::Percept {
        t: 0.1,
        hands: Vec::new(),
        segments: Vec::new(),
        places: Vec::new(),
        table_z: 0.75,
        gaze: Some(3),
    };
    let view = CameraView {
        name: "head_left",
        frame_id: "arm",
        focal: [100.0, 101.0],
        principal: [1.5, 1.0],
    };
    let rgb: Vec<u8> = (0..4 * 3 * 3).map(|i| i as u8).collect();
    let write = |tmp: &TempFile, encoding: Encoding| {
        let options = McapLogOptions {
            image_format: ImageFormat::Raw,
            tf_keyframe_secs: 0.0,
            encoding,
            ..Default::default()
        };
        let mut log = McapLog::create_with(&tmp.0, options).unwrap();
        log.log_scene(&scene(), &header, 0.0).unwrap();
        for i in 0..3 {
            log.log_snapshot(&header, &snapshot(0.05 * f64::from(i), "reach"))
                .unwrap();
        }
        log.log_text(0.1, LogLevel::Warning, "grasp slipped").unwrap();
        log.log_camera_image(0.1, &view, 4, 3, &rgb).unwrap();
        let any = serde_json::json!({ "type": "object" });
        log.log_json("/pbd/percept", "pbd.Percept", &any, 0.1, &percept)
            .unwrap();
        log.log_json(
            "/pbd/decision",
            "pbd.Decision",
            &any,
            0.1,
            &serde_json::json!({"place": "bin-a"}),
        )
        .unwrap();
        log.finish().unwrap();
    };
    let (ros, fox) = (TempFile::new("ros2"), TempFile::new("fox"));
    write(&ros, Encoding::Ros2);
    write(&fox, Encoding::Foxglove);
    let bytes = std::fs::read(&ros.0).unwrap();
    // The header record (opcode 1) holds the profile `ros2` (a u32 length, then the text).
    assert_eq!(bytes[8], 1);
    assert_eq!(&bytes[17..25], b"\x04\x00\x00\x00ros2");

    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    for c in summary.channels.values() {
        let s = c.schema.as_ref().unwrap();
        assert_eq!(
            (s.encoding.as_str(), c.message_encoding.as_str()),
            ("ros2msg", "cdr"),
            "{}",
            c.topic
        );
        // Each schema is the type's definition and those of the types it uses.
        let text = std::str::from_utf8(&s.data).unwrap();
        assert!(!text.contains("MSG: ") || text.contains(&"=".repeat(80)), "{text}");
    }
    let by_topic = messages_by_topic(&bytes);
    let q = |topic: &str, k: usize| -> Vec<f64> {
        serde_json::from_value(by_topic[topic][k].1["position"].clone()).unwrap()
    };
    for (k, (_, w)) in by_topic["/fingertips/right/3"].iter().enumerate() {
        let s = snapshot(0.05 * k as f64, "reach");
        assert_eq!(q("/joint_states", k), s.q, "encoders exactly (CDR carries the doubles)");
        assert_eq!(q("/joint_references", k), s.q_ref);
        assert_eq!(w["wrench"]["force"]["z"], 3.0);
        assert_eq!(w["header"]["frame_id"], "world");
    }
    assert_eq!(by_topic["/fingertips/left/1"].len(), 3);
    // /tf: the same frames as the Foxglove encoding writes.
    let fox_bytes = std::fs::read(&fox.0).unwrap();
    let fox_topics = messages_by_topic(&fox_bytes);
    let ros_pairs: Vec<(String, String)> = by_topic["/tf"][0].1["transforms"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            (
                t["header"]["frame_id"].as_str().unwrap().to_owned(),
                t["child_frame_id"].as_str().unwrap().to_owned(),
            )
        })
        .collect();
    assert_eq!(ros_pairs, tf_pairs(&fox_topics["/tf"][0].1));
    // The scene as markers: a DELETEALL first, then the table, places and object.
    let markers = by_topic["/scene"][0].1["markers"].as_array().unwrap();
    assert_eq!(markers[0]["action"], msg::Marker::DELETEALL);
    assert!(markers.len() > 4, "{}", markers.len());
    let log = &by_topic["/log"][0].1;
    assert_eq!(
        (log["level"].as_u64(), log["msg"].as_str()),
        (Some(30), Some("grasp slipped"))
    );
    let image = &by_topic["/camera/head_left/image"][0].1;
    assert_eq!((image["width"].as_u64(), image["step"].as_u64()), (Some(4), Some(12)));
    let info = &by_topic["/camera/head_left/camera_info"][0].1;
    assert_eq!(info["k"][0], 100.0);
    assert_eq!(info["header"]["frame_id"], "arm");

    // pbd's own messages read back as the JSON of the other encoding, byte for byte.
    let topics = ["/pbd/percept", "/pbd/decision"];
    let (r, f) = (
        read_recording(&ros.0, &topics).unwrap(),
        read_recording(&fox.0, &topics).unwrap(),
    );
    assert!(r.foreign_channels.is_empty(), "{:?}", r.foreign_channels);
    assert_eq!(r.messages, f.messages);
    assert_eq!(r.messages.len(), 2);
    // And every channel of the file is one pbd reads.
    assert!(read_recording(&ros.0, &[]).unwrap().foreign_channels.is_empty());
}

#[test]
fn log_encodings_parse_and_print() {
    for (text, want) in [
        ("foxglove", Encoding::Foxglove),
        ("json", Encoding::Foxglove),
        ("ros2", Encoding::Ros2),
        ("cdr", Encoding::Ros2),
    ] {
        assert_eq!(text.parse::<Encoding>().unwrap(), want);
    }
    assert_eq!(Encoding::Ros2.to_string(), "ros2");
    let e = "rosbag".parse::<Encoding>().unwrap_err().to_string();
    assert!(e.contains("rosbag") && e.contains("ros2"), "{e}");
}

//! `pbd grasp generate --mcap`: the ranked pre-grasps are drawn in Foxglove's 3D panel with the
//! presented scene and the robot.

use std::path::PathBuf;

use pbd::grasp::{GenerateOptions, generate};
use pbd::mcap_log::{TOPIC_GRASP_CANDIDATES, TOPIC_ROBOT, TOPIC_SCENE, TOPIC_TF, read_recording};
use serde_json::Value;

fn model() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../py/tests/data/grasp-prototypes.json")
}

#[test]
fn generated_pre_grasps_are_drawn_where_the_report_puts_them() {
    let dir = std::env::temp_dir().join(format!("pbd-grasp-candidates-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("candidates.mcap");
    let report = generate(&GenerateOptions {
        model: model(),
        object: "jif-1".into(),
        n: 4,
        mcap: Some(out.clone()),
        ..GenerateOptions::default()
    })
    .unwrap();
    assert!(!report.pre_grasps.is_empty());
    let rec = read_recording(&out, &[]).unwrap();
    for t in [TOPIC_SCENE, TOPIC_ROBOT, TOPIC_TF] {
        assert!(rec.topic(t).next().is_some(), "{t} is written");
    }
    let drawn: Vec<Value> = rec
        .topic(TOPIC_GRASP_CANDIDATES)
        .map(|(_, bytes)| pbd::mcap_log::message_json("foxglove.SceneUpdate", "protobuf", bytes).unwrap())
        .collect();
    assert_eq!(drawn.len(), 1);
    let entities = drawn[0]["entities"].as_array().unwrap();
    assert_eq!(entities.len(), report.pre_grasps.len());
    for (e, g) in entities.iter().zip(&report.pre_grasps) {
        assert_eq!(e["id"], format!("pre-grasp/{}", g.rank));
        // The approach arrow ends at the palm: its start plus its length along its direction.
        let a = &e["arrows"][0];
        let p = &a["pose"]["position"];
        let q = &a["pose"]["orientation"];
        let (x, y, z, w) = (
            q["x"].as_f64().unwrap(),
            q["y"].as_f64().unwrap(),
            q["z"].as_f64().unwrap(),
            q["w"].as_f64().unwrap(),
        );
        // +x of the arrow's frame, rotated by the quaternion.
        let dir = [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y + w * z),
            2.0 * (x * z - w * y),
        ];
        let len = a["shaft_length"].as_f64().unwrap() + a["head_length"].as_f64().unwrap();
        for (i, axis) in ["x", "y", "z"].iter().enumerate() {
            let tip = p[axis].as_f64().unwrap() + len * dir[i];
            assert!(
                (tip - g.world_position[i]).abs() < 1e-3,
                "rank {}: tip {tip} vs palm {:?}",
                g.rank,
                g.world_position
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_model_file_is_never_the_output() {
    let err = generate(&GenerateOptions {
        model: model(),
        object: "jif-1".into(),
        mcap: Some(model()),
        ..GenerateOptions::default()
    })
    .unwrap_err();
    assert!(format!("{err:#}").contains("grasp-prototypes.json"), "{err:#}");
}

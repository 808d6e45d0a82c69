//! The shipped Foxglove layout (`assets/foxglove/pbd-layout.json`) refers only to panels it
//! defines and to topics pbd writes.

use pbd::mcap_log::{
    FOXGLOVE_LAYOUT, TOPIC_ACTIVITY, TOPIC_DECISION, TOPIC_FINGERTIP_ARROWS, TOPIC_FINGERTIPS, TOPIC_GRASP_CANDIDATES,
    TOPIC_JOINT_STATES, TOPIC_LOG, TOPIC_ROBOT, TOPIC_SCENE, TOPIC_SCHEMA_STATE, TOPIC_TF, calibration_topic,
    camera_topic,
};
use serde_json::Value;

/// Every panel id the layout tree names.
fn panels(node: &Value, out: &mut Vec<String>) {
    match node {
        Value::String(id) => out.push(id.clone()),
        Value::Object(map) => {
            for key in ["first", "second"] {
                panels(&map[key], out);
            }
            assert!(matches!(map["direction"].as_str(), Some("row" | "column")));
        }
        other => panic!("unexpected layout node {other}"),
    }
}

/// Every topic a panel configuration refers to (topic keys, image and calibration topics, message
/// paths up to their first field).
fn topics(v: &Value, key: Option<&str>, out: &mut Vec<String>) {
    match v {
        Value::Object(map) => {
            for (k, child) in map {
                if k == "topics" {
                    out.extend(child.as_object().unwrap().keys().cloned());
                }
                topics(child, Some(k), out);
            }
        }
        Value::Array(items) => items.iter().for_each(|i| topics(i, key, out)),
        Value::String(s) if matches!(key, Some("imageTopic" | "calibrationTopic" | "topicPath" | "value")) => {
            out.push(s.split('.').next().unwrap().to_owned());
        }
        _ => {}
    }
}

#[test]
fn the_layout_shows_what_pbd_writes() {
    let layout: Value = serde_json::from_str(FOXGLOVE_LAYOUT).expect("the layout is JSON");
    let config = layout["configById"].as_object().unwrap();
    let mut ids = Vec::new();
    panels(&layout["layout"], &mut ids);
    ids.sort();
    let mut defined: Vec<String> = config.keys().cloned().collect();
    defined.sort();
    assert_eq!(
        ids, defined,
        "every panel is placed once and every placed panel is configured"
    );

    let mut used = Vec::new();
    topics(&layout["configById"], None, &mut used);
    let written = [
        TOPIC_TF,
        TOPIC_SCENE,
        TOPIC_ROBOT,
        TOPIC_FINGERTIPS,
        TOPIC_FINGERTIP_ARROWS,
        TOPIC_JOINT_STATES,
        TOPIC_ACTIVITY,
        TOPIC_LOG,
        TOPIC_SCHEMA_STATE,
        TOPIC_DECISION,
        TOPIC_GRASP_CANDIDATES,
    ]
    .map(str::to_owned)
    .into_iter()
    .chain(
        ["head_left", "head_right"]
            .into_iter()
            .flat_map(|c| [camera_topic(c), calibration_topic(c)]),
    )
    .collect::<Vec<_>>();
    assert!(used.len() > 10, "{used:?}");
    for t in &used {
        assert!(
            written.contains(t),
            "the layout refers to {t}, which pbd does not write"
        );
    }
    for t in [TOPIC_ROBOT, TOPIC_SCENE, TOPIC_FINGERTIP_ARROWS, TOPIC_SCHEMA_STATE] {
        assert!(used.iter().any(|u| u == t), "the layout shows {t}");
    }
}

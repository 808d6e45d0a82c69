//! JSON Schema texts (schema encoding `jsonschema`) for the channels of a pbd log.
//!
//! Foxglove recognises its well-known message types by schema *name* (`foxglove.FrameTransforms`, …)
//! and reads JSON messages with `JSON.parse`; the schema text tells it the field types, so that the
//! message-path syntax, plots and `bytes` fields work: a `time` is an object titled `time` with
//! `sec`/`nsec`, an enum is a `oneOf` of numeric `const`s, and a `bytes` field is a string with
//! `contentEncoding: base64` (Foxglove decodes it to bytes only because the schema says so).
//!
//! The Foxglove texts below follow the structure of the published schemas
//! (<https://docs.foxglove.dev/docs/sdk/schemas>, foxglove-sdk `schemas/jsonschema/*.json`) with field
//! names, types, titles and `required` lists kept and the prose descriptions dropped; the optional
//! `message_id` / `lineage` fields are left out because pbd never writes them. The `pbd.*` schemas are
//! pbd's own and carry their documentation.

use serde_json::{Map, Value, json};

/// `{type: object, title, properties, required}`.
fn object(title: &str, properties: &[(&str, Value)], required: &[&str]) -> Value {
    let props: Map<String, Value> = properties.iter().map(|(k, v)| ((*k).to_owned(), v.clone())).collect();
    let mut obj = Map::new();
    if !title.is_empty() {
        obj.insert("title".into(), json!(title));
    }
    obj.insert("type".into(), json!("object"));
    obj.insert("properties".into(), Value::Object(props));
    obj.insert("required".into(), json!(required));
    Value::Object(obj)
}

/// The same value with a `description` added.
fn described(mut v: Value, description: &str) -> Value {
    if let Value::Object(map) = &mut v {
        map.insert("description".into(), json!(description));
    }
    v
}

fn array(items: Value) -> Value {
    json!({ "type": "array", "items": items })
}

fn number() -> Value {
    json!({ "type": "number" })
}

fn string() -> Value {
    json!({ "type": "string" })
}

fn boolean() -> Value {
    json!({ "type": "boolean" })
}

fn uint() -> Value {
    json!({ "type": "integer", "minimum": 0 })
}

fn bytes() -> Value {
    json!({ "type": "string", "contentEncoding": "base64" })
}

fn time() -> Value {
    json!({
        "type": "object",
        "title": "time",
        "properties": {
            "sec": { "type": "integer", "minimum": 0 },
            "nsec": { "type": "integer", "minimum": 0, "maximum": 999_999_999 }
        }
    })
}

fn duration() -> Value {
    json!({
        "type": "object",
        "title": "duration",
        "properties": {
            "sec": { "type": "integer" },
            "nsec": { "type": "integer", "minimum": 0, "maximum": 999_999_999 }
        }
    })
}

/// A numeric enum: `oneOf` of `{title, const}`.
fn enumeration(title: &str, values: &[(&str, u32)]) -> Value {
    let one_of: Vec<Value> = values
        .iter()
        .map(|(name, v)| json!({ "title": name, "const": v }))
        .collect();
    json!({ "title": title, "oneOf": one_of })
}

fn vector3() -> Value {
    object(
        "foxglove.Vector3",
        &[("x", number()), ("y", number()), ("z", number())],
        &["x", "y", "z"],
    )
}

fn point3() -> Value {
    object(
        "foxglove.Point3",
        &[("x", number()), ("y", number()), ("z", number())],
        &["x", "y", "z"],
    )
}

fn quaternion() -> Value {
    object(
        "foxglove.Quaternion",
        &[("x", number()), ("y", number()), ("z", number()), ("w", number())],
        &["x", "y", "z", "w"],
    )
}

fn color() -> Value {
    object(
        "foxglove.Color",
        &[("r", number()), ("g", number()), ("b", number()), ("a", number())],
        &["r", "g", "b", "a"],
    )
}

fn pose() -> Value {
    object(
        "foxglove.Pose",
        &[("position", vector3()), ("orientation", quaternion())],
        &["position", "orientation"],
    )
}

fn key_value_pair() -> Value {
    object(
        "foxglove.KeyValuePair",
        &[("key", string()), ("value", string())],
        &["key", "value"],
    )
}

fn frame_transform() -> Value {
    object(
        "foxglove.FrameTransform",
        &[
            ("timestamp", time()),
            ("parent_frame_id", string()),
            ("child_frame_id", string()),
            ("translation", vector3()),
            ("rotation", quaternion()),
        ],
        &[
            "timestamp",
            "parent_frame_id",
            "child_frame_id",
            "translation",
            "rotation",
        ],
    )
}

/// `foxglove.FrameTransforms`.
pub(super) fn frame_transforms() -> Value {
    object(
        "foxglove.FrameTransforms",
        &[("transforms", array(frame_transform()))],
        &["transforms"],
    )
}

fn arrow_primitive() -> Value {
    let fields = [
        "pose",
        "shaft_length",
        "shaft_diameter",
        "head_length",
        "head_diameter",
        "color",
    ];
    object(
        "foxglove.ArrowPrimitive",
        &[
            ("pose", pose()),
            ("shaft_length", number()),
            ("shaft_diameter", number()),
            ("head_length", number()),
            ("head_diameter", number()),
            ("color", color()),
        ],
        &fields,
    )
}

/// Cube and sphere primitives have the same fields.
fn sized_primitive(title: &str) -> Value {
    object(
        title,
        &[("pose", pose()), ("size", vector3()), ("color", color())],
        &["pose", "size", "color"],
    )
}

fn cylinder_primitive() -> Value {
    object(
        "foxglove.CylinderPrimitive",
        &[
            ("pose", pose()),
            ("size", vector3()),
            ("bottom_scale", number()),
            ("top_scale", number()),
            ("color", color()),
        ],
        &["pose", "size", "bottom_scale", "top_scale", "color"],
    )
}

fn line_primitive() -> Value {
    object(
        "foxglove.LinePrimitive",
        &[
            (
                "type",
                enumeration(
                    "foxglove.LineType",
                    &[("LINE_STRIP", 0), ("LINE_LOOP", 1), ("LINE_LIST", 2)],
                ),
            ),
            ("pose", pose()),
            ("thickness", number()),
            ("scale_invariant", boolean()),
            ("points", array(point3())),
            ("color", color()),
            ("colors", array(color())),
            ("indices", array(uint())),
        ],
        &[
            "type",
            "pose",
            "thickness",
            "scale_invariant",
            "points",
            "color",
            "colors",
            "indices",
        ],
    )
}

fn triangle_list_primitive() -> Value {
    object(
        "foxglove.TriangleListPrimitive",
        &[
            ("pose", pose()),
            ("points", array(point3())),
            ("color", color()),
            ("colors", array(color())),
            ("indices", array(uint())),
        ],
        &["pose", "points", "color", "colors", "indices"],
    )
}

fn text_primitive() -> Value {
    object(
        "foxglove.TextPrimitive",
        &[
            ("pose", pose()),
            ("billboard", boolean()),
            ("font_size", number()),
            ("scale_invariant", boolean()),
            ("color", color()),
            ("text", string()),
        ],
        &["pose", "billboard", "font_size", "scale_invariant", "color", "text"],
    )
}

fn model_primitive() -> Value {
    object(
        "foxglove.ModelPrimitive",
        &[
            ("pose", pose()),
            ("scale", vector3()),
            ("color", color()),
            ("override_color", boolean()),
            ("url", string()),
            ("media_type", string()),
            ("data", bytes()),
        ],
        &["pose", "scale", "color", "override_color", "url", "media_type", "data"],
    )
}

fn scene_entity_deletion() -> Value {
    object(
        "foxglove.SceneEntityDeletion",
        &[
            ("timestamp", time()),
            (
                "type",
                enumeration("foxglove.SceneEntityDeletionType", &[("MATCHING_ID", 0), ("ALL", 1)]),
            ),
            ("id", string()),
        ],
        &["timestamp", "type", "id"],
    )
}

fn scene_entity() -> Value {
    object(
        "foxglove.SceneEntity",
        &[
            ("timestamp", time()),
            ("frame_id", string()),
            ("id", string()),
            ("lifetime", duration()),
            ("frame_locked", boolean()),
            ("metadata", array(key_value_pair())),
            ("arrows", array(arrow_primitive())),
            ("cubes", array(sized_primitive("foxglove.CubePrimitive"))),
            ("spheres", array(sized_primitive("foxglove.SpherePrimitive"))),
            ("cylinders", array(cylinder_primitive())),
            ("lines", array(line_primitive())),
            ("triangles", array(triangle_list_primitive())),
            ("texts", array(text_primitive())),
            ("models", array(model_primitive())),
        ],
        &[
            "timestamp",
            "frame_id",
            "id",
            "lifetime",
            "frame_locked",
            "metadata",
            "arrows",
            "cubes",
            "spheres",
            "cylinders",
            "lines",
            "triangles",
            "texts",
            "models",
        ],
    )
}

/// `foxglove.SceneUpdate`.
pub(super) fn scene_update() -> Value {
    object(
        "foxglove.SceneUpdate",
        &[
            ("deletions", array(scene_entity_deletion())),
            ("entities", array(scene_entity())),
        ],
        &["deletions", "entities"],
    )
}

/// `foxglove.Log`.
pub(super) fn log() -> Value {
    let level = enumeration(
        "foxglove.LogLevel",
        &[
            ("UNKNOWN", 0),
            ("DEBUG", 1),
            ("INFO", 2),
            ("WARNING", 3),
            ("ERROR", 4),
            ("FATAL", 5),
        ],
    );
    object(
        "foxglove.Log",
        &[
            ("timestamp", time()),
            ("level", level),
            ("message", string()),
            ("name", string()),
            ("file", string()),
            ("line", uint()),
        ],
        &["timestamp", "level", "message", "name", "file", "line"],
    )
}

/// `foxglove.RawImage`.
pub(super) fn raw_image() -> Value {
    object(
        "foxglove.RawImage",
        &[
            ("timestamp", time()),
            ("frame_id", string()),
            ("width", uint()),
            ("height", uint()),
            ("encoding", string()),
            ("step", uint()),
            ("data", bytes()),
        ],
        &["timestamp", "frame_id", "width", "height", "encoding", "step", "data"],
    )
}

fn numbers(description: &str) -> Value {
    described(array(number()), description)
}

fn xyz(description: &str) -> Value {
    described(
        object(
            "",
            &[("x", number()), ("y", number()), ("z", number())],
            &["x", "y", "z"],
        ),
        description,
    )
}

/// `pbd.JointState`.
pub(super) fn joint_state() -> Value {
    described(
        object(
            "pbd.JointState",
            &[
                ("timestamp", described(time(), "Simulated time")),
                (
                    "name",
                    described(
                        array(string()),
                        "Independent joint names (URDF), in the simulator's order",
                    ),
                ),
                (
                    "position",
                    numbers("Encoder readings, parallel to `name` (rad; m for prismatic joints)"),
                ),
                ("velocity", numbers("Joint velocities, parallel to `name` (rad/s; m/s)")),
                (
                    "position_ref",
                    numbers("Motor position setpoints, parallel to `name` (rad; m)"),
                ),
            ],
            &["timestamp", "name", "position", "velocity", "position_ref"],
        ),
        "Dexter's joints at one instant: encoders, velocities and motor setpoints",
    )
}

/// `pbd.FingertipWrenches`.
pub(super) fn fingertip_wrenches() -> Value {
    let arm = json!({ "type": "string", "enum": ["left", "right"], "description": "Which hand" });
    let wrench = object(
        "pbd.FingertipWrench",
        &[
            ("arm", arm),
            (
                "finger",
                described(
                    json!({ "type": "integer", "minimum": 1, "maximum": 3 }),
                    "Finger 1, 2 or 3",
                ),
            ),
            ("force", xyz("Force on the finger from contacts (N), world frame")),
            (
                "torque",
                xyz("Torque about the fingertip frame's origin (N·m), world frame"),
            ),
            (
                "in_contact",
                described(boolean(), "Whether any contact touches the distal link or tip"),
            ),
        ],
        &["arm", "finger", "force", "torque", "in_contact"],
    );
    described(
        object(
            "pbd.FingertipWrenches",
            &[
                ("timestamp", described(time(), "Simulated time")),
                (
                    "fingertips",
                    described(array(wrench), "Left hand F1–F3, then right hand F1–F3"),
                ),
            ],
            &["timestamp", "fingertips"],
        ),
        "The six fingertip force/torque sensors of the two BarrettHands",
    )
}

/// `pbd.Activity`.
pub(super) fn activity() -> Value {
    described(
        object(
            "pbd.Activity",
            &[
                ("timestamp", described(time(), "Simulated time")),
                (
                    "text",
                    described(
                        string(),
                        "What the task layer is doing, e.g. `reach left → jif`; empty if idle",
                    ),
                ),
            ],
            &["timestamp", "text"],
        ),
        "What the task layer is doing; written when it changes",
    )
}

/// `foxglove.CompressedImage` (`format`: `jpeg` or `png`).
pub(super) fn compressed_image() -> Value {
    object(
        "foxglove.CompressedImage",
        &[
            ("timestamp", time()),
            ("frame_id", string()),
            ("data", bytes()),
            ("format", string()),
        ],
        &["timestamp", "frame_id", "data", "format"],
    )
}

/// `foxglove.CameraCalibration` (pinhole, no distortion).
pub(super) fn camera_calibration() -> Value {
    object(
        "foxglove.CameraCalibration",
        &[
            ("timestamp", time()),
            ("frame_id", string()),
            ("width", uint()),
            ("height", uint()),
            ("distortion_model", string()),
            ("D", array(number())),
            ("K", array(number())),
            ("R", array(number())),
            ("P", array(number())),
        ],
        &[
            "timestamp",
            "frame_id",
            "width",
            "height",
            "distortion_model",
            "D",
            "K",
            "R",
            "P",
        ],
    )
}

/// `pbd.SchemaState`: where a schema stands (inferred from a demonstration, or the executive's own
/// during an execution), with the monitor observation `x` it was judged from, one boolean per
/// library action (named in `action_names`), so that each plots as a 0/1 line.
pub(super) fn schema_state(action_names: &[&str]) -> Value {
    let x: Vec<(&str, Value)> = action_names.iter().map(|n| (*n, boolean())).collect();
    described(
        object(
            "pbd.SchemaState",
            &[
                ("timestamp", described(time(), "Simulated time")),
                ("schema", described(string(), "The schema (`gap` between instances)")),
                ("state", described(string(), "The state's name")),
                (
                    "state_index",
                    described(
                        json!({ "type": "integer" }),
                        "Index of the state in the schema; -1 in a gap",
                    ),
                ),
                (
                    "action",
                    described(
                        string(),
                        "The action chosen in this state (executions; empty at a goal)",
                    ),
                ),
                ("arm", described(string(), "ψ's arm (executions)")),
                ("place", described(string(), "ψ's place (executions)")),
                (
                    "transfer",
                    described(boolean(), "ψ bound a hand-to-hand transfer (executions)"),
                ),
                (
                    "contingency",
                    described(string(), "The contingency edge taken into this state, if any"),
                ),
                (
                    "x",
                    described(
                        object("", &x, &[]),
                        "Monitor observation: which actions' predicates hold",
                    ),
                ),
            ],
            &["timestamp", "schema", "state", "state_index", "x"],
        ),
        "Where a schema stands",
    )
}

/// `pbd.Decision`: what the robot decided for one seen segment, before acting on it.
pub(super) fn decision() -> Value {
    described(
        object(
            "pbd.Decision",
            &[
                ("timestamp", described(time(), "Simulated time")),
                ("segment", described(uint(), "The robot's segment (track id)")),
                (
                    "decision",
                    described(
                        string(),
                        "`execute`, `ignore` (not part of the task) or `skip` (out of reach)",
                    ),
                ),
                ("place", described(string(), "The place chosen (empty if none)")),
                (
                    "log_bayes_factor",
                    described(number(), "ln B10 of task relevance (a model's decision)"),
                ),
                ("pick_arm", described(string(), "The arm that picks")),
                (
                    "place_arm",
                    described(string(), "The arm that places (differs for a hand-to-hand transfer)"),
                ),
                ("transfer", described(boolean(), "A hand-to-hand transfer")),
                (
                    "posterior",
                    described(json!({ "type": "object" }), "Posterior over places"),
                ),
                ("reason", described(string(), "Why")),
            ],
            &["timestamp", "segment", "decision", "reason"],
        ),
        "A decision of the robot on one seen segment",
    )
}

//! JSON Schema texts (schema encoding `jsonschema`) for pbd's own channels (`pbd.*`), which stay
//! JSON: Foxglove plots and inspects them through the message-path syntax, a `time` being an object
//! titled `time` with `sec`/`nsec`. Foxglove's well-known topics are Protobuf, with the descriptors
//! the `foxglove` crate ships (`foxglove::Encode::get_schema`).

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

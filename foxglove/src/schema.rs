//! The JSON schemas of the channels (JSON Schema, as Foxglove reads them
//! for `json` channels). `foxglove.*` schemas name Foxglove's own message
//! types, which it recognises by name; it needs only their top level here.
//! The `cosim.*` schemas list every numeric field, so that Foxglove's
//! plot panel offers them.

use serde_json::{json, Value};

/// A channel's schema: its name and its JSON Schema text.
#[derive(Debug, Clone, PartialEq)]
pub struct Schema {
    pub name: &'static str,
    pub text: String,
}

/// A JSON schema of an object with these properties (name, JSON type).
fn object(title: &'static str, properties: &[(&str, Value)]) -> Schema {
    let props: serde_json::Map<String, Value> = properties
        .iter()
        .map(|(k, v)| (k.to_string(), v.clone()))
        .collect();
    Schema {
        name: title,
        text: json!({ "title": title, "type": "object", "properties": props }).to_string(),
    }
}

fn vector() -> Value {
    json!({ "type": "object", "properties": {
        "x": { "type": "number" }, "y": { "type": "number" }, "z": { "type": "number" } } })
}

fn number() -> Value {
    json!({ "type": "number" })
}

fn array() -> Value {
    json!({ "type": "array" })
}

pub fn scene_update() -> Schema {
    object(
        "foxglove.SceneUpdate",
        &[("deletions", array()), ("entities", array())],
    )
}

pub fn frame_transforms() -> Schema {
    object("foxglove.FrameTransforms", &[("transforms", array())])
}

pub fn body_state() -> Schema {
    object(
        "cosim.BodyState",
        &[
            ("position", vector()),
            ("orientation", json!({ "type": "object" })),
            ("linear_velocity", vector()),
            ("angular_velocity", vector()),
        ],
    )
}

pub fn energy() -> Schema {
    object(
        "cosim.Energy",
        &[
            ("kinetic", number()),
            ("potential", number()),
            ("total", number()),
            ("total_midpoint", number()),
        ],
    )
}

/// A step report with these numeric fields.
pub fn step_report(fields: &[&str]) -> Schema {
    let props: Vec<(&str, Value)> = fields.iter().map(|f| (*f, number())).collect();
    object("cosim.StepReport", &props)
}

pub fn force() -> Schema {
    object(
        "cosim.Force",
        &[("force", vector()), ("magnitude", number())],
    )
}

/// A hinge's angle (rad) and rate (rad/s) or a slider's offset (m) and
/// speed (m/s), as joints.csv holds them.
pub fn joint_coordinate() -> Schema {
    object(
        "cosim.JointCoordinate",
        &[("position", number()), ("rate", number())],
    )
}

//! A run as an MCAP recording for Foxglove (`run --mcap`, `plot DIR
//! --mcap`), written from the run's files alone, like the figures: a
//! recording of a co-simulation (`cosim record`) converts the same way.
//!
//! Messages are JSON with JSON-schema schemas (Foxglove reads both; no
//! protobuf code generation). The 3-D view uses Foxglove's well-known
//! message names, `foxglove.SceneUpdate` and `foxglove.FrameTransforms`,
//! which Foxglove recognises by name; their fields follow Foxglove's
//! published message definitions. The numeric channels have schemas of
//! our own, so that Foxglove's plot panel offers their fields.
//!
//! Channels:
//! - `/scene` (`foxglove.SceneUpdate`), one per state: a sphere per body
//!   with a small marker sphere on its body x axis (the rotation shows), a
//!   thin large box per plane, a line per joint (anchor or centre to
//!   centre), an arrow per contact with a normal force, from the contact
//!   point along the force, 5 cm per decade of newtons.
//! - `/tf` (`foxglove.FrameTransforms`), one per state: `world` to each
//!   body's frame (named after the body).
//! - `/bodies/NAME` (`cosim.BodyState`), one per state.
//! - `/energy` (`cosim.Energy`) and `/solver` (`cosim.StepReport`), one
//!   per step.
//! - `/forces/KIND/NAME` (`cosim.Force`, N: the step's impulse over h),
//!   one per step in which that contact or joint had an impulse.

use crate::engine::Model;
use crate::plot::data::RunData;
use cosim_shared::scene::WORLD;
use cosim_shared::Scene;
use nalgebra::{UnitQuaternion, Vector3};
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::fmt;
use std::io::BufWriter;
use std::path::Path;

/// Why a recording could not be written.
#[derive(Debug)]
pub enum McapError {
    /// The run's files are missing or malformed.
    Read(String),
    /// Writing the file failed.
    Write(String),
}

impl fmt::Display for McapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            McapError::Read(m) => write!(f, "cannot read the run: {m}"),
            McapError::Write(m) => write!(f, "cannot write the recording: {m}"),
        }
    }
}

impl std::error::Error for McapError {}

/// What a recording holds: messages per topic.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Written {
    pub messages: BTreeMap<String, u64>,
}

/// Length of a force arrow per decade of newtons (m).
const ARROW_PER_DECADE: f64 = 0.05;
/// Side of the square drawn for a plane (m).
const PLANE_SIDE: f64 = 4.0;

/// A time in s as the recording's nanoseconds.
fn nanos(t: f64) -> u64 {
    (t.max(0.0) * 1e9).round() as u64
}

fn time(t: f64) -> Value {
    let ns = nanos(t);
    json!({ "sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000 })
}

fn vec3(v: &Vector3<f64>) -> Value {
    json!({ "x": v.x, "y": v.y, "z": v.z })
}

fn quat(q: &UnitQuaternion<f64>) -> Value {
    json!({ "x": q.i, "y": q.j, "z": q.k, "w": q.w })
}

fn color(i: usize, alpha: f64) -> Value {
    let c = crate::plot::color(i);
    json!({ "r": c.0 as f64 / 255.0, "g": c.1 as f64 / 255.0, "b": c.2 as f64 / 255.0, "a": alpha })
}

fn grey(v: f64, alpha: f64) -> Value {
    json!({ "r": v, "g": v, "b": v, "a": alpha })
}

fn pose(p: &Vector3<f64>, q: &UnitQuaternion<f64>) -> Value {
    json!({ "position": vec3(p), "orientation": quat(q) })
}

/// The rotation taking direction `from` to direction `to`.
fn turn(from: &Vector3<f64>, to: &Vector3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::rotation_between(from, to).unwrap_or_else(|| {
        // Opposite directions: half a turn about an axis normal to `from`.
        let axis = from.cross(&Vector3::x());
        let axis = if axis.norm() > 1e-6 {
            axis
        } else {
            from.cross(&Vector3::y())
        };
        UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), std::f64::consts::PI)
    })
}

/// A JSON schema of an object with these properties (name, JSON type).
fn object_schema(title: &str, properties: &[(&str, Value)]) -> Vec<u8> {
    let props: serde_json::Map<String, Value> = properties
        .iter()
        .map(|(k, v)| (k.to_string(), v.clone()))
        .collect();
    json!({ "title": title, "type": "object", "properties": props })
        .to_string()
        .into_bytes()
}

fn vector_schema() -> Value {
    json!({ "type": "object", "properties": {
        "x": { "type": "number" }, "y": { "type": "number" }, "z": { "type": "number" } } })
}

fn number() -> Value {
    json!({ "type": "number" })
}

fn array() -> Value {
    json!({ "type": "array" })
}

/// The body state of `run.bodies[b].rows[i]`: position, orientation.
fn body_pose(row: &[f64; 13]) -> (Vector3<f64>, UnitQuaternion<f64>) {
    let x = Vector3::new(row[0], row[1], row[2]);
    let q =
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(row[3], row[4], row[5], row[6]));
    (x, q)
}

struct Out {
    w: mcap::Writer<BufWriter<std::fs::File>>,
    written: Written,
    topics: BTreeMap<String, u16>,
    schemas: BTreeMap<&'static str, u16>,
}

impl Out {
    fn schema(&mut self, name: &'static str, data: Vec<u8>) -> Result<u16, McapError> {
        if let Some(&id) = self.schemas.get(name) {
            return Ok(id);
        }
        let id = self
            .w
            .add_schema(name, "jsonschema", &data)
            .map_err(|e| McapError::Write(e.to_string()))?;
        self.schemas.insert(name, id);
        Ok(id)
    }

    fn channel(&mut self, topic: &str, schema: u16) -> Result<u16, McapError> {
        if let Some(&id) = self.topics.get(topic) {
            return Ok(id);
        }
        let id = self
            .w
            .add_channel(schema, topic, "json", &BTreeMap::new())
            .map_err(|e| McapError::Write(e.to_string()))?;
        self.topics.insert(topic.to_string(), id);
        Ok(id)
    }

    fn put(&mut self, channel: u16, topic: &str, t: f64, msg: &Value) -> Result<(), McapError> {
        let count = self.written.messages.entry(topic.to_string()).or_default();
        let ns = nanos(t);
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: *count as u32,
            log_time: ns,
            publish_time: ns,
        };
        *count += 1;
        self.w
            .write_to_known_channel(&header, msg.to_string().as_bytes())
            .map_err(|e| McapError::Write(e.to_string()))
    }
}

/// Writes the run in `dir` (its `scene.toml` and CSV files) as an MCAP
/// recording to `path`.
pub fn write(dir: &Path, path: &Path) -> Result<Written, McapError> {
    let run = RunData::load(dir).map_err(|e| McapError::Read(e.to_string()))?;
    let scene = Scene::load(&dir.join("scene.toml")).map_err(|e| McapError::Read(e.to_string()))?;
    if scene.bodies.len() != run.bodies.len() {
        return Err(McapError::Read(format!(
            "scene.toml has {} bodies, states.csv {}",
            scene.bodies.len(),
            run.bodies.len()
        )));
    }
    let file = std::fs::File::create(path)
        .map_err(|e| McapError::Write(format!("{}: {e}", path.display())))?;
    let w = mcap::WriteOptions::new()
        .compression(None)
        .profile("")
        .create(BufWriter::new(file))
        .map_err(|e| McapError::Write(e.to_string()))?;
    let mut out = Out {
        w,
        written: Written::default(),
        topics: BTreeMap::new(),
        schemas: BTreeMap::new(),
    };
    states(&mut out, &run, &scene, &Model::from_scene(&scene))?;
    steps(&mut out, &run)?;
    out.w
        .finish()
        .map_err(|e| McapError::Write(e.to_string()))?;
    Ok(out.written)
}

/// Everything per state: the scene, the transforms, the body states.
fn states(out: &mut Out, run: &RunData, scene: &Scene, model: &Model) -> Result<(), McapError> {
    let scene_schema = out.schema(
        "foxglove.SceneUpdate",
        object_schema(
            "foxglove.SceneUpdate",
            &[("deletions", array()), ("entities", array())],
        ),
    )?;
    let tf_schema = out.schema(
        "foxglove.FrameTransforms",
        object_schema("foxglove.FrameTransforms", &[("transforms", array())]),
    )?;
    let body_schema = out.schema(
        "cosim.BodyState",
        object_schema(
            "cosim.BodyState",
            &[
                ("position", vector_schema()),
                ("orientation", json!({ "type": "object" })),
                ("linear_velocity", vector_schema()),
                ("angular_velocity", vector_schema()),
            ],
        ),
    )?;
    let scene_ch = out.channel("/scene", scene_schema)?;
    let tf_ch = out.channel("/tf", tf_schema)?;
    let body_ch: Vec<u16> = run
        .bodies
        .iter()
        .map(|b| out.channel(&format!("/bodies/{}", b.name), body_schema))
        .collect::<Result<_, _>>()?;
    let h = run.h().unwrap_or(1.0);
    let index: BTreeMap<&str, usize> = scene
        .bodies
        .iter()
        .enumerate()
        .map(|(i, b)| (b.name.as_str(), i))
        .collect();
    for (i, &t) in run.t.iter().enumerate() {
        let poses: Vec<(Vector3<f64>, UnitQuaternion<f64>)> =
            run.bodies.iter().map(|b| body_pose(&b.rows[i])).collect();
        let stamp = time(t);
        let mut entities = Vec::new();
        for (b, ((x, q), desc)) in poses.iter().zip(&scene.bodies).enumerate() {
            let r = desc.radius;
            let marker = x + q * Vector3::new(0.75 * r, 0.0, 0.0);
            entities.push(json!({
                "timestamp": stamp, "frame_id": "world", "id": format!("body/{}", desc.name),
                "lifetime": time(0.0), "frame_locked": false, "metadata": [],
                "spheres": [
                    { "pose": pose(x, q), "size": vec3(&Vector3::repeat(2.0 * r)), "color": color(b, 1.0) },
                    { "pose": pose(&marker, q), "size": vec3(&Vector3::repeat(0.35 * r)), "color": grey(0.1, 1.0) }
                ],
                "arrows": [], "cubes": [], "cylinders": [], "lines": [], "triangles": [], "texts": [], "models": []
            }));
        }
        for p in &scene.planes {
            let n = Vector3::from(p.normal).normalize();
            // The box's top face on the plane.
            let centre = Vector3::from(p.point) - n * 0.001;
            entities.push(json!({
                "timestamp": stamp, "frame_id": "world", "id": format!("plane/{}", p.name),
                "lifetime": time(0.0), "frame_locked": false, "metadata": [],
                "cubes": [{ "pose": pose(&centre, &turn(&Vector3::z(), &n)),
                            "size": { "x": PLANE_SIDE, "y": PLANE_SIDE, "z": 0.002 },
                            "color": grey(0.75, 0.35) }],
                "arrows": [], "spheres": [], "cylinders": [], "lines": [], "triangles": [], "texts": [], "models": []
            }));
        }
        for j in &scene.joints {
            let end = |name: &str| index.get(name).map(|&k| poses[k].0);
            let a = end(&j.body_a).unwrap_or_else(|| Vector3::from(j.anchor));
            let b = end(&j.body_b).unwrap_or_else(|| Vector3::from(j.anchor));
            let mut points = vec![vec3(&a)];
            if j.body_a == WORLD || j.body_b == WORLD {
                points.insert(0, vec3(&Vector3::from(j.anchor)));
            }
            points.push(vec3(&b));
            entities.push(json!({
                "timestamp": stamp, "frame_id": "world", "id": format!("joint/{}", j.name),
                "lifetime": time(0.0), "frame_locked": false, "metadata": [],
                "lines": [{ "type": 0, "pose": pose(&Vector3::zeros(), &UnitQuaternion::identity()),
                            "thickness": 0.01, "scale_invariant": false, "points": points,
                            "color": grey(0.2, 1.0), "colors": [], "indices": [] }],
                "arrows": [], "spheres": [], "cubes": [], "cylinders": [], "triangles": [], "texts": [], "models": []
            }));
        }
        // Contact forces of the step that ended in this state.
        let mut arrows = Vec::new();
        if i > 0 {
            for ((kind, name), series) in &run.impulses {
                let Some(Some(p)) = series.get(i - 1) else {
                    continue;
                };
                if kind != "normal" {
                    continue;
                }
                let Some(at) = crate::plot::contact_point(model, run, i, name) else {
                    continue;
                };
                let f = Vector3::from(*p) / h;
                let size = f.norm();
                if size <= 0.0 {
                    continue;
                }
                let length = ARROW_PER_DECADE * (1.0 + size).log10();
                arrows.push(json!({
                    // Foxglove's arrow points along its pose's +x.
                    "pose": pose(&at, &turn(&Vector3::x(), &f)),
                    "shaft_length": 0.7 * length, "shaft_diameter": 0.006,
                    "head_length": 0.3 * length, "head_diameter": 0.015,
                    "color": json!({ "r": 0.85, "g": 0.1, "b": 0.1, "a": 1.0 })
                }));
            }
        }
        entities.push(json!({
            "timestamp": stamp, "frame_id": "world", "id": "contacts",
            "lifetime": time(0.0), "frame_locked": false, "metadata": [],
            "arrows": arrows,
            "spheres": [], "cubes": [], "cylinders": [], "lines": [], "triangles": [], "texts": [], "models": []
        }));
        out.put(
            scene_ch,
            "/scene",
            t,
            &json!({ "deletions": [], "entities": entities }),
        )?;

        let transforms: Vec<Value> = poses
            .iter()
            .zip(&scene.bodies)
            .map(|((x, q), d)| {
                json!({ "timestamp": stamp, "parent_frame_id": "world", "child_frame_id": d.name,
                        "translation": vec3(x), "rotation": quat(q) })
            })
            .collect();
        out.put(tf_ch, "/tf", t, &json!({ "transforms": transforms }))?;
        for (b, body) in run.bodies.iter().enumerate() {
            let r = &body.rows[i];
            let msg = json!({
                "position": { "x": r[0], "y": r[1], "z": r[2] },
                "orientation": { "w": r[3], "x": r[4], "y": r[5], "z": r[6] },
                "linear_velocity": { "x": r[7], "y": r[8], "z": r[9] },
                "angular_velocity": { "x": r[10], "y": r[11], "z": r[12] },
            });
            out.put(body_ch[b], &format!("/bodies/{}", body.name), t, &msg)?;
        }
    }
    Ok(())
}

/// Everything per step: energy, the solver's report, forces.
fn steps(out: &mut Out, run: &RunData) -> Result<(), McapError> {
    let energy_schema = out.schema(
        "cosim.Energy",
        object_schema(
            "cosim.Energy",
            &[
                ("kinetic", number()),
                ("potential", number()),
                ("total", number()),
                ("total_midpoint", number()),
            ],
        ),
    )?;
    let report_fields = [
        "pivots",
        "residual",
        "lcp_size",
        "contacts_in_lcp",
        "active_contacts",
        "max_penetration",
        "max_joint_error",
        "t_total",
    ];
    let report_props: Vec<(&str, Value)> = report_fields.iter().map(|f| (*f, number())).collect();
    let report_schema = out.schema(
        "cosim.StepReport",
        object_schema("cosim.StepReport", &report_props),
    )?;
    let force_schema = out.schema(
        "cosim.Force",
        object_schema(
            "cosim.Force",
            &[("force", vector_schema()), ("magnitude", number())],
        ),
    )?;
    let energy_ch = out.channel("/energy", energy_schema)?;
    let report_ch = out.channel("/solver", report_schema)?;
    let column = |name: &str, k: usize| run.steps.get(name).and_then(|v| v.get(k)).copied();
    for (k, &t) in run.step_t.iter().enumerate() {
        let e = |n| column(n, k).unwrap_or(f64::NAN);
        out.put(
            energy_ch,
            "/energy",
            t,
            &json!({ "kinetic": e("kinetic"), "potential": e("potential"),
                     "total": e("energy"), "total_midpoint": e("energy_midpoint") }),
        )?;
        let report: serde_json::Map<String, Value> = report_fields
            .iter()
            .filter_map(|f| column(f, k).map(|v| (f.to_string(), json!(v))))
            .collect();
        out.put(report_ch, "/solver", t, &Value::Object(report))?;
    }
    let h = run.h().unwrap_or(1.0);
    for ((kind, name), series) in &run.impulses {
        let topic = format!("/forces/{kind}/{name}");
        let ch = out.channel(&topic, force_schema)?;
        for (k, p) in series.iter().enumerate() {
            let (Some(p), Some(&t)) = (p, run.step_t.get(k)) else {
                continue;
            };
            let f = Vector3::from(*p) / h;
            out.put(
                ch,
                &topic,
                t,
                &json!({ "force": vec3(&f), "magnitude": f.norm() }),
            )?;
        }
    }
    Ok(())
}

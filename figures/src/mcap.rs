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
//! - `/shapes` (`foxglove.SceneUpdate`), once at the start where bodies
//!   have hull shapes (collision meshes): their triangles, locked to the
//!   body's frame (per state they were 0.4 MB of JSON for a Panda).
//! - `/visuals` (`foxglove.SceneUpdate`), once at the start where bodies have
//!   `[[body.visual]]`s: each body's visual meshes (the files' bytes) and
//!   primitives, locked to its frame, which `/tf` moves.
//! - `/tf` (`foxglove.FrameTransforms`), one per state: `world` to each
//!   body's frame (named after the body).
//! - `/bodies/NAME` (`cosim.BodyState`), one per state.
//! - `/joints/NAME` (`cosim.JointCoordinate`), one per state, for each
//!   hinge and slider where the run has `joints.csv`: its `position`
//!   (angle in rad or offset in m) and `rate`.
//! - `/energy` (`cosim.Energy`) and `/solver` (`cosim.StepReport`), one
//!   per step.
//! - `/forces/KIND/NAME` (`cosim.Force`, N: the step's impulse over h),
//!   one per step in which that contact or joint had an impulse.

use crate::data::RunData;
use cosim_engine::Model;
pub use cosim_foxglove::record::Written;
use cosim_foxglove::record::{RecordError, Recording};
use cosim_foxglove::{draw, schema, Arrow, Drawing, Pose};
use cosim_shared::Scene;
use nalgebra::Vector3;
use serde_json::{json, Value};
use std::fmt;
use std::path::Path;

/// Why a recording could not be written.
#[derive(Debug)]
pub enum McapError {
    /// The run's files are missing or malformed.
    Read(String),
    /// Writing the file failed.
    Write(RecordError),
}

impl fmt::Display for McapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            McapError::Read(m) => write!(f, "cannot read the run: {m}"),
            McapError::Write(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for McapError {}

impl From<RecordError> for McapError {
    fn from(e: RecordError) -> Self {
        McapError::Write(e)
    }
}

/// The body state of `run.bodies[b].rows[i]` as drawn.
fn body_pose(row: &[f64; 13]) -> Pose {
    Pose::new([row[0], row[1], row[2]], [row[3], row[4], row[5], row[6]])
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
    let mut rec = Recording::create(path)?;
    states(&mut rec, &run, &scene, &Model::from_scene(&scene))?;
    steps(&mut rec, &run)?;
    Ok(rec.finish()?)
}

/// Everything per state: the scene, the transforms, the body states.
fn states(
    rec: &mut Recording,
    run: &RunData,
    scene: &Scene,
    model: &Model,
) -> Result<(), McapError> {
    let h = run.h().unwrap_or(1.0);
    let drawing = Drawing::new(scene);
    let topics: Vec<String> = run
        .bodies
        .iter()
        .map(|b| format!("/bodies/{}", b.name))
        .collect();
    let joint_topics: Vec<String> = run
        .coordinates
        .iter()
        .map(|c| format!("/joints/{}", c.name))
        .collect();
    let (once, not_drawn) = cosim_foxglove::visuals::sent_once(scene, &drawing);
    rec.not_drawn(not_drawn);
    for (topic, msg) in &once {
        rec.put(
            topic,
            schema::scene_update,
            run.t.first().copied().unwrap_or(0.0),
            msg,
        )?;
    }
    let mut state = cosim_engine::State::initial(model);
    for (i, &t) in run.t.iter().enumerate() {
        let poses: Vec<Pose> = run.bodies.iter().map(|b| body_pose(&b.rows[i])).collect();
        crate::pose_state(run, i, &mut state);
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
                let Some(at) = crate::contact_point(model, &state, name) else {
                    continue;
                };
                arrows.push(Arrow {
                    at,
                    force: Vector3::from(*p) / h,
                });
            }
        }
        let msg = drawing.scene_update(t, &poses, &arrows);
        rec.put("/scene", schema::scene_update, t, &msg)?;
        let msg = drawing.frame_transforms(t, &poses);
        rec.put("/tf", schema::frame_transforms, t, &msg)?;
        for (body, topic) in run.bodies.iter().zip(&topics) {
            let msg = draw::body_state(&body.rows[i]);
            rec.put(topic, schema::body_state, t, &msg)?;
        }
        for (c, topic) in run.coordinates.iter().zip(&joint_topics) {
            if let Some(&(position, rate)) = c.values.get(i) {
                let msg = draw::joint_coordinate(position, rate);
                rec.put(topic, schema::joint_coordinate, t, &msg)?;
            }
        }
    }
    Ok(())
}

/// The step report's fields on `/solver`.
const REPORT_FIELDS: [&str; 9] = [
    "pivots",
    "residual",
    "lcp_size",
    "contacts_in_lcp",
    "active_contacts",
    "max_penetration",
    "max_joint_error",
    "max_joint_angle_error",
    "t_total",
];

/// Everything per step: energy, the solver's report, forces.
fn steps(rec: &mut Recording, run: &RunData) -> Result<(), McapError> {
    let column = |name: &str, k: usize| run.steps.get(name).and_then(|v| v.get(k)).copied();
    for (k, &t) in run.step_t.iter().enumerate() {
        let e = |n| column(n, k).unwrap_or(f64::NAN);
        let msg = json!({ "kinetic": e("kinetic"), "potential": e("potential"),
                          "total": e("energy"), "total_midpoint": e("energy_midpoint") });
        rec.put("/energy", schema::energy, t, &msg)?;
        let report: serde_json::Map<String, Value> = REPORT_FIELDS
            .iter()
            .filter_map(|f| column(f, k).map(|v| (f.to_string(), json!(v))))
            .collect();
        let report_schema = || schema::step_report(&REPORT_FIELDS);
        rec.put("/solver", report_schema, t, &Value::Object(report))?;
    }
    let h = run.h().unwrap_or(1.0);
    for ((kind, name), series) in &run.impulses {
        let topic = format!("/forces/{kind}/{name}");
        for (k, p) in series.iter().enumerate() {
            let (Some(p), Some(&t)) = (p, run.step_t.get(k)) else {
                continue;
            };
            let f = Vector3::from(*p) / h;
            let msg = draw::force_message(&f);
            rec.put(&topic, schema::force, t, &msg)?;
        }
    }
    Ok(())
}

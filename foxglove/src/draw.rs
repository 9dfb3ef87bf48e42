//! A state drawn as Foxglove messages (JSON): the 3-D scene
//! (`foxglove.SceneUpdate`), the body frames (`foxglove.FrameTransforms`)
//! and the numeric body state. The same drawing serves the recordings
//! (`run --mcap`) and the live view (`cosim view`).
//!
//! Field names follow Foxglove's published message definitions; Foxglove
//! recognises `foxglove.*` messages by their schema name.

use crate::palette;
use cosim_shared::scene::WORLD;
use cosim_shared::{PlacedShape, Scene, ShapeDesc};
use nalgebra::{Quaternion, Unit, UnitQuaternion, Vector3};
use serde_json::{json, Value};
use std::collections::BTreeMap;

/// Length of a force arrow per decade of newtons (m).
pub const ARROW_PER_DECADE: f64 = 0.05;
/// Side of the square drawn for a plane (m).
pub const PLANE_SIDE: f64 = 4.0;

/// A body's position and orientation, world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub position: Vector3<f64>,
    pub orientation: UnitQuaternion<f64>,
}

impl Pose {
    /// From a position and a quaternion `[w, x, y, z]` (normalised here:
    /// a state read from text may be off by round-off).
    pub fn new(position: [f64; 3], wxyz: [f64; 4]) -> Pose {
        Pose {
            position: Vector3::from(position),
            orientation: UnitQuaternion::from_quaternion(Quaternion::new(
                wxyz[0], wxyz[1], wxyz[2], wxyz[3],
            )),
        }
    }
}

/// One contact's force as drawn: an arrow from the contact point along
/// the force on the first body (N).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arrow {
    pub at: Vector3<f64>,
    pub force: Vector3<f64>,
}

/// A time in s as nanoseconds (what MCAP and the WebSocket protocol stamp).
pub fn nanos(t: f64) -> u64 {
    (t.max(0.0) * 1e9).round() as u64
}

/// A Foxglove `Time`.
pub fn time(t: f64) -> Value {
    let ns = nanos(t);
    json!({ "sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000 })
}

pub(crate) fn vec3(v: &Vector3<f64>) -> Value {
    json!({ "x": v.x, "y": v.y, "z": v.z })
}

/// A hull's faces as triangles (fans), three points each, in the shape's
/// frame; none for the other shapes.
fn hull_triangles(shape: &ShapeDesc) -> Vec<[f64; 3]> {
    let ShapeDesc::Hull { points } = shape else {
        return Vec::new();
    };
    let Ok(h) = cosim_shared::scene::hull::convex_hull(points) else {
        return Vec::new();
    };
    h.faces
        .iter()
        .flat_map(|f| (1..f.len().saturating_sub(1)).flat_map(move |k| [f[0], f[k], f[k + 1]]))
        .map(|k| h.vertices[k])
        .collect()
}

/// A scene's quaternion `[w, x, y, z]`, normalised.
pub(crate) fn quaternion(q: &[f64; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
}

fn quat(q: &UnitQuaternion<f64>) -> Value {
    json!({ "x": q.i, "y": q.j, "z": q.k, "w": q.w })
}

pub(crate) fn color(i: usize, alpha: f64) -> Value {
    let [r, g, b] = palette::color(i);
    json!({ "r": r as f64 / 255.0, "g": g as f64 / 255.0, "b": b as f64 / 255.0, "a": alpha })
}

fn grey(v: f64, alpha: f64) -> Value {
    json!({ "r": v, "g": v, "b": v, "a": alpha })
}

pub(crate) fn pose(p: &Vector3<f64>, q: &UnitQuaternion<f64>) -> Value {
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
        UnitQuaternion::from_axis_angle(&Unit::new_normalize(axis), std::f64::consts::PI)
    })
}

/// A scene entity with only the primitives given (Foxglove wants every
/// list present).
fn entity(stamp: &Value, id: &str, parts: &[(&str, Value)]) -> Value {
    let mut e = json!({
        "timestamp": stamp, "frame_id": "world", "id": id,
        "lifetime": time(0.0), "frame_locked": false, "metadata": [],
        "arrows": [], "cubes": [], "spheres": [], "cylinders": [], "lines": [],
        "triangles": [], "texts": [], "models": []
    });
    for (k, v) in parts {
        e[*k] = v.clone();
    }
    e
}

/// [`entity`] in body `frame`'s frame, moving with it (`frame_locked`):
/// drawn once, placed by each `/tf` after.
pub(crate) fn locked_entity(
    stamp: &Value,
    id: &str,
    frame: &str,
    parts: &[(&str, Value)],
) -> Value {
    let mut e = entity(stamp, id, parts);
    e["frame_id"] = json!(frame);
    e["frame_locked"] = json!(true);
    e
}

/// What a scene looks like, read once from its description.
#[derive(Debug, Clone)]
pub struct Drawing {
    names: Vec<String>,
    /// Per body its shapes, each with its hull's triangles (three points
    /// each, shape frame) where it is a hull.
    shapes: Vec<Vec<(PlacedShape, Vec<[f64; 3]>)>>,
    planes: Vec<(String, Vector3<f64>, Vector3<f64>)>,
    joints: Vec<Link>,
    /// The named frames (`[[body.frame]]`): body index, name, pose in the
    /// body's frame.
    frames: Vec<(usize, String, Value, Value)>,
}

/// A joint as drawn: a line from its anchor or first body to the other.
#[derive(Debug, Clone)]
struct Link {
    name: String,
    anchor: Vector3<f64>,
    /// Body index of each end (`None`: the world).
    a: Option<usize>,
    b: Option<usize>,
}

impl Drawing {
    pub fn new(scene: &Scene) -> Drawing {
        let index: BTreeMap<&str, usize> = scene
            .bodies
            .iter()
            .enumerate()
            .map(|(i, b)| (b.name.as_str(), i))
            .collect();
        let end = |name: &str| (name != WORLD).then(|| index.get(name).copied()).flatten();
        Drawing {
            names: scene.bodies.iter().map(|b| b.name.clone()).collect(),
            shapes: scene
                .bodies
                .iter()
                .map(|b| {
                    b.shapes()
                        .into_iter()
                        .map(|p| {
                            let triangles = hull_triangles(&p.shape);
                            (p, triangles)
                        })
                        .collect()
                })
                .collect(),
            planes: scene
                .planes
                .iter()
                .map(|p| {
                    (
                        p.name.clone(),
                        Vector3::from(p.normal).normalize(),
                        Vector3::from(p.point),
                    )
                })
                .collect(),
            joints: scene
                .joints
                .iter()
                .map(|j| Link {
                    name: j.name.clone(),
                    anchor: Vector3::from(j.anchor),
                    a: end(&j.body_a),
                    b: end(&j.body_b),
                })
                .collect(),
            frames: scene
                .frames()
                .map(|(k, f)| {
                    let q = quaternion(&f.orientation);
                    (
                        k,
                        f.name.clone(),
                        vec3(&Vector3::from(f.position)),
                        quat(&q),
                    )
                })
                .collect(),
        }
    }

    /// Body names, in the scene's order.
    pub fn bodies(&self) -> &[String] {
        &self.names
    }

    /// Outward unit normal of plane `i`.
    pub fn plane_normal(&self, i: usize) -> Option<Vector3<f64>> {
        self.planes.get(i).map(|p| p.1)
    }

    /// The `foxglove.SceneUpdate` of a state at time `t`: per body its
    /// shape (a sphere, a cube, a capsule as a cylinder between two
    /// spheres) with a small marker sphere on its body x axis (the
    /// rotation shows), a thin large box per plane, a line per joint
    /// (anchor or centre to centre), an arrow per contact force, from the
    /// contact point along the force, [`ARROW_PER_DECADE`] per decade of
    /// newtons.
    pub fn scene_update(&self, t: f64, poses: &[Pose], arrows: &[Arrow]) -> Value {
        let stamp = time(t);
        let mut entities = Vec::with_capacity(poses.len() + self.planes.len() + 2);
        for (b, (p, shapes)) in poses.iter().zip(&self.shapes).enumerate() {
            let c = color(b, 1.0);
            let (mut spheres, mut cylinders, mut cubes) = (Vec::new(), Vec::new(), Vec::new());
            for (placed, _) in shapes {
                let q = &(p.orientation * quaternion(&placed.orientation));
                let x = &(p.position + p.orientation * Vector3::from(placed.position));
                let ball = |at: &Vector3<f64>, r: f64, c: &Value| json!({ "pose": pose(at, q), "size": vec3(&Vector3::repeat(2.0 * r)), "color": c });
                match placed.shape {
                    ShapeDesc::Sphere { radius } => spheres.push(ball(x, radius, &c)),
                    ShapeDesc::Capsule {
                        radius,
                        half_length,
                    } => {
                        let axis = q * Vector3::new(0.0, 0.0, half_length);
                        spheres.push(ball(&(x - axis), radius, &c));
                        spheres.push(ball(&(x + axis), radius, &c));
                        // Foxglove's cylinder runs along its pose's z.
                        cylinders.push(json!({ "pose": pose(x, q),
                                 "size": vec3(&Vector3::new(2.0 * radius, 2.0 * radius, 2.0 * half_length)),
                                 "bottom_scale": 1.0, "top_scale": 1.0, "color": c }));
                    }
                    ShapeDesc::Box { half_extents: h } => cubes.push(json!({ "pose": pose(x, q),
                             "size": vec3(&(Vector3::from(h) * 2.0)), "color": c })),
                    ShapeDesc::Cylinder {
                        radius,
                        half_length,
                    } => cylinders.push(json!({ "pose": pose(x, q),
                             "size": vec3(&Vector3::new(2.0 * radius, 2.0 * radius, 2.0 * half_length)),
                             "bottom_scale": 1.0, "top_scale": 1.0, "color": c })),
                    // Sent once, locked to the body's frame (`hulls_update`).
                    ShapeDesc::Hull { .. } => {}
                }
                // The marker just inside the surface on the body's x axis,
                // on a body's one shape at its centre of mass (shapes away
                // from the centre show the rotation themselves).
                let hull = matches!(placed.shape, ShapeDesc::Hull { .. });
                if shapes.len() == 1 && placed.centred() && !hull {
                    let (reach, size) = match placed.shape {
                        ShapeDesc::Sphere { radius } => (0.75 * radius, 0.35 * radius),
                        ShapeDesc::Capsule { radius, .. } | ShapeDesc::Cylinder { radius, .. } => {
                            (0.75 * radius, 0.35 * radius)
                        }
                        ShapeDesc::Box { half_extents: h } => {
                            let small = h[0].min(h[1]).min(h[2]);
                            (h[0], 0.7 * small)
                        }
                        ShapeDesc::Hull { .. } => (0.0, 0.0),
                    };
                    let marker = x + q * Vector3::new(reach, 0.0, 0.0);
                    spheres.push(ball(&marker, 0.5 * size, &grey(0.1, 1.0)));
                }
            }
            let parts = [
                ("cylinders", Value::Array(cylinders)),
                ("cubes", Value::Array(cubes)),
                ("spheres", Value::Array(spheres)),
            ];
            entities.push(entity(&stamp, &format!("body/{}", self.names[b]), &parts));
        }
        for (name, n, point) in &self.planes {
            // The box's top face on the plane.
            let centre = point - n * 0.001;
            let cubes = json!([{ "pose": pose(&centre, &turn(&Vector3::z(), n)),
                                 "size": { "x": PLANE_SIDE, "y": PLANE_SIDE, "z": 0.002 },
                                 "color": grey(0.75, 0.35) }]);
            entities.push(entity(
                &stamp,
                &format!("plane/{name}"),
                &[("cubes", cubes)],
            ));
        }
        for Link { name, anchor, a, b } in &self.joints {
            let at = |end: &Option<usize>| end.and_then(|k| poses.get(k)).map(|p| p.position);
            let mut points = Vec::new();
            if a.is_none() || b.is_none() {
                points.push(vec3(anchor));
            }
            points.extend([at(a), at(b)].into_iter().flatten().map(|p| vec3(&p)));
            let lines = json!([{ "type": 0, "pose": pose(&Vector3::zeros(), &UnitQuaternion::identity()),
                                 "thickness": 0.01, "scale_invariant": false, "points": points,
                                 "color": grey(0.2, 1.0), "colors": [], "indices": [] }]);
            entities.push(entity(
                &stamp,
                &format!("joint/{name}"),
                &[("lines", lines)],
            ));
        }
        let arrows: Vec<Value> = arrows
            .iter()
            .filter(|a| a.force.norm() > 0.0)
            .map(|a| {
                let length = ARROW_PER_DECADE * (1.0 + a.force.norm()).log10();
                json!({
                    // Foxglove's arrow points along its pose's +x.
                    "pose": pose(&a.at, &turn(&Vector3::x(), &a.force)),
                    "shaft_length": 0.7 * length, "shaft_diameter": 0.006,
                    "head_length": 0.3 * length, "head_diameter": 0.015,
                    "color": { "r": 0.85, "g": 0.1, "b": 0.1, "a": 1.0 }
                })
            })
            .collect();
        entities.push(entity(
            &stamp,
            "contacts",
            &[("arrows", Value::Array(arrows))],
        ));
        json!({ "deletions": [], "entities": entities })
    }

    /// The hull shapes (collision meshes) as one `foxglove.SceneUpdate`,
    /// each body's locked to its frame (which `/tf` moves), so sent once
    /// rather than per state (a Panda's hulls are 0.4 MB of JSON); `None`
    /// when no body has a hull.
    pub fn hulls_update(&self) -> Option<Value> {
        let stamp = time(0.0);
        let entities: Vec<Value> = self
            .shapes
            .iter()
            .enumerate()
            .filter(|(_, shapes)| shapes.iter().any(|(_, t)| !t.is_empty()))
            .map(|(b, shapes)| {
                let c = color(b, 1.0);
                let triangles: Vec<Value> = shapes
                    .iter()
                    .filter(|(_, t)| !t.is_empty())
                    .map(|(placed, t)| {
                        let at = Vector3::from(placed.position);
                        json!({ "pose": pose(&at, &quaternion(&placed.orientation)),
                                "points": t.iter().map(|v| vec3(&Vector3::from(*v))).collect::<Vec<_>>(),
                                "color": c, "colors": [], "indices": [] })
                    })
                    .collect();
                locked_entity(
                    &stamp,
                    &format!("hull/{}", self.names[b]),
                    &self.names[b],
                    &[("triangles", Value::Array(triangles))],
                )
            })
            .collect();
        (!entities.is_empty()).then(|| json!({ "deletions": [], "entities": entities }))
    }

    /// The `foxglove.FrameTransforms` of a state: `world` to each body's
    /// frame (named after the body), then each body to its named frames
    /// (a robot's merged links, by their names).
    pub fn frame_transforms(&self, t: f64, poses: &[Pose]) -> Value {
        let stamp = time(t);
        let mut transforms: Vec<Value> = poses
            .iter()
            .zip(&self.names)
            .map(|(p, name)| {
                json!({ "timestamp": stamp, "parent_frame_id": "world", "child_frame_id": name,
                        "translation": vec3(&p.position), "rotation": quat(&p.orientation) })
            })
            .collect();
        transforms.extend(self.frames.iter().map(|(b, name, at, q)| {
            json!({ "timestamp": stamp, "parent_frame_id": self.names[*b], "child_frame_id": name,
                    "translation": at, "rotation": q })
        }));
        json!({ "transforms": transforms })
    }
}

/// A body's state as `cosim.BodyState`: the 13 numbers of a states.csv
/// row or a state frame's body (position, quaternion `[w, x, y, z]`,
/// linear and angular velocity), as written, not normalised.
pub fn body_state(row: &[f64; 13]) -> Value {
    let r = row;
    json!({
        "position": { "x": r[0], "y": r[1], "z": r[2] },
        "orientation": { "w": r[3], "x": r[4], "y": r[5], "z": r[6] },
        "linear_velocity": { "x": r[7], "y": r[8], "z": r[9] },
        "angular_velocity": { "x": r[10], "y": r[11], "z": r[12] },
    })
}

/// A force (N) as `cosim.Force`: the vector and its magnitude.
pub fn force_message(f: &Vector3<f64>) -> Value {
    json!({ "force": vec3(f), "magnitude": f.norm() })
}

/// A `cosim.JointCoordinate` message: a hinge's angle or a slider's
/// offset and its rate.
pub fn joint_coordinate(position: f64, rate: f64) -> Value {
    json!({ "position": position, "rate": rate })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_arrow_points_along_its_force() {
        let scene = Scene::parse(
            "[sim]\ndt = 0.01\nduration = 1.0\n[[body]]\nname = \"a\"\nradius = 0.1\nmass = 1.0\nposition = [0.0, 0.0, 1.0]\n",
            "test",
        )
        .expect("a valid scene");
        let d = Drawing::new(&scene);
        let pose = Pose::new([0.0, 0.0, 1.0], [1.0, 0.0, 0.0, 0.0]);
        let force = Vector3::new(0.0, 0.0, 99.0);
        let msg = d.scene_update(
            0.5,
            &[pose],
            &[Arrow {
                at: Vector3::zeros(),
                force,
            }],
        );
        let arrow = &msg["entities"][1]["arrows"][0];
        let q = &arrow["pose"]["orientation"];
        let q = UnitQuaternion::from_quaternion(Quaternion::new(
            q["w"].as_f64().unwrap_or(f64::NAN),
            q["x"].as_f64().unwrap_or(f64::NAN),
            q["y"].as_f64().unwrap_or(f64::NAN),
            q["z"].as_f64().unwrap_or(f64::NAN),
        ));
        assert!((q * Vector3::x() - Vector3::z()).norm() < 1e-12);
        // Two decades of newtons: two arrow lengths per decade.
        let length = arrow["shaft_length"].as_f64().unwrap_or(0.0)
            + arrow["head_length"].as_f64().unwrap_or(0.0);
        assert!((length - 2.0 * ARROW_PER_DECADE).abs() < 1e-12);
        assert_eq!(msg["entities"][0]["id"], "body/a");
        assert_eq!(msg["entities"][0]["spheres"][0]["size"]["x"], 0.2);
    }
}

//! URDF import (issue 17, point 3): a robot description turned into a
//! scene, written as scene text and read by `Scene::parse`, so that its
//! checks and their messages are the scene file's.
//!
//! The subset, as MuJoCo's and Drake's importers read it:
//!
//! - a link is a body: its `<inertial>` mass and inertia, its one
//!   `<collision>` a sphere, box or capsule (a cylinder becomes the
//!   capsule of its radius and overall length, its ends rounded; said on
//!   import), centred on the inertial origin with the same axes (a shape
//!   is centred on its body's centre of mass here);
//! - a root link without mass or collision (`world`, `base_footprint`) is
//!   the fixed world; a root link with mass is welded to the world (a
//!   fixed base, MuJoCo's default for a robot without a free joint);
//! - `revolute`, `continuous`, `prismatic` and `fixed` joints; a
//!   revolute's or prismatic's `<limit lower upper>` is its `range`; the
//!   joints are passive, as MuJoCo and Drake leave them unless an
//!   actuator drives them (issue 45: a velocity motor with target 0 made
//!   of every `effort` held a pendulum still, PyBullet's best-known
//!   gotcha); `effort` and `velocity` bound actuators, which the URDF has
//!   none of; a joint's two links do not collide (MuJoCo's parent-child
//!   filter);
//! - a floor plane at z = 0 and the scene file's defaults (h = 1 ms, 3 s).
//!
//! Anything else (a mesh, several collisions, a floating, planar or
//! mimic joint, a link that is no joint's child and not the root, a
//! collision away from the centre of mass) is refused with the link or
//! joint named. Left out as they change no rigid-body answer here or have
//! no counterpart: visuals, materials, `<dynamics>` damping and friction,
//! `<calibration>`, `<safety_controller>` and a limit's `velocity`.

use cosim_shared::{Scene, SceneError};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use std::fmt::Write as _;
use std::path::Path;

/// Reads a `.urdf` file as a scene named after the file.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| fault(&file, "", format!("cannot read the file: {e}")))?;
    let name = path
        .file_stem()
        .map_or("robot".into(), |s| s.to_string_lossy().into_owned());
    scene(&text, &file, &name)
}

fn fault(file: &str, field: &str, message: String) -> SceneError {
    SceneError {
        file: file.to_string(),
        location: None,
        field: field.to_string(),
        message,
    }
}

fn pose(p: &urdf_rs::Pose) -> Isometry3<f64> {
    let [r, pi, y] = *p.rpy;
    Isometry3::from_parts(
        Translation3::from(Vector3::from(*p.xyz)),
        // URDF's rpy: about the fixed x, y, z axes in that order, R =
        // Rz(yaw) Ry(pitch) Rx(roll), nalgebra's order too.
        UnitQuaternion::from_euler_angles(r, pi, y),
    )
}

/// The scene of URDF text `text` (from `file`), named `name`.
pub fn scene(text: &str, file: &str, name: &str) -> Result<Scene, SceneError> {
    let robot =
        urdf_rs::read_from_string(text).map_err(|e| fault(file, "", format!("not a URDF: {e}")))?;
    let link = |n: &str| robot.links.iter().position(|l| l.name == n);
    for j in &robot.joints {
        for (key, l) in [("parent", &j.parent.link), ("child", &j.child.link)] {
            if link(l).is_none() {
                return Err(fault(
                    file,
                    &format!("joint {:?}.{key}", j.name),
                    format!("= {l:?}: no such link"),
                ));
            }
        }
    }
    let is_child = |l: &str| robot.joints.iter().any(|j| j.child.link == l);
    let roots: Vec<&str> = robot
        .links
        .iter()
        .map(|l| l.name.as_str())
        .filter(|l| !is_child(l))
        .collect();
    let [root] = roots[..] else {
        return Err(fault(
            file,
            "robot",
            format!(
                "has {} root links ({roots:?}): a URDF is one tree",
                roots.len()
            ),
        ));
    };
    // World frames of the links, from the root down the joints.
    let mut frame: Vec<Option<Isometry3<f64>>> = vec![None; robot.links.len()];
    frame[link(root).unwrap_or(0)] = Some(Isometry3::identity());
    for _ in 0..robot.links.len() {
        for j in &robot.joints {
            let (p, c) = (link(&j.parent.link), link(&j.child.link));
            if let (Some(p), Some(c)) = (p, c) {
                if let (Some(tp), None) = (frame[p], frame[c]) {
                    frame[c] = Some(tp * pose(&j.origin));
                }
            }
        }
    }
    let mut s = format!(
        "[sim]\nname = {name:?}\ndt = 0.001\nduration = 3.0\ngravity = [0.0, 0.0, -9.81]\nfriction_directions = 8\n\n"
    );
    let v3 = |v: Vector3<f64>| format!("[{:?}, {:?}, {:?}]", v.x, v.y, v.z);
    // Which links are bodies: all but a root without mass or collision.
    let world_root = robot
        .links
        .iter()
        .find(|l| l.name == root)
        .is_some_and(|l| l.inertial.mass.value == 0.0 && l.collision.is_empty());
    for (k, l) in robot.links.iter().enumerate() {
        if world_root && l.name == root {
            continue;
        }
        let field = |key: &str| format!("link {:?}.{key}", l.name);
        let Some(t) = frame[k] else {
            return Err(fault(
                file,
                &field("name"),
                "is not reached from the root".into(),
            ));
        };
        let [c] = &l.collision[..] else {
            return Err(fault(
                file,
                &field("collision"),
                format!(
                    "has {} <collision> elements: a body here has exactly one shape",
                    l.collision.len()
                ),
            ));
        };
        let (a, b) = (&l.inertial.origin, &c.origin);
        let apart = (0..3)
            .any(|i| (a.xyz[i] - b.xyz[i]).abs() > 1e-9 || (a.rpy[i] - b.rpy[i]).abs() > 1e-9);
        if apart {
            return Err(fault(
                file,
                &field("collision.origin"),
                format!(
                    "= xyz {:?} rpy {:?}, not the <inertial> origin xyz {:?} rpy {:?}: a shape is \
                     centred on its body's centre of mass here",
                    *b.xyz, *b.rpy, *a.xyz, *a.rpy
                ),
            ));
        }
        let shape = match &c.geometry {
            urdf_rs::Geometry::Sphere { radius } => format!("radius = {radius:?}\n"),
            urdf_rs::Geometry::Box { size } => {
                format!(
                    "half_extents = [{:?}, {:?}, {:?}]\n",
                    size[0] / 2.0,
                    size[1] / 2.0,
                    size[2] / 2.0
                )
            }
            urdf_rs::Geometry::Capsule { radius, length } => {
                format!("radius = {radius:?}\nhalf_length = {:?}\n", length / 2.0)
            }
            urdf_rs::Geometry::Cylinder { radius, length } => {
                // The capsule of the same radius and overall length.
                let half = length / 2.0 - radius;
                if half > 0.0 {
                    eprintln!(
                        "note: link {:?}: its cylinder is a capsule here (same radius and length, ends rounded)",
                        l.name
                    );
                    format!("radius = {radius:?}\nhalf_length = {half:?}\n")
                } else {
                    eprintln!(
                        "note: link {:?}: its cylinder (no longer than wide) is a sphere here",
                        l.name
                    );
                    format!("radius = {:?}\n", radius.max(length / 2.0))
                }
            }
            urdf_rs::Geometry::Mesh { filename, .. } => {
                return Err(fault(
                    file,
                    &field("collision.geometry"),
                    format!(
                    "is the mesh {filename:?}: outside the subset (sphere, box, capsule, cylinder)"
                ),
                ))
            }
        };
        let body = t * pose(a);
        let q = body.rotation;
        let i = &l.inertial.inertia;
        let _ = write!(
            s,
            "[[body]]\nname = {:?}\n{shape}mass = {:?}\ninertia = [{:?}, {:?}, {:?}, {:?}, {:?}, {:?}]\nposition = {}\norientation = [{:?}, {:?}, {:?}, {:?}]\nfriction = 0.5\n\n",
            l.name,
            l.inertial.mass.value,
            i.ixx,
            i.iyy,
            i.izz,
            i.ixy,
            i.ixz,
            i.iyz,
            v3(body.translation.vector),
            q.w,
            q.i,
            q.j,
            q.k
        );
    }
    s += "[[plane]]\nname = \"floor\"\nnormal = [0.0, 0.0, 1.0]\npoint = [0.0, 0.0, 0.0]\nfriction = 0.5\n\n";
    if !world_root {
        let at =
            v3(frame[link(root).unwrap_or(0)].map_or(Vector3::zeros(), |t| t.translation.vector));
        let _ = write!(
            s,
            "[[joint]]\nname = \"{root}_to_world\"\ntype = \"fixed\"\nbody_a = \"world\"\nbody_b = {root:?}\nanchor = {at}\n\n"
        );
    }
    for j in &robot.joints {
        let field = |key: &str| format!("joint {:?}.{key}", j.name);
        use urdf_rs::JointType as T;
        let kind = match j.joint_type {
            T::Revolute | T::Continuous => "revolute",
            T::Prismatic => "prismatic",
            T::Fixed => "fixed",
            ref other => {
                return Err(fault(
                    file,
                    &field("type"),
                    format!(
                        "= {other:?}: outside the subset (revolute, continuous, prismatic, fixed)"
                    ),
                ))
            }
        };
        if let Some(m) = &j.mimic {
            return Err(fault(
                file,
                &field("mimic"),
                format!(
                    "= {:?}: outside the subset (a coupled joint needs a constraint between coordinates)",
                    m.joint
                ),
            ));
        }
        let parent = frame[link(&j.parent.link).unwrap_or(0)].unwrap_or_else(Isometry3::identity);
        let at = parent * pose(&j.origin);
        let side = |l: &str| {
            if world_root && l == root {
                "world".to_string()
            } else {
                l.to_string()
            }
        };
        let _ = write!(
            s,
            "[[joint]]\nname = {:?}\ntype = \"{kind}\"\nbody_a = {:?}\nbody_b = {:?}\nanchor = {}\ncollide = false\n",
            j.name,
            side(&j.parent.link),
            side(&j.child.link),
            v3(at.translation.vector)
        );
        if kind != "fixed" {
            let axis = at.rotation * Vector3::from(*j.axis.xyz);
            let _ = writeln!(s, "axis = {}", v3(axis));
            let (lo, hi) = (j.limit.lower, j.limit.upper);
            if j.joint_type != T::Continuous && lo.is_finite() && hi.is_finite() && lo < hi {
                let _ = writeln!(s, "range = [{lo:?}, {hi:?}]");
            }
        }
        s.push('\n');
    }
    Scene::parse(&s, file)
}

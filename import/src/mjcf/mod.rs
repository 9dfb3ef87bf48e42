//! MJCF import (MuJoCo's format: the dm_control suite, gymnasium's
//! models, MuJoCo Menagerie), read as MuJoCo's compiler reads it (issue
//! 45, point 4) and written as our scene:
//!
//! - `<include>`s, `<default>` classes (`class`, `childclass`, `main`),
//!   the compiler's `angle`, `eulerseq`, `inertiafromgeom`,
//!   `inertiagrouprange`, `boundmass`, `boundinertia`, `settotalmass`,
//!   `meshdir` and `autolimits`; `<option>`'s `timestep` and `gravity`,
//!   and its `<flag>`s that switch off gravity, contacts, limits,
//!   equalities, friction loss, springs and dampers, or actuators;
//! - masses as MuJoCo makes them (`mass.rs`): each geom's from its volume
//!   and density or its `mass`, a body's from its geoms in the inertia
//!   groups or its `<inertial>`; bodies with no joint are welded to their
//!   parent and become one body with it (MuJoCo's `fusestatic`), named
//!   after the top one, the others its named frames (`[[body.frame]]`);
//!   bodies welded to the world are bodies fixed to it;
//! - `free`, `ball`, `hinge` and `slide` joints with ranges. A body on
//!   several joints (a hip's three hinges, a planar root's two slides and
//!   a hinge) is a chain in maximal coordinates: one body per joint but
//!   the last (named `body~joint`, at the joint's anchor, a tenth of the
//!   body's mass and inertia taken from it), said;
//! - the bodies as written (`qpos0`), or at a `<key>`'s `qpos`;
//! - geoms: planes of the world are planes; spheres, capsules and boxes
//!   as they are; cylinders and ellipsoids as hulls of points on them and
//!   meshes as their hulls (said); a geom with `contype` and
//!   `conaffinity` 0 is visual only;
//! - actuators on joints: `position` (and `general` with an affine bias
//!   that is one) a servo, `velocity` a velocity actuator, both implicit
//!   and bounded by `forcerange`; `motor` leaves the joint to the
//!   controller's torque; a joint's `stiffness` and `damping` a spring and
//!   damper where no actuator holds the joint; `frictionloss` dry
//!   friction where nothing else does (one drive per joint: what is left
//!   out is said);
//! - `<contact><exclude>` of two jointed bodies, equality `connect`
//!   (spherical joint), `weld` (fixed joint) and `joint` (its linear part:
//!   the scene's `mimic`);
//! - a hinge's, slide's or ball's `armature` (a free joint's is said).
//!
//! Left out and said: tendons and what acts on them, heightfields, activation dynamics, an equality `joint`'s terms past
//! the linear one.

mod defaults;
mod frame;
pub mod mass;
mod read;
mod xml;

use crate::options::{Imported, Options};
use crate::problems::Problems;
use crate::UNBOUNDED;
use cosim_shared::scene::{FrameEntry, MotorDesc, ShapeKind, MIN_MOMENT};
use cosim_shared::{
    BodyDesc, JointDesc, JointKind as Kind, PlaneDesc, Scene, SceneError, ShapeEntry, VisualEntry,
    VisualKind, WORLD,
};
use mass::Mass;
use nalgebra::{Isometry3, Matrix3, Point3, Translation3, UnitQuaternion, Vector3};
use read::{GeomKind, JointKind, Model};
use std::collections::HashMap;
use std::path::Path;

/// A chain body's share of the mass and inertia of the body whose joints
/// it chains, taken from that body. A tenth: at a hundredth PGS diverged
/// on gymnasium's hopper after 1.9 s (mass ratios of 100 in its root).
pub const CHAIN_SHARE: f64 = 0.1;

/// Appended to a joint's name where a body has it (MJCF names bodies and
/// joints apart; a scene names both in one space).
pub const JOINT_SUFFIX: &str = ":joint";

/// Reads an MJCF file as a scene named after its model (or file).
pub fn load(path: &Path, options: Options) -> Result<Imported, SceneError> {
    crate::read_with(path, options, import)
}

/// The scene of MJCF text `text` from `file` (whose folder `dir` includes
/// and meshes are found from).
pub fn import(
    text: &str,
    file: &str,
    name: &str,
    dir: Option<&Path>,
    options: Options,
) -> Result<Imported, SceneError> {
    let mut problems = Problems::new(file);
    let Some(tree) = xml::parse(text, file, dir, &mut problems) else {
        problems.check()?;
        return Err(SceneError {
            file: file.into(),
            location: None,
            field: String::new(),
            message: "not an MJCF file".into(),
        });
    };
    let model = read::model(&tree, &mut problems);
    let mut notes: Vec<String> = model.left_out.clone();
    let built = Builder::new(&model, dir, &options, &mut problems, &mut notes).build(name);
    problems.check()?;
    let mut scene = built.ok_or_else(|| SceneError {
        file: file.into(),
        location: None,
        field: String::new(),
        message: "the model could not be built".into(),
    })?;
    if options.floor {
        scene.planes.push(PlaneDesc {
            name: "floor".into(),
            normal: [0.0, 0.0, 1.0],
            point: [0.0; 3],
            friction: 1.0,
            restitution: 0.0,
        });
    }
    scene.validate(file)?;
    Ok(Imported { scene, notes })
}

/// Where a MuJoCo body stands: its world frame and its joints' world
/// anchors and axes (before each joint's own motion, as MuJoCo's
/// kinematics takes them).
struct Placed {
    frame: Vec<Isometry3<f64>>,
    /// Per body, per joint: (anchor, axis) in the world.
    joints: Vec<Vec<(Vector3<f64>, Vector3<f64>)>>,
}

struct Builder<'a> {
    m: &'a Model,
    dir: Option<&'a Path>,
    options: &'a Options,
    problems: &'a mut Problems,
    notes: &'a mut Vec<String>,
}

/// A body's name in the scene: MuJoCo's, or `body<id>` for one without.
fn body_name(m: &Model, b: usize) -> String {
    if b == 0 {
        WORLD.to_string()
    } else if m.bodies[b].name.is_empty() {
        format!("body{b}")
    } else {
        m.bodies[b].name.clone()
    }
}

/// The joints' names in MuJoCo's order: MuJoCo's (`joint<id>` for one
/// without), `name:joint` where a body has the name (MJCF keeps bodies and
/// joints apart, a scene names both in one).
fn joint_names(m: &Model) -> Vec<String> {
    let mut k = 0;
    let mut out = Vec::new();
    for b in &m.bodies {
        for j in &b.joints {
            let name = if j.name.is_empty() {
                format!("joint{k}")
            } else {
                j.name.clone()
            };
            let clash = (0..m.bodies.len()).any(|b| body_name(m, b) == name);
            out.push(if clash {
                format!("{name}{JOINT_SUFFIX}")
            } else {
                name
            });
            k += 1;
        }
    }
    out
}

impl Builder<'_> {
    fn new<'a>(
        m: &'a Model,
        dir: Option<&'a Path>,
        options: &'a Options,
        problems: &'a mut Problems,
        notes: &'a mut Vec<String>,
    ) -> Builder<'a> {
        Builder {
            m,
            dir,
            options,
            problems,
            notes,
        }
    }

    /// Each body's own mass properties in its frame, as MuJoCo's compiler
    /// makes them (`settotalmass` applied), and the meshes' hulls.
    fn masses(&mut self, hulls: &HashMap<usize, (Vec<[f64; 3]>, Option<Mass>)>) -> Vec<Mass> {
        let m = self.m;
        let c = &m.compiler;
        let mut out: Vec<Mass> = m
            .bodies
            .iter()
            .enumerate()
            .map(|(k, b)| {
                if k == 0 {
                    return Mass::zero();
                }
                let from_geoms = match c.from_geom {
                    read::FromGeom::True => true,
                    read::FromGeom::False => false,
                    read::FromGeom::Auto => b.inertial.is_none(),
                };
                let mut total = if from_geoms {
                    b.geoms
                        .iter()
                        .filter(|g| (c.groups[0]..=c.groups[1]).contains(&g.group))
                        .filter_map(|g| {
                            let mesh = match g.kind {
                                GeomKind::Mesh(i) => hulls.get(&i).and_then(|h| h.1.as_ref()),
                                _ => None,
                            };
                            mass::of_geom(g, mesh)
                        })
                        .fold(Mass::zero(), |a, g| a.add(&g))
                } else if let Some(i) = &b.inertial {
                    let [xx, yy, zz, xy, xz, yz] = i.inertia;
                    let local = Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz);
                    Mass {
                        mass: i.mass,
                        com: Vector3::zeros(),
                        inertia: local,
                    }
                    .moved(&i.pose)
                } else {
                    Mass::zero()
                };
                if total.mass < c.boundmass {
                    total.mass = c.boundmass;
                }
                if c.boundinertia > 0.0 {
                    for d in 0..3 {
                        total.inertia[(d, d)] = total.inertia[(d, d)].max(c.boundinertia);
                    }
                }
                total
            })
            .collect();
        if let Some(target) = c.settotalmass {
            let sum: f64 = out.iter().map(|b| b.mass).sum();
            if sum > 0.0 {
                for b in out.iter_mut().skip(1) {
                    *b = b.scaled(target / sum);
                }
            }
        }
        out
    }

    /// The initial coordinates: per joint, its `qpos` entries (a hinge's
    /// or slide's one, a ball's quaternion, a free joint's position and
    /// quaternion), from the key asked for or `qpos0`, then the options'
    /// joint positions.
    fn coordinates(&mut self, names: &[String]) -> Vec<Vec<f64>> {
        let m = self.m;
        let mut q: Vec<Vec<f64>> = Vec::new();
        let mut k = 0;
        for (b, body) in m.bodies.iter().enumerate() {
            for j in &body.joints {
                q.push(match j.kind {
                    JointKind::Hinge | JointKind::Slide => vec![j.reference],
                    JointKind::Ball => vec![1.0, 0.0, 0.0, 0.0],
                    JointKind::Free => {
                        // qpos0 of a free joint is the body as written, in
                        // the world: filled in by `place`.
                        let _ = b;
                        Vec::new()
                    }
                });
                k += 1;
            }
        }
        let _ = k;
        if let Some(want) = &self.options.keyframe {
            match m.keys.iter().find(|key| &key.name == want) {
                None => {
                    let known: Vec<&str> = m.keys.iter().map(|k| k.name.as_str()).collect();
                    self.problems.add(
                        0,
                        "<keyframe>",
                        format!("no <key name={want:?}>; the file has {known:?}"),
                    )
                }
                Some(key) => {
                    let width = |j: &read::Joint| match j.kind {
                        JointKind::Free => 7,
                        JointKind::Ball => 4,
                        _ => 1,
                    };
                    let all: Vec<&read::Joint> = m.bodies.iter().flat_map(|b| &b.joints).collect();
                    let total: usize = all.iter().map(|j| width(j)).sum();
                    match &key.qpos {
                        Some(v) if v.len() == total => {
                            let mut at = 0;
                            for (j, slot) in all.iter().zip(q.iter_mut()) {
                                let n = width(j);
                                *slot = v[at..at + n].to_vec();
                                at += n;
                            }
                        }
                        Some(v) => self.problems.add(
                            0,
                            format!("<key name={want:?}>.qpos"),
                            format!("has {} numbers; the joints take {total}", v.len()),
                        ),
                        None => {}
                    }
                }
            }
        }
        // A coordinate outside its joint's range starts at the nearer
        // limit (as the URDF importer does), not yanked in by the first
        // step; said.
        let all: Vec<&read::Joint> = m.bodies.iter().flat_map(|b| &b.joints).collect();
        for (k, j) in all.iter().enumerate() {
            if let (Some(r), [c]) = (j.range, q[k].as_mut_slice()) {
                if *c < r[0] || *c > r[1] {
                    let near = c.clamp(r[0], r[1]);
                    self.notes.push(format!(
                        "joint {:?}: its coordinate {c} is outside its range {r:?}: it starts at {near}",
                        names[k]
                    ));
                    *c = near;
                }
            }
        }
        for (name, &value) in &self.options.positions {
            match names.iter().position(|n| n == name) {
                Some(i) if q[i].len() == 1 => {
                    if let Some(r) = all[i].range.filter(|r| value < r[0] || value > r[1]) {
                        self.problems.add(
                            0,
                            format!("joint {name:?}"),
                            format!("position {value} is outside its range {r:?}"),
                        );
                    }
                    q[i][0] = value;
                }
                Some(_) => self.problems.add(
                    0,
                    format!("joint {name:?}"),
                    "is not a hinge or slide: it takes no single position",
                ),
                None => self.problems.add(
                    0,
                    format!("joint {name:?}"),
                    format!("no such joint; the file's are {names:?}"),
                ),
            }
        }
        q
    }

    /// Forward kinematics at the coordinates `q`, as MuJoCo's: a body's
    /// frame is its parent's times its pose, then each joint in order
    /// moves it about (or along) the joint's axis by the coordinate less
    /// its `ref`.
    fn place(&self, q: &[Vec<f64>]) -> Placed {
        let m = self.m;
        let mut frame = vec![Isometry3::identity(); m.bodies.len()];
        let mut joints = vec![Vec::new(); m.bodies.len()];
        let mut k = 0;
        for (b, body) in m.bodies.iter().enumerate().skip(1) {
            let mut x = frame[body.parent] * body.pose;
            for j in &body.joints {
                let anchor = x * Point3::from(j.pos);
                let axis = x.rotation * j.axis;
                joints[b].push((anchor.coords, axis));
                let c = &q[k];
                k += 1;
                match j.kind {
                    JointKind::Hinge => {
                        let turn = UnitQuaternion::from_axis_angle(
                            &nalgebra::Unit::new_unchecked(axis),
                            c[0] - j.reference,
                        );
                        x = about(anchor, turn) * x;
                    }
                    JointKind::Slide => {
                        x = Translation3::from(axis * (c[0] - j.reference)) * x;
                    }
                    JointKind::Ball => {
                        let local = quat(c);
                        let turn = x.rotation * local * x.rotation.inverse();
                        x = about(anchor, turn) * x;
                    }
                    JointKind::Free if c.len() == 7 => {
                        x = Isometry3::from_parts(
                            Translation3::new(c[0], c[1], c[2]),
                            quat(&c[3..]),
                        );
                    }
                    JointKind::Free => {}
                }
            }
            frame[b] = x;
        }
        Placed { frame, joints }
    }

    fn build(&mut self, name: &str) -> Option<Scene> {
        let m = self.m;
        let names = joint_names(m);
        let hulls = self.hulls();
        let own = self.masses(&hulls);
        let q = self.coordinates(&names);
        let placed = self.place(&q);
        // Groups: a body with joints (or a mocap body, or a child of the
        // world) tops its own; one without joints is welded to its
        // parent's.
        let n = m.bodies.len();
        let mut top = vec![0; n];
        for b in 1..n {
            let body = &m.bodies[b];
            top[b] = if !body.joints.is_empty() || body.parent == 0 || body.mocap {
                b
            } else {
                top[body.parent]
            };
        }
        let header = format!(
            "[sim]\nname = {:?}\ndt = {:?}\nduration = 5.0\ngravity = {:?}\nfriction_directions = 8\n",
            m.name.as_deref().unwrap_or(name),
            m.timestep,
            m.gravity
        );
        let mut scene = Scene::read(&header, "<mjcf>").ok()?;
        // Visual geoms touch nothing (contype and conaffinity 0).
        let collides = |g: &read::Geom| g.contype != 0 || g.conaffinity != 0;
        for g in &m.bodies[0].geoms {
            if !collides(g) {
                continue;
            }
            if g.kind == GeomKind::Plane {
                let normal = g.pose.rotation * Vector3::z();
                scene.planes.push(PlaneDesc {
                    name: if g.name.is_empty() {
                        format!("plane{}", scene.planes.len())
                    } else {
                        g.name.clone()
                    },
                    normal: normal.into(),
                    point: g.pose.translation.vector.into(),
                    friction: g.friction,
                    restitution: 0.0,
                });
            } else {
                self.notes.push(format!(
                    "{}: a shape of the world other than a plane is left out",
                    g.label
                ));
            }
        }
        // The bodies (one per group) and what holds each.
        let mut group_body: Vec<String> = vec![String::new(); n];
        group_body[0] = WORLD.into();
        let self_collision = self.options.self_collision;
        let group_name = m.name.clone().unwrap_or_else(|| name.to_string());
        for t in (1..n).filter(|&b| top[b] == b) {
            let members: Vec<usize> = (1..n).filter(|&b| top[b] == t).collect();
            let world_mass = members
                .iter()
                .map(|&b| own[b].moved(&placed.frame[b]))
                .fold(Mass::zero(), |a, x| a.add(&x));
            let body = &m.bodies[t];
            let merged: Vec<String> = members[1..].iter().map(|&b| body_name(m, b)).collect();
            if !merged.is_empty() {
                self.notes.push(format!(
                    "bodies {merged:?} have no joint: one body with {:?}",
                    body_name(m, t)
                ));
            }
            let held = body.joints.is_empty() || body.mocap;
            let turn = placed.frame[t].rotation;
            let (mass, com, inertia) = if world_mass.mass > 0.0 {
                (world_mass.mass, world_mass.com, world_mass.inertia)
            } else if held {
                (
                    1.0,
                    placed.frame[t].translation.vector,
                    Matrix3::identity() * 1e-2,
                )
            } else {
                self.problems.add(
                    body.line,
                    body.label.clone(),
                    "moves on a joint but has no mass (nor have the bodies welded to it)",
                );
                continue;
            };
            let pose = Isometry3::from_parts(Translation3::from(com), turn);
            let mut shapes = Vec::new();
            let mut visual = Vec::new();
            let mut friction: f64 = 0.0;
            for &b in &members {
                for g in &m.bodies[b].geoms {
                    let at = pose.inverse() * placed.frame[b] * g.pose;
                    visual.extend(self.visual(g, &at));
                    if !collides(g) {
                        continue;
                    }
                    if let Some(entry) = self.shape(g, &at, &hulls) {
                        shapes.push(entry);
                        friction = friction.max(g.friction);
                    }
                }
            }
            let local = turn.to_rotation_matrix();
            let mut i = local.matrix().transpose() * inertia * local.matrix();
            let body_label = body_name(m, t);
            if let Some(least) = raise(&mut i) {
                self.notes.push(format!(
                    "body {body_label:?}: its inertia's least moment {least:e} kg m^2 is raised to {MIN_MOMENT:e}"
                ));
            }
            let mut desc = BodyDesc {
                name: body_label.clone(),
                radius: None,
                half_length: None,
                half_extents: None,
                mass,
                inertia: Some(six(&i)),
                position: com.into(),
                orientation: [turn.w, turn.i, turn.j, turn.k],
                velocity: [0.0; 3],
                angular_velocity: [0.0; 3],
                friction,
                restitution: 0.0,
                force: [0.0; 3],
                group: (!self_collision).then(|| group_name.clone()),
                shape: shapes,
                visual,
                // The welded bodies' frames, by their names.
                frame: members[1..]
                    .iter()
                    .map(|&b| {
                        let at = pose.inverse() * placed.frame[b];
                        let q = at.rotation;
                        FrameEntry {
                            name: body_name(m, b),
                            position: at.translation.vector.into(),
                            orientation: [q.w, q.i, q.j, q.k],
                        }
                    })
                    .collect(),
            };
            if desc.shape.is_empty() && desc.inertia.is_none() {
                desc.inertia = Some(six(&Matrix3::identity()));
            }
            group_body[t] = body_label;
            scene.bodies.push(desc);
        }
        // The joints: each group to its parent's, through a chain of small
        // bodies where the top body has several.
        let parent_of = |t: usize| group_body[top[m.bodies[t].parent]].clone();
        let mut k0 = 0;
        let mut first_joint = vec![0; n];
        for (b, body) in m.bodies.iter().enumerate() {
            first_joint[b] = k0;
            k0 += body.joints.len();
        }
        for t in (1..n).filter(|&b| top[b] == b) {
            if group_body[t].is_empty() {
                continue;
            }
            let body = &m.bodies[t];
            let child = group_body[t].clone();
            let parent = parent_of(t);
            if body.joints.is_empty() || body.mocap {
                scene.joints.push(fixed(
                    &format!("{child}:weld"),
                    &parent,
                    &child,
                    scene_point(&scene, &child),
                ));
                continue;
            }
            if body.joints.iter().any(|j| j.kind == JointKind::Free) {
                if body.joints.len() > 1 {
                    self.problems.add(
                        body.line,
                        body.label.clone(),
                        "a free joint must be a body's only joint",
                    );
                }
                if self.options.fixed_base && body.parent == 0 {
                    scene.joints.push(fixed(
                        &format!("{child}:base"),
                        WORLD,
                        &child,
                        scene_point(&scene, &child),
                    ));
                }
                continue;
            }
            let count = body.joints.len();
            // The chain's bodies take their share of the body's mass and
            // inertia from it (the total mass is MuJoCo's), each at its
            // joint's anchor: at the body's centre of mass instead, PGS
            // diverged on gymnasium's swimmer, whose hinge is 1 m away.
            let Some(c) = scene.bodies.iter().position(|d| d.name == child) else {
                continue;
            };
            let (mass, inertia, orientation) = {
                let d = &mut scene.bodies[c];
                let keep = 1.0 - CHAIN_SHARE * (count - 1) as f64;
                let whole = (d.mass, d.inertia);
                d.mass *= keep;
                d.inertia = d.inertia.map(|x| {
                    let mut i = from_six(&x) * keep;
                    raise(&mut i);
                    six(&i)
                });
                (whole.0, whole.1, d.orientation)
            };
            let mut a = parent.clone();
            for (i, j) in body.joints.iter().enumerate() {
                let k = first_joint[t] + i;
                let (anchor, axis) = placed.joints[t][i];
                let b = if i + 1 == count {
                    child.clone()
                } else {
                    let v = format!("{child}~{}", names[k]);
                    scene.bodies.push(BodyDesc {
                        name: v.clone(),
                        radius: None,
                        half_length: None,
                        half_extents: None,
                        mass: mass * CHAIN_SHARE,
                        inertia: inertia.map(|x| {
                            let mut i = from_six(&x) * CHAIN_SHARE;
                            raise(&mut i);
                            six(&i)
                        }),
                        position: anchor.into(),
                        orientation,
                        velocity: [0.0; 3],
                        angular_velocity: [0.0; 3],
                        friction: 0.0,
                        restitution: 0.0,
                        force: [0.0; 3],
                        group: None,
                        shape: Vec::new(),
                        visual: Vec::new(),
                        frame: Vec::new(),
                    });
                    v
                };
                let desc = self.joint(j, &names[k], &a, &b, anchor, axis, &q[k]);
                scene.joints.extend(desc);
                a = b;
            }
            if count > 1 {
                self.notes.push(format!(
                    "body {child:?} moves on {count} joints: a chain of {} bodies between them, each {} % of its mass and inertia",
                    count - 1,
                    CHAIN_SHARE * 100.0
                ));
            }
        }
        self.drives(&mut scene, &names);
        self.equalities(&mut scene, &placed, &group_body, &top);
        self.joint_equalities(&mut scene, &names);
        self.excludes(&mut scene, &group_body, &top);
        Some(scene)
    }

    /// The joint `j` (named `name`) between `a` and `b` at its world
    /// anchor and axis, at coordinate `c`.
    #[allow(clippy::too_many_arguments)]
    fn joint(
        &mut self,
        j: &read::Joint,
        name: &str,
        a: &str,
        b: &str,
        anchor: Vector3<f64>,
        axis: Vector3<f64>,
        c: &[f64],
    ) -> Option<JointDesc> {
        let kind = match j.kind {
            JointKind::Hinge => Kind::Revolute,
            JointKind::Slide => Kind::Prismatic,
            JointKind::Ball => Kind::Spherical,
            JointKind::Free => return None,
        };
        let mut range = j.range;
        if let (Kind::Revolute, Some(r)) = (kind, range) {
            let pi = std::f64::consts::PI;
            if r[0] < -pi || r[1] > pi {
                let clamped = [r[0].max(-pi), r[1].min(pi)];
                self.notes.push(format!(
                    "joint {name:?}: its range {r:?} is beyond [-pi, pi]: {clamped:?} taken"
                ));
                range = (clamped[0] < clamped[1]).then_some(clamped);
            }
        }
        if kind == Kind::Spherical && j.range.is_some() {
            self.notes.push(format!(
                "joint {name:?}: a ball joint's range is not modelled"
            ));
            range = None;
        }
        let mut position = match kind {
            Kind::Revolute | Kind::Prismatic => c.first().copied(),
            _ => None,
        };
        if kind == Kind::Revolute {
            position = position.map(wrap);
        }
        // A slider's anchor is its child's point at coordinate zero.
        let anchor = if kind == Kind::Prismatic {
            anchor - axis * j.reference
        } else {
            anchor
        };
        Some(JointDesc {
            name: name.to_string(),
            kind,
            body_a: a.to_string(),
            body_b: b.to_string(),
            anchor: anchor.into(),
            axis: matches!(kind, Kind::Revolute | Kind::Prismatic).then(|| axis.into()),
            torque: [0.0; 3],
            force: None,
            collide: a == WORLD,
            position: position.filter(|p| *p != 0.0),
            range,
            limit_restitution: None,
            motor: None,
            max_effort: None,
            mimic: None,
            armature: None,
        })
    }

    /// Where mesh asset `i`'s file is: under the compiler's `meshdir`,
    /// relative to the main file's folder.
    fn mesh_path(&self, i: usize) -> std::path::PathBuf {
        let m = self.m;
        let base = match (&m.compiler.meshdir, self.dir) {
            (Some(d), Some(dir)) => dir.join(d),
            (Some(d), None) => Path::new(d).to_path_buf(),
            (None, Some(dir)) => dir.to_path_buf(),
            (None, None) => Path::new(".").to_path_buf(),
        };
        base.join(&m.meshes[i].file)
    }

    /// How geom `g` at `at` in its body's frame looks: MuJoCo draws every
    /// geom of the groups its viewer shows by default (0, 1 and 2),
    /// meshes as their files (not their hulls); planes of moving bodies
    /// and heightfields are not drawn.
    fn visual(&self, g: &read::Geom, at: &Isometry3<f64>) -> Option<VisualEntry> {
        if !(0..=2).contains(&g.group) {
            return None;
        }
        let [a, b, c] = g.size;
        let (kind, size, mesh, scale) = match g.kind {
            GeomKind::Sphere => (VisualKind::Sphere, vec![a], None, [1.0; 3]),
            GeomKind::Capsule => (VisualKind::Capsule, vec![a, b], None, [1.0; 3]),
            GeomKind::Cylinder => (VisualKind::Cylinder, vec![a, b], None, [1.0; 3]),
            GeomKind::Box => (VisualKind::Box, vec![a, b, c], None, [1.0; 3]),
            GeomKind::Ellipsoid => (VisualKind::Ellipsoid, vec![a, b, c], None, [1.0; 3]),
            GeomKind::Mesh(i) => {
                let path = self.mesh_path(i);
                let path = std::path::absolute(&path).unwrap_or(path);
                let scale = self.m.meshes[i].scale;
                (
                    VisualKind::Mesh,
                    Vec::new(),
                    Some(path.to_string_lossy().into_owned()),
                    scale,
                )
            }
            GeomKind::Plane | GeomKind::Other(_) => return None,
        };
        Some(VisualEntry {
            kind,
            mesh,
            scale,
            size,
            position: at.translation.vector.into(),
            orientation: [at.rotation.w, at.rotation.i, at.rotation.j, at.rotation.k],
            color: Some(g.rgba.map(|x| x.clamp(0.0, 1.0))),
        })
    }

    /// Every mesh's hull points (in the mesh's frame, scaled) and solid.
    fn hulls(&mut self) -> HashMap<usize, (Vec<[f64; 3]>, Option<Mass>)> {
        let m = self.m;
        let mut out = HashMap::new();
        // Only meshes that collide or weigh: a visual mesh is drawn from
        // its file, and the full hull of one (gymnasium-robotics' Panda:
        // 10^5 vertices) took minutes.
        let groups = m.compiler.groups;
        let used: std::collections::BTreeSet<usize> = m
            .bodies
            .iter()
            .flat_map(|b| &b.geoms)
            .filter(|g| {
                g.contype != 0 || g.conaffinity != 0 || (groups[0]..=groups[1]).contains(&g.group)
            })
            .filter_map(|g| match g.kind {
                GeomKind::Mesh(i) => Some(i),
                _ => None,
            })
            .collect();
        let mut meshes = crate::mesh::Meshes::default();
        for i in used {
            let asset = &m.meshes[i];
            let path = self.mesh_path(i);
            match meshes.solid(&path, asset.scale) {
                Ok((points, solid)) => {
                    out.insert(i, (points, solid));
                }
                Err(e) => self
                    .problems
                    .add(asset.line, format!("<mesh name={:?}>", asset.name), e),
            }
        }
        out
    }

    /// The scene shape of geom `g` at pose `at` in its body's frame.
    fn shape(
        &mut self,
        g: &read::Geom,
        at: &Isometry3<f64>,
        hulls: &HashMap<usize, (Vec<[f64; 3]>, Option<Mass>)>,
    ) -> Option<ShapeEntry> {
        let [a, b, c] = g.size;
        let mut e = ShapeEntry {
            radius: None,
            half_length: None,
            half_extents: None,
            hull: None,
            kind: None,
            position: at.translation.vector.into(),
            orientation: [at.rotation.w, at.rotation.i, at.rotation.j, at.rotation.k],
        };
        match g.kind {
            GeomKind::Sphere => e.radius = Some(a),
            GeomKind::Capsule => {
                e.radius = Some(a);
                e.half_length = Some(b);
            }
            GeomKind::Box => e.half_extents = Some([a, b, c]),
            GeomKind::Cylinder => {
                e.radius = Some(a);
                e.half_length = Some(b);
                e.kind = Some(ShapeKind::Cylinder);
            }
            GeomKind::Ellipsoid => {
                e.hull = Some(ellipsoid_points(a, b, c));
                self.note_once("ellipsoids are hulls of 62 points on them");
            }
            GeomKind::Mesh(i) => {
                let (points, _) = hulls.get(&i)?;
                e.hull = Some(points.clone());
            }
            GeomKind::Plane => {
                self.notes
                    .push(format!("{}: a plane on a moving body is left out", g.label));
                return None;
            }
            GeomKind::Other(kind) => {
                self.notes
                    .push(format!("{}: a {kind} is not modelled; left out", g.label));
                return None;
            }
        }
        Some(e)
    }

    fn note_once(&mut self, note: &str) {
        if !self.notes.iter().any(|n| n == note) {
            self.notes.push(note.to_string());
        }
    }

    /// Actuators, springs, dampers and dry friction as the joints' motors:
    /// one per joint, the first that applies (actuator, spring, damper,
    /// friction); the rest said.
    fn drives(&mut self, scene: &mut Scene, names: &[String]) {
        let m = self.m;
        let joints: Vec<&read::Joint> = m.bodies.iter().flat_map(|b| &b.joints).collect();
        let find = |scene: &Scene, name: &str| scene.joints.iter().position(|j| j.name == name);
        for a in &m.actuators {
            let label = &a.label;
            let joint = match &a.joint {
                Ok(j) => j,
                Err(what) => {
                    self.notes.push(format!(
                        "{label}: drives {what}, which is not modelled; left out"
                    ));
                    continue;
                }
            };
            let Some(k) = joints.iter().position(|j| &j.name == joint) else {
                self.problems.add(
                    a.line,
                    label.clone(),
                    format!("joint {joint:?}: no such joint"),
                );
                continue;
            };
            let joint = &names[k];
            if let Some(d) = &a.dynamics {
                self.notes.push(format!(
                    "{label}: its activation dynamics ({d}) are left out: the control acts at once"
                ));
            }
            let Some(s) = find(scene, joint) else {
                self.notes.push(format!(
                    "{label}: drives joint {joint:?}, a free or ball joint: left out"
                ));
                continue;
            };
            let g = a.gear;
            let bound = a
                .forcerange
                .map(|r| r[0].abs().max(r[1].abs()) * g.abs())
                .filter(|b| *b > 0.0);
            let [b0, b1, b2] = a.bias;
            let motor = if b1 < 0.0 {
                // gain ctrl + b0 + b1 g q + b2 g q': a servo to
                // (gain ctrl + b0) / (-b1 g) with kp = -b1 g^2.
                Some(MotorDesc {
                    speed: 0.0,
                    position: Some(scene.joints[s].position.unwrap_or(0.0)),
                    kp: Some(-b1 * g * g),
                    kd: Some((-b2 * g * g).max(0.0)),
                    kv: None,
                    max_effort: bound.unwrap_or(UNBOUNDED),
                })
            } else if b2 < 0.0 && b1 == 0.0 {
                Some(MotorDesc {
                    speed: 0.0,
                    position: None,
                    kp: None,
                    kd: None,
                    kv: Some(-b2 * g * g),
                    max_effort: bound.unwrap_or(UNBOUNDED),
                })
            } else {
                let _ = b0;
                None
            };
            match motor {
                None => {
                    // force = gain ctrl, clamped to forcerange, times the
                    // gear: the torque is bounded by both ranges.
                    let by_ctrl = a
                        .ctrlrange
                        .map(|r| r[0].abs().max(r[1].abs()) * (a.gain * g).abs());
                    let effort = [bound, by_ctrl].into_iter().flatten().reduce(f64::min);
                    let asymmetric = [a.forcerange, a.ctrlrange]
                        .into_iter()
                        .flatten()
                        .any(|r| r[0] != -r[1]);
                    let mut note = format!(
                        "{label}: a torque on joint {joint:?} (gear {g}), set by the controller"
                    );
                    if let Some(e) = effort {
                        note += &format!(", within +-{e}");
                        if asymmetric {
                            note += " (its ranges are not symmetric: the wider side is taken)";
                        }
                    }
                    self.notes.push(note);
                    if let Some(e) = effort.filter(|e| *e > 0.0) {
                        scene.joints[s].max_effort = Some(e);
                    }
                }
                Some(_) if scene.joints[s].motor.is_some() => self.notes.push(format!(
                    "{label}: joint {joint:?} has a drive already; left out"
                )),
                Some(mut d) => {
                    if joints[k].damping > 0.0 {
                        if let Some(kd) = d.kd.as_mut() {
                            *kd += joints[k].damping;
                        } else {
                            self.notes.push(format!(
                                "joint {joint:?}: its damping is left out beside its velocity actuator"
                            ));
                        }
                    }
                    d.max_effort = d.max_effort.max(f64::MIN_POSITIVE);
                    scene.joints[s].motor = Some(d);
                }
            }
        }
        for (k, j) in joints.iter().enumerate() {
            let Some(s) = find(scene, &names[k]) else {
                if j.stiffness > 0.0 || j.damping > 0.0 || j.frictionloss > 0.0 || j.armature > 0.0
                {
                    self.notes.push(format!(
                        "joint {:?}: its stiffness, damping, friction and armature are left out (a free joint)",
                        names[k]
                    ));
                }
                continue;
            };
            if j.armature > 0.0 && scene.joints[s].kind != Kind::Fixed {
                scene.joints[s].armature = Some(j.armature);
            }
            if scene.joints[s].kind == Kind::Spherical {
                if j.stiffness > 0.0 || j.damping > 0.0 || j.frictionloss > 0.0 {
                    self.notes.push(format!(
                        "joint {:?}: its stiffness, damping and friction are left out (a ball joint)",
                        names[k]
                    ));
                }
                continue;
            }
            if scene.joints[s].motor.is_some() {
                if j.stiffness > 0.0 || j.frictionloss > 0.0 {
                    self.notes.push(format!(
                        "joint {:?}: its stiffness and friction are left out beside its actuator",
                        names[k]
                    ));
                }
                continue;
            }
            let motor = if j.stiffness > 0.0 {
                Some(MotorDesc {
                    speed: 0.0,
                    position: Some(j.springref),
                    kp: Some(j.stiffness),
                    kd: Some(j.damping),
                    kv: None,
                    max_effort: UNBOUNDED,
                })
            } else if j.damping > 0.0 {
                Some(MotorDesc {
                    speed: 0.0,
                    position: None,
                    kp: None,
                    kd: None,
                    kv: Some(j.damping),
                    max_effort: UNBOUNDED,
                })
            } else if j.frictionloss > 0.0 {
                Some(MotorDesc {
                    speed: 0.0,
                    position: None,
                    kp: None,
                    kd: None,
                    kv: None,
                    max_effort: j.frictionloss,
                })
            } else {
                None
            };
            if motor.is_some() && (j.stiffness > 0.0 || j.damping > 0.0) && j.frictionloss > 0.0 {
                self.notes.push(format!(
                    "joint {:?}: its friction is left out beside its spring or damper",
                    names[k]
                ));
            }
            scene.joints[s].motor = motor;
        }
        if let Some(servo) = self.options.servo {
            for j in scene
                .joints
                .iter_mut()
                .filter(|j| matches!(j.kind, Kind::Revolute | Kind::Prismatic))
            {
                j.motor = Some(MotorDesc {
                    speed: 0.0,
                    position: Some(j.position.unwrap_or(0.0)),
                    kp: Some(servo.kp),
                    kd: Some(servo.kd),
                    kv: None,
                    max_effort: servo.max_effort.unwrap_or(UNBOUNDED),
                });
            }
        }
    }

    fn equalities(
        &mut self,
        scene: &mut Scene,
        placed: &Placed,
        group_body: &[String],
        top: &[usize],
    ) {
        let m = self.m;
        let index = |name: &str| -> Option<usize> {
            if name == WORLD {
                return Some(0);
            }
            (0..m.bodies.len()).find(|&b| body_name(m, b) == name)
        };
        for (k, e) in m.equalities.iter().enumerate() {
            let (b1, b2, kind, anchor) = match e {
                read::Equality::Connect {
                    body1,
                    body2,
                    anchor,
                } => (body1, body2, Kind::Spherical, Some(*anchor)),
                read::Equality::Weld { body1, body2 } => (body1, body2, Kind::Fixed, None),
                read::Equality::Joint { .. } => continue,
                read::Equality::Other(label) => {
                    self.notes
                        .push(format!("{label}: this equality is not modelled; left out"));
                    continue;
                }
            };
            let (Some(i1), Some(i2)) = (index(b1), index(b2)) else {
                self.problems.add(
                    0,
                    format!("<equality> {k}"),
                    format!("bodies {b1:?} and {b2:?}: one is not in the file"),
                );
                continue;
            };
            let point = match anchor {
                Some(a) => (placed.frame[i1] * Point3::from(a)).coords,
                None => placed.frame[i1].translation.vector,
            };
            let (a, b) = (group_body[top[i1]].clone(), group_body[top[i2]].clone());
            if a == b || a.is_empty() || b.is_empty() {
                continue;
            }
            scene.joints.push(JointDesc {
                name: format!("equality{k}"),
                kind,
                body_a: b,
                body_b: a,
                anchor: point.into(),
                axis: None,
                torque: [0.0; 3],
                force: None,
                collide: false,
                position: None,
                range: None,
                limit_restitution: None,
                motor: None,
                max_effort: None,
                mimic: None,
                armature: None,
            });
        }
    }

    /// Equality `joint`s: the first joint's coordinate follows the
    /// second's, `q1 = c0 + c1 q2` (the scene's `mimic`). A polynomial's
    /// higher terms are left out and said; so is a coupling to no second
    /// joint (`q1 = c0`, a joint held in place) and one of a joint with
    /// no coordinate.
    fn joint_equalities(&mut self, scene: &mut Scene, names: &[String]) {
        let m = self.m;
        let joints: Vec<&read::Joint> = m.bodies.iter().flat_map(|b| &b.joints).collect();
        for e in &m.equalities {
            let read::Equality::Joint {
                joint1,
                joint2,
                polycoef: c,
                label,
            } = e
            else {
                continue;
            };
            let Some(joint2) = joint2 else {
                self.notes.push(format!(
                    "{label}: a joint held at {} with no second joint is not modelled; left out",
                    c[0]
                ));
                continue;
            };
            let scene_name = |name: &str| {
                joints
                    .iter()
                    .position(|j| j.name == name)
                    .map(|k| names[k].clone())
            };
            let (Some(n1), Some(n2)) = (scene_name(joint1), scene_name(joint2)) else {
                self.notes.push(format!(
                    "{label}: joint {joint1:?} or {joint2:?} is not in the file; left out"
                ));
                continue;
            };
            let axial = |s: &Scene, n: &str| {
                s.joints
                    .iter()
                    .position(|j| j.name == n && matches!(j.kind, Kind::Revolute | Kind::Prismatic))
            };
            let (Some(f), Some(_)) = (axial(scene, &n1), axial(scene, &n2)) else {
                self.notes.push(format!(
                    "{label}: couples a joint with no coordinate (free or ball); left out"
                ));
                continue;
            };
            if c[2..].iter().any(|&x| x != 0.0) {
                self.notes.push(format!(
                    "{label}: its polycoef's terms past the linear one are left out"
                ));
            }
            // The follower starts where its leader puts it (MuJoCo's soft
            // equality pulls it there; a rigid one started off would have
            // to close the gap in one step); where its range forbids it,
            // the coupling cannot hold and is left out.
            let leader = scene.joints.iter().find(|j| j.name == n2);
            let q = c[0] + c[1] * leader.and_then(|j| j.position).unwrap_or(0.0);
            let follower = &scene.joints[f];
            let (lo, hi) = follower.range.map_or(
                if follower.kind == Kind::Revolute {
                    (-std::f64::consts::PI, std::f64::consts::PI)
                } else {
                    (f64::NEG_INFINITY, f64::INFINITY)
                },
                |[lo, hi]| (lo, hi),
            );
            if !(lo..=hi).contains(&q) {
                self.notes.push(format!(
                    "{label}: puts joint {joint1:?} at {q}, outside its range [{lo}, {hi}]; left out"
                ));
                continue;
            }
            if scene.joints[f].mimic.is_some() {
                self.notes.push(format!(
                    "{label}: joint {joint1:?} follows another joint already; left out"
                ));
                continue;
            }
            scene.joints[f].position = Some(q).filter(|q| *q != 0.0);
            scene.joints[f].mimic = Some(cosim_shared::MimicDesc {
                joint: n2,
                multiplier: c[1],
                offset: c[0],
            });
        }
    }

    fn excludes(&mut self, scene: &mut Scene, group_body: &[String], top: &[usize]) {
        let m = self.m;
        for (b1, b2, _) in &m.excludes {
            let find = |n: &str| (0..m.bodies.len()).find(|&b| body_name(m, b) == n);
            let (Some(i1), Some(i2)) = (find(b1), find(b2)) else {
                self.notes.push(format!(
                    "<exclude body1={b1:?} body2={b2:?}>: a body is not in the file; left out"
                ));
                continue;
            };
            let (a, b) = (&group_body[top[i1]], &group_body[top[i2]]);
            let joined = scene
                .joints
                .iter_mut()
                .find(|j| (&j.body_a == a && &j.body_b == b) || (&j.body_a == b && &j.body_b == a));
            match joined {
                Some(j) => j.collide = false,
                None if self.options.self_collision => self.notes.push(format!(
                    "<exclude body1={b1:?} body2={b2:?}>: only a joint's two bodies can be kept apart; left out"
                )),
                None => {}
            }
        }
    }
}

/// A rotation about a world point.
fn about(point: Point3<f64>, turn: UnitQuaternion<f64>) -> Isometry3<f64> {
    Translation3::from(point.coords)
        * Isometry3::from_parts(Translation3::identity(), turn)
        * Translation3::from(-point.coords)
}

fn quat(c: &[f64]) -> UnitQuaternion<f64> {
    let q = nalgebra::Quaternion::new(c[0], c[1], c[2], c[3]);
    if q.norm() > 1e-14 {
        UnitQuaternion::from_quaternion(q)
    } else {
        UnitQuaternion::identity()
    }
}

/// An angle into [-pi, pi].
fn wrap(a: f64) -> f64 {
    let pi = std::f64::consts::PI;
    if (-pi..=pi).contains(&a) {
        a
    } else {
        (a + pi).rem_euclid(2.0 * pi) - pi
    }
}

/// Raises the principal moments of `i` under [`MIN_MOMENT`] to it (the
/// least the scene takes); the least moment it had, if raised.
fn raise(i: &mut Matrix3<f64>) -> Option<f64> {
    let eig = i.symmetric_eigen();
    let least = eig.eigenvalues.min();
    (least < MIN_MOMENT).then(|| {
        let raised = eig.eigenvalues.map(|v| v.max(MIN_MOMENT));
        *i = eig.eigenvectors * Matrix3::from_diagonal(&raised) * eig.eigenvectors.transpose();
        least
    })
}

fn from_six(i: &[f64; 6]) -> Matrix3<f64> {
    let [xx, yy, zz, xy, xz, yz] = *i;
    Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz)
}

fn six(i: &Matrix3<f64>) -> [f64; 6] {
    [
        i[(0, 0)],
        i[(1, 1)],
        i[(2, 2)],
        i[(0, 1)],
        i[(0, 2)],
        i[(1, 2)],
    ]
}

fn scene_point(scene: &Scene, body: &str) -> Vector3<f64> {
    scene
        .bodies
        .iter()
        .find(|b| b.name == body)
        .map_or(Vector3::zeros(), |b| Vector3::from(b.position))
}

fn fixed(name: &str, a: &str, b: &str, at: Vector3<f64>) -> JointDesc {
    JointDesc {
        name: name.to_string(),
        kind: Kind::Fixed,
        body_a: a.to_string(),
        body_b: b.to_string(),
        anchor: at.into(),
        axis: None,
        torque: [0.0; 3],
        force: None,
        collide: a == WORLD,
        position: None,
        range: None,
        limit_restitution: None,
        motor: None,
        max_effort: None,
        mimic: None,
        armature: None,
    }
}

/// An ellipsoid's hull points: poles and 5 rings of 12.
fn ellipsoid_points(a: f64, b: f64, c: f64) -> Vec<[f64; 3]> {
    let mut out = vec![[0.0, 0.0, c], [0.0, 0.0, -c]];
    for ring in 1..=5 {
        let phi = ring as f64 * std::f64::consts::PI / 6.0;
        for k in 0..12 {
            let t = k as f64 * std::f64::consts::TAU / 12.0;
            out.push([
                a * phi.sin() * t.cos(),
                b * phi.sin() * t.sin(),
                c * phi.cos(),
            ]);
        }
    }
    out
}

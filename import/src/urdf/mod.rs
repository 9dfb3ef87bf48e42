//! URDF import: a robot description turned into a scene, written as scene
//! text and read by `Scene::parse`, so that its checks and their messages
//! are the scene file's. As MuJoCo's, PyBullet's and Drake's importers read
//! it (issue 45, point 3):
//!
//! - the file is read tolerantly (`read.rs`) and every problem of it is
//!   said at once, each with its line;
//! - links joined by fixed joints are one body (MuJoCo's `fusestatic`):
//!   masses, centres of mass and inertias combined, every link's
//!   collisions its shapes at their poses; a link with no mass rides on
//!   its parent that way, and the merged names are said and kept as the
//!   body's named frames (`[[body.frame]]`, at each link's origin);
//! - the root is the world when it has no mass (`world`, `base_footprint`,
//!   PyBullet's mass 0); a root with mass floats free (PyBullet's and
//!   Drake's default) unless the options fix it to the world; a `floating`
//!   joint leaves its child free;
//! - `revolute`, `continuous`, `prismatic` and `spherical` joints, passive
//!   (MuJoCo and Drake leave a joint no actuator drives free; PyBullet's
//!   velocity motors are its best-known gotcha): `<limit lower upper>` is
//!   the range, `effort` bounds what drives the joint (a servo, and a
//!   controller's torque: MuJoCo's `actuatorfrcrange`), `velocity` is not
//!   used;
//!   `<dynamics damping>` is a viscous damper (a velocity actuator holding
//!   rate 0, implicit in the step, MuJoCo's joint `damping`), and
//!   `<dynamics friction>` dry friction where there is no damping (a motor
//!   holding rate 0 with at most that effort, MuJoCo's `frictionloss`); a
//!   joint's two bodies do not collide (MuJoCo's parent-child filter);
//! - a robot's links do not touch each other unless the options ask
//!   (PyBullet's default; a scene `group`);
//! - no floor unless the options ask for one, then under the robot's
//!   lowest point.
//!
//! `<mimic>` is the scene's `mimic` (`constraint::coupling`), the follower
//! started where its leader puts it. Cylinders are cylinders
//! (`collision/cylinder.rs`); meshes their convex hulls, a mesh that
//! cannot be found or read a problem, with the file it resolves to.

mod package;
mod read;

pub use package::resolve;
pub use read::{Geometry, JointType, Robot};

use crate::problems::Problems;
use crate::UNBOUNDED;
use cosim_shared::{Scene, SceneError};
use nalgebra::{Isometry3, Matrix3, UnitQuaternion, Vector3};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

pub use crate::options::{Imported, Options};

/// Reads a `.urdf` file as a scene named after the file.
pub fn load(path: &Path, options: Options) -> Result<Imported, SceneError> {
    crate::read_with(path, options, import)
}

/// The scene of URDF text `text` (from `file`, whose folder `dir` mesh
/// paths are relative to), named `name`.
pub fn import(
    text: &str,
    file: &str,
    name: &str,
    dir: Option<&Path>,
    options: Options,
) -> Result<Imported, SceneError> {
    let mut problems = Problems::new(file);
    let robot = read::robot(text, &mut problems);
    let mut notes: Vec<String> = robot
        .visual_problems
        .iter()
        .map(|p| format!("{p}: not drawn"))
        .collect();
    let start = starts(&robot, &options.positions, &mut problems);
    let tree = Tree::new(&robot, &start, &mut problems);
    let mut s = format!(
        "[sim]\nname = {name:?}\ndt = 0.001\nduration = 3.0\ngravity = [0.0, 0.0, -9.81]\nfriction_directions = 8\n\n"
    );
    let mut lowest = f64::INFINITY;
    if let Some(tree) = &tree {
        tree.write(
            &robot,
            dir,
            &options,
            &mut s,
            &mut problems,
            &mut notes,
            &mut lowest,
        );
    }
    problems.check()?;
    if options.floor {
        // Under the robot's lowest point, so that it starts on the floor,
        // not in it.
        let z = if lowest.is_finite() { lowest } else { 0.0 };
        if z != 0.0 {
            notes.push(format!(
                "the floor is at z = {z:.6} m, under the robot's lowest point"
            ));
        }
        let _ = write!(
            s,
            "[[plane]]\nname = \"floor\"\nnormal = [0.0, 0.0, 1.0]\npoint = [0.0, 0.0, {z:?}]\nfriction = 0.5\n\n"
        );
    }
    let scene = Scene::parse(&s, file)?;
    Ok(Imported { scene, notes })
}

/// The scene of URDF text with the default options, for tests and tools
/// that read text (no mesh can be found from it).
pub fn scene(text: &str, file: &str, name: &str) -> Result<Scene, SceneError> {
    import(text, file, name, None, Options::default()).map(|i| i.scene)
}

/// The kinematic tree: each link's world frame at zero and its group (the
/// links joined to it by fixed joints, named by the topmost).
struct Tree {
    /// Per link: its world frame.
    frame: Vec<Isometry3<f64>>,
    /// Per link: the index of its group's top link.
    group: Vec<usize>,
    root: usize,
    /// Whether the root link is the world (it has no mass).
    world_root: bool,
    /// Per link, the joint whose child it is.
    parent_joint: Vec<Option<usize>>,
    /// Per joint, its parent and child links (`None`: no such link, said).
    ends: Vec<(Option<usize>, Option<usize>)>,
    /// Per joint, its coordinate in the frames above.
    start: Vec<f64>,
}

fn v3(v: &Vector3<f64>) -> String {
    format!("[{:?}, {:?}, {:?}]", v.x, v.y, v.z)
}

fn quat(q: &UnitQuaternion<f64>) -> String {
    format!("[{:?}, {:?}, {:?}, {:?}]", q.w, q.i, q.j, q.k)
}

impl Tree {
    /// The tree with each joint `k` at coordinate `start[k]`.
    fn new(robot: &read::Robot, start: &[f64], problems: &mut Problems) -> Option<Tree> {
        let n = robot.links.len();
        if n == 0 {
            if problems.list.is_empty() {
                problems.add(0, "<robot>", "has no <link>");
            }
            return None;
        }
        let index = |name: &str| robot.links.iter().position(|l| l.name == name);
        for (k, l) in robot.links.iter().enumerate() {
            if let Some(first) = robot.links[..k].iter().find(|o| o.name == l.name) {
                problems.add(
                    l.line,
                    format!("link {:?}", l.name),
                    format!(
                        "a second link of this name (the first on line {})",
                        first.line
                    ),
                );
            }
        }
        let ends: Vec<(Option<usize>, Option<usize>)> = robot
            .joints
            .iter()
            .map(|j| (index(&j.parent), index(&j.child)))
            .collect();
        let mut parent_joint: Vec<Option<usize>> = vec![None; n];
        for (k, j) in robot.joints.iter().enumerate() {
            let what = format!("joint {:?}", j.name);
            let (p, c) = ends[k];
            for (tag, name, found) in [("parent", &j.parent, p), ("child", &j.child, c)] {
                if found.is_none() {
                    problems.add(
                        j.line,
                        what.as_str(),
                        format!("<{tag} link={name:?}>: no such link"),
                    );
                }
            }
            if let Some(c) = c {
                match parent_joint[c] {
                    Some(other) => problems.add(
                        j.line,
                        what.as_str(),
                        format!(
                            "link {:?} is the child of joint {:?} too: a URDF is a tree",
                            j.child, robot.joints[other].name
                        ),
                    ),
                    None => parent_joint[c] = Some(k),
                }
            }
        }
        let roots: Vec<usize> = (0..n).filter(|&l| parent_joint[l].is_none()).collect();
        let [root] = roots[..] else {
            let names: Vec<&str> = roots
                .iter()
                .map(|&l| robot.links[l].name.as_str())
                .collect();
            problems.add(
                0,
                "<robot>",
                format!(
                    "has {} root links {names:?} (links no joint has as child): a URDF is one tree",
                    roots.len()
                ),
            );
            return None;
        };
        // The root is the world when it has no mass (`world`,
        // `base_footprint`; PyBullet's static base of mass 0).
        let world_root = robot.links[root]
            .inertial
            .as_ref()
            .is_none_or(|i| i.mass <= 0.0);
        // World frames and groups, from the root down.
        let mut frame = vec![None; n];
        let mut group = vec![usize::MAX; n];
        frame[root] = Some(Isometry3::identity());
        group[root] = root;
        let mut order = vec![root];
        let mut k = 0;
        while k < order.len() {
            let l = order[k];
            k += 1;
            for ((j, &(_, c)), &q) in robot
                .joints
                .iter()
                .zip(&ends)
                .zip(start)
                .filter(|((_, e), _)| e.0 == Some(l))
            {
                let Some(c) = c else { continue };
                if frame[c].is_some() {
                    continue;
                }
                frame[c] = frame[l].map(|t| t * j.origin * motion(j, q));
                // A fixed joint merges its child into its parent's body,
                // but for the world's: each link fixed to the world is a
                // body welded to it.
                let merge = j.kind == JointType::Fixed && !(world_root && l == root);
                group[c] = if merge { group[l] } else { c };
                order.push(c);
            }
        }
        // Whether a link's way up meets a joint whose parent is missing
        // (said already).
        let orphan = |mut l: usize| {
            for _ in 0..n {
                let Some(j) = parent_joint[l] else {
                    return false;
                };
                match ends[j].0 {
                    Some(p) => l = p,
                    None => return true,
                }
            }
            false
        };
        for (l, f) in frame.iter().enumerate() {
            if f.is_none() {
                // A body of its own, so that its other problems are found.
                group[l] = l;
                if orphan(l) {
                    continue;
                }
                problems.add(
                    robot.links[l].line,
                    format!("link {:?}", robot.links[l].name),
                    "is not reached from the root: its joints form a loop",
                );
            }
        }
        let frame: Vec<Isometry3<f64>> = frame.into_iter().map(Option::unwrap_or_default).collect();
        Some(Tree {
            frame,
            group,
            root,
            world_root,
            parent_joint,
            ends,
            start: start.to_vec(),
        })
    }

    /// The links of group `g` (top link first).
    fn members(&self, g: usize) -> impl Iterator<Item = usize> + '_ {
        (0..self.group.len()).filter(move |&l| self.group[l] == g)
    }

    /// The groups: their top links, in file order.
    fn groups(&self) -> Vec<usize> {
        (0..self.group.len())
            .filter(|&l| self.group[l] == l)
            .collect()
    }

    /// Whether group `g` is held by the world: the world root's, or fixed
    /// to it by a joint of its own.
    fn held(&self, robot: &read::Robot, g: usize) -> bool {
        self.world_root
            && (g == self.root
                || self.parent_joint[g].is_some_and(|j| robot.joints[j].kind == JointType::Fixed))
    }

    /// Writes the bodies and joints; `lowest` takes the lowest z of the
    /// shapes.
    #[allow(clippy::too_many_arguments)]
    fn write(
        &self,
        robot: &read::Robot,
        dir: Option<&Path>,
        options: &Options,
        s: &mut String,
        problems: &mut Problems,
        notes: &mut Vec<String>,
        lowest: &mut f64,
    ) {
        let links = &robot.links;
        let mut meshes = crate::mesh::Meshes::default();
        // Per group: the body it is, or `world`.
        let mut body_name = vec![String::new(); links.len()];
        for g in self.groups() {
            let what = format!("link {:?}", links[g].name);
            let merged: Vec<&str> = self
                .members(g)
                .skip(1)
                .map(|l| links[l].name.as_str())
                .collect();
            if !merged.is_empty() {
                notes.push(format!(
                    "links {merged:?} are fixed to link {:?}: one body with it",
                    links[g].name
                ));
            }
            let shapes: Vec<(usize, &read::Collision)> = self
                .members(g)
                .flat_map(|l| links[l].collisions.iter().map(move |c| (l, c)))
                .collect();
            let held = self.held(robot, g);
            for l in self.members(g) {
                let Some(i) = links[l].inertial.as_ref().filter(|i| i.mass > 0.0) else {
                    continue;
                };
                if let (_, Some(instead)) = inertia_of(i) {
                    notes.push(format!(
                        "link {:?}: its inertia {:?} is not positive definite or has a moment under 1e-12 kg m^2: {instead} taken",
                        links[l].name, i.inertia,
                    ));
                }
            }
            let mass = Mass::of(self, links, g);
            if held && shapes.is_empty() && mass.is_none() {
                body_name[g] = "world".into();
                continue;
            }
            let name = links[g].name.clone();
            body_name[g] = name.clone();
            let (mass, at, inertia) = match mass {
                Some(b) => (b.mass, b.frame, b.inertia),
                None if held => {
                    notes.push(format!(
                        "link {:?} is fixed to the world and has shapes but no mass: a body of 1 kg welded to the world",
                        links[g].name
                    ));
                    (1.0, self.frame[g], Matrix3::identity() * 1e-2)
                }
                // Its mass could not be read: said already.
                None if self
                    .members(g)
                    .any(|l| links[l].inertial.as_ref().is_some_and(|i| i.mass.is_nan())) =>
                {
                    continue
                }
                None => {
                    let names: Vec<&str> =
                        self.members(g).map(|l| links[l].name.as_str()).collect();
                    problems.add(
                        links[g].line,
                        what,
                        format!(
                            "moves on a joint but has no mass (with the links fixed to it: {names:?}): \
                             give it an <inertial> with a positive mass and inertia"
                        ),
                    );
                    continue;
                }
            };
            if !options.self_collision {
                let _ = writeln!(s, "[[body]]\ngroup = {:?}", robot.name);
            } else {
                s.push_str("[[body]]\n");
            }
            let _ = write!(
                s,
                "name = {name:?}\nmass = {mass:?}\ninertia = [{:?}, {:?}, {:?}, {:?}, {:?}, {:?}]\nposition = {}\norientation = {}\nfriction = 0.5\n",
                inertia[(0, 0)],
                inertia[(1, 1)],
                inertia[(2, 2)],
                inertia[(0, 1)],
                inertia[(0, 2)],
                inertia[(1, 2)],
                v3(&at.translation.vector),
                quat(&at.rotation),
            );
            for (l, c) in shapes {
                if let Some((shape, support)) =
                    shape_text(c, &links[l].name, dir, &mut meshes, problems)
                {
                    *lowest = lowest.min(support.lowest(&(self.frame[l] * c.origin)));
                    let pose = at.inverse() * self.frame[l] * c.origin;
                    let _ = write!(
                        s,
                        "[[body.shape]]\n{shape}position = {}\norientation = {}\n",
                        v3(&pose.translation.vector),
                        quat(&pose.rotation)
                    );
                }
            }
            // The merged links' frames, by their names (MuJoCo keeps
            // them as bodies; Drake and Pinocchio as frames).
            for l in self.members(g).filter(|&l| l != g) {
                let pose = at.inverse() * self.frame[l];
                let _ = write!(
                    s,
                    "[[body.frame]]\nname = {:?}\nposition = {}\norientation = {}\n",
                    links[l].name,
                    v3(&pose.translation.vector),
                    quat(&pose.rotation)
                );
            }
            for l in self.members(g) {
                for v in &links[l].visuals {
                    let pose = at.inverse() * self.frame[l] * v.origin;
                    if let Some(text) = visual_text(v, robot, &links[l].name, dir, notes) {
                        let _ = write!(
                            s,
                            "[[body.visual]]\n{text}position = {}\norientation = {}\n",
                            v3(&pose.translation.vector),
                            quat(&pose.rotation)
                        );
                    }
                }
            }
            s.push('\n');
            // The root held by the world, or fixed by the options.
            if g == self.root && (held || options.fixed_base) {
                let _ = write!(
                    s,
                    "[[joint]]\nname = \"{name}_to_world\"\ntype = \"fixed\"\nbody_a = \"world\"\nbody_b = {name:?}\nanchor = {}\n\n",
                    v3(&at.translation.vector)
                );
            }
        }
        let body_of = |l: usize| -> Option<&str> {
            let name = &body_name[self.group[l]];
            (!name.is_empty()).then_some(name.as_str())
        };
        for (k, (j, &ends)) in robot.joints.iter().zip(&self.ends).enumerate() {
            let what = format!("joint {:?}", j.name);
            let (Some(p), Some(c)) = ends else {
                continue;
            };
            let kind = match j.kind {
                JointType::Revolute | JointType::Continuous => "revolute",
                JointType::Prismatic => "prismatic",
                JointType::Spherical => "spherical",
                // A fixed joint whose child was not merged: to the world.
                JointType::Fixed if self.group[c] == c => "fixed",
                JointType::Fixed | JointType::Floating => continue,
                JointType::Planar => {
                    problems.add(
                        j.line,
                        what,
                        "type=\"planar\": not modelled (no joint of two free directions)",
                    );
                    continue;
                }
            };
            let (Some(a), Some(b)) = (body_of(p), body_of(c)) else {
                continue;
            };
            if a == b {
                continue;
            }
            let hinge_or_slider = matches!(kind, "revolute" | "prismatic");
            if hinge_or_slider && j.axis.norm() <= 1e-12 {
                problems.add(
                    j.line,
                    what,
                    "<axis xyz=\"0 0 0\">: a hinge or slider needs an axis",
                );
                continue;
            }
            let at = self.frame[p] * j.origin;
            // A URDF's links and joints have names of their own kinds; a
            // scene's are one set: a joint named as a link (a body, a
            // frame) or as the world is renamed.
            let name = if body_name.contains(&j.name) || links.iter().any(|l| l.name == j.name) {
                let renamed = format!("{}_joint", j.name);
                notes.push(format!(
                    "joint {:?} is named as a link: it is {renamed:?} here",
                    j.name
                ));
                renamed
            } else {
                j.name.clone()
            };
            let _ = write!(
                s,
                "[[joint]]\nname = {name:?}\ntype = \"{kind}\"\nbody_a = {a:?}\nbody_b = {b:?}\nanchor = {}\ncollide = false\n",
                v3(&at.translation.vector)
            );
            if hinge_or_slider {
                let _ = writeln!(s, "axis = {}", v3(&(at.rotation * j.axis.normalize())));
            }
            if let Some((lo, hi)) = range_of(j) {
                if (j.lower, j.upper) != (Some(lo), Some(hi)) {
                    notes.push(format!(
                        "joint {:?}: its limits [{}, {}] rad are held within [-pi, pi]",
                        j.name,
                        j.lower.unwrap_or(lo),
                        j.upper.unwrap_or(hi)
                    ));
                }
                let _ = writeln!(s, "range = [{lo:?}, {hi:?}]");
            }
            let q = self.start[k];
            if q != 0.0 {
                if !options.positions.contains_key(&j.name) {
                    notes.push(format!(
                        "joint {:?}: its zero lies outside its limits: it starts at {q}",
                        j.name
                    ));
                }
                let _ = writeln!(s, "position = {q:?}");
            }
            // The effort limit bounds a controller's torque (MuJoCo's
            // actuatorfrcrange from a URDF's effort) and whatever drives
            // the joint.
            let effort = j.effort.filter(|&e| e > 0.0);
            if let (Some(e), true) = (effort, hinge_or_slider) {
                let _ = writeln!(s, "max_effort = {e:?}");
            }
            if let (Some(servo), true) = (options.servo, hinge_or_slider) {
                if j.damping > 0.0 {
                    notes.push(format!(
                        "joint {:?}: the servo drives it: its <dynamics damping> is left out",
                        j.name
                    ));
                }
                // The file's effort limit bounds it (MuJoCo's forcerange
                // from a URDF's effort), unless the servo gives its own.
                match servo.max_effort.or(effort) {
                    Some(f) => {
                        let _ = writeln!(
                            s,
                            "motor = {{ position = {q:?}, kp = {:?}, kd = {:?}, max_effort = {f:?} }}",
                            servo.kp, servo.kd
                        );
                        if j.friction > 0.0 {
                            notes.push(format!(
                                "joint {:?}: the servo drives it: its <dynamics friction> is left out",
                                j.name
                            ));
                        }
                    }
                    None => problems.add(
                        j.line,
                        what,
                        "a servo needs the joint's <limit effort> (or the servo's max_effort)",
                    ),
                }
            } else if j.damping > 0.0 && hinge_or_slider {
                // A viscous damper, implicit in the step (MuJoCo's joint
                // damping): a velocity actuator holding rate 0, bounded
                // by the joint's effort limit where it has one (a huge
                // bound beside the step's small impulses makes Lemke's
                // pivots lose precision).
                let bound = effort.unwrap_or(UNBOUNDED);
                let _ = writeln!(
                    s,
                    "motor = {{ speed = 0.0, kv = {:?}, max_effort = {bound:?} }}",
                    j.damping
                );
                if j.friction > 0.0 {
                    notes.push(format!(
                        "joint {:?}: its <dynamics friction> is left out beside its damping",
                        j.name
                    ));
                }
            } else if j.friction > 0.0 && hinge_or_slider {
                let _ = writeln!(
                    s,
                    "motor = {{ speed = 0.0, max_effort = {:?} }}",
                    j.friction
                );
            }
            if !hinge_or_slider && (j.damping > 0.0 || j.friction > 0.0) {
                notes.push(format!(
                    "joint {:?}: <dynamics> is left out on a {kind} joint",
                    j.name
                ));
            }
            if let Some((m, multiplier, offset)) = &j.mimic {
                let leader = robot.joints.iter().position(|l| &l.name == m);
                let put = leader.map(|l| multiplier * self.start[l] + offset);
                match leader.map(|l| &robot.joints[l]) {
                    Some(l) if hinge_or_slider && moves(l) && l.name != j.name && put != Some(q) => {
                        notes.push(format!(
                            "joint {:?}: <mimic joint={m:?}> puts it at {}, but it starts at {q} (its limits, or a position given): it moves on its own",
                            j.name,
                            put.unwrap_or(q)
                        ));
                    }
                    Some(l) if hinge_or_slider && moves(l) && l.name != j.name => {
                        // The leader's name as written above (renamed
                        // where it is a link's).
                        let leader =
                            if body_name.contains(&l.name) || links.iter().any(|k| k.name == l.name) {
                                format!("{}_joint", l.name)
                            } else {
                                l.name.clone()
                            };
                        let _ = writeln!(
                            s,
                            "mimic = {{ joint = {leader:?}, multiplier = {multiplier:?}, offset = {offset:?} }}"
                        );
                    }
                    _ => notes.push(format!(
                        "joint {:?}: <mimic joint={m:?}> names no other hinge or slider: it moves on its own",
                        j.name
                    )),
                }
            }
            s.push('\n');
        }
    }
}

/// The limits a hinge's or slider's coordinate is held within, if any.
/// PyBullet's rule: lower > upper is no limit; so is a hinge's range of a
/// full turn or more. A hinge's coordinate lies in [-pi, pi] here: a
/// limit beyond is held at pi (the caller says so).
fn range_of(j: &read::Joint) -> Option<(f64, f64)> {
    use std::f64::consts::PI;
    let (JointType::Revolute | JointType::Prismatic, Some(lo), Some(hi)) =
        (j.kind, j.lower, j.upper)
    else {
        return None;
    };
    if j.kind == JointType::Prismatic {
        return (lo < hi).then_some((lo, hi));
    }
    let (lo, hi) = (lo.max(-PI), hi.min(PI));
    (lo < hi && j.upper? - j.lower? < 2.0 * PI).then_some((lo, hi))
}

/// Each joint's initial coordinate: the one `positions` gives it, else
/// `start_of`'s. A named joint that is not one, or cannot move, or a
/// coordinate outside the joint's limits, is a problem.
fn starts(
    robot: &read::Robot,
    positions: &BTreeMap<String, f64>,
    problems: &mut Problems,
) -> Vec<f64> {
    for name in positions.keys() {
        if !robot.joints.iter().any(|j| &j.name == name) {
            let known: Vec<&str> = robot
                .joints
                .iter()
                .filter(|j| moves(j))
                .map(|j| j.name.as_str())
                .collect();
            problems.add(
                0,
                format!("joint {name:?}"),
                format!("given an initial position, but the robot has no such joint (its joints: {known:?})"),
            );
        }
    }
    let mut start: Vec<f64> = robot
        .joints
        .iter()
        .map(|j| {
            let Some(&q) = positions.get(&j.name) else {
                return start_of(j);
            };
            let what = format!("joint {:?}", j.name);
            if !moves(j) {
                problems.add(
                    j.line,
                    what,
                    "given an initial position, but it is not a hinge or slider",
                );
                return 0.0;
            }
            // A continuous joint's angle is read on the circle.
            let q = if j.kind == JointType::Continuous {
                (q + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
            } else {
                q
            };
            match range_of(j) {
                Some((lo, hi)) if !(lo..=hi).contains(&q) => {
                    problems.add(
                        j.line,
                        what,
                        format!("the initial position {q} lies outside its limits [{lo}, {hi}]"),
                    );
                    0.0f64.clamp(lo, hi)
                }
                _ if !q.is_finite()
                    || (j.kind == JointType::Revolute && q.abs() > std::f64::consts::PI) =>
                {
                    problems.add(
                        j.line,
                        what,
                        format!("the initial position {q} is not an angle within [-pi, pi]"),
                    );
                    0.0
                }
                _ => q,
            }
        })
        .collect();
    // A follower not given a position starts where its leader puts it
    // (`q = multiplier q_leader + offset`) when that lies within its
    // limits; else its coupling pulls it there over the first steps.
    for (k, j) in robot.joints.iter().enumerate() {
        let Some((m, multiplier, offset)) = &j.mimic else {
            continue;
        };
        let leader = robot.joints.iter().position(|l| &l.name == m);
        if let (Some(l), false) = (leader, positions.contains_key(&j.name)) {
            let q = multiplier * start[l] + offset;
            let (lo, hi) = range_of(j).unwrap_or(match j.kind {
                JointType::Prismatic => (f64::NEG_INFINITY, f64::INFINITY),
                _ => (-std::f64::consts::PI, std::f64::consts::PI),
            });
            if moves(j) && (lo..=hi).contains(&q) {
                start[k] = q;
            }
        }
    }
    start
}

/// Whether a joint has a coordinate (a hinge or a slider).
fn moves(j: &read::Joint) -> bool {
    matches!(
        j.kind,
        JointType::Revolute | JointType::Continuous | JointType::Prismatic
    )
}

/// Where a joint starts: at its zero, or where its limits exclude it at
/// the nearer limit (MuJoCo clamps `qpos0` into range the same way when
/// it simulates, and PyBullet's first step pulls the joint there).
fn start_of(j: &read::Joint) -> f64 {
    range_of(j).map_or(0.0, |(lo, hi)| 0.0f64.clamp(lo, hi))
}

/// The child's frame in the joint's as the joint stands at `q`: turned
/// about the axis (hinge) or moved along it (slider).
fn motion(j: &read::Joint, q: f64) -> Isometry3<f64> {
    if q == 0.0 || j.axis.norm() <= 1e-12 {
        return Isometry3::identity();
    }
    let axis = nalgebra::Unit::new_normalize(j.axis);
    match j.kind {
        JointType::Prismatic => Isometry3::translation(q * axis.x, q * axis.y, q * axis.z),
        _ => Isometry3::from_parts(
            Default::default(),
            UnitQuaternion::from_axis_angle(&axis, q),
        ),
    }
}

/// What a shape reaches, for its lowest point: a capsule (radius, half
/// length along z; a ball's is 0), a box (half extents), a hull (points).
enum Support {
    Capsule(f64, f64),
    Cylinder(f64, f64),
    Box([f64; 3]),
    Points(Vec<[f64; 3]>),
}

impl Support {
    /// The lowest world z of the shape at `at`.
    fn lowest(&self, at: &Isometry3<f64>) -> f64 {
        let z = at.translation.vector.z;
        let r = at.rotation.to_rotation_matrix();
        let up = r.matrix().row(2);
        match self {
            Support::Capsule(radius, half) => z - radius - half * up[2].abs(),
            // The lowest rim point: the axis's rise over an end, the
            // radius across it.
            Support::Cylinder(radius, half) => {
                z - half * up[2].abs() - radius * (1.0 - up[2] * up[2]).max(0.0).sqrt()
            }
            Support::Box(h) => z - (0..3).map(|k| h[k] * up[k].abs()).sum::<f64>(),
            Support::Points(p) => p
                .iter()
                .map(|v| (at * nalgebra::Point3::from(*v)).z)
                .fold(f64::INFINITY, f64::min),
        }
    }
}

/// A collision's shape as scene keys and its support, or `None` (with a
/// problem) for what is not read.
/// A `<visual>` as a `[[body.visual]]`'s type, size or file, scale and
/// colour; `None` (said) when its mesh cannot be found.
fn visual_text(
    v: &read::Visual,
    robot: &read::Robot,
    link: &str,
    dir: Option<&Path>,
    notes: &mut Vec<String>,
) -> Option<String> {
    let mut t = match &v.geometry {
        Geometry::Sphere(r) => format!("type = \"sphere\"\nsize = [{r:?}]\n"),
        Geometry::Box(size) => {
            let h = size.map(|x| x / 2.0);
            format!(
                "type = \"box\"\nsize = [{:?}, {:?}, {:?}]\n",
                h[0], h[1], h[2]
            )
        }
        Geometry::Cylinder { radius, length } => {
            format!(
                "type = \"cylinder\"\nsize = [{radius:?}, {:?}]\n",
                length / 2.0
            )
        }
        Geometry::Capsule { radius, length } => {
            format!(
                "type = \"capsule\"\nsize = [{radius:?}, {:?}]\n",
                length / 2.0
            )
        }
        Geometry::Mesh { filename, scale } => match package::resolve(filename, dir) {
            Ok(path) => {
                let path = std::path::absolute(&path).unwrap_or(path);
                format!(
                    "type = \"mesh\"\nmesh = {:?}\nscale = {}\n",
                    path.to_string_lossy(),
                    v3(&Vector3::from(*scale))
                )
            }
            Err(e) => {
                notes.push(format!(
                    "link {link:?}: the visual mesh {filename:?} is not drawn: {e}"
                ));
                return None;
            }
        },
    };
    let color = v.rgba.or_else(|| {
        v.material
            .as_ref()
            .and_then(|m| robot.materials.get(m).copied())
    });
    if let Some(c) = color {
        let _ = writeln!(
            t,
            "color = [{:?}, {:?}, {:?}, {:?}]",
            c[0], c[1], c[2], c[3]
        );
    }
    Some(t)
}

fn shape_text(
    c: &read::Collision,
    link: &str,
    dir: Option<&Path>,
    meshes: &mut crate::mesh::Meshes,
    problems: &mut Problems,
) -> Option<(String, Support)> {
    Some(match &c.geometry {
        Geometry::Sphere(r) => (format!("radius = {r:?}\n"), Support::Capsule(*r, 0.0)),
        Geometry::Box(size) => {
            let h = size.map(|x| x / 2.0);
            (
                format!("half_extents = [{:?}, {:?}, {:?}]\n", h[0], h[1], h[2]),
                Support::Box(h),
            )
        }
        Geometry::Capsule { radius, length } => (
            format!("radius = {radius:?}\nhalf_length = {:?}\n", length / 2.0),
            Support::Capsule(*radius, length / 2.0),
        ),
        Geometry::Cylinder { radius, length } => (
            format!(
                "type = \"cylinder\"\nradius = {radius:?}\nhalf_length = {:?}\n",
                length / 2.0
            ),
            Support::Cylinder(*radius, length / 2.0),
        ),
        Geometry::Mesh { filename, scale } => {
            let what = format!("link {link:?} <collision>");
            let hull = package::resolve(filename, dir).and_then(|p| meshes.hull(&p, *scale));
            match hull {
                Ok(points) => {
                    let list: Vec<String> = points
                        .iter()
                        .map(|v| format!("[{:?}, {:?}, {:?}]", v[0], v[1], v[2]))
                        .collect();
                    (
                        format!("hull = [{}]\n", list.join(", ")),
                        Support::Points(points),
                    )
                }
                Err(e) => {
                    problems.add(c.line, what, format!("the mesh {filename:?}: {e}"));
                    return None;
                }
            }
        }
    })
}

/// A group's mass properties: total mass, the body frame (at the centre of
/// mass, turned as the top link's inertial frame) and the inertia about it
/// in that frame.
struct Mass {
    mass: f64,
    frame: Isometry3<f64>,
    inertia: Matrix3<f64>,
}

impl Mass {
    /// `None` when the group has no mass.
    fn of(tree: &Tree, links: &[read::Link], g: usize) -> Option<Mass> {
        let parts: Vec<(f64, Isometry3<f64>, Matrix3<f64>)> = tree
            .members(g)
            .filter_map(|l| {
                let i = links[l].inertial.as_ref()?;
                (i.mass > 0.0).then(|| (i.mass, tree.frame[l] * i.origin, inertia_of(i).0))
            })
            .collect();
        let mass: f64 = parts.iter().map(|p| p.0).sum();
        if mass <= 0.0 {
            return None;
        }
        // One part: its inertial frame as it is (the same numbers).
        if let [(m, at, inertia)] = parts[..] {
            return Some(Mass {
                mass: m,
                frame: at,
                inertia,
            });
        }
        let c = parts
            .iter()
            .map(|(m, at, _)| at.translation.vector * *m)
            .sum::<Vector3<f64>>()
            / mass;
        let turn = links[g]
            .inertial
            .as_ref()
            .map_or(tree.frame[g].rotation, |i| {
                tree.frame[g].rotation * i.origin.rotation
            });
        let frame = Isometry3::from_parts(c.into(), turn);
        let mut inertia = Matrix3::zeros();
        for (m, at, i) in &parts {
            // Into the body's axes, then moved to its centre of mass.
            let r = (turn.inverse() * at.rotation).to_rotation_matrix();
            let d = turn.inverse_transform_vector(&(at.translation.vector - c));
            inertia += r.matrix() * i * r.matrix().transpose()
                + (Matrix3::identity() * d.norm_squared() - d * d.transpose()) * *m;
        }
        Some(Mass {
            mass,
            frame,
            inertia,
        })
    }
}

/// The radius (m) of the solid ball whose inertia a link with mass but
/// none given takes (icub's links carry zeros).
const BALL: f64 = 0.05;

// Below `MIN_MOMENT` (the scene's least principal moment) an inertia is
// taken as missing: iCub's `r_ankle_1` carries 1e-20 kg m^2 under 0.75
// kg, whose inverse swamps the joints' rows so that the solver holds none
// of them. MuJoCo refuses moments below its mjMINVAL (1e-15).
use cosim_shared::scene::MIN_MOMENT;

/// A link's inertia matrix as written; where it is not positive definite
/// or has a moment below [`MIN_MOMENT`] (files carry such), its diagonal,
/// as PyBullet reads every inertia, or failing that a solid ball's of
/// radius [`BALL`] and the link's mass: a zero inertia under a mass turns
/// any torque into an unbounded spin. With it, what was taken instead of
/// the file's, for `Tree::write` to say.
fn inertia_of(i: &read::Inertial) -> (Matrix3<f64>, Option<&'static str>) {
    let [xx, yy, zz, xy, xz, yz] = i.inertia;
    let full = Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz);
    if usable(&full) {
        return (full, None);
    }
    let diagonal = Matrix3::from_diagonal(&Vector3::new(xx, yy, zz));
    if usable(&diagonal) {
        return (diagonal, Some("its diagonal (as PyBullet reads it)"));
    }
    (
        Matrix3::identity() * (0.4 * i.mass * BALL * BALL),
        Some("a solid ball's of radius 5 cm"),
    )
}

/// Whether an inertia is positive definite with every principal moment at
/// least [`MIN_MOMENT`].
fn usable(m: &Matrix3<f64>) -> bool {
    positive_definite(m) && m.symmetric_eigenvalues().min() >= MIN_MOMENT
}

/// Whether a symmetric matrix is positive definite (its Cholesky factor
/// exists).
pub(crate) fn positive_definite(m: &Matrix3<f64>) -> bool {
    m.iter().all(|x| x.is_finite()) && m.cholesky().is_some()
}

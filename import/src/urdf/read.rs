//! URDF text to its links and joints, as tolerant as PyBullet's and
//! MuJoCo's readers: elements in any order, unknown elements and attributes
//! passed over (`<gazebo>`, `<transmission>`, a `<material>` anywhere),
//! what the format leaves optional given its default (an `<origin>` is
//! the identity, an `<axis>` is x, a `<limit>` needs no `velocity`).
//! What cannot be read is a [`Problem`](crate::problems::Problem) with its
//! line, and reading goes on, so that a file's problems come together.

use crate::problems::Problems;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use roxmltree::Node;

/// A link: its mass properties and collision shapes.
#[derive(Debug, Clone)]
pub struct Link {
    pub name: String,
    pub line: u32,
    /// The `<inertial>`, if any: its frame in the link's, mass, and
    /// `[ixx, iyy, izz, ixy, ixz, iyz]` about its origin in its axes.
    pub inertial: Option<Inertial>,
    pub collisions: Vec<Collision>,
    pub visuals: Vec<Visual>,
}

/// A `<visual>`: drawn, never collided.
#[derive(Debug, Clone)]
pub struct Visual {
    pub origin: Isometry3<f64>,
    pub geometry: Geometry,
    /// Its `<material>`: a colour of its own, or the name of the robot's.
    pub rgba: Option<[f64; 4]>,
    pub material: Option<String>,
}

#[derive(Debug, Clone)]
pub struct Inertial {
    pub origin: Isometry3<f64>,
    pub mass: f64,
    pub inertia: [f64; 6],
}

#[derive(Debug, Clone)]
pub struct Collision {
    pub line: u32,
    pub origin: Isometry3<f64>,
    pub geometry: Geometry,
}

#[derive(Debug, Clone, PartialEq)]
pub enum Geometry {
    /// Full edge lengths.
    Box([f64; 3]),
    Sphere(f64),
    Cylinder {
        radius: f64,
        length: f64,
    },
    /// URDF 1.x's extension, as urdf-rs and PyBullet read it.
    Capsule {
        radius: f64,
        length: f64,
    },
    Mesh {
        filename: String,
        scale: [f64; 3],
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointType {
    Revolute,
    Continuous,
    Prismatic,
    Fixed,
    Floating,
    Planar,
    /// Not in the URDF standard; PyBullet and urdf-rs read it.
    Spherical,
}

#[derive(Debug, Clone)]
pub struct Joint {
    pub name: String,
    pub line: u32,
    pub kind: JointType,
    pub parent: String,
    pub child: String,
    /// The child link's frame in the parent's at zero.
    pub origin: Isometry3<f64>,
    /// In the joint's (the child link's) frame, as written; x by default.
    pub axis: Vector3<f64>,
    pub lower: Option<f64>,
    pub upper: Option<f64>,
    pub effort: Option<f64>,
    pub velocity: Option<f64>,
    pub damping: f64,
    pub friction: f64,
    /// `<mimic joint multiplier offset>`.
    pub mimic: Option<(String, f64, f64)>,
}

/// A robot as its file describes it.
#[derive(Debug, Clone, Default)]
pub struct Robot {
    pub name: String,
    pub links: Vec<Link>,
    pub joints: Vec<Joint>,
    /// The robot's named `<material>` colours.
    pub materials: std::collections::HashMap<String, [f64; 4]>,
    /// What could not be read of the `<visual>`s (drawn only, so said,
    /// not refused: PyBullet loads such files), with its line.
    pub visual_problems: Vec<String>,
}

/// Reads `text`; what cannot be read goes to `problems`.
pub fn robot(text: &str, problems: &mut Problems) -> Robot {
    let doc = match roxmltree::Document::parse(text) {
        Ok(d) => d,
        Err(e) => {
            problems.add(e.pos().row, "", format!("not XML: {e}"));
            return Robot::default();
        }
    };
    let root = doc.root_element();
    let mut r = Reader {
        doc: &doc,
        problems,
    };
    if root.tag_name().name() != "robot" {
        r.problems.add(
            r.line(root),
            format!("<{}>", root.tag_name().name()),
            "the root element is not <robot>: not a URDF",
        );
        return Robot::default();
    }
    let mut robot = Robot {
        name: root.attribute("name").unwrap_or("robot").to_string(),
        ..Default::default()
    };
    for node in root.children().filter(Node::is_element) {
        match node.tag_name().name() {
            "link" => {
                let mut visual = Problems::new("");
                let link = r.link(node, &mut visual);
                robot
                    .visual_problems
                    .extend(visual.list.iter().map(|p| p.to_string()));
                robot.links.extend(link);
            }
            "joint" => robot.joints.extend(r.joint(node)),
            "material" => {
                if let (Some(name), Some(c)) = (node.attribute("name"), rgba(node)) {
                    robot.materials.insert(name.to_string(), c);
                }
            }
            // Transmissions, Gazebo's and others' extensions:
            // nothing of the rigid bodies.
            _ => {}
        }
    }
    robot
}

struct Reader<'a, 'p> {
    doc: &'a roxmltree::Document<'a>,
    problems: &'p mut Problems,
}

/// A `<material>`'s `<color rgba>`, when it has one that reads.
fn rgba(material: Node) -> Option<[f64; 4]> {
    let text = child(material, "color")?.attribute("rgba")?;
    let v: Vec<f64> = text
        .split_whitespace()
        .map(|w| w.parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect::<Option<_>>()?;
    let c: [f64; 4] = v.try_into().ok()?;
    Some(c.map(|x| x.clamp(0.0, 1.0)))
}

fn child<'a, 'i>(node: Node<'a, 'i>, tag: &str) -> Option<Node<'a, 'i>> {
    node.children()
        .find(|c| c.is_element() && c.tag_name().name() == tag)
}

impl Reader<'_, '_> {
    fn line(&self, node: Node) -> u32 {
        self.doc.text_pos_at(node.range().start).row
    }

    /// Attribute `attr` of `node` as numbers, `n` of them; `None` when
    /// absent, a problem when present and not `n` finite numbers.
    fn numbers<const N: usize>(&mut self, node: Node, attr: &str, what: &str) -> Option<[f64; N]> {
        let text = node.attribute(attr)?;
        let values: Vec<Option<f64>> = text
            .split_whitespace()
            .map(|w| w.parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect();
        match values.as_slice().try_into() {
            Ok(v) if values.iter().all(Option::is_some) => {
                let v: [Option<f64>; N] = v;
                Some(v.map(|x| x.unwrap_or(0.0)))
            }
            _ => {
                self.problems.add(
                    self.line(node),
                    what,
                    format!(
                        "{attr}=\"{text}\": not {N} finite number{}",
                        if N == 1 { "" } else { "s" }
                    ),
                );
                None
            }
        }
    }

    fn number(&mut self, node: Node, attr: &str, what: &str) -> Option<f64> {
        self.numbers::<1>(node, attr, what).map(|[x]| x)
    }

    /// A required attribute: a problem when absent.
    fn required(&mut self, node: Node, attr: &str, what: &str) -> Option<f64> {
        if node.attribute(attr).is_none() {
            self.problems.add(
                self.line(node),
                what,
                format!("<{}> has no {attr}", node.tag_name().name()),
            );
        }
        self.number(node, attr, what)
    }

    /// The `<origin xyz rpy>` child of `node`: the identity when absent.
    fn origin(&mut self, node: Node, what: &str) -> Isometry3<f64> {
        let Some(o) = child(node, "origin") else {
            return Isometry3::identity();
        };
        let xyz = self.numbers::<3>(o, "xyz", what).unwrap_or([0.0; 3]);
        let [r, p, y] = self.numbers::<3>(o, "rpy", what).unwrap_or([0.0; 3]);
        Isometry3::from_parts(
            Translation3::from(Vector3::from(xyz)),
            // URDF's rpy: about the fixed x, y, z axes in that order, R =
            // Rz(yaw) Ry(pitch) Rx(roll), nalgebra's order too.
            UnitQuaternion::from_euler_angles(r, p, y),
        )
    }

    fn name(&mut self, node: Node, kind: &str) -> Option<String> {
        match node.attribute("name") {
            Some(n) if !n.trim().is_empty() => Some(n.to_string()),
            _ => {
                self.problems
                    .add(self.line(node), format!("<{kind}>"), "has no name");
                None
            }
        }
    }

    /// A `<link>`; its `<visual>`s' problems go to `visual`.
    fn link(&mut self, node: Node, visual: &mut Problems) -> Option<Link> {
        let name = self.name(node, "link")?;
        let what = format!("link {name:?}");
        let inertial = child(node, "inertial").map(|i| {
            let w = format!("{what} <inertial>");
            let mass = match child(i, "mass") {
                // NaN: not read (said), so that no other problem follows.
                Some(m) => self.required(m, "value", &w).unwrap_or(f64::NAN),
                None => 0.0,
            };
            let inertia = match child(i, "inertia") {
                Some(n) => ["ixx", "iyy", "izz", "ixy", "ixz", "iyz"]
                    .map(|a| self.number(n, a, &w).unwrap_or(0.0)),
                None => [0.0; 6],
            };
            Inertial {
                origin: self.origin(i, &w),
                mass,
                inertia,
            }
        });
        let mut collisions = Vec::new();
        for (k, c) in node
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "collision")
            .enumerate()
        {
            let w = format!("{what} <collision> {}", k + 1);
            let origin = self.origin(c, &w);
            if let Some(geometry) = self.geometry(c, &w) {
                collisions.push(Collision {
                    line: self.line(c),
                    origin,
                    geometry,
                });
            }
        }
        let mut visuals = Vec::new();
        for (k, v) in node
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "visual")
            .enumerate()
        {
            let w = format!("{what} <visual> {}", k + 1);
            // Read with the visual's own problem list (said, not refused).
            let mut sub = Reader {
                doc: self.doc,
                problems: &mut *visual,
            };
            let origin = sub.origin(v, &w);
            let material = child(v, "material");
            if let Some(geometry) = sub.geometry(v, &w) {
                visuals.push(Visual {
                    origin,
                    geometry,
                    rgba: material.and_then(rgba),
                    material: material.and_then(|m| m.attribute("name").map(str::to_string)),
                });
            }
        }
        Some(Link {
            name,
            line: self.line(node),
            inertial,
            collisions,
            visuals,
        })
    }

    fn geometry(&mut self, node: Node, what: &str) -> Option<Geometry> {
        let Some(g) = child(node, "geometry") else {
            self.problems
                .add(self.line(node), what, "has no <geometry>");
            return None;
        };
        let Some(shape) = g.children().find(Node::is_element) else {
            self.problems
                .add(self.line(g), what, "<geometry> holds no shape");
            return None;
        };
        let w = format!("{what} <{}>", shape.tag_name().name());
        let positive = |r: &mut Self, x: Option<f64>, attr: &str| match x {
            Some(v) if v > 0.0 => Some(v),
            Some(v) => {
                r.problems.add(
                    r.line(shape),
                    w.as_str(),
                    format!("{attr}=\"{v}\": must be positive"),
                );
                None
            }
            None => None,
        };
        Some(match shape.tag_name().name() {
            "box" => {
                let size = self.numbers::<3>(shape, "size", &w);
                if size.is_none() && shape.attribute("size").is_none() {
                    self.problems
                        .add(self.line(shape), w.as_str(), "<box> has no size");
                }
                let size = size?;
                if size.iter().any(|&s| s <= 0.0) {
                    self.problems.add(
                        self.line(shape),
                        w.as_str(),
                        format!("size {size:?}: each must be positive"),
                    );
                    return None;
                }
                Geometry::Box(size)
            }
            "sphere" => {
                let r = self.required(shape, "radius", &w);
                Geometry::Sphere(positive(self, r, "radius")?)
            }
            kind @ ("cylinder" | "capsule") => {
                let r = self.required(shape, "radius", &w);
                let l = self.required(shape, "length", &w);
                let (radius, length) = (positive(self, r, "radius"), positive(self, l, "length"));
                let (radius, length) = (radius?, length?);
                if kind == "cylinder" {
                    Geometry::Cylinder { radius, length }
                } else {
                    Geometry::Capsule { radius, length }
                }
            }
            "mesh" => {
                let Some(filename) = shape.attribute("filename") else {
                    self.problems
                        .add(self.line(shape), w.as_str(), "<mesh> has no filename");
                    return None;
                };
                let scale = match self.numbers::<3>(shape, "scale", &w) {
                    Some(s) => s,
                    // One number for all three axes, as some files write it.
                    None => match shape.attribute("scale").and_then(|s| s.trim().parse().ok()) {
                        Some(s) => [s; 3],
                        None => [1.0; 3],
                    },
                };
                Geometry::Mesh {
                    filename: filename.to_string(),
                    scale,
                }
            }
            other => {
                self.problems.add(
                    self.line(shape),
                    what,
                    format!("<{other}> is not a URDF shape (box, sphere, cylinder, capsule, mesh)"),
                );
                return None;
            }
        })
    }

    fn joint(&mut self, node: Node) -> Option<Joint> {
        let name = self.name(node, "joint")?;
        let what = format!("joint {name:?}");
        let line = self.line(node);
        let kind = match node.attribute("type") {
            Some("revolute") => JointType::Revolute,
            Some("continuous") => JointType::Continuous,
            Some("prismatic") => JointType::Prismatic,
            Some("fixed") => JointType::Fixed,
            Some("floating") => JointType::Floating,
            Some("planar") => JointType::Planar,
            Some("spherical" | "ball") => JointType::Spherical,
            Some(other) => {
                self.problems.add(
                    line,
                    what,
                    format!(
                        "type=\"{other}\": not a joint type (revolute, continuous, prismatic, \
                         fixed, floating, planar, spherical)"
                    ),
                );
                return None;
            }
            None => {
                self.problems.add(line, what, "has no type");
                return None;
            }
        };
        let mut end = |tag: &str| match child(node, tag).and_then(|n| n.attribute("link")) {
            Some(l) => Some(l.to_string()),
            None => {
                self.problems
                    .add(line, what.as_str(), format!("has no <{tag} link=...>"));
                None
            }
        };
        let (parent, child_link) = (end("parent"), end("child"));
        let origin = self.origin(node, &what);
        // Checked where it counts (a hinge's or slider's): files give
        // fixed joints `<axis xyz="0 0 0">`.
        let axis = child(node, "axis")
            .and_then(|a| self.numbers::<3>(a, "xyz", &what))
            .map_or(Vector3::x(), Vector3::from);
        let w = format!("{what} <limit>");
        let (lower, upper, effort, velocity) = match child(node, "limit") {
            Some(l) => (
                self.number(l, "lower", &w),
                self.number(l, "upper", &w),
                self.number(l, "effort", &w),
                self.number(l, "velocity", &w),
            ),
            None => (None, None, None, None),
        };
        let w = format!("{what} <dynamics>");
        let (damping, friction) = match child(node, "dynamics") {
            Some(d) => (
                self.number(d, "damping", &w).unwrap_or(0.0),
                self.number(d, "friction", &w).unwrap_or(0.0),
            ),
            None => (0.0, 0.0),
        };
        let w = format!("{what} <mimic>");
        let mimic = child(node, "mimic").and_then(|m| {
            let j = m.attribute("joint")?.to_string();
            Some((
                j,
                self.number(m, "multiplier", &w).unwrap_or(1.0),
                self.number(m, "offset", &w).unwrap_or(0.0),
            ))
        });
        Some(Joint {
            name,
            line,
            kind,
            parent: parent?,
            child: child_link?,
            origin,
            axis,
            lower,
            upper,
            effort,
            velocity,
            damping,
            friction,
            mimic,
        })
    }
}

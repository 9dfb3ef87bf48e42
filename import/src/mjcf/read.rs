//! The MJCF tree to a typed model: compiler settings, the body tree (in
//! MuJoCo's body order, depth first, the world at 0), geoms, joints,
//! actuators, contact exclusions, equalities, keyframes and meshes, each
//! element's attributes its own over its class's defaults. What cannot be
//! read is a problem with its element and line, and reading goes on.

use super::defaults::{Defaults, ACTUATORS};
use super::frame::{self, Angles};
use super::xml::{El, Tree};
use crate::problems::Problems;
use nalgebra::{Isometry3, Translation3, Vector3};

/// `inertiafromgeom`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FromGeom {
    /// From the geoms where a body has no `<inertial>` (the default).
    Auto,
    True,
    False,
}

#[derive(Debug, Clone)]
pub struct Compiler {
    pub angles: Angles,
    pub from_geom: FromGeom,
    /// Geoms of groups in this range count for a body's mass.
    pub groups: [i64; 2],
    pub boundmass: f64,
    pub boundinertia: f64,
    pub settotalmass: Option<f64>,
    pub meshdir: Option<String>,
    pub autolimits: bool,
}

#[derive(Debug, Clone)]
pub struct Model {
    pub name: Option<String>,
    pub compiler: Compiler,
    pub timestep: f64,
    pub gravity: [f64; 3],
    /// Index 0 is the world.
    pub bodies: Vec<Body>,
    pub meshes: Vec<MeshAsset>,
    /// `<material>` colours by name (`rgba`; textures are not read).
    pub materials: std::collections::HashMap<String, [f64; 4]>,
    pub actuators: Vec<Actuator>,
    /// `<contact><exclude body1 body2>`: pairs of body names.
    pub excludes: Vec<(String, String, u32)>,
    pub equalities: Vec<Equality>,
    pub keys: Vec<Key>,
    /// Elements read but not modelled, one line each.
    pub left_out: Vec<String>,
}

#[derive(Debug, Clone)]
pub struct Body {
    /// MuJoCo's name ("" when the file gives none).
    pub name: String,
    pub parent: usize,
    /// In the parent's frame, at the joints' reference coordinates.
    pub pose: Isometry3<f64>,
    pub inertial: Option<Inertial>,
    pub geoms: Vec<Geom>,
    pub joints: Vec<Joint>,
    /// A mocap body: moved by the user, fixed in the world here.
    pub mocap: bool,
    pub line: u32,
    pub label: String,
}

#[derive(Debug, Clone)]
pub struct Inertial {
    /// Its frame in the body's.
    pub pose: Isometry3<f64>,
    pub mass: f64,
    /// `[ixx, iyy, izz, ixy, ixz, iyz]` about its origin in its axes.
    pub inertia: [f64; 6],
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GeomKind {
    Plane,
    Sphere,
    Capsule,
    Cylinder,
    Ellipsoid,
    Box,
    /// Index into `Model::meshes`.
    Mesh(usize),
    /// A kind not read (heightfields, SDFs), with its name.
    Other(&'static str),
}

#[derive(Debug, Clone)]
pub struct Geom {
    pub name: String,
    pub kind: GeomKind,
    /// Sphere: radius; capsule, cylinder: radius, half length; box,
    /// ellipsoid: half sizes.
    pub size: [f64; 3],
    /// In the body's frame.
    pub pose: Isometry3<f64>,
    /// `mass`, which overrides `density`.
    pub mass: Option<f64>,
    pub density: f64,
    pub group: i64,
    /// The colour drawn: `rgba`, else its material's, else MuJoCo's grey.
    pub rgba: [f64; 4],
    pub contype: i64,
    pub conaffinity: i64,
    /// Sliding friction.
    pub friction: f64,
    pub line: u32,
    pub label: String,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    Free,
    Ball,
    Hinge,
    Slide,
}

#[derive(Debug, Clone)]
pub struct Joint {
    pub name: String,
    pub kind: JointKind,
    /// In the body's frame.
    pub pos: Vector3<f64>,
    /// Unit, in the body's frame.
    pub axis: Vector3<f64>,
    /// The limits when limited (rad or m).
    pub range: Option<[f64; 2]>,
    /// The coordinate at which the body stands as written (`ref`).
    pub reference: f64,
    pub stiffness: f64,
    pub springref: f64,
    pub damping: f64,
    pub armature: f64,
    pub frictionloss: f64,
}

#[derive(Debug, Clone)]
pub struct MeshAsset {
    pub name: String,
    pub file: String,
    pub scale: [f64; 3],
    pub line: u32,
}

/// What an actuator drives and how: force = gain ctrl + bias[0] + bias[1]
/// length + bias[2] velocity, times the gear on the joint (MuJoCo's
/// affine `general`; the shortcuts set gain and bias).
#[derive(Debug, Clone)]
pub struct Actuator {
    /// The joint it drives, or what else it names (`tendon "t"`).
    pub joint: Result<String, String>,
    pub gear: f64,
    pub bias: [f64; 3],
    pub forcerange: Option<[f64; 2]>,
    pub ctrlrange: Option<[f64; 2]>,
    /// The gain on the control (`gainprm[0]`; a `motor`'s is 1).
    pub gain: f64,
    /// Activation dynamics left out (`dyntype`), said.
    pub dynamics: Option<String>,
    pub line: u32,
    pub label: String,
}

#[derive(Debug, Clone)]
pub enum Equality {
    /// Two bodies held at a point, given in body1's frame.
    Connect {
        body1: String,
        body2: String,
        anchor: Vector3<f64>,
    },
    Weld {
        body1: String,
        body2: String,
    },
    /// `joint1 = polycoef[0] + polycoef[1] joint2 + ...` (joint2 absent:
    /// `joint1 = polycoef[0]`).
    Joint {
        joint1: String,
        joint2: Option<String>,
        polycoef: [f64; 5],
        label: String,
    },
    /// Anything else (joint couplings, tendons, sites), named.
    Other(String),
}

#[derive(Debug, Clone)]
pub struct Key {
    pub name: String,
    pub qpos: Option<Vec<f64>>,
}

/// Reads the model out of the tree.
pub fn model(tree: &Tree, problems: &mut Problems) -> Model {
    let root = &tree.root;
    let defaults = Defaults::read(root);
    let mut r = Reader {
        tree,
        defaults: &defaults,
        problems,
    };
    let compiler = r.compiler(root);
    let mut m = Model {
        name: root.attr("model").map(str::to_string),
        compiler,
        timestep: 0.002,
        gravity: [0.0, 0.0, -9.81],
        bodies: vec![Body {
            name: "world".into(),
            parent: 0,
            pose: Isometry3::identity(),
            inertial: None,
            geoms: Vec::new(),
            joints: Vec::new(),
            mocap: false,
            line: 0,
            label: "<worldbody>".into(),
        }],
        meshes: Vec::new(),
        materials: std::collections::HashMap::new(),
        actuators: Vec::new(),
        excludes: Vec::new(),
        equalities: Vec::new(),
        keys: Vec::new(),
        left_out: Vec::new(),
    };
    for o in root.all("option") {
        let cls = "main";
        if let Some(v) = r.num(o, cls, "timestep") {
            m.timestep = v;
        }
        if let Some(g) = r.vec(o, cls, "gravity", 3) {
            m.gravity = [g[0], g[1], g[2]];
        }
    }
    for a in root.all("asset") {
        for mat in a.all("material") {
            let cls = r.class(mat, "main");
            if let Some(name) = mat.attr("name") {
                let c = r.vec(mat, &cls, "rgba", 4).unwrap_or(vec![1.0; 4]);
                m.materials
                    .insert(name.to_string(), [c[0], c[1], c[2], c[3]]);
            }
        }
        for mesh in a.all("mesh") {
            let cls = r.class(mesh, "main");
            let Some(file) = mesh.attr("file") else {
                m.left_out.push(format!(
                    "{}: a mesh given by its vertices in the file, not read",
                    tree.label(mesh)
                ));
                continue;
            };
            let name = mesh.attr("name").map_or_else(
                || {
                    std::path::Path::new(file)
                        .file_stem()
                        .map_or(String::new(), |s| s.to_string_lossy().into_owned())
                },
                str::to_string,
            );
            let scale = r.vec(mesh, &cls, "scale", 3).unwrap_or(vec![1.0; 3]);
            m.meshes.push(MeshAsset {
                name,
                file: file.to_string(),
                scale: [scale[0], scale[1], scale[2]],
                line: tree.line(mesh),
            });
        }
    }
    for w in root.all("worldbody") {
        r.body_contents(w, 0, "main", &mut m);
    }
    for a in root.all("actuator") {
        for el in &a.children {
            r.actuator(el, &mut m);
        }
    }
    for c in root.all("contact") {
        for el in &c.children {
            match (el.tag.as_str(), el.attr("body1"), el.attr("body2")) {
                ("exclude", Some(a), Some(b)) => {
                    m.excludes.push((a.into(), b.into(), tree.line(el)))
                }
                ("exclude", _, _) => {
                    r.problems
                        .add(tree.line(el), tree.label(el), "needs body1 and body2")
                }
                _ => m.left_out.push(format!(
                    "{}: explicit contact pairs are not read; the shapes' own filters decide",
                    tree.label(el)
                )),
            }
        }
    }
    for e in root.all("equality") {
        for el in &e.children {
            let eq = match (el.tag.as_str(), el.attr("body1"), el.attr("body2")) {
                ("connect", Some(a), b) => {
                    let cls = r.class(el, "main");
                    let anchor = r.vec(el, &cls, "anchor", 3).unwrap_or(vec![0.0; 3]);
                    Equality::Connect {
                        body1: a.into(),
                        body2: b.unwrap_or("world").into(),
                        anchor: Vector3::new(anchor[0], anchor[1], anchor[2]),
                    }
                }
                ("weld", Some(a), b) => Equality::Weld {
                    body1: a.into(),
                    body2: b.unwrap_or("world").into(),
                },
                ("joint", _, _) if el.attr("joint1").is_some() => {
                    let cls = r.class(el, "main");
                    let c = r
                        .prefix(el, &cls, "polycoef", &[0.0, 1.0, 0.0, 0.0, 0.0])
                        .unwrap_or(vec![0.0, 1.0, 0.0, 0.0, 0.0]);
                    Equality::Joint {
                        joint1: el.attr("joint1").unwrap_or_default().into(),
                        joint2: el.attr("joint2").map(Into::into),
                        polycoef: [c[0], c[1], c[2], c[3], c[4]],
                        label: tree.label(el),
                    }
                }
                _ => Equality::Other(tree.label(el)),
            };
            m.equalities.push(eq);
        }
    }
    for t in root.all("tendon") {
        for el in &t.children {
            m.left_out
                .push(format!("{}: tendons are not modelled", tree.label(el)));
        }
    }
    for k in root.all("keyframe") {
        for el in k.all("key") {
            let qpos = el
                .attr("qpos")
                .map(|_| r.vec(el, "main", "qpos", 0).unwrap_or_default());
            m.keys.push(Key {
                name: el.attr("name").unwrap_or("").to_string(),
                qpos,
            });
        }
    }
    for o in root.all("option") {
        for f in o.all("flag") {
            r.flags(f, &mut m);
        }
    }
    m
}

struct Reader<'a> {
    tree: &'a Tree,
    defaults: &'a Defaults,
    problems: &'a mut Problems,
}

impl Reader<'_> {
    /// The class an element takes: its own `class`, or the one it
    /// inherits (a body's `childclass`, else `main`).
    fn class(&mut self, el: &El, inherited: &str) -> String {
        match el.attr("class") {
            Some(c) if self.defaults.has(c) => c.to_string(),
            Some(c) => {
                self.problems.add(
                    self.tree.line(el),
                    format!("{}.class", self.tree.label(el)),
                    format!("{c:?}: no <default class={c:?}>"),
                );
                inherited.to_string()
            }
            None => inherited.to_string(),
        }
    }

    /// An attribute, the element's own or its class's.
    fn get<'e>(&'e self, el: &'e El, class: &str, attr: &str) -> Option<&'e str> {
        el.attr(attr)
            .or_else(|| self.defaults.get(class, &el.tag, attr))
    }

    /// A numeric attribute with `n` numbers (any count for `n == 0`);
    /// `None` when absent or unreadable (said).
    fn vec(&mut self, el: &El, class: &str, attr: &str, n: usize) -> Option<Vec<f64>> {
        let text = self.get(el, class, attr)?.to_string();
        let parsed: Result<Vec<f64>, _> = text.split_whitespace().map(str::parse::<f64>).collect();
        match parsed {
            Ok(v) if (n == 0 || v.len() == n) && v.iter().all(|x| x.is_finite()) => Some(v),
            _ => {
                let want = if n == 0 {
                    "finite numbers".to_string()
                } else {
                    format!("{n} finite numbers")
                };
                self.problems.add(
                    self.tree.line(el),
                    format!("{}.{attr}", self.tree.label(el)),
                    format!("= {text:?}: {want} expected"),
                );
                None
            }
        }
    }

    fn num(&mut self, el: &El, class: &str, attr: &str) -> Option<f64> {
        self.vec(el, class, attr, 1).map(|v| v[0])
    }

    /// Up to `n` numbers, the missing ones taken from `fill` (MuJoCo reads
    /// `size`, `gear` and `gainprm` so).
    fn prefix(&mut self, el: &El, class: &str, attr: &str, fill: &[f64]) -> Option<Vec<f64>> {
        let v = self.vec(el, class, attr, 0)?;
        let mut out = fill.to_vec();
        for (o, x) in out.iter_mut().zip(&v) {
            *o = *x;
        }
        if v.len() > fill.len() {
            self.problems.add(
                self.tree.line(el),
                format!("{}.{attr}", self.tree.label(el)),
                format!("has {} numbers: at most {} expected", v.len(), fill.len()),
            );
        }
        Some(out)
    }

    fn flag(&mut self, el: &El, class: &str, attr: &str) -> Option<bool> {
        match self.get(el, class, attr)? {
            "true" => Some(true),
            "false" => Some(false),
            "auto" => None,
            other => {
                let other = other.to_string();
                self.problems.add(
                    self.tree.line(el),
                    format!("{}.{attr}", self.tree.label(el)),
                    format!("= {other:?}: true, false or auto expected"),
                );
                None
            }
        }
    }

    /// `<option><flag>`: what MuJoCo's `disableflags` switch off, done
    /// to the model as its compiler and step do: `gravity` (no gravity),
    /// `contact` (no geom collides), `limit`, `equality`, `frictionloss`,
    /// `passive` (no joint spring or damper), `actuation` (no actuator),
    /// and `constraint` (contacts, limits, equalities and friction loss at
    /// once). The solver's own flags (`warmstart`, `energy`, ...) change
    /// nothing here.
    fn flags(&mut self, f: &El, m: &mut Model) {
        for name in [
            "gravity",
            "contact",
            "constraint",
            "limit",
            "equality",
            "frictionloss",
            "passive",
            "actuation",
        ] {
            match f.attr(name) {
                None | Some("enable") => continue,
                Some("disable") => {}
                Some(other) => {
                    self.problems.add(
                        self.tree.line(f),
                        format!("{}.{name}", self.tree.label(f)),
                        format!("= {other:?}: enable or disable expected"),
                    );
                    continue;
                }
            }
            let constraint = name == "constraint";
            if name == "gravity" {
                m.gravity = [0.0; 3];
            }
            if constraint || name == "contact" {
                for g in m.bodies.iter_mut().flat_map(|b| b.geoms.iter_mut()) {
                    g.contype = 0;
                    g.conaffinity = 0;
                }
            }
            let joints = |m: &mut Model, f: fn(&mut Joint)| {
                m.bodies
                    .iter_mut()
                    .flat_map(|b| b.joints.iter_mut())
                    .for_each(f)
            };
            if constraint || name == "limit" {
                joints(m, |j| j.range = None);
            }
            if constraint || name == "frictionloss" {
                joints(m, |j| j.frictionloss = 0.0);
            }
            if name == "passive" {
                joints(m, |j| {
                    j.stiffness = 0.0;
                    j.damping = 0.0;
                });
            }
            if constraint || name == "equality" {
                m.equalities.clear();
            }
            if name == "actuation" {
                m.actuators.clear();
            }
        }
    }

    fn compiler(&mut self, root: &El) -> Compiler {
        let mut c = Compiler {
            angles: Angles::default(),
            from_geom: FromGeom::Auto,
            groups: [0, 5],
            boundmass: 0.0,
            boundinertia: 0.0,
            settotalmass: None,
            meshdir: None,
            autolimits: true,
        };
        for el in root.all("compiler") {
            let label = self.tree.label(el);
            let line = self.tree.line(el);
            match el.attr("angle") {
                None => {}
                Some("degree") => c.angles.unit = std::f64::consts::PI / 180.0,
                Some("radian") => c.angles.unit = 1.0,
                Some(o) => self.problems.add(
                    line,
                    format!("{label}.angle"),
                    format!("= {o:?}: degree or radian expected"),
                ),
            }
            if let Some(s) = el.attr("eulerseq") {
                match s.as_bytes() {
                    [a, b, c2] if [a, b, c2].iter().all(|x| b"xyzXYZ".contains(x)) => {
                        c.angles.eulerseq = [*a, *b, *c2]
                    }
                    _ => self.problems.add(
                        line,
                        format!("{label}.eulerseq"),
                        format!("= {s:?}: three of x, y, z, X, Y, Z expected"),
                    ),
                }
            }
            match el.attr("inertiafromgeom") {
                None => {}
                Some("auto") => c.from_geom = FromGeom::Auto,
                Some("true") => c.from_geom = FromGeom::True,
                Some("false") => c.from_geom = FromGeom::False,
                Some(o) => self.problems.add(
                    line,
                    format!("{label}.inertiafromgeom"),
                    format!("= {o:?}: true, false or auto expected"),
                ),
            }
            if let Some(g) = self.vec(el, "main", "inertiagrouprange", 2) {
                c.groups = [g[0] as i64, g[1] as i64];
            }
            if let Some(v) = self.num(el, "main", "boundmass") {
                c.boundmass = v;
            }
            if let Some(v) = self.num(el, "main", "boundinertia") {
                c.boundinertia = v;
            }
            if let Some(v) = self.num(el, "main", "settotalmass") {
                c.settotalmass = (v > 0.0).then_some(v);
            }
            if let Some(d) = el.attr("meshdir").or(el.attr("assetdir")) {
                c.meshdir = Some(d.to_string());
            }
            if let Some(a) = el.attr("autolimits") {
                c.autolimits = a == "true";
            }
            if el.attr("coordinate") == Some("global") {
                self.problems.add(
                    line,
                    format!("{label}.coordinate"),
                    "= \"global\": MuJoCo dropped global coordinates; local ones are read",
                );
            }
        }
        c
    }

    fn pose(&mut self, el: &El, class: &str, angles: &Angles) -> Isometry3<f64> {
        const TURNS: [&str; 5] = ["quat", "axisangle", "euler", "xyaxes", "zaxis"];
        // Classes give poses to geoms and sites only; an element's own
        // orientation replaces its class's.
        let classed = el.tag == "geom" || el.tag == "site";
        let own_turn = TURNS.iter().any(|a| el.attr(a).is_some());
        let mut values: Vec<(&str, Vec<f64>)> = Vec::new();
        for a in std::iter::once("pos").chain(TURNS) {
            let own = el.attr(a).is_some();
            let take = own || (classed && (a == "pos" || !own_turn));
            if let Some(v) = take.then(|| self.vec(el, class, a, 0)).flatten() {
                values.push((a, v));
            }
        }
        let get = |a: &str| values.iter().find(|(k, _)| *k == a).map(|(_, v)| v.clone());
        match frame::pose(&get, angles) {
            Ok(p) => p,
            Err(e) => {
                self.problems
                    .add(self.tree.line(el), self.tree.label(el), e);
                Isometry3::identity()
            }
        }
    }

    /// Reads the children of body `index` (the world's or a `<body>`'s),
    /// whose inherited class is `class`.
    fn body_contents(&mut self, el: &El, index: usize, class: &str, m: &mut Model) {
        let angles = m.compiler.angles.clone();
        for c in &el.children {
            match c.tag.as_str() {
                "geom" => {
                    let g = self.geom(c, class, &angles, m);
                    m.bodies[index].geoms.extend(g);
                }
                "joint" | "freejoint" => {
                    let j = self.joint(c, class, &angles, m);
                    m.bodies[index].joints.extend(j);
                }
                "inertial" => {
                    let pose = self.pose(c, class, &angles);
                    let mass = self.num(c, class, "mass").unwrap_or(0.0);
                    let inertia = if let Some(f) = self.vec(c, class, "fullinertia", 6) {
                        [f[0], f[1], f[2], f[3], f[4], f[5]]
                    } else if let Some(d) = self.vec(c, class, "diaginertia", 3) {
                        [d[0], d[1], d[2], 0.0, 0.0, 0.0]
                    } else {
                        self.problems.add(
                            self.tree.line(c),
                            self.tree.label(c),
                            "needs diaginertia or fullinertia",
                        );
                        [0.0; 6]
                    };
                    m.bodies[index].inertial = Some(Inertial {
                        pose,
                        mass,
                        inertia,
                    });
                }
                "body" => {
                    let own = self.class(c, class);
                    let child_class = match c.attr("childclass") {
                        Some(cc) if self.defaults.has(cc) => cc.to_string(),
                        Some(cc) => {
                            self.problems.add(
                                self.tree.line(c),
                                format!("{}.childclass", self.tree.label(c)),
                                format!("{cc:?}: no <default class={cc:?}>"),
                            );
                            own.clone()
                        }
                        None => class.to_string(),
                    };
                    let pose = self.pose(c, &own, &angles);
                    let k = m.bodies.len();
                    m.bodies.push(Body {
                        name: c.attr("name").unwrap_or("").to_string(),
                        parent: index,
                        pose,
                        inertial: None,
                        geoms: Vec::new(),
                        joints: Vec::new(),
                        mocap: c.attr("mocap") == Some("true"),
                        line: self.tree.line(c),
                        label: self.tree.label(c),
                    });
                    self.body_contents(c, k, &child_class, m);
                }
                "frame" => {
                    // A frame's pose composes onto what it holds.
                    let pose = self.pose(c, class, &angles);
                    let cc = c.attr("childclass").unwrap_or(class).to_string();
                    let start = (
                        m.bodies.len(),
                        m.bodies[index].geoms.len(),
                        m.bodies[index].joints.len(),
                    );
                    self.body_contents(c, index, &cc, m);
                    for g in &mut m.bodies[index].geoms[start.1..] {
                        g.pose = pose * g.pose;
                    }
                    for j in &mut m.bodies[index].joints[start.2..] {
                        j.pos = pose * j.pos;
                        j.axis = pose.rotation * j.axis;
                    }
                    if let Some(i) = &mut m.bodies[index].inertial {
                        if c.all("inertial").next().is_some() {
                            i.pose = pose * i.pose;
                        }
                    }
                    for b in &mut m.bodies[start.0..] {
                        if b.parent == index {
                            b.pose = pose * b.pose;
                        }
                    }
                }
                "site" | "camera" | "light" | "composite" | "plugin" | "attach" => {
                    if matches!(c.tag.as_str(), "composite" | "attach" | "plugin") {
                        m.left_out.push(format!("{}: not read", self.tree.label(c)));
                    }
                }
                _ => {}
            }
        }
    }

    fn geom(&mut self, el: &El, inherited: &str, angles: &Angles, m: &mut Model) -> Option<Geom> {
        let class = self.class(el, inherited);
        let cls = class.as_str();
        let label = self.tree.label(el);
        let line = self.tree.line(el);
        let kind = match self.get(el, cls, "type").unwrap_or("sphere") {
            "plane" => GeomKind::Plane,
            "sphere" => GeomKind::Sphere,
            "capsule" => GeomKind::Capsule,
            "cylinder" => GeomKind::Cylinder,
            "ellipsoid" => GeomKind::Ellipsoid,
            "box" => GeomKind::Box,
            "mesh" => {
                let Some(name) = self.get(el, cls, "mesh").map(str::to_string) else {
                    self.problems.add(line, label, "a mesh geom needs mesh=");
                    return None;
                };
                match m.meshes.iter().position(|a| a.name == name) {
                    Some(k) => GeomKind::Mesh(k),
                    None => {
                        self.problems.add(
                            line,
                            format!("{label}.mesh"),
                            format!("{name:?}: no such <mesh>"),
                        );
                        return None;
                    }
                }
            }
            "hfield" => GeomKind::Other("hfield"),
            "sdf" => GeomKind::Other("sdf"),
            other => {
                let other = other.to_string();
                self.problems.add(
                    line,
                    format!("{label}.type"),
                    format!("= {other:?}: not a geom type"),
                );
                return None;
            }
        };
        let size = self
            .prefix(el, cls, "size", &[0.0; 3])
            .unwrap_or(vec![0.0; 3]);
        let mut size = [size[0], size[1], size[2]];
        let mut pose = self.pose(el, cls, angles);
        if let Some(ft) = self.vec(el, cls, "fromto", 6) {
            let a = Vector3::new(ft[0], ft[1], ft[2]);
            let b = Vector3::new(ft[3], ft[4], ft[5]);
            match frame::z_to(&(b - a)) {
                Some(q)
                    if matches!(
                        kind,
                        GeomKind::Capsule
                            | GeomKind::Cylinder
                            | GeomKind::Box
                            | GeomKind::Ellipsoid
                    ) =>
                {
                    pose = Isometry3::from_parts(Translation3::from((a + b) / 2.0), q);
                    let half = (b - a).norm() / 2.0;
                    if matches!(kind, GeomKind::Capsule | GeomKind::Cylinder) {
                        size[1] = half;
                    } else {
                        size[2] = half;
                    }
                }
                _ => self.problems.add(
                    line,
                    format!("{label}.fromto"),
                    "needs two distinct points, on a capsule, cylinder, box or ellipsoid",
                ),
            }
        }
        let needed = match kind {
            GeomKind::Sphere => 1,
            GeomKind::Capsule | GeomKind::Cylinder => 2,
            GeomKind::Ellipsoid | GeomKind::Box => 3,
            _ => 0,
        };
        if !size[..needed].iter().all(|s| *s > 0.0) {
            self.problems.add(
                line,
                format!("{label}.size"),
                format!("{:?}: {needed} positive sizes expected", &size[..needed]),
            );
            return None;
        }
        let int = |r: &mut Self, a: &str, d: i64| r.num(el, cls, a).map_or(d, |v| v as i64);
        let friction = self.prefix(el, cls, "friction", &[1.0, 0.005, 0.0001]);
        Some(Geom {
            name: el.attr("name").unwrap_or("").to_string(),
            kind,
            size,
            pose,
            mass: self.num(el, cls, "mass"),
            density: self.num(el, cls, "density").unwrap_or(1000.0),
            group: int(self, "group", 0),
            rgba: match (
                self.vec(el, cls, "rgba", 4),
                self.get(el, cls, "material")
                    .and_then(|n| m.materials.get(n)),
            ) {
                (Some(c), _) => [c[0], c[1], c[2], c[3]],
                (None, Some(c)) => *c,
                (None, None) => [0.5, 0.5, 0.5, 1.0],
            },
            contype: int(self, "contype", 1),
            conaffinity: int(self, "conaffinity", 1),
            friction: friction.map_or(1.0, |f| f[0]),
            line,
            label,
        })
    }

    fn joint(&mut self, el: &El, inherited: &str, angles: &Angles, m: &Model) -> Option<Joint> {
        let class = self.class(el, inherited);
        let cls = class.as_str();
        let label = self.tree.label(el);
        let line = self.tree.line(el);
        let kind = if el.tag == "freejoint" {
            JointKind::Free
        } else {
            match self.get(el, cls, "type").unwrap_or("hinge") {
                "free" => JointKind::Free,
                "ball" => JointKind::Ball,
                "hinge" => JointKind::Hinge,
                "slide" => JointKind::Slide,
                other => {
                    let other = other.to_string();
                    self.problems.add(
                        line,
                        format!("{label}.type"),
                        format!("= {other:?}: free, ball, hinge or slide expected"),
                    );
                    return None;
                }
            }
        };
        let free = kind == JointKind::Free;
        let pos = if free {
            None
        } else {
            self.vec(el, cls, "pos", 3)
        }
        .unwrap_or(vec![0.0; 3]);
        let axis = if free {
            None
        } else {
            self.vec(el, cls, "axis", 3)
        }
        .unwrap_or(vec![0.0, 0.0, 1.0]);
        let axis = Vector3::new(axis[0], axis[1], axis[2]);
        let Some(axis) = axis.try_normalize(1e-14) else {
            self.problems.add(line, format!("{label}.axis"), "is zero");
            return None;
        };
        // Angles of hinges (and a ball's range) are in the compiler's unit.
        let unit = if matches!(kind, JointKind::Hinge | JointKind::Ball) {
            angles.unit
        } else {
            1.0
        };
        let range = if free {
            None
        } else {
            self.vec(el, cls, "range", 2)
        };
        let limited = if free {
            Some(false)
        } else {
            self.flag(el, cls, "limited")
        };
        let has_range = range.as_ref().is_some_and(|r| r[0] != 0.0 || r[1] != 0.0);
        let limited = limited.unwrap_or(m.compiler.autolimits && has_range);
        let range = match range {
            Some(r) if limited => {
                if r[0] >= r[1] {
                    self.problems.add(
                        line,
                        format!("{label}.range"),
                        format!("{r:?}: the lower limit must be below the upper"),
                    );
                }
                Some([r[0] * unit, r[1] * unit])
            }
            None if limited => {
                self.problems.add(
                    line,
                    format!("{label}.range"),
                    "is missing on a limited joint",
                );
                None
            }
            _ => None,
        };
        let scalar = |r: &mut Self, a: &str| if free { None } else { r.num(el, cls, a) };
        let reference = scalar(self, "ref").unwrap_or(0.0) * unit;
        let springref = scalar(self, "springref").unwrap_or(0.0) * unit;
        let stiffness = scalar(self, "stiffness").unwrap_or(0.0);
        let damping = self.num(el, cls, "damping").unwrap_or(0.0);
        let armature = self.num(el, cls, "armature").unwrap_or(0.0);
        let frictionloss = self.num(el, cls, "frictionloss").unwrap_or(0.0);
        Some(Joint {
            name: el.attr("name").unwrap_or("").to_string(),
            kind,
            pos: Vector3::new(pos[0], pos[1], pos[2]),
            axis,
            range,
            reference,
            stiffness,
            springref,
            damping,
            armature,
            frictionloss,
        })
    }

    fn actuator(&mut self, el: &El, m: &mut Model) {
        let tag = el.tag.as_str();
        let label = self.tree.label(el);
        let line = self.tree.line(el);
        if !ACTUATORS.contains(&tag) {
            return;
        }
        let class = self.class(el, "main");
        let cls = class.as_str();
        let joint = match (
            el.attr("joint").or(el.attr("jointinparent")),
            ["tendon", "site", "body"]
                .into_iter()
                .find(|a| el.attr(a).is_some()),
        ) {
            (Some(j), _) => Ok(j.to_string()),
            (None, Some(a)) => Err(format!("{a} {:?}", el.attr(a).unwrap_or(""))),
            (None, None) => {
                self.problems
                    .add(line, label, "names no joint, tendon, site or body");
                return;
            }
        };
        let gear = self
            .prefix(el, cls, "gear", &[1.0; 6])
            .map_or(1.0, |g| g[0]);
        let range = |r: &mut Self, a: &str, lim: &str| -> Option<[f64; 2]> {
            let v = r.vec(el, cls, a, 2)?;
            let nonzero = v[0] != 0.0 || v[1] != 0.0;
            let on = r
                .flag(el, cls, lim)
                .unwrap_or(m.compiler.autolimits && nonzero);
            on.then_some([v[0], v[1]])
        };
        let forcerange = range(self, "forcerange", "forcelimited");
        let ctrlrange = range(self, "ctrlrange", "ctrllimited");
        let gain = match tag {
            "motor" | "general" => self
                .prefix(el, cls, "gainprm", &[1.0; 10])
                .map_or(1.0, |g| g[0]),
            _ => 1.0,
        };
        // The gain scales the control alone: the drive's kind and gains
        // are in the bias.
        let bias = match tag {
            "motor" => [0.0; 3],
            "position" => {
                let kp = self.num(el, cls, "kp").unwrap_or(1.0);
                let kv = self.num(el, cls, "kv").unwrap_or(0.0);
                [0.0, -kp, -kv]
            }
            "velocity" => {
                let kv = self.num(el, cls, "kv").unwrap_or(1.0);
                [0.0, 0.0, -kv]
            }
            "general" => {
                let b = self
                    .prefix(el, cls, "biasprm", &[0.0; 10])
                    .unwrap_or(vec![0.0; 3]);
                let gaintype = self.get(el, cls, "gaintype").unwrap_or("fixed").to_string();
                let biastype = self.get(el, cls, "biastype").unwrap_or("none").to_string();
                if gaintype != "fixed" || !matches!(biastype.as_str(), "none" | "affine") {
                    m.left_out.push(format!(
                        "{label}: gaintype {gaintype:?} / biastype {biastype:?}: only fixed gains and affine biases are read; left out"
                    ));
                    return;
                }
                if biastype == "affine" {
                    [b[0], b[1], b[2]]
                } else {
                    [0.0; 3]
                }
            }
            other => {
                m.left_out
                    .push(format!("{label}: a {other} actuator is not modelled"));
                return;
            }
        };
        let dynamics = self
            .get(el, cls, "dyntype")
            .filter(|d| *d != "none")
            .map(str::to_string);
        m.actuators.push(Actuator {
            joint,
            gear,
            bias,
            forcerange,
            ctrlrange,
            gain,
            dynamics,
            line,
            label,
        });
    }
}

//! The work-precision cases (issue #6): scenes with a known answer, and the
//! one scorer that turns any engine's trajectory into an error.
//!
//! The scorer reads only what every engine can report (poses, twists, and
//! the normal force of each named contact), so Rapier and MuJoCo in the
//! peers package (`bench/peers`) are scored by this same code: one
//! definition of "error" for everybody on the diagrams.

use super::text::{capsule, cuboid, force, hinge, joint, plane, sphere};
use cosim_engine::Model;
use cosim_shared::{JointKind, Scene, SceneError, ShapeDesc};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use std::f64::consts::FRAC_PI_4;

pub const G: f64 = 9.81;

/// The cases, in the order of the issue.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CaseId {
    /// S1: a solid sphere rolls down a 30 degree incline, mu = 0.5.
    Rolling,
    /// S2: a sphere sliding at 2 m/s on a floor, mu = 0.3, until it rolls.
    SlideToRoll,
    /// S3: a drop from 1 m with e = 0.5.
    Bounce,
    /// S4: five spheres on spherical joints, a chain released horizontal.
    Chain,
    /// S6: two spheres pushed into a corner, mu = 0: static equilibrium.
    Corner,
    /// S7: five capsule links on hinges, a chain released horizontal.
    HingeChain,
    /// S8: a box sent down a 0.2 rad incline, mu = 0.5, slides to rest.
    BoxIncline,
    /// The reference scene against a converged run.
    Reference,
}

pub const ALL: [CaseId; 8] = [
    CaseId::Rolling,
    CaseId::SlideToRoll,
    CaseId::Bounce,
    CaseId::Chain,
    CaseId::Corner,
    CaseId::HingeChain,
    CaseId::BoxIncline,
    CaseId::Reference,
];

// Constants of the cases and their exact answers.
const R: f64 = 0.1;
const INCLINE: f64 = 30.0;
const S2_MU: f64 = 0.3;
const S2_V0: f64 = 2.0;
const S3_DROP: f64 = 1.0;
const S3_E: f64 = 0.5;
const S4_LINKS: usize = 5;
const S4_LINK: f64 = 0.3;
const S4_R: f64 = 0.05;
const S6_FORCE: f64 = 10.0;
/// The time (s) at which S4 and S7 are compared with their converged
/// reference.
pub const CHAIN_REFERENCE_T: f64 = 1.0;

const S7_LINKS: usize = 5;
const S7_LINK: f64 = 0.3;
const S7_R: f64 = 0.03;
const S8_INCLINE: f64 = 0.2;
const S8_MU: f64 = 0.5;
const S8_V0: f64 = 1.0;
const S8_HALF: [f64; 3] = [0.1, 0.1, 0.05];
/// Simulated seconds of the reference case: long enough for impacts
/// between the spheres, the floor and a wall (0.09, 0.19 s), short enough
/// that the chaotic trajectory still converges as h shrinks. Measured: the
/// runs at h = 2e-5 and 1e-5 differ by 0.45 mm over 0.3 s, by 1.0 mm over
/// 0.5 s.
pub const REFERENCE_SECONDS: f64 = 0.3;

/// S1: `d = (1/2) (5/7) g sin(theta) t^2` at t = 1 s.
pub fn rolling_distance() -> f64 {
    0.5 * 5.0 / 7.0 * G * INCLINE.to_radians().sin()
}
/// S2: rolling speed `5/7 v0`, reached at `t* = 2 v0 / (7 mu g)`.
pub fn slide_final_speed() -> f64 {
    5.0 / 7.0 * S2_V0
}
pub fn slide_roll_time() -> f64 {
    2.0 * S2_V0 / (7.0 * S2_MU * G)
}
/// S3: apex `e^2 h`.
pub fn bounce_apex() -> f64 {
    S3_E * S3_E * S3_DROP
}
/// S8: the box decelerates at `a = g (mu cos - sin)` while it slides, so
/// it stops after `v0^2 / (2 a)` (0.17493 m), at `v0 / a` (0.350 s).
pub fn incline_deceleration() -> f64 {
    G * (S8_MU * S8_INCLINE.cos() - S8_INCLINE.sin())
}
pub fn incline_stop_distance() -> f64 {
    S8_V0 * S8_V0 / (2.0 * incline_deceleration())
}
/// S8: what semi-implicit Euler travels at step `h`: the speed falls by
/// `a h` each step until the step that would reverse it, and each step
/// moves `h` times the new speed: `h sum_{k=1..K} (v0 - k a h)`,
/// `K = floor(v0 / (a h))`. About `v0 h / 2` short of the continuous
/// answer.
pub fn incline_discrete_distance(h: f64) -> f64 {
    let a = incline_deceleration();
    let stop = (S8_V0 / (a * h)).floor() as u64;
    (1..=stop).map(|k| h * (S8_V0 - k as f64 * a * h)).sum()
}
/// S8's incline: its unit normal and the direction down its slope.
fn incline_frame() -> (Vector3<f64>, Vector3<f64>) {
    let th = S8_INCLINE;
    (
        Vector3::new(th.sin(), 0.0, th.cos()),
        Vector3::new(th.cos(), 0.0, -th.sin()),
    )
}
/// S6: the normal force of each contact at static equilibrium. With mu = 0
/// the forces are unique: the 10 N push (-x, -y)/sqrt 2 on B is carried by
/// the y = 0 wall (its y part) and through A into the x = 0 wall (its x
/// part); each floor carries its sphere's weight; nothing pushes A into
/// the y = 0 wall, and B does not touch the x = 0 wall.
pub fn corner_forces() -> [(&'static str, f64); 6] {
    let half = S6_FORCE / 2f64.sqrt();
    [
        ("A/floor", G),
        ("A/wall_x", half),
        ("A/wall_y", 0.0),
        ("B/floor", G),
        ("B/wall_y", half),
        ("A/B", half),
    ]
}

impl CaseId {
    pub fn key(self) -> &'static str {
        match self {
            CaseId::Rolling => "S1",
            CaseId::SlideToRoll => "S2",
            CaseId::Bounce => "S3",
            CaseId::Chain => "S4",
            CaseId::Corner => "S6",
            CaseId::HingeChain => "S7",
            CaseId::BoxIncline => "S8",
            CaseId::Reference => "REF",
        }
    }

    pub fn title(self) -> &'static str {
        match self {
            CaseId::Rolling => "S1 rolling down 30 deg, distance at 1 s",
            CaseId::SlideToRoll => "S2 slide to roll, speed at 1 s",
            CaseId::Bounce => "S3 bounce, first apex",
            CaseId::Chain => "S4 chain of 5, largest energy drift over 10 s",
            CaseId::Corner => "S6 corner, contact forces against equilibrium",
            CaseId::HingeChain => "S7 hinge chain of 5 capsules, largest energy drift over 10 s",
            CaseId::BoxIncline => "S8 box sliding to rest on a 0.2 rad incline, distance",
            CaseId::Reference => "reference scene, positions against a converged run",
        }
    }

    /// What `Score::error` measures, with its unit.
    pub fn error_name(self) -> &'static str {
        match self {
            CaseId::Rolling => "|distance - 1.7518 m| (m)",
            CaseId::SlideToRoll => "|speed - 10/7 m/s| (m/s)",
            CaseId::Bounce => "|apex - 0.25 m| (m)",
            CaseId::Chain => "max |E(t) - E(0)| / sum m g L over 10 s",
            CaseId::Corner => "max |F - F_eq| over the last 0.5 s (N)",
            CaseId::HingeChain => "max |E(t) - E(0)| / sum m g L over 10 s",
            CaseId::BoxIncline => "|distance - 0.17493 m| (m)",
            CaseId::Reference => "max position error over 0.3 s (m)",
        }
    }

    pub fn parse(s: &str) -> Option<CaseId> {
        ALL.into_iter().find(|c| c.key().eq_ignore_ascii_case(s))
    }

    /// Simulated seconds.
    pub fn duration(self) -> f64 {
        match self {
            CaseId::Rolling
            | CaseId::SlideToRoll
            | CaseId::Bounce
            | CaseId::Corner
            | CaseId::BoxIncline => 1.0,
            CaseId::Chain | CaseId::HingeChain => 10.0,
            CaseId::Reference => REFERENCE_SECONDS,
        }
    }

    /// The case's scene at step `h`, friction directions `nd`.
    pub fn scene(self, h: f64, nd: usize) -> Result<Scene, SceneError> {
        let steps = (self.duration() / h).round() as u64;
        let mut scene = match self {
            CaseId::Reference => cosim_shared::scenes::reference()?,
            _ => Scene::parse(&self.toml(h, steps), self.key())?,
        };
        scene.sim.dt = h;
        scene.sim.duration = None;
        scene.sim.steps = Some(steps);
        scene.sim.friction_directions = nd;
        scene.sim.name = Some(self.key().to_string());
        // The cases measure the time stepping against analytic answers,
        // at rest too (S6's forces): a sleeping body's contacts leave the
        // step and report no impulse.
        scene.sim.sleep = cosim_shared::SleepDesc::off();
        Ok(scene)
    }

    fn toml(self, h: f64, steps: u64) -> String {
        let sim = format!("[sim]\ndt = {h:e}\nsteps = {steps}\n");
        match self {
            CaseId::Rolling => {
                let th = INCLINE.to_radians();
                let n = [th.sin(), 0.0, th.cos()];
                sim + &sphere(
                    "ball",
                    R,
                    1.0,
                    [n[0] * R, 0.0, n[2] * R],
                    [0.0; 3],
                    0.5,
                    0.0,
                ) + &plane("incline", n, [0.0; 3], 0.5, 0.0)
            }
            CaseId::SlideToRoll => {
                sim + &sphere("ball", R, 1.0, [0.0, 0.0, R], [S2_V0, 0.0, 0.0], S2_MU, 0.0)
                    + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], S2_MU, 0.0)
            }
            CaseId::Bounce => {
                // The drop height is that of the sphere's lowest point.
                sim + &sphere("ball", R, 1.0, [0.0, 0.0, S3_DROP + R], [0.0; 3], 0.0, S3_E)
                    + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.0, S3_E)
            }
            CaseId::Chain => {
                // Link i pivots about the centre of sphere i-1 (the first
                // about the fixed point at the origin): a chain of 0.3 m
                // rigid links with the mass in the spheres, as a MuJoCo
                // user would write it with ball joints.
                // "No contact": the links pass through each other.
                let mut s = sim + "sphere_contacts = false\n";
                for i in 0..S4_LINKS {
                    let x = S4_LINK * (i + 1) as f64;
                    s += &sphere(
                        &format!("s{i}"),
                        S4_R,
                        1.0,
                        [x, 0.0, 0.0],
                        [0.0; 3],
                        0.0,
                        0.0,
                    );
                }
                for i in 0..S4_LINKS {
                    let a = chain_parent("s", i);
                    s += &joint(
                        &format!("j{i}"),
                        &a,
                        &format!("s{i}"),
                        [S4_LINK * i as f64, 0.0, 0.0],
                    );
                }
                s
            }
            CaseId::Corner => {
                let f = S6_FORCE / 2f64.sqrt();
                sim + &sphere("A", R, 1.0, [R, R, R], [0.0; 3], 0.0, 0.0)
                    + &sphere("B", R, 1.0, [3.0 * R, R, R], [0.0; 3], 0.0, 0.0)
                    + &force([-f, -f, 0.0])
                    + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.0, 0.0)
                    + &plane("wall_x", [1.0, 0.0, 0.0], [0.0; 3], 0.0, 0.0)
                    + &plane("wall_y", [0.0, 1.0, 0.0], [0.0; 3], 0.0, 0.0)
            }
            CaseId::HingeChain => {
                // Link i spans x in [i L, (i+1) L]: a capsule along its
                // body z, turned a quarter about y onto x, hinged about y
                // at its inner end to link i-1 (the first to the world).
                // Its joint's two bodies overlap at the hinge and do not
                // touch (MuJoCo's default between parent and child).
                let mut s = sim + "sphere_contacts = false\n";
                let onto_x = [FRAC_PI_4.cos(), 0.0, FRAC_PI_4.sin(), 0.0];
                for i in 0..S7_LINKS {
                    let x = S7_LINK * (i as f64 + 0.5);
                    s += &capsule(
                        &format!("l{i}"),
                        S7_R,
                        0.5 * S7_LINK - S7_R,
                        1.0,
                        [x, 0.0, 0.0],
                        onto_x,
                        [0.0; 3],
                        [0.0; 3],
                        0.0,
                    );
                }
                for i in 0..S7_LINKS {
                    let a = chain_parent("l", i);
                    s += &hinge(
                        &format!("j{i}"),
                        &a,
                        &format!("l{i}"),
                        [S7_LINK * i as f64, 0.0, 0.0],
                        [0.0, 1.0, 0.0],
                    );
                }
                s
            }
            CaseId::BoxIncline => {
                // The box lies on its largest face, turned with the slope
                // (about y), sent straight down it.
                let (n, down) = incline_frame();
                let half_angle = 0.5 * S8_INCLINE;
                sim + &cuboid(
                    "box",
                    S8_HALF,
                    1.0,
                    (n * S8_HALF[2]).into(),
                    [half_angle.cos(), 0.0, half_angle.sin(), 0.0],
                    (down * S8_V0).into(),
                    [0.0; 3],
                    S8_MU,
                ) + &plane("incline", n.into(), [0.0; 3], S8_MU, 0.0)
            }
            CaseId::Reference => unreachable!("the reference scene is built in"),
        }
    }
}

/// The body link `i` of a chain hangs from: the world, or link i-1.
fn chain_parent(prefix: &str, i: usize) -> String {
    match i {
        0 => "world".to_string(),
        _ => format!("{prefix}{}", i - 1),
    }
}

/// Pose and twist of one body, world frame; `q` is `[w, x, y, z]`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose {
    pub x: [f64; 3],
    pub q: [f64; 4],
    pub v: [f64; 3],
    pub w: [f64; 3],
}

/// What an engine reports after a step at time `t`: the bodies in the
/// scene's order, and the normal force (N) of each contact named `a/b` as
/// in the scene (contacts not listed carry no force).
#[derive(Debug, Clone, Default)]
pub struct Sample {
    pub t: f64,
    pub bodies: Vec<Pose>,
    pub forces: Vec<(String, f64)>,
}

/// A case's error (`CaseId::error_name`) and its secondary figures.
#[derive(Debug, Clone, PartialEq)]
pub struct Score {
    pub error: f64,
    pub metrics: Vec<(&'static str, f64)>,
}

impl Score {
    /// The secondary figure `name`, if the case has it.
    pub fn metric(&self, name: &str) -> Option<f64> {
        self.metrics
            .iter()
            .find(|(n, _)| *n == name)
            .map(|&(_, v)| v)
    }
}

fn v3(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}
fn rot(q: [f64; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
}

/// A joint as the scorer sees it: body A (`None`: the world) and its local
/// anchor, body B and its local anchor. The same for a hinge's axis.
type JointAnchors = (Option<usize>, Vector3<f64>, usize, Vector3<f64>);

/// Streams a trajectory into a [`Score`].
pub struct Scorer {
    case: CaseId,
    scene: Scene,
    samples: u64,
    // S1, S2, S3
    slip_distance: f64,
    max_slip: f64,
    sink: f64,
    roll_time: Option<f64>,
    bounced: bool,
    apex: Option<f64>,
    climbing_max: f64,
    /// Time and bodies of the last sample (the finish reads them).
    last_t: Option<f64>,
    last: Vec<Pose>,
    // S4
    e0: Option<f64>,
    max_drift: f64,
    joint_error: f64,
    anchors: Vec<JointAnchors>,
    axis_error: f64,
    axes: Vec<JointAnchors>,
    /// Body-frame inertia of each body, as our engine takes it from the
    /// scene (the shape's, or the scene's own).
    inertias: Vec<Matrix3<f64>>,
    // S8
    stop_time: Option<f64>,
    pitch: f64,
    // S6
    force_error: f64,
    force_sum: Vec<f64>,
    force_sq: Vec<f64>,
    force_n: u64,
    start: Vec<Vector3<f64>>,
    drift: f64,
    // Reference
    reference: Option<Vec<(f64, Vec<[f64; 3]>)>>,
    position_error: f64,
}

impl Scorer {
    /// `scene` is the case's scene as run (its dt and bodies); `reference`
    /// the converged trajectory (`CaseId::Reference`; the chains' at
    /// `CHAIN_REFERENCE_T`), positions at the times it lists.
    pub fn new(
        case: CaseId,
        scene: &Scene,
        reference: Option<Vec<(f64, Vec<[f64; 3]>)>>,
    ) -> Scorer {
        let mut anchors = Vec::new();
        let mut axes = Vec::new();
        let find = |n: &str| scene.bodies.iter().position(|b| b.name == n);
        for j in &scene.joints {
            let anchor = v3(j.anchor);
            let local = |i: usize, w: Vector3<f64>| {
                rot(scene.bodies[i].orientation).inverse_transform_vector(&w)
            };
            let a = find(&j.body_a);
            let Some(b) = find(&j.body_b) else { continue };
            let at = |i: usize| local(i, anchor - v3(scene.bodies[i].position));
            anchors.push((a, a.map_or(anchor, at), b, at(b)));
            if let (JointKind::Revolute, Some(axis)) = (j.kind, j.axis) {
                let axis = v3(axis).normalize();
                let along = |i: usize| local(i, axis);
                axes.push((a, a.map_or(axis, along), b, along(b)));
            }
        }
        let inertias = Model::from_scene(scene)
            .bodies
            .iter()
            .map(|b| b.inertia)
            .collect();
        Scorer {
            case,
            scene: scene.clone(),
            samples: 0,
            slip_distance: 0.0,
            max_slip: 0.0,
            sink: 0.0,
            roll_time: None,
            bounced: false,
            apex: None,
            climbing_max: f64::NEG_INFINITY,
            last_t: None,
            last: Vec::new(),
            e0: None,
            max_drift: 0.0,
            joint_error: 0.0,
            anchors,
            axis_error: 0.0,
            axes,
            inertias,
            stop_time: None,
            pitch: 0.0,
            force_error: 0.0,
            force_sum: vec![0.0; corner_forces().len()],
            force_sq: vec![0.0; corner_forces().len()],
            force_n: 0,
            start: scene.bodies.iter().map(|b| v3(b.position)).collect(),
            drift: 0.0,
            reference,
            position_error: 0.0,
        }
    }

    /// Total energy: kinetic (translation and rotation, `w . R J R^T w`
    /// with the body-frame inertia J) plus gravity's potential.
    fn energy(&self, bodies: &[Pose]) -> f64 {
        let g = v3(self.scene.sim.gravity);
        self.scene
            .bodies
            .iter()
            .zip(&self.inertias)
            .zip(bodies)
            .map(|((b, j), p)| {
                let w = rot(p.q).inverse_transform_vector(&v3(p.w));
                0.5 * b.mass * v3(p.v).norm_squared() + 0.5 * w.dot(&(j * w))
                    - b.mass * g.dot(&v3(p.x))
            })
            .sum()
    }

    /// How far the box's lowest vertex is below the first plane (m).
    fn box_sink(&self, p: &Pose) -> f64 {
        let plane = &self.scene.planes[0];
        let n = v3(plane.normal).normalize();
        let ShapeDesc::Box { half_extents: e } = self.scene.bodies[0].shape() else {
            return 0.0;
        };
        let q = rot(p.q);
        // The lowest vertex puts each half extent against the normal.
        let local = q.inverse_transform_vector(&n);
        let reach: f64 = (0..3).map(|k| e[k] * local[k].abs()).sum();
        reach - n.dot(&(v3(p.x) - v3(plane.point)))
    }

    /// The contact point's slip speed of body 0 on the first plane.
    fn slip(&self, p: &Pose) -> f64 {
        let n = v3(self.scene.planes[0].normal).normalize();
        (v3(p.v) + v3(p.w).cross(&(-n * sphere_radius(&self.scene.bodies[0])))).norm()
    }

    fn height(&self, p: &Pose) -> f64 {
        let n = v3(self.scene.planes[0].normal).normalize();
        n.dot(&(v3(p.x) - v3(self.scene.planes[0].point))) - sphere_radius(&self.scene.bodies[0])
    }

    pub fn observe(&mut self, s: &Sample) {
        self.samples += 1;
        let dt = self.last_t.map_or(s.t, |t| s.t - t);
        match self.case {
            CaseId::Rolling | CaseId::SlideToRoll => {
                let p = &s.bodies[0];
                let slip = self.slip(p);
                self.slip_distance += slip * dt;
                self.max_slip = self.max_slip.max(slip);
                self.sink = self.sink.max(-self.height(p));
                // Rolling has started once the contact point's slip is
                // below 1 mm/s (soft-contact engines creep and never reach 0).
                if self.roll_time.is_none() && slip < 1e-3 {
                    self.roll_time = Some(s.t);
                }
            }
            CaseId::Bounce => {
                let p = &s.bodies[0];
                let z = self.height(p);
                self.sink = self.sink.max(-z);
                let up = v3(p.v).dot(&v3(self.scene.planes[0].normal).normalize());
                if !self.bounced && up > 0.0 {
                    self.bounced = true;
                }
                if self.bounced && self.apex.is_none() {
                    self.climbing_max = self.climbing_max.max(z);
                    if up <= 0.0 {
                        self.apex = Some(self.climbing_max);
                    }
                }
            }
            CaseId::BoxIncline => {
                let p = &s.bodies[0];
                let q0 = rot(self.scene.bodies[0].orientation);
                self.pitch = self.pitch.max(q0.angle_to(&rot(p.q)));
                self.sink = self.sink.max(self.box_sink(p));
                // At rest once below 1 mm/s (soft contacts creep).
                if self.stop_time.is_none() && v3(p.v).norm() < 1e-3 {
                    self.stop_time = Some(s.t);
                }
            }
            CaseId::Chain | CaseId::HingeChain => {
                self.compare(s);
                let e = self.energy(&s.bodies);
                let e0 = *self.e0.get_or_insert(e);
                self.max_drift = self.max_drift.max((e - e0).abs());
                for (a, la, b, lb) in &self.anchors {
                    let pa = match a {
                        Some(i) => v3(s.bodies[*i].x) + rot(s.bodies[*i].q) * la,
                        None => *la,
                    };
                    let pb = v3(s.bodies[*b].x) + rot(s.bodies[*b].q) * lb;
                    self.joint_error = self.joint_error.max((pa - pb).norm());
                }
                for (a, la, b, lb) in &self.axes {
                    let ua = match a {
                        Some(i) => rot(s.bodies[*i].q) * la,
                        None => *la,
                    };
                    let ub = rot(s.bodies[*b].q) * lb;
                    self.axis_error = self.axis_error.max(ua.cross(&ub).norm().min(1.0).asin());
                }
            }
            CaseId::Corner => {
                for (i, b) in s.bodies.iter().enumerate() {
                    self.drift = self.drift.max((v3(b.x) - self.start[i]).norm());
                }
                if s.t > self.scene.sim.dt * self.scene.step_count() as f64 - 0.5 + 1e-9 {
                    self.force_n += 1;
                    for (k, (name, exact)) in corner_forces().into_iter().enumerate() {
                        let f = s
                            .forces
                            .iter()
                            .filter(|(n, _)| n == name)
                            .map(|(_, f)| f)
                            .sum::<f64>();
                        self.force_error = self.force_error.max((f - exact).abs());
                        self.force_sum[k] += f;
                        self.force_sq[k] += f * f;
                    }
                }
            }
            CaseId::Reference => self.compare(s),
        }
        self.last_t = Some(s.t);
        self.last.clear();
        self.last.extend_from_slice(&s.bodies);
    }

    /// The largest position error against the reference at its sample
    /// times (to the step).
    fn compare(&mut self, s: &Sample) {
        let Some(reference) = &self.reference else {
            return;
        };
        let h = self.scene.sim.dt;
        if let Some((_, xs)) = reference.iter().find(|(t, _)| (t - s.t).abs() < 0.5 * h) {
            for (x, p) in xs.iter().zip(&s.bodies) {
                self.position_error = self.position_error.max((v3(*x) - v3(p.x)).norm());
            }
        }
    }

    pub fn finish(self) -> Score {
        let last = &self.last;
        match self.case {
            CaseId::Rolling => {
                let th = INCLINE.to_radians();
                let down = Vector3::new(th.cos(), 0.0, -th.sin());
                let start = v3(self.scene.bodies[0].position);
                let d = last.first().map_or(0.0, |p| (v3(p.x) - start).dot(&down));
                Score {
                    error: (d - rolling_distance()).abs(),
                    metrics: vec![
                        ("distance_m", d),
                        ("slip_m", self.slip_distance),
                        ("sink_m", self.sink),
                    ],
                }
            }
            CaseId::SlideToRoll => {
                let speed = last.first().map_or(0.0, |p| v3(p.v).norm());
                let tr = self.roll_time.unwrap_or(f64::INFINITY);
                Score {
                    error: (speed - slide_final_speed()).abs(),
                    metrics: vec![
                        ("speed_m_s", speed),
                        ("roll_time_s", tr),
                        ("roll_time_error_s", (tr - slide_roll_time()).abs()),
                        ("sink_m", self.sink),
                    ],
                }
            }
            CaseId::Bounce => {
                let apex = self.apex.unwrap_or(f64::NAN);
                Score {
                    error: (apex - bounce_apex()).abs(),
                    metrics: vec![("apex_m", apex), ("sink_m", self.sink)],
                }
            }
            CaseId::BoxIncline => {
                let (_, down) = incline_frame();
                let start = v3(self.scene.bodies[0].position);
                let d = last.first().map_or(0.0, |p| (v3(p.x) - start).dot(&down));
                let creep = last.first().map_or(0.0, |p| v3(p.v).norm());
                let stop = self.stop_time.unwrap_or(f64::INFINITY);
                Score {
                    error: (d - incline_stop_distance()).abs(),
                    metrics: vec![
                        ("distance_m", d),
                        ("stop_time_s", stop),
                        (
                            "stop_time_error_s",
                            (stop - S8_V0 / incline_deceleration()).abs(),
                        ),
                        ("end_speed_m_s", creep),
                        ("pitch_rad", self.pitch),
                        ("sink_m", self.sink),
                    ],
                }
            }
            CaseId::Chain | CaseId::HingeChain => {
                let scale: f64 = self
                    .scene
                    .bodies
                    .iter()
                    .map(|b| b.mass * G * v3(b.position).norm())
                    .sum();
                // Scored on the largest drift over the run, which the end
                // point flatters (RK4's peaks during the whip and comes
                // back), beside the end point and the position error at
                // `CHAIN_REFERENCE_T` against the converged reference.
                let e_end = self.energy(last);
                let position = match self.reference {
                    Some(_) => self.position_error,
                    None => f64::NAN,
                };
                let mut metrics = vec![
                    (
                        "end_energy_drift",
                        (e_end - self.e0.unwrap_or(e_end)).abs() / scale,
                    ),
                    (crate::accuracy::POSITION_1S, position),
                    ("joint_error_m", self.joint_error),
                ];
                if self.case == CaseId::HingeChain {
                    metrics.push(("axis_error_rad", self.axis_error));
                }
                Score {
                    error: self.max_drift / scale,
                    metrics,
                }
            }
            CaseId::Corner => {
                let n = self.force_n.max(1) as f64;
                let jitter = self
                    .force_sum
                    .iter()
                    .zip(&self.force_sq)
                    .map(|(s, q)| (q / n - (s / n).powi(2)).max(0.0).sqrt())
                    .fold(0.0, f64::max);
                let mean_error = corner_forces()
                    .iter()
                    .zip(&self.force_sum)
                    .map(|((_, exact), s)| (s / n - exact).abs())
                    .fold(0.0, f64::max);
                Score {
                    error: if self.force_n == 0 {
                        f64::NAN
                    } else {
                        self.force_error
                    },
                    metrics: vec![
                        ("mean_force_error_n", mean_error),
                        ("force_std_n", jitter),
                        ("position_drift_m", self.drift),
                    ],
                }
            }
            CaseId::Reference => Score {
                error: if self.reference.is_some() {
                    self.position_error
                } else {
                    f64::NAN
                },
                metrics: vec![],
            },
        }
    }
}

/// The radius of a case's body: every case is of spheres (the peers'
/// shared ground), written by `text.rs`.
fn sphere_radius(b: &cosim_shared::BodyDesc) -> f64 {
    b.radius.unwrap_or(0.0)
}

//! The bottom layer: the compiled scene, immutable while the simulation
//! runs (MuJoCo's `mjModel`), its parameters, the [`State`] that changes
//! (MuJoCo's `mjData`), and the few types and functions of both that every
//! stage above shares (the islands' union-find, a joint's anchor). It
//! imports no stage.

pub mod hull;
pub mod islands;
pub mod kinematics;
pub mod params;
pub mod state;

pub use params::{Compliance, Params, PgsParams, Skips, Sleep, Stop};
pub use state::{BodyState, State, WarmContact, WarmCursor};

use cosim_shared::Scene;
use nalgebra::{Matrix3, Unit, UnitQuaternion, Vector3};

/// A body's shape in its own frame, centred on the centre of mass.
/// Another shape is a new variant, an inertia below and a file per shape
/// pair under `collision/`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    Sphere {
        radius: f64,
    },
    /// The points within `radius` of the segment from `-half_length` to
    /// `half_length` along the body's z axis.
    Capsule {
        radius: f64,
        half_length: f64,
    },
    /// Half its edge lengths along the body's axes.
    Box {
        half: Vector3<f64>,
    },
    /// A convex hull, `Model::hulls[index]`; `bound` its farthest
    /// vertex's distance from the shape's origin. A cylinder (`cylinder`:
    /// its radius and half length, about z) is the hull of a prism of
    /// [`hull::CYLINDER_SIDES`] sides against boxes, capsules, hulls and
    /// cylinders, and itself, exactly, against planes, spheres and a box's
    /// or hull's face that carries it.
    Hull {
        index: usize,
        bound: f64,
        cylinder: Option<(f64, f64)>,
    },
}

impl Shape {
    /// The shape of a description; a hull's is added to `hulls`.
    pub fn from_desc(d: &cosim_shared::ShapeDesc, hulls: &mut Vec<hull::Hull>) -> Shape {
        use cosim_shared::ShapeDesc as D;
        match *d {
            D::Hull { ref points } => {
                let h = hull::Hull::new(points);
                let bound = h.bound;
                hulls.push(h);
                Shape::Hull {
                    index: hulls.len() - 1,
                    bound,
                    cylinder: None,
                }
            }
            D::Cylinder {
                radius,
                half_length,
            } => {
                hulls.push(hull::Hull::cylinder(radius, half_length));
                Shape::Hull {
                    index: hulls.len() - 1,
                    bound: radius.hypot(half_length),
                    cylinder: Some((radius, half_length)),
                }
            }
            D::Sphere { radius } => Shape::Sphere { radius },
            D::Capsule {
                radius,
                half_length,
            } => Shape::Capsule {
                radius,
                half_length,
            },
            D::Box { half_extents: h } => Shape::Box {
                half: Vector3::new(h[0], h[1], h[2]),
            },
        }
    }

    /// Body-frame inertia about the centre of mass of a solid of uniform
    /// density and mass `mass`.
    pub fn inertia(&self, mass: f64) -> Matrix3<f64> {
        match *self {
            // Solid sphere: J = 2/5 m R^2 I.
            Shape::Sphere { radius } => Matrix3::identity() * (0.4 * mass * radius * radius),
            // Cuboid of edges 2a, 2b, 2c: J_x = m (b^2 + c^2) / 3, ...
            Shape::Box { half: h } => {
                let (x, y, z) = (h.x * h.x, h.y * h.y, h.z * h.z);
                Matrix3::from_diagonal(&Vector3::new(y + z, x + z, x + y)) * (mass / 3.0)
            }
            // A cylinder of radius r and length 2l and two hemispheres,
            // masses in proportion to their volumes (2 pi r^2 l and
            // 4/3 pi r^3). About the axis: m_c r^2 / 2 + m_s 2 r^2 / 5.
            // Across it: the cylinder's m_c (r^2 / 4 + l^2 / 3); each
            // hemisphere (m_s / 2) has 2 r^2 / 5 about its own flat face's
            // centre, its centre of mass 3 r / 8 beyond that face, so by
            // the parallel axes theorem (twice: to its centre of mass,
            // then to ours at distance l + 3 r / 8) the pair adds
            // m_s (2 r^2 / 5 + l^2 + 3 l r / 4).
            Shape::Capsule {
                radius: r,
                half_length: l,
            } => {
                // Volumes over pi.
                let (vc, vs) = (2.0 * r * r * l, 4.0 / 3.0 * r * r * r);
                let (mc, ms) = (mass * vc / (vc + vs), mass * vs / (vc + vs));
                let axial = mc * r * r / 2.0 + ms * 0.4 * r * r;
                let across =
                    mc * (r * r / 4.0 + l * l / 3.0) + ms * (0.4 * r * r + l * l + 0.75 * l * r);
                Matrix3::from_diagonal(&Vector3::new(across, across, axial))
            }
            // A solid cylinder of radius r and length 2l: m r^2 / 2 about
            // its axis, m (3 r^2 + 4 l^2) / 12 across.
            Shape::Hull {
                cylinder: Some((r, l)),
                ..
            } => {
                let across = mass * (3.0 * r * r + 4.0 * l * l) / 12.0;
                Matrix3::from_diagonal(&Vector3::new(across, across, 0.5 * mass * r * r))
            }
            // A body with a hull gives its inertia (validated): a ball's
            // of the bound, never used.
            Shape::Hull { bound, .. } => Matrix3::identity() * (0.4 * mass * bound * bound),
        }
    }

    /// How far the shape reaches from its centre along the unit world
    /// direction `dir` when turned by `q` (its support function): a
    /// body's lowest point above a plane is its centre's height less its
    /// extent along the plane's normal.
    pub fn extent(&self, q: &UnitQuaternion<f64>, dir: &Vector3<f64>) -> f64 {
        let d = q.inverse_transform_vector(dir);
        match *self {
            Shape::Sphere { radius } => radius,
            Shape::Capsule {
                radius,
                half_length,
            } => radius + half_length * d.z.abs(),
            Shape::Box { half } => half.dot(&d.abs()),
            // Its bounding ball's (the figures' shadows only).
            Shape::Hull { bound, .. } => bound,
        }
    }

    /// The lever (m) that turns the body's angular speed into its
    /// surface's speed in the bounds of the broad phase and the pruning
    /// (`|v| + |w| spin_reach`): none for a sphere, whose gaps depend on
    /// its centre alone; the bounding radius for the others, whose
    /// vertices and ends sweep as they turn.
    pub fn spin_reach(&self) -> f64 {
        match self {
            Shape::Sphere { .. } => 0.0,
            _ => self.bounding_radius(),
        }
    }

    /// The radius of the smallest sphere about the centre that holds the
    /// shape: the broad phase's bound.
    pub fn bounding_radius(&self) -> f64 {
        match *self {
            Shape::Sphere { radius } => radius,
            Shape::Capsule {
                radius,
                half_length,
            } => radius + half_length,
            Shape::Box { half } => half.norm(),
            Shape::Hull { bound, .. } => bound,
        }
    }
}

/// Where a shape sits in its body's frame (whose origin is the centre of
/// mass).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Offset {
    pub x: Vector3<f64>,
    pub q: UnitQuaternion<f64>,
}

/// One of a body's shapes: at the centre of mass, turned as the body
/// (`offset: None`, a body's one shape as the scene's own fields give it,
/// computed as before: the same bits), or at an offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geom {
    pub shape: Shape,
    pub offset: Option<Offset>,
    /// A box's hull (`Model::hulls`), in a scene with hulls: a box against
    /// a hull is a pair of hulls.
    pub hull: Option<usize>,
}

impl Geom {
    /// The radius about the body's centre of mass of a sphere that holds
    /// the shape.
    pub fn bounding_radius(&self) -> f64 {
        self.shape.bounding_radius() + self.offset.map_or(0.0, |o| o.x.norm())
    }

    /// How far the shape reaches from the body's centre of mass along the
    /// unit world direction `dir`, the body turned by `q`.
    pub fn extent(&self, q: &UnitQuaternion<f64>, dir: &Vector3<f64>) -> f64 {
        match self.offset {
            None => self.shape.extent(q, dir),
            Some(o) => (q * o.x).dot(dir) + self.shape.extent(&(q * o.q), dir),
        }
    }
}

#[derive(Debug, Clone)]
pub struct Body {
    pub name: String,
    /// Its shapes: one for a scene's sphere, capsule or box; several or
    /// none for a robot's link (`[[body.shape]]`).
    pub shapes: Vec<Geom>,
    /// The radius about the centre of mass of a sphere that holds every
    /// shape: the broad phase's bound (0 with no shape).
    pub bound: f64,
    /// The lever (m) that turns the body's angular speed into its
    /// surface's speed in the bounds of the broad phase and the pruning
    /// (`Shape::spin_reach`; the bound for shapes away from the centre).
    pub spin_reach: f64,
    pub mass: f64,
    pub inv_mass: f64,
    /// Body-frame inertia and its inverse (diagonal: the shapes' axes are
    /// the body's; `applied::inverse_masses` turns them into the world).
    pub inertia: Matrix3<f64>,
    pub inv_inertia: Matrix3<f64>,
    pub friction: f64,
    pub restitution: f64,
    /// Constant world-frame force besides gravity (N).
    pub force: Vector3<f64>,
}

#[derive(Debug, Clone)]
pub struct Plane {
    pub name: String,
    /// Unit normal; bodies stay on this side.
    pub normal: Vector3<f64>,
    /// `normal . x = offset` on the plane.
    pub offset: f64,
    pub friction: f64,
    pub restitution: f64,
}

/// One side of a joint: a body or the fixed world.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Attachment {
    World,
    Body(usize),
}

/// A joint: pins a point fixed in body A to a point fixed in body B (or
/// the world), `psi_b = x_A + R_A a_A - x_B - R_B a_B = 0` (three rows;
/// two, normal to the axis, for a slider), and constrains the relative
/// rotation as `turning` says (joint.rs).
#[derive(Debug, Clone)]
pub struct Joint {
    pub name: String,
    pub a: Attachment,
    pub b: Attachment,
    /// Anchor in A's body frame (a world point when A is the world).
    pub local_a: Vector3<f64>,
    pub local_b: Vector3<f64>,
    /// Constant joint effort from the scene, the initial held input: a
    /// torque (N m), or for a slider a force (N) at B's anchor
    /// (`applied::free_velocity`).
    pub effort: Vector3<f64>,
    /// The largest held effort (`applied::bounded`): infinite unless the
    /// scene bounds it.
    pub max_effort: f64,
    pub turning: Turning,
    /// Prismatic: the unit sliding axis in A's frame (a world direction
    /// for the world); the anchors may part along it only.
    pub slide: Option<Vector3<f64>>,
    /// Whether the two bodies' shapes touch (see `Model::excluded`).
    pub collide: bool,
    /// A hinge's or slider's coordinate limits (`limit.rs`).
    pub limits: Option<Limits>,
    /// A hinge's or slider's velocity motor (`motor.rs`).
    pub motor: Option<Motor>,
    /// A rotor's inertia on the coordinate's rate (kg m^2, or kg for a
    /// slider; 0 for none): `constraint::armature`.
    pub armature: f64,
}

/// `q_follower = ratio q_leader + offset` (a URDF `<mimic>`, an MJCF
/// `<equality><joint>`): two hinges' or sliders' coordinates tied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coupling {
    pub follower: usize,
    pub leader: usize,
    pub ratio: f64,
    pub offset: f64,
}

/// A joint motor: the coordinate's rate driven to `speed` (the scene's;
/// a controller's `Engine::set_motor_speed` holds another) by an effort of
/// at most `max_effort` (N m or N), rigidly or through `gains`; for a
/// position servo `speed` is the target coordinate (`motor.rs`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motor {
    pub speed: f64,
    pub max_effort: f64,
    pub gains: Gains,
}

/// How a motor drives its coordinate (`motor.rs`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Gains {
    /// The rate held at the target up to the effort bound.
    Rigid,
    /// A velocity actuator: effort `kv (v* - x')` (N m s/rad or N s/m).
    Velocity { kv: f64 },
    /// A position servo: effort `kp (q* - q) - kd x'`, implicit in the step.
    Position { kp: f64, kd: f64 },
}

/// A coordinate's limits (rad or m, `joint::coordinate`'s units) and the
/// restitution of a hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    pub lower: f64,
    pub upper: f64,
    pub restitution: f64,
}

/// What a joint leaves of the relative rotation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Turning {
    /// Spherical: every rotation is free.
    Free,
    /// Revolute: only about the hinge axis, a unit vector held in each
    /// side's frame (A's and B's; a world direction for the world).
    /// `zero_a`, `zero_b`: one direction normal to the axis as each side
    /// held it at t = 0, where the hinge's angle is zero
    /// (`joint::coordinate`).
    Axis {
        a: Vector3<f64>,
        b: Vector3<f64>,
        zero_a: Vector3<f64>,
        zero_b: Vector3<f64>,
    },
    /// Fixed: none. B's orientation is A's times `rel` (A's frame to B's,
    /// as at t = 0).
    Locked { rel: UnitQuaternion<f64> },
}

impl Joint {
    /// Constraint rows: three for the anchor (two for a slider), plus two
    /// (hinge) or three (fixed, slider) on the rotation.
    pub fn rows(&self) -> usize {
        self.anchor_rows()
            + match self.turning {
                Turning::Free => 0,
                Turning::Axis { .. } => 2,
                Turning::Locked { .. } => 3,
            }
    }

    /// The scene's name of the joint's type.
    pub fn kind(&self) -> &'static str {
        match (self.turning, self.slide) {
            (Turning::Free, _) => "spherical",
            (Turning::Axis { .. }, _) => "revolute",
            (Turning::Locked { .. }, Some(_)) => "prismatic",
            (Turning::Locked { .. }, None) => "fixed",
        }
    }

    /// The rotor's rows (`constraint::armature`): one on a hinge's or
    /// slider's rate, three on a spherical joint's relative spin, none
    /// without armature (or on a fixed joint, which has no rate).
    pub fn armature_rows(&self) -> usize {
        if self.armature <= 0.0 {
            return 0;
        }
        match (self.turning, self.slide) {
            (Turning::Free, _) => 3,
            (Turning::Locked { .. }, None) => 0,
            _ => 1,
        }
    }

    /// The rows on the anchors, first in the joint's rows: three, or two
    /// for a slider.
    pub fn anchor_rows(&self) -> usize {
        if self.slide.is_some() {
            2
        } else {
            3
        }
    }
}

/// What body A of a contact touches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Counterpart {
    Plane(usize),
    Body(usize),
    /// The fixed world: a joint limit's other side when the joint holds a
    /// body to the world (`joint::limits`).
    World,
}

/// One side of an impulse: a body, a plane or the world.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Party {
    World,
    Body(usize),
    Plane(usize),
}

impl From<Counterpart> for Party {
    fn from(c: Counterpart) -> Party {
        match c {
            Counterpart::Plane(p) => Party::Plane(p),
            Counterpart::Body(j) => Party::Body(j),
            Counterpart::World => Party::World,
        }
    }
}

/// The weld group of the world (see `Model::weld`).
pub const WELDED_TO_WORLD: usize = usize::MAX;

/// Each body's weld group: the islands of the fixed joints
/// (`Islands::partition`), the world as body `n`; a group is named by its
/// island's root, or [`WELDED_TO_WORLD`].
fn weld_groups(n: usize, joints: &[Joint]) -> Vec<usize> {
    let node = |a: Attachment| match a {
        Attachment::World => n,
        Attachment::Body(i) => i,
    };
    let mut islands = islands::Islands::default();
    islands.partition(
        n + 1,
        joints
            .iter()
            .filter(|j| matches!(j.turning, Turning::Locked { .. }) && j.slide.is_none())
            .map(|j| (node(j.a), Counterpart::Body(node(j.b)))),
    );
    let world = islands.root_of(n);
    (0..n)
        .map(|i| match islands.root_of(i) {
            r if r == world => WELDED_TO_WORLD,
            r => r,
        })
        .collect()
}

/// Initial pose and twist of a body, world frame.
#[derive(Debug, Clone, Copy)]
pub struct InitialBody {
    pub position: Vector3<f64>,
    pub orientation: UnitQuaternion<f64>,
    pub velocity: Vector3<f64>,
    pub angular_velocity: Vector3<f64>,
}

#[derive(Debug, Clone)]
pub struct Model {
    pub name: String,
    pub bodies: Vec<Body>,
    pub planes: Vec<Plane>,
    pub joints: Vec<Joint>,
    /// Where each joint's rows start in the joint block (one more entry:
    /// the block's size).
    pub joint_start: Vec<usize>,
    /// Per body, its weld group: bodies tied by fixed joints share one,
    /// and [`WELDED_TO_WORLD`] is the group of the world. Contacts inside
    /// a group are not generated (collision/mod.rs): their rows would lie
    /// in the span of the fixed joints' rows, a zero row of the reduced
    /// LCP whose round-off can make it infeasible (found by the random
    /// scenes: a sphere welded to the world resting on a plane). MuJoCo
    /// excludes such pairs too.
    pub weld: Vec<usize>,
    /// The body pairs `(i, j)`, `i < j`, ascending, that a joint with
    /// `collide = false` keeps out of contact (MuJoCo's parent-child
    /// filter, Drake's collision filter groups).
    pub excluded: Vec<(usize, usize)>,
    /// Per body, its collision group (the scene's `group`, numbered in
    /// order of first use): bodies of one group never touch each other.
    pub group: Vec<Option<usize>>,
    /// Per body, whether it is a side of some joint (such a body never
    /// sleeps, and the projection out of deep penetration leaves it).
    pub jointed: Vec<bool>,
    /// The joints with a motor, ascending: motor `k` is joint
    /// `motors[k]`'s (its row follows the joint block's, `motor.rs`).
    pub motors: Vec<usize>,
    /// Joints whose coordinate follows another's (`constraint::coupling`):
    /// one row each, after every joint's rows in the joint block.
    pub couplings: Vec<Coupling>,
    pub params: Params,
    pub initial: Vec<InitialBody>,
    /// Contact ids per pair of bodies: per pair of their shapes 1 in a
    /// scene of spheres (a pair touches at one point), [`MAX_FEATURES`]
    /// where a box or capsule may touch at several (`collision/`); times
    /// `shape_slots` squared.
    pub features: usize,
    /// The most shapes a body has (at least 1): a contact's feature is
    /// `(shape of A * shape_slots + shape of B) * per pair + its own`
    /// (`Model::shape_feature`).
    pub shape_slots: usize,
    /// The scene's convex hulls (`Shape::Hull`, `Geom::hull`).
    pub hulls: Vec<hull::Hull>,
}

pub use cosim_shared::MAX_FEATURES;

/// How contact coefficients combine (Box2D's rule): friction is the geometric
/// mean, so a frictionless side makes the contact frictionless; restitution
/// the larger, so one bouncy side makes the contact bounce.
pub fn mix_friction(a: f64, b: f64) -> f64 {
    (a * b).sqrt()
}
pub fn mix_restitution(a: f64, b: f64) -> f64 {
    a.max(b)
}

impl Model {
    /// Compiles a validated scene. Validation already refused every value
    /// this could not handle, so nothing here can fail.
    pub fn from_scene(scene: &Scene) -> Model {
        let v3 = |a: [f64; 3]| Vector3::new(a[0], a[1], a[2]);
        let mut hulls = Vec::new();
        let any_hull = scene.bodies.iter().flat_map(|b| b.shapes()).any(|p| {
            matches!(
                p.shape,
                cosim_shared::ShapeDesc::Hull { .. } | cosim_shared::ShapeDesc::Cylinder { .. }
            )
        });
        let bodies: Vec<Body> = scene
            .bodies
            .iter()
            .map(|b| {
                let shapes: Vec<Geom> = b
                    .shapes()
                    .iter()
                    .map(|p| Geom {
                        shape: Shape::from_desc(&p.shape, &mut hulls),
                        hull: match p.shape {
                            cosim_shared::ShapeDesc::Box { half_extents: h } if any_hull => {
                                hulls.push(hull::Hull::cuboid(&v3(h)));
                                Some(hulls.len() - 1)
                            }
                            _ => None,
                        },
                        offset: (!p.centred()).then(|| {
                            let [w, x, y, z] = p.orientation;
                            Offset {
                                x: v3(p.position),
                                q: UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                                    w, x, y, z,
                                )),
                            }
                        }),
                    })
                    .collect();
                let inertia = match (b.inertia, shapes.first()) {
                    (Some([xx, yy, zz, xy, xz, yz]), _) => {
                        Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz)
                    }
                    // Validated: one shape on the centre of mass.
                    (None, Some(g)) => g.shape.inertia(b.mass),
                    (None, None) => Matrix3::identity(),
                };
                let bound = shapes.iter().map(Geom::bounding_radius).fold(0.0, f64::max);
                let spin_reach = match shapes.as_slice() {
                    [g] if g.offset.is_none() => g.shape.spin_reach(),
                    _ => bound,
                };
                Body {
                    name: b.name.clone(),
                    shapes,
                    bound,
                    spin_reach,
                    mass: b.mass,
                    inv_mass: 1.0 / b.mass,
                    inertia,
                    inv_inertia: inertia.try_inverse().unwrap_or_else(Matrix3::zeros),
                    friction: b.friction,
                    restitution: b.restitution,
                    force: v3(b.force),
                }
            })
            .collect();
        let initial: Vec<InitialBody> = scene
            .bodies
            .iter()
            .map(|b| {
                let [w, x, y, z] = b.orientation;
                InitialBody {
                    position: v3(b.position),
                    orientation: UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                        w, x, y, z,
                    )),
                    velocity: v3(b.velocity),
                    angular_velocity: v3(b.angular_velocity),
                }
            })
            .collect();
        let planes = scene
            .planes
            .iter()
            .map(|p| {
                let n = v3(p.normal).normalize();
                Plane {
                    name: p.name.clone(),
                    normal: n,
                    offset: n.dot(&v3(p.point)),
                    friction: p.friction,
                    restitution: p.restitution,
                }
            })
            .collect();
        let find = |name: &str| match scene.bodies.iter().position(|b| b.name == name) {
            Some(i) => Attachment::Body(i),
            None => Attachment::World,
        };
        // The anchor is a world point at t = 0; store it in each body's frame.
        let local = |att: Attachment, anchor: Vector3<f64>| match att {
            Attachment::World => anchor,
            Attachment::Body(i) => initial[i]
                .orientation
                .inverse_transform_vector(&(anchor - initial[i].position)),
        };
        // A side's orientation at t = 0 (the world's: the identity).
        let turned = |att: Attachment| match att {
            Attachment::World => UnitQuaternion::identity(),
            Attachment::Body(i) => initial[i].orientation,
        };
        let joints: Vec<Joint> = scene
            .joints
            .iter()
            .map(|j| {
                let (a, b) = (find(&j.body_a), find(&j.body_b));
                let anchor = v3(j.anchor);
                // Validated: finite and not zero where the kind needs it.
                let axis = v3(j.axis.unwrap_or([0.0, 0.0, 1.0])).normalize();
                let locked = Turning::Locked {
                    rel: turned(a).inverse() * turned(b),
                };
                use cosim_shared::JointKind as K;
                let turning = match j.kind {
                    K::Spherical => Turning::Free,
                    K::Revolute => {
                        let zero = kinematics::perpendicular(&axis);
                        // B stands turned by its initial coordinate: its
                        // zero direction is A's turned as far.
                        let zero_b = match j.position {
                            Some(q) if q != 0.0 => {
                                UnitQuaternion::from_axis_angle(&Unit::new_normalize(axis), q)
                                    * zero
                            }
                            _ => zero,
                        };
                        Turning::Axis {
                            a: turned(a).inverse_transform_vector(&axis),
                            b: turned(b).inverse_transform_vector(&axis),
                            zero_a: turned(a).inverse_transform_vector(&zero),
                            zero_b: turned(b).inverse_transform_vector(&zero_b),
                        }
                    }
                    K::Fixed | K::Prismatic => locked,
                };
                let slide =
                    (j.kind == K::Prismatic).then(|| turned(a).inverse_transform_vector(&axis));
                Joint {
                    name: j.name.clone(),
                    a,
                    b,
                    local_a: local(a, anchor),
                    // A slider's B anchor lies its initial coordinate
                    // along the axis from A's.
                    local_b: match (j.kind, j.position) {
                        (K::Prismatic, Some(q)) if q != 0.0 => local(b, anchor + q * axis),
                        _ => local(b, anchor),
                    },
                    effort: v3(j.force.unwrap_or(j.torque)),
                    max_effort: j.max_effort.unwrap_or(f64::INFINITY),
                    turning,
                    slide,
                    collide: j.collide,
                    limits: j.range.map(|[lower, upper]| Limits {
                        lower,
                        upper,
                        restitution: j.limit_restitution.unwrap_or(0.0),
                    }),
                    motor: j.motor.map(|m| Motor {
                        speed: m.position.unwrap_or(m.speed),
                        gains: match (m.position, m.kv) {
                            (Some(_), _) => Gains::Position {
                                kp: m.kp.unwrap_or(0.0),
                                kd: m.kd.unwrap_or(0.0),
                            },
                            (None, Some(kv)) => Gains::Velocity { kv },
                            (None, None) => Gains::Rigid,
                        },
                        max_effort: m.max_effort,
                    }),
                    armature: j.armature.unwrap_or(0.0),
                }
            })
            .collect();
        let weld = weld_groups(scene.bodies.len(), &joints);
        let mut excluded: Vec<(usize, usize)> = joints
            .iter()
            .filter(|j| !j.collide)
            .filter_map(|j| match (j.a, j.b) {
                (Attachment::Body(a), Attachment::Body(b)) => Some((a.min(b), a.max(b))),
                _ => None,
            })
            .collect();
        excluded.sort_unstable();
        excluded.dedup();
        let mut jointed = vec![false; scene.bodies.len()];
        for j in &joints {
            for side in [j.a, j.b] {
                if let Attachment::Body(i) = side {
                    jointed[i] = true;
                }
            }
        }
        let joints_with_motors: Vec<usize> = (0..joints.len())
            .filter(|&j| joints[j].motor.is_some())
            .collect();
        let mut joint_start = vec![0];
        for j in &joints {
            joint_start.push(joint_start[joint_start.len() - 1] + j.rows());
        }
        let s = &scene.sim;
        Model {
            name: scene.name().to_string(),
            bodies,
            planes,
            joints,
            joint_start,
            weld,
            excluded,
            group: {
                let mut names: Vec<&str> = Vec::new();
                scene
                    .bodies
                    .iter()
                    .map(|b| {
                        b.group
                            .as_deref()
                            .map(|g| match names.iter().position(|n| *n == g) {
                                Some(k) => k,
                                None => {
                                    names.push(g);
                                    names.len() - 1
                                }
                            })
                    })
                    .collect()
            },
            jointed,
            motors: joints_with_motors,
            couplings: scene
                .joints
                .iter()
                .enumerate()
                .filter_map(|(follower, j)| {
                    let m = j.mimic.as_ref()?;
                    // Validated: the leader exists.
                    let leader = scene.joints.iter().position(|l| l.name == m.joint)?;
                    Some(Coupling {
                        follower,
                        leader,
                        ratio: m.multiplier,
                        offset: m.offset,
                    })
                })
                .collect(),
            params: Params {
                h: s.dt,
                gravity: v3(s.gravity),
                friction_directions: s.friction_directions,
                solver: s.solver,
                friction_cone: s.friction_cone,
                beta: s.beta,
                restitution_threshold: s.restitution_threshold,
                contact_margin: s.contact_margin,
                full: false,
                sphere_contacts: s.sphere_contacts,
                skips: Skips::default(),
                lemke_max_pivots: None,
                fallback: true,
                contact_compliance: scene
                    .compliance
                    .and_then(|c| c.contact)
                    .map(Compliance::from),
                joint_compliance: scene.compliance.and_then(|c| c.joint).map(Compliance::from),
                position_update: s.position_update,
                integrator: s.integrator,
                sleep: s.sleep.enabled.then_some(Sleep {
                    after: s.sleep.after,
                    linear: s.sleep.linear_speed,
                    angular: s.sleep.angular_speed,
                }),
                pgs: s.pgs.map_or_else(PgsParams::default, |d| PgsParams {
                    velocity_tolerance: d.tolerance,
                    max_iterations: d.max_iterations,
                    stop: d.stop,
                    relative: d.relative,
                    ..Default::default()
                }),
            },
            initial,
            features: scene.contact_features(),
            shape_slots: scene.most_shapes(),
            hulls,
        }
    }

    /// The feature of a pair of bodies' contact `own` (below the per-pair
    /// count of its shapes' file) between A's shape `sa` and B's `sb` (0
    /// for a plane).
    pub fn shape_feature(&self, sa: usize, sb: usize, own: usize) -> usize {
        let per_pair = self.features / (self.shape_slots * self.shape_slots);
        (sa * self.shape_slots + sb) * per_pair + own
    }

    /// The canonical index of the potential contact `feature` (below
    /// [`Model::features`]) of body `a` with `b`: `pair * features +
    /// feature`, where `pair` is the pair's place in the full enumeration
    /// (body-plane body-major, then the body pairs `a < b` in order). It
    /// identifies the contact from step to step whether or not the broad
    /// phase lists the contacts between, and the collision stage lists
    /// contacts in ascending id.
    pub fn contact_id(&self, a: usize, b: Counterpart, feature: usize) -> usize {
        let (n, np) = (self.bodies.len(), self.planes.len());
        let pair = match b {
            Counterpart::Plane(p) => a * np + p,
            // Pairs (a, a+1 .. n-1) for a = 0, 1, ...: a (2n - a - 1) / 2 of
            // them come before row a.
            Counterpart::Body(j) => n * np + a * (2 * n - a - 1) / 2 + (j - a - 1),
            Counterpart::World => {
                unreachable!("no shape touches the world itself: a limit's id is limit_id's")
            }
        };
        pair * self.features + feature
    }

    /// The bodies of contact `id`: the inverse of [`Model::contact_id`]
    /// but for the feature ([`Model::contact_feature`]).
    pub fn contact_bodies(&self, id: usize) -> (usize, Counterpart) {
        let (n, np) = (self.bodies.len(), self.planes.len());
        let shapes = self.potential_contacts();
        if id >= shapes {
            return self.limit_bodies((id - shapes) / 2);
        }
        let id = id / self.features;
        if id < n * np {
            return (id / np, Counterpart::Plane(id % np));
        }
        // The row a of pair k: the last a with a (2n - a - 1) / 2 <= k,
        // the smaller root of a^2 - (2n - 1) a + 2k = 0 rounded down, then
        // corrected in integers (the root's rounding is far below one for
        // any n whose pairs fit an index: (2n - 1)^2 is exact below 2^53).
        // Closed form, not a bisection: the step looks up every warm
        // contact's bodies, and the bisection was a fifth of a sleeping
        // pile's step.
        let k = id - n * np;
        let before = |a: usize| a * (2 * n - a - 1) / 2;
        let m = (2 * n) as f64 - 1.0;
        let root = 0.5 * (m - (m * m - 8.0 * k as f64).max(0.0).sqrt());
        let mut a = (root.max(0.0) as usize).min(n.saturating_sub(2));
        while a > 0 && before(a) > k {
            a -= 1;
        }
        while a + 1 < n && before(a + 1) <= k {
            a += 1;
        }
        (a, Counterpart::Body(a + 1 + k - before(a)))
    }

    /// Which of its pair's contacts a shape contact `id` is (0 for the one
    /// contact of a pair of spheres; a box's vertex against a plane...).
    pub fn contact_feature(&self, id: usize) -> usize {
        id % self.features
    }

    /// Whether bodies `i` and `j` can be in contact: not in one weld
    /// group (`Model::weld`), nor one collision group (`Model::group`), nor
    /// a pair a joint keeps apart (`Model::excluded`).
    pub fn may_touch(&self, i: usize, j: usize) -> bool {
        self.weld[i] != self.weld[j]
            && (self.group[i].is_none() || self.group[i] != self.group[j])
            && self.excluded.binary_search(&(i.min(j), i.max(j))).is_err()
    }

    /// Per joint, whether it has a motor (what a motor target may name).
    pub fn motored(&self) -> Vec<bool> {
        self.joints.iter().map(|j| j.motor.is_some()).collect()
    }

    /// The contact id of joint `joint`'s lower (`upper = false`) or upper
    /// limit: past every potential contact of the shapes, so that the
    /// contact list, limits last, ascends by id.
    pub fn limit_id(&self, joint: usize, upper: bool) -> usize {
        self.potential_contacts() + 2 * joint + usize::from(upper)
    }

    /// The sides of joint `j` as a contact's: a body first (B when A is
    /// the world), then the other body or the world.
    pub fn limit_bodies(&self, j: usize) -> (usize, Counterpart) {
        let joint = &self.joints[j];
        match (joint.a, joint.b) {
            (Attachment::Body(a), Attachment::Body(b)) => (a, Counterpart::Body(b)),
            (Attachment::Body(i), Attachment::World) | (Attachment::World, Attachment::Body(i)) => {
                (i, Counterpart::World)
            }
            // The scene refuses a joint of the world to itself.
            (Attachment::World, Attachment::World) => (0, Counterpart::World),
        }
    }

    /// Number of potential contacts: [`Model::features`] for every body
    /// against every plane and, unless `sphere_contacts` is off, every
    /// other body (7 in the reference scene).
    pub fn potential_contacts(&self) -> usize {
        let n = self.bodies.len();
        let pairs = if self.params.sphere_contacts {
            n * n.saturating_sub(1) / 2
        } else {
            0
        };
        (n * self.planes.len() + pairs) * self.features
    }
}

impl Model {
    /// Rows of the joint block: every joint's, the rotors'
    /// (`constraint::armature`), then one per coupling.
    pub fn joint_rows(&self) -> usize {
        self.joint_start[self.joints.len()] + self.armature_rows() + self.couplings.len()
    }

    /// The rotors' rows (`Joint::armature_rows`).
    pub fn armature_rows(&self) -> usize {
        self.joints.iter().map(Joint::armature_rows).sum()
    }

    /// The name of one side of an impulse, as the outputs write it.
    pub fn party_name(&self, p: Party) -> &str {
        match p {
            Party::World => cosim_shared::scene::WORLD,
            Party::Body(i) => &self.bodies[i].name,
            Party::Plane(i) => &self.planes[i].name,
        }
    }

    /// Contact `id`'s name: `a/b`, e.g. `upper/floor`, and `a/b#k` for a
    /// pair's contact `k > 0` (`cosim_shared::contact_label`).
    pub fn contact_name(&self, id: usize, a: Party, b: Party) -> String {
        cosim_shared::contact_label(
            self.party_name(a),
            self.party_name(b),
            self.contact_feature(id),
        )
    }
}

//! The scene description: what a `.toml` scene file holds, and its validation.
//!
//! Parsing is strict (unknown fields are refused) so that a typo never turns
//! into a silently ignored setting. Every error names the file, the field (as a
//! path such as `body[1].mass` or `body "ball".mass`), the offending value and,
//! for syntax errors, the line and column that TOML reports.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;

/// Default stabilisation factor on the constraint violation (`beta` in
/// formulation.md): 1 removes the whole violation in one step, as in the notes.
pub const DEFAULT_BETA: f64 = 1.0;
/// Default restitution threshold `v_min` (m/s): slower approaches are treated
/// as resting contact, or resting objects jitter.
pub const DEFAULT_RESTITUTION_THRESHOLD: f64 = 1e-2;
/// Default margin (m) added to the distance a contact could close within a
/// step before it is left out of the LCP.
pub const DEFAULT_CONTACT_MARGIN: f64 = 1e-3;

/// A whole scene file.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    pub sim: SimDesc,
    #[serde(default, rename = "body")]
    pub bodies: Vec<BodyDesc>,
    #[serde(default, rename = "plane")]
    pub planes: Vec<PlaneDesc>,
    #[serde(default, rename = "joint")]
    pub joints: Vec<JointDesc>,
    /// The animation's camera; framed automatically when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<CameraDesc>,
    /// Contact and joint compliance; rigid (the default) where absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compliance: Option<ComplianceDesc>,
}

/// `[compliance]`: springs and dampers in physical units where a user
/// wants soft contact or soft joints, as ODE's CFM/ERP, MuJoCo's
/// solref/solimp and Drake's point-contact stiffness and dissipation give
/// them. Off by default: exact rigid contact is the engine's formulation.
/// `[compliance.contact]` acts on every contact's normal row while it
/// penetrates, `[compliance.joint]` on every joint row.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct ComplianceDesc {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact: Option<SpringDesc>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint: Option<SpringDesc>,
}

/// A spring and a damper along a constraint row.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpringDesc {
    /// N/m: the force per metre of penetration (contact) or joint error.
    pub stiffness: f64,
    /// N s/m: the force per m/s of the row's speed.
    #[serde(default)]
    pub damping: f64,
}

/// `[camera]`: overrides the animation's automatic framing.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    /// Direction from the scene towards the camera (orthographic view).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direction: Option<[f64; 3]>,
    /// World point at the centre of the picture.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<[f64; 3]>,
    /// Width of the world shown across the picture (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width: Option<f64>,
}

/// Which LCP solver runs the step.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum SolverChoice {
    /// Schur-complement reduction to a pure LCP, solved by Lemke's algorithm.
    #[default]
    Lemke,
    /// Projected Gauss-Seidel with a proximal step on the mixed problem.
    Pgs,
    /// Lemke, with PGS as the fallback when Lemke fails and alone on large
    /// problems; the step report says which ran and why.
    Auto,
}

impl SolverChoice {
    pub fn as_str(self) -> &'static str {
        match self {
            SolverChoice::Lemke => "lemke",
            SolverChoice::Pgs => "pgs",
            SolverChoice::Auto => "auto",
        }
    }
}

impl std::str::FromStr for SolverChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "lemke" => Ok(SolverChoice::Lemke),
            "pgs" => Ok(SolverChoice::Pgs),
            "auto" => Ok(SolverChoice::Auto),
            other => Err(format!(
                "unknown solver {other:?}, expected one of: lemke, pgs, auto"
            )),
        }
    }
}

/// How positions advance with the step's velocities.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum PositionUpdate {
    /// `x' = x + h v'` (semi-implicit Euler, the notes): first order.
    #[default]
    Euler,
    /// `x' = x + h (v + v') / 2` for bodies whose velocity changed smoothly
    /// this step, Euler for those in an impact and for bodies on joints:
    /// exact under constant acceleration (rolling, sliding, flight).
    Trapezoid,
}

/// The friction cone of the step.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum FrictionCone {
    /// `n_d` directions, `p_f >= 0, sum p_f <= mu p_n` (the notes; Lemke).
    #[default]
    Polyhedral,
    /// Isotropic `|p_t| <= mu p_n` (prox PGS only).
    Circular,
}

/// `[sim]`: the time stepping.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SimDesc {
    /// Scene name (output folder `out/<name>`); defaults to the file stem.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Step `h` in seconds.
    pub dt: f64,
    /// Simulated seconds for `run` (give this or `steps`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub duration: Option<f64>,
    /// Number of steps for `run` (give this or `duration`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub steps: Option<u64>,
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
    /// `n_d`, directions of the polyhedral friction cone.
    #[serde(default = "default_friction_directions")]
    pub friction_directions: usize,
    #[serde(default)]
    pub solver: SolverChoice,
    /// Friction cone: "polyhedral" (default) or "circular" (solver "pgs").
    #[serde(default)]
    pub friction_cone: FrictionCone,
    /// Stabilisation factor on penetration and joint error, in (0, 1].
    #[serde(default = "default_beta")]
    pub beta: f64,
    /// Normal approach speed (m/s) below which restitution is not applied.
    #[serde(default = "default_restitution_threshold")]
    pub restitution_threshold: f64,
    /// Extra distance (m) within which a contact always enters the LCP.
    #[serde(default = "default_contact_margin")]
    pub contact_margin: f64,
    /// Whether spheres collide with each other (true) or with the planes
    /// only (false): MuJoCo's contype/conaffinity for the common case of a
    /// jointed chain whose links must pass through each other.
    #[serde(default = "default_true")]
    pub sphere_contacts: bool,
    /// "euler" (default) or "trapezoid".
    #[serde(default)]
    pub position_update: PositionUpdate,
    /// `[sim.sleep]`: islands at rest leave the step until touched
    /// (absent: every body steps, the default: sleeping freezes a body
    /// whose speed is below a threshold, an approximation a scene opts in
    /// to).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sleep: Option<SleepDesc>,
    /// `[sim.pgs]`: when the iterative solver stops (absent: its defaults,
    /// the distance rule at 1e-6 m/s, for agreement with Lemke).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pgs: Option<PgsDesc>,
}

/// `[sim.pgs]`: the iterative solver's stopping rule.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PgsDesc {
    /// "distance" (to the answer, by the rate of convergence) or
    /// "residual" (the constraint violation of the last sweep).
    #[serde(default)]
    pub stop: PgsStop,
    /// What the rule bounds, m/s.
    #[serde(default = "default_pgs_tolerance")]
    pub tolerance: f64,
    /// The sweep cap: a safety net.
    #[serde(default = "default_pgs_max_iterations")]
    pub max_iterations: usize,
}

/// `[sim.pgs] stop`: what the tolerance bounds when PGS stops.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum PgsStop {
    /// The distance to the answer: the last sweep's largest velocity change
    /// and, while the sweeps shrink, what the rate of shrinking says is
    /// left (the engine's `pgs::within`). For comparisons with Lemke.
    #[default]
    Distance,
    /// The constraint violation: no update of the last sweep changed a
    /// velocity by more, so that every contact and joint, when the sweep
    /// reached it, held to the tolerance (m/s; `h` times it in position
    /// per step, which the stabilisation then corrects). The rule of the
    /// engines that step piles (Box2D, Rapier and Bullet stop on a sweep
    /// count alone); on a pile the distance rule waits for slow modes that
    /// move the velocities by little (measured: rate 0.998 per sweep on
    /// the 1,000 pile, thousands of sweeps per step).
    Residual,
}

impl std::str::FromStr for PgsStop {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "distance" => Ok(PgsStop::Distance),
            "residual" => Ok(PgsStop::Residual),
            other => Err(format!(
                "unknown stopping rule {other:?}, expected distance or residual"
            )),
        }
    }
}

/// PGS's default tolerance (m/s) and sweep cap, for `[sim.pgs]` and the
/// engine alike.
pub const DEFAULT_PGS_TOLERANCE: f64 = 1e-6;
pub const DEFAULT_PGS_MAX_ITERATIONS: usize = 5000;

fn default_pgs_tolerance() -> f64 {
    DEFAULT_PGS_TOLERANCE
}
fn default_pgs_max_iterations() -> usize {
    DEFAULT_PGS_MAX_ITERATIONS
}

/// `[sim.sleep]`: Box2D v3's defaults (0.05 m/s, half a second; Rapier's
/// are the same), judged as Box2D v3 and Jolt judge a spin, by the speed
/// it gives the body's bounding sphere (`engine/src/sleep.rs`).
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SleepDesc {
    /// Seconds an island must stay at rest before it sleeps.
    #[serde(default = "default_sleep_after")]
    pub after: f64,
    /// Speed (m/s) below which a body is at rest: its centre's, and the
    /// speed its spin gives its bounding sphere's surface.
    #[serde(default = "default_sleep_linear")]
    pub linear_speed: f64,
    /// Angular speed (rad/s) below which a body is at rest whatever its
    /// size (it spins slowly enough below either bound).
    #[serde(default = "default_sleep_angular")]
    pub angular_speed: f64,
}

impl Default for SleepDesc {
    fn default() -> Self {
        SleepDesc {
            after: default_sleep_after(),
            linear_speed: default_sleep_linear(),
            angular_speed: default_sleep_angular(),
        }
    }
}

fn default_sleep_after() -> f64 {
    0.5
}
fn default_sleep_linear() -> f64 {
    0.05
}
fn default_sleep_angular() -> f64 {
    0.05
}

fn default_true() -> bool {
    true
}

fn default_gravity() -> [f64; 3] {
    [0.0, 0.0, -9.81]
}
fn default_friction_directions() -> usize {
    8
}
fn default_beta() -> f64 {
    DEFAULT_BETA
}
fn default_restitution_threshold() -> f64 {
    DEFAULT_RESTITUTION_THRESHOLD
}
fn default_contact_margin() -> f64 {
    DEFAULT_CONTACT_MARGIN
}

/// `[[body]]`: a solid sphere (`radius`), capsule (`radius` and
/// `half_length`, its segment along the body's z axis, as MuJoCo's and
/// ODE's) or box (`half_extents`, along the body's axes).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BodyDesc {
    pub name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_length: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_extents: Option<[f64; 3]>,
    pub mass: f64,
    /// `[ixx, iyy, izz, ixy, ixz, iyz]` about the centre of mass in the
    /// body's frame (kg m^2), as URDF's `<inertia>`; absent: the shape's
    /// at uniform density.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inertia: Option<[f64; 6]>,
    pub position: [f64; 3],
    /// Unit quaternion, scalar first.
    #[serde(default = "identity_quaternion")]
    pub orientation: [f64; 4],
    #[serde(default)]
    pub velocity: [f64; 3],
    #[serde(default)]
    pub angular_velocity: [f64; 3],
    #[serde(default)]
    pub friction: f64,
    #[serde(default)]
    pub restitution: f64,
    /// Constant world-frame force (N) on the centre of mass, besides gravity.
    #[serde(default)]
    pub force: [f64; 3],
}

/// The most contacts one pair of shapes has: a box's eight vertices
/// against a plane (of which the engine lists the four lowest) bound every
/// pair's feature numbers.
pub const MAX_FEATURES: usize = 8;

/// The name a shape contact goes by in impulses.csv and the recordings:
/// `a/b` for a pair's first (a pair of spheres' only) contact, `a/b#k`
/// for its feature `k` (a box's vertex, a capsule's end...).
pub fn contact_label(a: &str, b: &str, feature: usize) -> String {
    if feature == 0 {
        format!("{a}/{b}")
    } else {
        format!("{a}/{b}#{feature}")
    }
}

/// A body's shape as the scene gives it (`BodyDesc::shape`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ShapeDesc {
    Sphere {
        radius: f64,
    },
    /// Half the segment's length along the body's z axis, and the radius.
    Capsule {
        radius: f64,
        half_length: f64,
    },
    Box {
        half_extents: [f64; 3],
    },
}

impl BodyDesc {
    /// The body's shape, or which fields are missing or clash (the message
    /// of the error `validate` names the body's field with).
    pub fn shape_or_error(&self) -> Result<ShapeDesc, (&'static str, String)> {
        match (self.radius, self.half_length, self.half_extents) {
            (Some(radius), None, None) => Ok(ShapeDesc::Sphere { radius }),
            (Some(radius), Some(half_length), None) => Ok(ShapeDesc::Capsule {
                radius,
                half_length,
            }),
            (None, None, Some(half_extents)) => Ok(ShapeDesc::Box { half_extents }),
            (None, Some(_), None) => Err((
                "radius",
                "is missing: a capsule needs radius beside half_length".into(),
            )),
            (None, None, None) => Err((
                "radius",
                "is missing: give radius (a sphere), radius and half_length (a capsule) \
                 or half_extents (a box)"
                    .into(),
            )),
            (_, _, Some(_)) => Err((
                "half_extents",
                "with radius or half_length: a body has one shape, a box (half_extents \
                 alone), a sphere (radius) or a capsule (radius and half_length)"
                    .into(),
            )),
        }
    }

    /// The body's shape; a sphere of radius 0 where the description has
    /// none (`validate` refuses it first).
    pub fn shape(&self) -> ShapeDesc {
        self.shape_or_error()
            .unwrap_or(ShapeDesc::Sphere { radius: 0.0 })
    }
}

fn identity_quaternion() -> [f64; 4] {
    [1.0, 0.0, 0.0, 0.0]
}

/// `[[plane]]`: a fixed infinite plane; bodies stay on the side its normal
/// points to.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PlaneDesc {
    pub name: String,
    pub normal: [f64; 3],
    pub point: [f64; 3],
    #[serde(default)]
    pub friction: f64,
    #[serde(default)]
    pub restitution: f64,
}

/// What a joint leaves free between its two sides.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum JointKind {
    /// The anchor points stay together; every rotation is free (3 rows).
    Spherical,
    /// A hinge: the anchors stay together and the bodies turn only about
    /// `axis` (5 rows).
    Revolute,
    /// The two sides move as one (6 rows).
    Fixed,
    /// A slider: no relative rotation, and the anchors move apart only
    /// along `axis` (5 rows).
    Prismatic,
}

/// `[[joint]]`: a bilateral joint between two bodies or a body and the world.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct JointDesc {
    pub name: String,
    #[serde(rename = "type")]
    pub kind: JointKind,
    /// `"world"` or a body name.
    pub body_a: String,
    pub body_b: String,
    /// World point at t = 0, fixed in both bodies from then on.
    pub anchor: [f64; 3],
    /// `revolute`: the hinge axis, a world direction at t = 0, fixed in
    /// both bodies from then on; `prismatic`: the sliding direction at
    /// t = 0, fixed in body_a (any length but zero). Only for these two.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// Constant joint torque: `+torque` on body_b, `-torque` on body_a.
    /// Not for a prismatic joint, whose effort is a force.
    #[serde(default)]
    pub torque: [f64; 3],
    /// `prismatic` only: constant force (N, world frame) on body_b at its
    /// anchor, its opposite on body_a at the same point; its part along
    /// the axis drives the slider (the joint holds the rest).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force: Option<[f64; 3]>,
    /// Whether the two bodies' shapes touch each other. MuJoCo and Drake
    /// leave a joint's two bodies out of contact (links overlap at their
    /// hinges); here the default is true, since the notes' scene has
    /// jointed spheres that collide. With the world as one side it changes
    /// nothing: the planes are not the world's body.
    #[serde(default = "default_true")]
    pub collide: bool,
    /// `revolute` and `prismatic` only: the coordinate's limits `[lower,
    /// upper]` (rad for a hinge, within [-pi, pi]; m for a slider), with
    /// `lower < upper`; the coordinate is 0 at t = 0 (MuJoCo's `range`,
    /// URDF's `<limit lower upper>`). Held by unilateral rows, each with
    /// its own stabilisation, as contacts are.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range: Option<[f64; 2]>,
    /// Newton restitution of a limit hit, in [0, 1] (0: the coordinate
    /// stops at the limit); only with `range`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limit_restitution: Option<f64>,
    /// `revolute` and `prismatic` only: a velocity motor (Rapier's and
    /// ODE's joint motor, MuJoCo's velocity actuator with a force range).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motor: Option<MotorDesc>,
}

/// A joint motor: drives the coordinate's rate to `speed` with an effort of
/// at most `max_effort`, one bounded row (`|p| <= max_effort h`).
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MotorDesc {
    /// The target rate (rad/s for a hinge, m/s for a slider); a
    /// controller may change it.
    pub speed: f64,
    /// The largest torque (N m) or force (N) the motor gives, > 0.
    pub max_effort: f64,
}

impl JointKind {
    pub fn as_str(self) -> &'static str {
        match self {
            JointKind::Spherical => "spherical",
            JointKind::Revolute => "revolute",
            JointKind::Fixed => "fixed",
            JointKind::Prismatic => "prismatic",
        }
    }
}

/// The name a joint uses for the fixed world.
pub const WORLD: &str = "world";

/// A scene that cannot be used, with everything needed to fix it.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    /// The file (or `<built-in>` for embedded scenes).
    pub file: String,
    /// Line and column (1-based), where TOML reports them.
    pub location: Option<(usize, usize)>,
    /// The field at fault, e.g. `body "ball".mass`; empty when TOML gives none.
    pub field: String,
    /// What is wrong, with the offending value.
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some((line, col)) = self.location {
            write!(f, ":{line}:{col}")?;
        }
        if self.field.is_empty() {
            write!(f, ": {}", self.message)
        } else if self.message.starts_with("= ") {
            // "body \"ball\".mass = -1: must be ..."
            write!(f, ": {} {}", self.field, self.message)
        } else {
            write!(f, ": {}: {}", self.field, self.message)
        }
    }
}

impl std::error::Error for SceneError {}

impl Scene {
    /// Reads and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SceneError {
            file: file.clone(),
            location: None,
            field: String::new(),
            message: format!("cannot read the file: {e}"),
        })?;
        let mut scene = Scene::parse(&text, &file)?;
        if scene.sim.name.is_none() {
            scene.sim.name = path.file_stem().map(|s| s.to_string_lossy().into_owned());
        }
        Ok(scene)
    }

    /// The scene as TOML text (with every default written out).
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    /// Parses and validates scene text; `file` only labels the errors.
    pub fn parse(text: &str, file: &str) -> Result<Scene, SceneError> {
        let scene: Scene = toml::from_str(text).map_err(|e| toml_error(&e, text, file))?;
        scene.validate(file)?;
        Ok(scene)
    }

    /// The scene's name, used for the output folder.
    pub fn name(&self) -> &str {
        self.sim.name.as_deref().unwrap_or("scene")
    }

    /// Number of steps `run` takes: `steps`, or `duration / dt` rounded.
    pub fn step_count(&self) -> u64 {
        match (self.sim.steps, self.sim.duration) {
            (Some(n), _) => n,
            (None, Some(t)) => (t / self.sim.dt).round() as u64,
            (None, None) => 0,
        }
    }

    /// Checks every rule that TOML's types cannot express.
    /// Contact ids per pair of shapes (the engine's `Model::features`): 1
    /// in a scene of spheres, which touch at one point, else
    /// [`MAX_FEATURES`]. A contact's id is `pair * features + feature`.
    pub fn contact_features(&self) -> usize {
        if self
            .bodies
            .iter()
            .all(|b| matches!(b.shape(), ShapeDesc::Sphere { .. }))
        {
            1
        } else {
            MAX_FEATURES
        }
    }

    pub fn validate(&self, file: &str) -> Result<(), SceneError> {
        let err = |field: String, message: String| SceneError {
            file: file.to_string(),
            location: None,
            field,
            message,
        };
        let sim = &self.sim;
        positive(sim.dt).map_err(|m| err("sim.dt".into(), m))?;
        match (sim.duration, sim.steps) {
            (Some(_), Some(_)) => {
                return Err(err(
                    "sim.steps".into(),
                    "give either sim.duration or sim.steps, not both".into(),
                ))
            }
            (None, None) => {
                return Err(err(
                    "sim.duration".into(),
                    "missing: give sim.duration (seconds) or sim.steps".into(),
                ))
            }
            (Some(t), None) => positive(t).map_err(|m| err("sim.duration".into(), m))?,
            (None, Some(0)) => {
                return Err(err("sim.steps".into(), "= 0: must be at least 1".into()))
            }
            (None, Some(_)) => {}
        }
        finite3(&sim.gravity).map_err(|m| err("sim.gravity".into(), m))?;
        if !(3..=64).contains(&sim.friction_directions) {
            return Err(err(
                "sim.friction_directions".into(),
                format!(
                    "= {}: must be between 3 and 64 (an even number keeps straight sliding exact)",
                    sim.friction_directions
                ),
            ));
        }
        if sim.friction_cone == FrictionCone::Circular && sim.solver != SolverChoice::Pgs {
            return Err(err(
                "sim.friction_cone".into(),
                format!(
                    "= \"circular\" needs solver = \"pgs\" (solver is {:?}): Lemke's LCP has the polyhedral cone",
                    sim.solver.as_str()
                ),
            ));
        }
        if !(sim.beta.is_finite() && sim.beta > 0.0 && sim.beta <= 1.0) {
            return Err(err(
                "sim.beta".into(),
                format!("= {}: must lie in (0, 1]", sim.beta),
            ));
        }
        nonneg(sim.restitution_threshold)
            .map_err(|m| err("sim.restitution_threshold".into(), m))?;
        nonneg(sim.contact_margin).map_err(|m| err("sim.contact_margin".into(), m))?;
        if let Some(sleep) = &sim.sleep {
            nonneg(sleep.after).map_err(|m| err("sim.sleep.after".into(), m))?;
            positive(sleep.linear_speed).map_err(|m| err("sim.sleep.linear_speed".into(), m))?;
            positive(sleep.angular_speed).map_err(|m| err("sim.sleep.angular_speed".into(), m))?;
        }
        if let Some(pgs) = &sim.pgs {
            positive(pgs.tolerance).map_err(|m| err("sim.pgs.tolerance".into(), m))?;
            if pgs.max_iterations == 0 {
                return Err(err(
                    "sim.pgs.max_iterations".into(),
                    "= 0: must be at least 1".into(),
                ));
            }
        }

        // (name, field that first used it), to refuse duplicates by name.
        let mut names: Vec<(String, String)> = Vec::new();
        let mut claim = |name: &str, field: String| -> Result<(), SceneError> {
            if name.trim().is_empty() {
                return Err(err(field, "is empty: every object needs a name".into()));
            }
            if name == WORLD {
                return Err(err(
                    field,
                    format!("= {name:?}: the name {WORLD:?} is reserved for the fixed world"),
                ));
            }
            if let Some((_, first)) = names.iter().find(|(n, _)| n == name) {
                return Err(err(
                    field,
                    format!("= {name:?}: duplicate name, already used by {first}"),
                ));
            }
            names.push((name.to_string(), field));
            Ok(())
        };

        for (i, b) in self.bodies.iter().enumerate() {
            claim(&b.name, format!("body[{i}].name"))?;
            let f = |k: &str| format!("body {:?}.{k}", b.name);
            match b.shape_or_error().map_err(|(k, m)| err(f(k), m))? {
                ShapeDesc::Sphere { radius } => {
                    positive(radius).map_err(|m| err(f("radius"), m))?;
                }
                ShapeDesc::Capsule {
                    radius,
                    half_length,
                } => {
                    positive(radius).map_err(|m| err(f("radius"), m))?;
                    positive(half_length).map_err(|m| err(f("half_length"), m))?;
                }
                ShapeDesc::Box { half_extents } => {
                    if half_extents.iter().any(|&h| positive(h).is_err()) {
                        return Err(err(
                            f("half_extents"),
                            format!(
                                "= {half_extents:?}: each half extent must be a positive \
                                 finite number"
                            ),
                        ));
                    }
                }
            }
            positive(b.mass).map_err(|m| err(f("mass"), m))?;
            if let Some(j) = b.inertia {
                // Positive definite: the leading minors of the symmetric
                // matrix are positive (Sylvester).
                let [xx, yy, zz, xy, xz, yz] = j;
                let minors = [
                    xx,
                    xx * yy - xy * xy,
                    xx * (yy * zz - yz * yz) - xy * (xy * zz - yz * xz) + xz * (xy * yz - yy * xz),
                ];
                if !j.iter().all(|x| x.is_finite()) || minors.iter().any(|&m| m <= 0.0) {
                    return Err(err(
                        f("inertia"),
                        format!(
                            "= {j:?}: [ixx, iyy, izz, ixy, ixz, iyz] must be finite and \
                             positive definite"
                        ),
                    ));
                }
            }
            finite3(&b.position).map_err(|m| err(f("position"), m))?;
            finite3(&b.velocity).map_err(|m| err(f("velocity"), m))?;
            finite3(&b.angular_velocity).map_err(|m| err(f("angular_velocity"), m))?;
            finite3(&b.force).map_err(|m| err(f("force"), m))?;
            unit_quaternion(&b.orientation).map_err(|m| err(f("orientation"), m))?;
            nonneg(b.friction).map_err(|m| err(f("friction"), m))?;
            unit_interval(b.restitution).map_err(|m| err(f("restitution"), m))?;
        }
        for (i, p) in self.planes.iter().enumerate() {
            claim(&p.name, format!("plane[{i}].name"))?;
            let f = |k: &str| format!("plane {:?}.{k}", p.name);
            finite3(&p.normal).map_err(|m| err(f("normal"), m))?;
            finite3(&p.point).map_err(|m| err(f("point"), m))?;
            let len2: f64 = p.normal.iter().map(|x| x * x).sum();
            if len2 <= 1e-24 {
                return Err(err(
                    f("normal"),
                    format!("= {:?}: a plane's normal must not be zero", p.normal),
                ));
            }
            nonneg(p.friction).map_err(|m| err(f("friction"), m))?;
            unit_interval(p.restitution).map_err(|m| err(f("restitution"), m))?;
        }
        for (i, j) in self.joints.iter().enumerate() {
            claim(&j.name, format!("joint[{i}].name"))?;
            let f = |k: &str| format!("joint {:?}.{k}", j.name);
            for (key, body) in [("body_a", &j.body_a), ("body_b", &j.body_b)] {
                if body != WORLD && !self.bodies.iter().any(|b| &b.name == body) {
                    let known: Vec<&str> = self.bodies.iter().map(|b| b.name.as_str()).collect();
                    return Err(err(
                        f(key),
                        format!(
                            "= {body:?}: unknown body (known: \"world\", {})",
                            known
                                .iter()
                                .map(|n| format!("{n:?}"))
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    ));
                }
            }
            if j.body_a == j.body_b {
                return Err(err(
                    f("body_b"),
                    format!("= {:?}: a joint needs two different bodies", j.body_b),
                ));
            }
            finite3(&j.anchor).map_err(|m| err(f("anchor"), m))?;
            finite3(&j.torque).map_err(|m| err(f("torque"), m))?;
            match (j.kind, j.force) {
                (JointKind::Prismatic, Some(force)) => {
                    finite3(&force).map_err(|m| err(f("force"), m))?
                }
                (kind, Some(_)) => {
                    return Err(err(
                        f("force"),
                        format!(
                            "only a prismatic joint has a force (this one is {}: its effort is a torque)",
                            kind.as_str()
                        ),
                    ))
                }
                (_, None) => {}
            }
            if j.kind == JointKind::Prismatic && j.torque != [0.0; 3] {
                return Err(err(
                    f("torque"),
                    "a prismatic joint's effort is a force: give `force`".into(),
                ));
            }
            match (j.kind, j.range) {
                (JointKind::Revolute | JointKind::Prismatic, Some([lo, hi])) => {
                    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                        return Err(err(
                            f("range"),
                            format!("= [{lo}, {hi}]: needs finite bounds with lower < upper"),
                        ));
                    }
                    let pi = std::f64::consts::PI;
                    if j.kind == JointKind::Revolute && (lo < -pi || hi > pi) {
                        return Err(err(
                            f("range"),
                            format!(
                                "= [{lo}, {hi}]: a hinge's limits are angles within [-pi, pi] (rad)"
                            ),
                        ));
                    }
                }
                (kind, Some(_)) => {
                    return Err(err(
                        f("range"),
                        format!(
                            "only a revolute or prismatic joint has a range (this one is {})",
                            kind.as_str()
                        ),
                    ))
                }
                (_, None) => {}
            }
            if let Some(motor) = j.motor {
                if !matches!(j.kind, JointKind::Revolute | JointKind::Prismatic) {
                    return Err(err(
                        f("motor"),
                        format!(
                            "only a revolute or prismatic joint has a motor (this one is {})",
                            j.kind.as_str()
                        ),
                    ));
                }
                if !motor.speed.is_finite() {
                    return Err(err(
                        f("motor.speed"),
                        format!("= {}: must be finite", motor.speed),
                    ));
                }
                positive(motor.max_effort).map_err(|m| err(f("motor.max_effort"), m))?;
            }
            if let Some(e) = j.limit_restitution {
                if j.range.is_none() {
                    return Err(err(
                        f("limit_restitution"),
                        "a limit's restitution needs the joint's `range`".into(),
                    ));
                }
                unit_interval(e).map_err(|m| err(f("limit_restitution"), m))?;
            }
            match (j.kind, j.axis) {
                (kind @ (JointKind::Revolute | JointKind::Prismatic), None) => {
                    return Err(err(
                        f("axis"),
                        format!("missing: a {} joint needs its axis", kind.as_str()),
                    ))
                }
                (JointKind::Revolute | JointKind::Prismatic, Some(a)) => {
                    finite3(&a).map_err(|m| err(f("axis"), m))?;
                    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
                    if !(n > 1e-9 && n.is_finite()) {
                        return Err(err(
                            f("axis"),
                            format!("= {a:?}: the axis needs a direction (not zero)"),
                        ));
                    }
                }
                (kind, Some(_)) => {
                    return Err(err(
                        f("axis"),
                        format!(
                            "only a revolute or prismatic joint has an axis (this one is {})",
                            kind.as_str()
                        ),
                    ))
                }
                (_, None) => {}
            }
        }
        if let Some(c) = &self.compliance {
            for (what, spring) in [("contact", c.contact), ("joint", c.joint)] {
                if let Some(k) = spring {
                    positive(k.stiffness)
                        .map_err(|m| err(format!("compliance.{what}.stiffness"), m))?;
                    nonneg(k.damping).map_err(|m| err(format!("compliance.{what}.damping"), m))?;
                }
            }
        }
        if let Some(c) = &self.camera {
            if let Some(d) = &c.direction {
                finite3(d).map_err(|m| err("camera.direction".into(), m))?;
                if d.iter().map(|x| x * x).sum::<f64>() <= 1e-24 {
                    return Err(err(
                        "camera.direction".into(),
                        format!("= {d:?}: must not be zero"),
                    ));
                }
            }
            if let Some(t) = &c.target {
                finite3(t).map_err(|m| err("camera.target".into(), m))?;
            }
            if let Some(w) = c.width {
                positive(w).map_err(|m| err("camera.width".into(), m))?;
            }
        }
        Ok(())
    }
}

fn positive(x: f64) -> Result<(), String> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(format!("= {x}: must be a positive finite number"))
    }
}

fn nonneg(x: f64) -> Result<(), String> {
    if x.is_finite() && x >= 0.0 {
        Ok(())
    } else {
        Err(format!("= {x}: must be a finite number >= 0"))
    }
}

fn unit_interval(x: f64) -> Result<(), String> {
    if x.is_finite() && (0.0..=1.0).contains(&x) {
        Ok(())
    } else {
        Err(format!("= {x}: must lie in [0, 1]"))
    }
}

fn finite3(v: &[f64; 3]) -> Result<(), String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(format!("= {v:?}: every component must be finite"))
    }
}

/// Refuses a quaternion that is not unit length rather than normalising it
/// silently: a typo in one component would otherwise become a different,
/// plausible-looking orientation.
fn unit_quaternion(q: &[f64; 4]) -> Result<(), String> {
    if !q.iter().all(|x| x.is_finite()) {
        return Err(format!("= {q:?}: every component must be finite"));
    }
    let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    if (norm - 1.0).abs() > 1e-6 {
        return Err(format!(
            "= {q:?}: not a unit quaternion (norm {norm}); give [w, x, y, z] with norm 1"
        ));
    }
    Ok(())
}

/// Turns a TOML error into a `SceneError` with the line and column of its span
/// and, where the message names it, the field at fault.
fn toml_error(e: &toml::de::Error, text: &str, file: &str) -> SceneError {
    let location = e.span().map(|span| line_col(text, span.start));
    let message = e.message().trim().to_string();
    // The field: the key on the offending line, when the span points into one.
    let field = e
        .span()
        .and_then(|span| key_at(text, span.start))
        .unwrap_or_default();
    SceneError {
        file: file.to_string(),
        location,
        field,
        message,
    }
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// The dotted path `table.key` of the key on the line holding `offset`,
/// e.g. `body.radius`, or `None` when that line holds no `key =`.
fn key_at(text: &str, offset: usize) -> Option<String> {
    let offset = offset.min(text.len());
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[offset..].find('\n').map_or(text.len(), |i| offset + i);
    let line = &text[line_start..line_end];
    let key = line.split('=').next()?.trim();
    if key.is_empty() || key.starts_with('[') || !line.contains('=') {
        return None;
    }
    // The nearest table header above the line; for an array of tables
    // (`[[body]]`) also its index, counting the same headers above it.
    let above: Vec<&str> = text[..line_start].lines().map(str::trim).collect();
    let header = above.iter().rev().find(|l| l.starts_with('['));
    Some(match header {
        Some(h) if h.starts_with("[[") => {
            let name = h.trim_matches(|c| c == '[' || c == ']').trim();
            let index = above.iter().filter(|l| *l == h).count() - 1;
            format!("{name}[{index}].{key}")
        }
        Some(h) => format!("{}.{key}", h.trim_matches(|c| c == '[' || c == ']').trim()),
        None => key.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
[sim]
dt = 0.001
duration = 1.0

[[body]]
name = "ball"
radius = 0.1
mass = 1.0
position = [0.0, 0.0, 0.5]
"#;

    #[test]
    fn minimal_scene_loads_with_defaults() {
        let s = Scene::parse(MINIMAL, "t.toml").expect("valid");
        assert_eq!(s.sim.friction_directions, 8);
        assert_eq!(s.sim.gravity, [0.0, 0.0, -9.81]);
        assert_eq!(s.bodies[0].orientation, [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(s.step_count(), 1000);
        // Written out and read back, it is the same scene.
        assert_eq!(Scene::parse(&s.to_toml(), "again.toml"), Ok(s));
    }

    #[test]
    fn pgs_stopping_rule_is_read_and_checked() {
        let with = |table: &str| {
            MINIMAL.replace("\n[[body]]", &format!("\n[sim.pgs]\n{table}\n\n[[body]]"))
        };
        let s =
            Scene::parse(&with("stop = \"residual\"\ntolerance = 0.01"), "t.toml").expect("valid");
        let pgs = s.sim.pgs.expect("read");
        assert_eq!((pgs.stop, pgs.tolerance), (PgsStop::Residual, 0.01));
        assert_eq!(pgs.max_iterations, 5000);
        assert_eq!(Scene::parse(&s.to_toml(), "again.toml"), Ok(s));
        let e = Scene::parse(&with("tolerance = -1.0"), "t.toml").unwrap_err();
        assert_eq!(e.field, "sim.pgs.tolerance", "{e}");
        let e = Scene::parse(&with("max_iterations = 0"), "t.toml").unwrap_err();
        assert_eq!(e.field, "sim.pgs.max_iterations", "{e}");
        let e = Scene::parse(&with("stop = \"sometimes\""), "t.toml").unwrap_err();
        assert!(e.to_string().contains("sometimes"), "{e}");
    }

    #[test]
    fn circular_cone_needs_pgs() {
        let text = MINIMAL.replace(
            "duration = 1.0",
            "duration = 1.0\nfriction_cone = \"circular\"",
        );
        let e = Scene::parse(&text, "t.toml").unwrap_err();
        assert_eq!(e.field, "sim.friction_cone", "{e}");
        let ok = text.replace("friction_cone", "solver = \"pgs\"\nfriction_cone");
        assert!(Scene::parse(&ok, "t.toml").is_ok());
    }

    #[test]
    fn syntax_error_has_line_and_field() {
        let text = MINIMAL.replace("mass = 1.0", "mass = 1.0.0");
        let e = Scene::parse(&text, "t.toml").unwrap_err();
        assert_eq!(e.location.map(|l| l.0), Some(9), "{e}");
        assert_eq!(e.field, "body[0].mass", "{e}");
    }

    #[test]
    fn unknown_field_is_named() {
        let text = MINIMAL.replace("mass = 1.0", "mass = 1.0\nmas = 2.0");
        let e = Scene::parse(&text, "t.toml").unwrap_err();
        assert!(e.to_string().contains("mas"), "{e}");
        assert_eq!(e.location.map(|l| l.0), Some(10), "{e}");
        assert_eq!(e.field, "body[0].mas", "{e}");
    }
}

//! `[sim]` and what it holds: step, solver, its stopping rule, sleeping,
//! compliance, and their defaults.

use serde::{Deserialize, Serialize};

/// Default stabilisation factor on the constraint violation (`beta` in
/// formulation.md): 1 removes the whole violation in one step, as in the notes.
pub const DEFAULT_BETA: f64 = 1.0;
/// Default restitution threshold `v_min` (m/s): slower approaches are treated
/// as resting contact, or resting objects jitter.
pub const DEFAULT_RESTITUTION_THRESHOLD: f64 = 1e-2;
/// Default margin (m) added to the distance a contact could close within a
/// step before it is left out of the LCP.
pub const DEFAULT_CONTACT_MARGIN: f64 = 1e-3;

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
    Lemke,
    /// Projected Gauss-Seidel with a proximal step on the mixed problem.
    Pgs,
    /// Lemke, with PGS as the fallback when Lemke fails and alone on large
    /// problems; the step report says which ran and why. The default: per
    /// island, Lemke's exact answer where the island is small (at most
    /// `AUTO_PGS_SIZE` unknowns, every shipped scene), PGS with the
    /// residual rule on a large one (a pile).
    #[default]
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

/// How an island with joints and no contact, limit or motor within reach
/// of the step advances (issue 48): every other island, and every island
/// under `Euler`, takes the velocity-level step.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum Integrator {
    /// The velocity-level step (the notes): first order, the joints held
    /// by their stabilisation.
    #[default]
    Euler,
    /// RATTLE: positions and velocities held on the joints to round-off,
    /// symplectic, second order.
    Rattle,
    /// RATTLE composed to fourth order (Suzuki's five stages).
    Rattle4,
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
    /// "euler" (default), "rattle" or "rattle4": the smooth islands' step.
    #[serde(default)]
    pub integrator: Integrator,
    /// `[sim.sleep]`: islands at rest leave the step until touched. On by
    /// default at [`SleepDesc::default`]'s thresholds, as in Rapier, Box2D
    /// and Jolt; `enabled = false` steps every body every step.
    #[serde(default)]
    pub sleep: SleepDesc,
    /// `[sim.pgs]`: when the iterative solver stops (absent: its defaults,
    /// the residual rule at 1e-2 m/s; `stop = "distance"` with a small
    /// tolerance for agreement with Lemke).
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
    /// Residual rule only: an island's tolerance is at least this fraction
    /// of the fastest speed at which its contacts approach at the step's
    /// start (ODEs' relative tolerance beside the absolute one), so that a
    /// landing at metres a second is not solved to the centimetre a second
    /// of a pile at rest; 0: the tolerance alone. In [0, 1).
    #[serde(default = "default_pgs_relative")]
    pub relative: f64,
}

/// `[sim.pgs] stop`: what the tolerance bounds when PGS stops.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum PgsStop {
    /// The distance to the answer: the last sweep's largest velocity change
    /// and, while the sweeps shrink, what the rate of shrinking says is
    /// left (the engine's `pgs::within`). For comparisons with Lemke.
    Distance,
    /// The constraint violation: no update of the last sweep changed a
    /// velocity by more, so that every contact and joint, when the sweep
    /// reached it, held to the tolerance (m/s; `h` times it in position
    /// per step, which the stabilisation then corrects). The rule of the
    /// engines that step piles (Box2D, Rapier and Bullet stop on a sweep
    /// count alone); on a pile the distance rule waits for slow modes that
    /// move the velocities by little (measured: rate 0.998 per sweep on
    /// the 1,000 pile, thousands of sweeps per step). The default.
    #[default]
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
/// engine alike. The tolerance bounds the residual rule's constraint
/// violation: 1 cm/s, 0.1 mm of position per step at h = 0.01 that the
/// stabilisation takes back (`bench pile`'s rule, measured there).
pub const DEFAULT_PGS_TOLERANCE: f64 = 1e-2;
pub const DEFAULT_PGS_MAX_ITERATIONS: usize = 5000;
pub const DEFAULT_PGS_RELATIVE: f64 = 1e-2;

fn default_pgs_tolerance() -> f64 {
    DEFAULT_PGS_TOLERANCE
}
fn default_pgs_relative() -> f64 {
    DEFAULT_PGS_RELATIVE
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
    /// Whether islands sleep at all.
    #[serde(default = "default_true")]
    pub enabled: bool,
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

impl SleepDesc {
    /// Sleeping off: every body steps every step.
    pub fn off() -> SleepDesc {
        SleepDesc {
            enabled: false,
            ..SleepDesc::default()
        }
    }
}

impl Default for SleepDesc {
    fn default() -> Self {
        SleepDesc {
            enabled: true,
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

pub(crate) fn default_true() -> bool {
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

//! The scene's time-stepping parameters as the stages take them: the step
//! size and the solver's settings, the skips, compliance, sleeping.

use cosim_shared::{FrictionCone, SolverChoice};
use nalgebra::Vector3;

/// Time-stepping parameters.
#[derive(Debug, Clone)]
pub struct Params {
    pub h: f64,
    pub gravity: Vector3<f64>,
    pub friction_directions: usize,
    pub solver: SolverChoice,
    pub friction_cone: FrictionCone,
    pub beta: f64,
    pub restitution_threshold: f64,
    pub contact_margin: f64,
    /// Keep every potential contact in the LCP (`--full`), as in the notes.
    pub full: bool,
    /// Sphere-sphere contacts enabled (the scene's `sphere_contacts`).
    pub sphere_contacts: bool,
    /// The skips, on by default; off only to measure what they save
    /// (`bench skips`) and to test that they do not change the answer.
    pub skips: Skips,
    /// A pivot cap for Lemke below its own (`1000 + 50 n`): a step that
    /// needs more fails with `pivot_limit` (and `auto` solves it with PGS),
    /// bounding a step's time. None: Lemke's own cap.
    pub lemke_max_pivots: Option<usize>,
    /// Where the rigid LCP has no solution Lemke finds, fall back to the
    /// relaxed and then the compliant formulation (`engine::fallback`),
    /// and refuse rigid answers that add energy. Off: such a step fails
    /// and the state stays (`serve --on-failure pause|abort`).
    pub fallback: bool,
    /// Springs and dampers on the contact normal rows and on the joint
    /// rows (the scene's `[compliance]`); `None`: rigid.
    pub contact_compliance: Option<Compliance>,
    pub joint_compliance: Option<Compliance>,
    pub position_update: cosim_shared::PositionUpdate,
    /// The smooth islands' step (`integrate::rattle`).
    pub integrator: cosim_shared::Integrator,
    /// Sleeping islands at rest (`sleep.rs`); `None`: every body steps.
    pub sleep: Option<Sleep>,
    /// The iterative solver's stopping rule (the scene's `[sim.pgs]`).
    pub pgs: PgsParams,
}

/// A spring of stiffness `k` (N/m) and a damper `c` (N s/m) along a
/// constraint row, in the step's terms.
///
/// Derivation. Along a row with violation `psi` (a contact's gap, negative
/// when it penetrates; a joint's error) and end-of-step speed
/// `v' = G^T nu'`, the implicit spring-damper gives the step's impulse
/// `p = -h (k (psi + h v') + c v')`. Solved for `v'`:
///
/// ```text
/// v' + ERP psi / h + CFM p = 0,   ERP = h k / (h k + c),
///                                 CFM = 1 / (h (h k + c))
/// ```
///
/// ODE's ERP and CFM, in physical units. So compliance is the rigid row
/// with its stabilisation factor `beta` replaced by `ERP` and `CFM` added
/// to its Delassus diagonal; for a contact the row stays complementary
/// (`>= 0 _|_ p >= 0`). As `k` grows with `c / k` fixed, `ERP -> 1` and
/// `CFM -> 0`: the rigid row with `beta = 1` (tested).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Compliance {
    pub stiffness: f64,
    pub damping: f64,
}

impl Compliance {
    pub fn erp(&self, h: f64) -> f64 {
        h * self.stiffness / (h * self.stiffness + self.damping)
    }

    pub fn cfm(&self, h: f64) -> f64 {
        1.0 / (h * (h * self.stiffness + self.damping))
    }
}

impl From<cosim_shared::scene::SpringDesc> for Compliance {
    fn from(s: cosim_shared::scene::SpringDesc) -> Compliance {
        Compliance {
            stiffness: s.stiffness,
            damping: s.damping,
        }
    }
}

impl Params {
    /// Whether the broad phase lists the contacts (`collision::Listing`),
    /// else every potential contact is listed, as in the notes.
    pub fn broad_phase(&self) -> bool {
        !self.full && self.skips.broad_phase
    }
}

/// Work a step leaves out when the scene does not need it. Pruning is
/// `Params::full`; the joint block is absent without joints by
/// construction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Skips {
    /// No friction rows (nor slack) for contacts with mu = 0.
    pub frictionless_rows: bool,
    /// PGS starts from the last step's impulses (by contact identity).
    pub warm_start: bool,
    /// Lemke first tries the last step's support, carried over by contact
    /// identity (`Lemke::solve_guess`).
    pub lemke_guess: bool,
    /// The broad phase lists only the sphere pairs within reach
    /// (`collision/broad.rs`) instead of every pair.
    pub broad_phase: bool,
    /// A step of a world asleep whole, with no input, advances the clock
    /// alone (`Engine::idle_step`), instead of running every stage on
    /// nothing.
    pub idle: bool,
}

impl Default for Skips {
    fn default() -> Self {
        Skips {
            frictionless_rows: true,
            warm_start: true,
            lemke_guess: true,
            broad_phase: true,
            idle: true,
        }
    }
}

/// The scene's sleeping thresholds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sleep {
    /// Seconds at rest before an island sleeps.
    pub after: f64,
    /// Speed (m/s) and angular speed (rad/s) below which a body is at rest.
    pub linear: f64,
    pub angular: f64,
}

/// Default stopping tolerance on the relative residual.
pub const DEFAULT_TOLERANCE: f64 = 1e-10;

/// Default iteration (sweep) cap.
pub const DEFAULT_MAX_ITERATIONS: usize = cosim_shared::DEFAULT_PGS_MAX_ITERATIONS;

/// Default physical stopping tolerance (m/s): see [`Pgs::solve`].
pub const DEFAULT_VELOCITY_TOLERANCE: f64 = cosim_shared::DEFAULT_PGS_TOLERANCE;

/// Default relative part of the residual rule's tolerance.
pub const DEFAULT_RELATIVE: f64 = cosim_shared::DEFAULT_PGS_RELATIVE;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PgsParams {
    pub tolerance: f64,
    pub max_iterations: usize,
    /// Relaxation factor omega on the step `1 / W_kk`.
    pub relaxation: f64,
    /// Stop when no update of a sweep changes a velocity by more (m/s).
    pub velocity_tolerance: f64,
    /// The NNCG momentum step after each sweep.
    pub momentum: bool,
    /// How `velocity_tolerance` stops the iteration.
    pub stop: Stop,
    /// Under the residual rule, an island's tolerance is at least this
    /// fraction of its fastest approach at the free velocity (see
    /// `Pgs::iterate`); 0: the tolerance alone.
    pub relative: f64,
}

/// What `velocity_tolerance` bounds when PGS stops (the scene's `[sim.pgs]
/// stop`).
pub use cosim_shared::PgsStop as Stop;

impl PgsParams {
    /// The velocity tolerance at which PGS agrees with Lemke to 1e-6 m/s
    /// on the reference scene and rests a stack's forces to 1e-6 of its
    /// weight (h = 1e-3): the comparisons of the tests and the stress
    /// suite use it. The default (the residual rule at 1e-2 m/s) stops
    /// far sooner, where a pile needs it.
    pub fn precise() -> PgsParams {
        PgsParams::distance(1e-9)
    }

    /// The distance rule at `tolerance` (m/s): PGS stops when what is left
    /// to the answer is below it, for comparisons with Lemke.
    pub fn distance(tolerance: f64) -> PgsParams {
        PgsParams {
            velocity_tolerance: tolerance,
            stop: Stop::Distance,
            ..PgsParams::default()
        }
    }
}

impl Default for PgsParams {
    fn default() -> Self {
        PgsParams {
            tolerance: DEFAULT_TOLERANCE,
            max_iterations: DEFAULT_MAX_ITERATIONS,
            relaxation: 1.0,
            velocity_tolerance: DEFAULT_VELOCITY_TOLERANCE,
            momentum: true,
            stop: Stop::Residual,
            relative: DEFAULT_RELATIVE,
        }
    }
}

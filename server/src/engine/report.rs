//! The step report: what every step says about itself.

use super::measure::Energy;
use super::mlcp::MlcpError;
use super::solver::LemkeError;
use std::time::Instant;

/// Why a step failed. The state is left as it was before the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepError {
    Lemke(LemkeError),
    Mlcp(MlcpError),
    /// The new velocities are not finite (an input or the scene overflowed).
    NonFinite,
}

impl std::fmt::Display for StepError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StepError::Lemke(e) => write!(f, "lemke: {e}"),
            StepError::Mlcp(e) => write!(f, "{e}"),
            StepError::NonFinite => write!(f, "non-finite velocities"),
        }
    }
}

impl StepError {
    /// A short machine-readable name (for `steps.csv`).
    pub fn code(&self) -> &'static str {
        match self {
            StepError::Lemke(LemkeError::RayTermination { .. }) => "ray_termination",
            StepError::Lemke(LemkeError::PivotLimit { .. }) => "pivot_limit",
            StepError::Lemke(LemkeError::NumericalBreakdown { .. }) => "numerical_breakdown",
            StepError::Mlcp(MlcpError::SingularJointBlock { .. }) => "singular_joint_block",
            StepError::NonFinite => "non_finite",
        }
    }
}

/// Wall time of each stage (s). Observational only: nothing in the physics
/// reads it, so the trajectory stays bit-exact whatever the clock does.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Timings {
    pub collision: f64,
    pub assemble: f64,
    pub solve: f64,
    pub integrate: f64,
    pub measure: f64,
    pub total: f64,
}

/// A stage clock: each [`Lap::lap`] reads the clock once and returns the
/// seconds since the last read, so one stage's end is the next one's start.
/// A read costs about 30 ns on this machine's VMs and a lockstep step is
/// under 10 us: one read per stage boundary, not two per stage.
#[derive(Debug, Clone, Copy)]
pub struct Lap {
    start: Instant,
    last: Instant,
}

impl Lap {
    pub fn start() -> Lap {
        let now = Instant::now();
        Lap {
            start: now,
            last: now,
        }
    }

    /// Seconds since the last lap (or the start).
    pub fn lap(&mut self) -> f64 {
        let now = Instant::now();
        let d = (now - self.last).as_secs_f64();
        self.last = now;
        d
    }

    /// Seconds from the start to the last lap (no clock read).
    pub fn total(&self) -> f64 {
        (self.last - self.start).as_secs_f64()
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    /// The step this report describes (the state after it has `step` steps).
    pub step: u64,
    pub t: f64,
    pub solver: &'static str,
    /// `None` when the step succeeded.
    pub error: Option<StepError>,
    /// Lemke pivots (or PGS sweeps) summed over the solves of the step
    /// (0: trivial LCP).
    pub pivots: usize,
    /// Largest relative natural-map residual of the step's LCP solves.
    pub residual: f64,
    /// Size of the largest pure LCP solved in the step (the first solve's,
    /// unless the velocity check added contacts).
    pub lcp_size: usize,
    /// Contacts in that LCP, and those with a positive normal impulse.
    pub contacts_in_lcp: usize,
    pub active_contacts: usize,
    /// Left-out contacts that the velocity check added back (re-solves).
    pub resolves: usize,
    /// The iterative solver stopped on its iteration cap, not its tolerance:
    /// the step went on with the answer it had (residual reported).
    pub not_converged: bool,
    /// Solves of the step that needed Lemke's regularised retry (see
    /// `solver::lemke`): their residual is up to 1e-6 instead of 1e-8;
    /// plus builds whose joint block was singular (redundant joints) and
    /// was regularised (see `mlcp::reduce_joints`).
    pub regularized: usize,
    /// Contacts that started the step deeper than `project::PENETRATION_SLOP`
    /// and were projected out (positions moved, velocities kept).
    pub projected: usize,
    /// The first solve used the matrix part made by `Engine::prepare`
    /// (kept or cut down): the inputs selected no contact it left out.
    pub early_matrix: bool,
    pub max_penetration: f64,
    pub max_joint_error: f64,
    pub energy: Energy,
    pub timings: Timings,
}

impl StepReport {
    pub fn ok(&self) -> bool {
        self.error.is_none()
    }

    pub fn status(&self) -> &'static str {
        match self.error {
            Some(e) => e.code(),
            None if self.not_converged => "not_converged",
            None => "solved",
        }
    }
}

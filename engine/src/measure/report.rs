//! The step report: what every step says about itself.

use crate::measure::Energy;
use crate::model::Party;
use crate::solver::fallback::Fallback;
use crate::solver::mlcp::MlcpError;
use crate::solver::{LemkeError, Rung};
use nalgebra::Vector3;
use std::time::Instant;

/// What an impulse row of the output describes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImpulseKind {
    Normal,
    Friction,
    /// A joint's anchor force impulse (N s).
    Joint,
    /// A hinge's, slider's or fixed joint's rotation rows' torque impulse
    /// (N m s, a couple).
    JointTorque,
    /// A joint limit's impulse on A: a couple (N m s) about a hinge's
    /// axis, a force impulse (N s) along a slider's.
    JointLimit,
    /// A joint motor's impulse on A, as a limit's (`motor.rs`).
    JointMotor,
}

/// The world-frame impulse on `a` over the step; `b` receives the opposite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpulseRecord {
    pub kind: ImpulseKind,
    /// Contact id (canonical index) or joint index.
    pub index: usize,
    pub a: Party,
    pub b: Party,
    pub impulse: Vector3<f64>,
}

/// Why a step failed. The state is left as it was before the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepError {
    Lemke(LemkeError),
    Mlcp(MlcpError),
    /// The new velocities are not finite (an input or the scene overflowed).
    NonFinite,
    /// The new pose of `body` is not finite: its velocities are finite but
    /// so large that a step's motion overflows.
    NonFinitePose {
        body: usize,
    },
}

impl std::fmt::Display for StepError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StepError::Lemke(e) => write!(f, "lemke: {e}"),
            StepError::Mlcp(e) => write!(f, "{e}"),
            StepError::NonFinite => write!(f, "non-finite velocities"),
            StepError::NonFinitePose { body } => write!(
                f,
                "the new pose of body {body} is not finite (its velocity overflows a step)"
            ),
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
            StepError::NonFinitePose { .. } => "non_finite_pose",
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
    /// Islands of the step's final LCP (bodies tied by its contacts and
    /// joints, `island.rs`), and the bodies of the largest; 0 on a failed
    /// step.
    pub islands: usize,
    pub largest_island: usize,
    /// Islands of the final solve that Lemke solved and that PGS iterated
    /// (each island is solved on its own, `split.rs`; with `auto` on a
    /// large step, Lemke takes the small ones). An island of joints alone
    /// in flight has no LCP: Lemke's count leaves it out.
    pub lemke_islands: usize,
    pub pgs_islands: usize,
    /// Islands stepped by RATTLE (`integrator = "rattle"` or "rattle4"),
    /// and those that could have been but whose position iteration failed
    /// (left to the velocity-level step).
    pub smooth_islands: usize,
    pub smooth_left: usize,
    /// Bodies asleep after the step (`sleep.rs`).
    pub sleeping: usize,
    /// Left-out contacts that the velocity check added back (re-solves).
    pub resolves: usize,
    /// Contacts the answer would close that its LCP did not hold: found
    /// by the velocity check after the step's PGS sweeps ran out (the
    /// cap bounds a step's sweeps over its re-solves), so not solved
    /// again. They enter the next step's LCP, penetrating if they closed.
    pub left_out: usize,
    /// The iterative solver stopped on its iteration cap, not its tolerance:
    /// the step went on with the answer it had (residual reported).
    pub not_converged: bool,
    /// Solves of the step that needed Lemke's regularised retry (see
    /// `solver::lemke`): their residual is up to 1e-6 instead of 1e-8;
    /// plus builds whose joint block was singular (redundant joints) and
    /// was regularised (see `mlcp::reduce_joints`).
    pub regularized: usize,
    /// Lemke answers taken from the final basis factored again
    /// (`Lemke::refine`): the tableau's had lost digits.
    pub refined: usize,
    /// The highest rung of Lemke's ladder a solve of the step needed
    /// (`Other`: no Lemke solve, e.g. PGS).
    pub rung: Rung,
    /// The formulation the step fell back to where the rigid LCP has no
    /// solution Lemke finds (see `engine::fallback`); `None`: rigid.
    pub fallback: Option<Fallback>,
    /// A rigid answer was found but gave more kinetic energy than the
    /// stabilisation may (`fallback::allowance`, `fallback::explained`),
    /// so the step fell back.
    pub energy_refused: bool,
    /// The kinetic energy over the free motion's that the step's answer
    /// was allowed by the energy check (J; `fallback::Solved::allowance`):
    /// what the stabilisation and the motors may have given. For a
    /// fallback the motors' work alone (`Mlcp::motor_work`);
    /// infinite with `Params::fallback` off (not checked).
    pub energy_allowance: f64,
    /// Contacts that started the step deeper than `project::slop`
    /// and were projected out (positions moved, velocities kept).
    pub projected: usize,
    /// The first solve used the matrix part made by `Engine::prepare`
    /// (kept or cut down): the inputs selected no contact it left out.
    pub early_matrix: bool,
    pub max_penetration: f64,
    /// Largest anchor error (m) and rotation error (rad) of the joints
    /// (`joint::anchor_error`, `joint::angle_error`).
    pub max_joint_error: f64,
    pub max_joint_angle_error: f64,
    /// Joints whose held effort their bound clamped (`applied::bounded`).
    pub clamped_efforts: usize,
    pub energy: Energy,
    pub timings: Timings,
}

impl StepReport {
    /// Records a solve's formulation and energy check (the last solve's
    /// answer is the step's); true when it fell back.
    pub fn took(
        &mut self,
        fallback: Option<Fallback>,
        energy_refused: bool,
        allowance: f64,
    ) -> bool {
        self.fallback = Fallback::max(self.fallback, fallback);
        self.energy_refused |= energy_refused;
        self.energy_allowance = allowance;
        fallback.is_some()
    }

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

/// Per-run counts of the solve ladder (see `engine::fallback`), from the
/// step reports: what a user reads to see how often each rung was needed.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LadderCounts {
    /// Steps by the highest rung of Lemke's ladder they needed, indexed as
    /// [`Rung::LADDER`].
    pub rungs: [u64; 5],
    /// Steps with an answer refined from its final basis.
    pub refined: u64,
    /// Steps that fell back to the relaxed formulation, and to the
    /// compliant one (with the largest compliance used).
    pub relaxed: u64,
    pub compliant: u64,
    pub max_compliance: f64,
    /// Steps whose rigid answer the energy check refused.
    pub energy_refused: u64,
}

impl LadderCounts {
    pub fn add(&mut self, r: &StepReport) {
        if r.error.is_some() {
            return;
        }
        if let Some(i) = r.rung.index() {
            self.rungs[i] += 1;
        }
        self.refined += u64::from(r.refined > 0);
        match r.fallback {
            Some(Fallback::Relaxed) => self.relaxed += 1,
            Some(Fallback::Compliant { eps }) => {
                self.compliant += 1;
                self.max_compliance = self.max_compliance.max(eps);
            }
            None => {}
        }
        self.energy_refused += u64::from(r.energy_refused);
    }

    /// Adds another run's counts (a suite of runs).
    pub fn merge(&mut self, other: &LadderCounts) {
        for (a, b) in self.rungs.iter_mut().zip(other.rungs) {
            *a += b;
        }
        self.refined += other.refined;
        self.relaxed += other.relaxed;
        self.compliant += other.compliant;
        self.max_compliance = self.max_compliance.max(other.max_compliance);
        self.energy_refused += other.energy_refused;
    }

    /// Steps that did not solve the rigid LCP of formulation.md.
    pub fn fell_back(&self) -> u64 {
        self.relaxed + self.compliant
    }
}

/// The ladder's counts on one line of a run summary.
impl std::fmt::Display for LadderCounts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let rungs: Vec<String> = Rung::LADDER
            .iter()
            .zip(self.rungs)
            .filter(|(_, n)| *n > 0)
            .map(|(r, n)| format!("{} {n}", r.as_str()))
            .collect();
        write!(
            f,
            "{}; refined {}; fell back: relaxed {}, compliant {} (largest eps {:.1e}), energy-refused {}",
            if rungs.is_empty() { "no Lemke solve".to_string() } else { rungs.join(", ") },
            self.refined,
            self.relaxed,
            self.compliant,
            self.max_compliance,
            self.energy_refused
        )
    }
}

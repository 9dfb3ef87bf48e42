//! The solve stage's ladder of formulations for Lemke: a step goes on
//! where the rigid LCP has no solution, and says so.
//!
//! 1. The rigid LCP of formulation.md, by Lemke's own ladder of pivot
//!    tolerances, refinement and regularisation (`solver::lemke`).
//! 2. [`Fallback::Relaxed`]: the same matrix with the offsets that ask for
//!    motion left out of `q` ([`Offsets::Relaxed`]: no joint drift term,
//!    normal offsets clipped at zero). Always solvable in exact arithmetic,
//!    never adds energy (the derivation is at [`Offsets`]).
//! 3. [`Fallback::Compliant`]: the relaxed problem on `M + eps I`, `eps`
//!    the least of [`COMPLIANCE`] (relative to `max |M_ij|`, or the contact
//!    rows' scale before the joints are eliminated, the larger) for which
//!    Lemke's answer verifies against that regularised problem. `M + eps I`
//!    is strictly copositive, so a solution exists for every `q`; `eps` is
//!    a compliance of every row (m/s per N s), reported.
//!
//! A rigid answer is also refused, and the step relaxed, when it gives more
//! kinetic energy than the free motion plus what the stabilisation may give
//! ([`allowances`], [`explained`]): the
//! solvable neighbours of an unsolvable LCP have huge impulses, and their
//! answers inject energy through the offsets (see there).
//!
//! Each rung's answer is verified against the problem it claims to solve.
//! The step report carries the rung, so a run counts how often each was
//! needed.
//!
//! The ladder is climbed island by island (issue 48): an island's energy
//! check weighs its own rows, and only the islands that need a fallback
//! take it, so a far-away pendulum keeps its rigid answer, to the bit,
//! while another island is relaxed.

use crate::constraint::applied::InvMass;
use crate::constraint::contact::Contact;
use crate::model::Params;
use crate::solver::island::Groups;
use crate::solver::mlcp::{Mlcp, Offsets};
use crate::solver::split::Split;
use crate::solver::{Lemke, LemkeError, SolveInfo};

/// The compliances tried by [`Fallback::Compliant`], relative to the LCP
/// matrix's largest entry, least first (Drake's regularised Lemke climbs a
/// schedule the same way, verifying every candidate).
pub const COMPLIANCE: [f64; 5] = [1e-8, 1e-6, 1e-4, 1e-2, 1.0];

/// How much of [`Mlcp::stabilisation_budget_by_island`] a rigid answer may use
/// before it is refused: the budget counts each row alone, and rows that
/// share a body need a little more (two contacts of one sphere).
pub const BUDGET_FACTOR: f64 = 2.0;

/// Kinetic energy gains below this (J, plus `ENERGY_RELATIVE` of the free
/// motion's energy) are round-off of the energy sum.
const ENERGY_ABSOLUTE: f64 = 1e-12;
const ENERGY_RELATIVE: f64 = 1e-9;

/// The formulation a step fell back to where the rigid LCP failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fallback {
    /// Solved with [`Offsets::Relaxed`]: no separation asked of any row.
    Relaxed,
    /// Solved with [`Offsets::Relaxed`] on `M + eps I`; `eps` absolute (the
    /// LCP's units: m/s per N s).
    Compliant { eps: f64 },
}

impl Fallback {
    pub fn as_str(self) -> &'static str {
        match self {
            Fallback::Relaxed => "relaxed",
            Fallback::Compliant { .. } => "compliant",
        }
    }

    /// The stronger of two (a step's solves may fall back differently).
    pub fn max(a: Option<Fallback>, b: Option<Fallback>) -> Option<Fallback> {
        match (a, b) {
            (Some(Fallback::Compliant { eps: x }), Some(Fallback::Compliant { eps: y })) => {
                Some(Fallback::Compliant { eps: x.max(y) })
            }
            (Some(c @ Fallback::Compliant { .. }), _)
            | (_, Some(c @ Fallback::Compliant { .. })) => Some(c),
            (Some(Fallback::Relaxed), _) | (_, Some(Fallback::Relaxed)) => Some(Fallback::Relaxed),
            (None, None) => None,
        }
    }
}

/// The diagonal of the LCP matrix, kept while a compliance is added to it,
/// and the rigid answer while the energy check forms the relaxed one.
#[derive(Debug, Default)]
pub struct Scratch {
    diagonal: Vec<f64>,
    /// The LCP by island.
    split: Split,
    /// The rigid answer and its offsets while the relaxed one is formed.
    z: Vec<f64>,
    offset: Vec<f64>,
    /// Per island: the rigid answer's gain, the stabilisation budget and
    /// the allowance, the relaxed answer's gain, the offsets' work at its
    /// impulses, where it ended, and a mask of islands to solve.
    gain: Vec<f64>,
    budget: Vec<f64>,
    allow: Vec<f64>,
    relaxed_gain: Vec<f64>,
    work: Vec<f64>,
    rung: Vec<Rung>,
    mask: Vec<bool>,
}

impl Scratch {
    /// Islands of the last solve with LCP unknowns (each solved alone).
    pub fn islands(&self) -> usize {
        self.split.islands()
    }

    /// Whether island `g` of the last solve fell back.
    pub fn fell(&self, g: usize) -> bool {
        matches!(self.rung.get(g), Some(Rung::Fell(_)))
    }
}

/// The step's data that the right-hand side is formed from.
#[derive(Clone, Copy)]
pub struct Step<'a> {
    pub nu_free: &'a [f64],
    pub contacts: &'a [Contact],
    pub params: &'a Params,
    pub minv: &'a [InvMass],
    /// The awake bodies (`sleep::Awake`): a sleeping body's free velocity
    /// is zero.
    pub awake: &'a [u32],
    /// The rows by island: each is solved on its own.
    pub groups: &'a Groups,
    /// `auto`: where the rigid problem fails, give its error back at once
    /// (the step goes to PGS) instead of climbing to the relaxed and
    /// compliant rungs.
    pub escape: bool,
}

/// What the ladder gave.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solved {
    pub info: SolveInfo,
    pub fallback: Option<Fallback>,
    /// A rigid answer was found but refused by the energy check.
    pub energy_refused: bool,
    /// The kinetic energy over the free motion's that the answer was
    /// allowed (J): the energy check's bound for a rigid answer; for a
    /// fallback, which adds no energy of its own, the motors' work
    /// (`Mlcp::motor_work`, zero without motors).
    pub allowance: f64,
}

/// The rigid answer's energy check, first part, island by island: the
/// kinetic energy an island's answer that gains `gain[g]` over the free
/// motion may gain, into `allow`. Gains at round-off pass outright (most
/// steps lose energy to their constraints, and then the budget, a
/// coupling per row, need not be formed); others may gain
/// [`BUDGET_FACTOR`] times the island's stabilisation budget (a resting
/// or sliding contact, a bounce), formed into `budget` when needed.
///
/// Each island's rotors (`constraint::armature`) add what their implicit
/// coupling may give ([`Mlcp::add_rotor_work`]).
pub fn allowances(m: &Mlcp, gain: &[f64], step: Step, budget: &mut Vec<f64>, allow: &mut Vec<f64>) {
    let round_off = round_off(step);
    let mut formed = false;
    allow.clear();
    for &gain in gain {
        allow.push(if gain <= round_off {
            round_off
        } else {
            if !formed {
                m.stabilisation_budget_by_island(step.params, step.minv, step.groups, budget);
                formed = true;
            }
            BUDGET_FACTOR * budget[allow.len()] + round_off
        });
    }
    m.add_rotor_work(step.nu_free, step.groups, allow);
}

/// The gains that are round-off of the energy sum (J): an absolute floor
/// and a share of the free motion's kinetic energy.
pub fn round_off(step: Step) -> f64 {
    // Over the awake bodies' entries, in body order: the sleeping ones
    // add exact zeros, so the sum has the bits of the sum over all.
    let free: f64 = 0.5
        * (step.awake.iter())
            .flat_map(|&i| &step.nu_free[6 * i as usize..6 * i as usize + 6])
            .map(|v| v * v)
            .sum::<f64>();
    ENERGY_ABSOLUTE + ENERGY_RELATIVE * free
}

/// The energy check, second part, for an answer that gained more than its
/// [`allowances`]: held against the relaxed answer of the same step, it may
/// gain what the relaxed answer gains (if anything; a relaxed answer that
/// dissipates does not pull the bound below the offsets' work: S4 at
/// h = 1e-2, step 112, had a healthy rigid gain of 1.1e-5 J against a
/// relaxed loss of 6.1e-5 J and was refused), plus `BUDGET_FACTOR` times
/// the work its offsets would do at the relaxed impulses
/// (`Mlcp::offset_work_by_island`), plus the allowance. A jointed chain that swings
/// holds its joints with impulses of the relaxed answer's size and passes;
/// a chain locked against a contact (joint_torques, step 2069: 1.7e5 N s)
/// needs impulses 1e4 times those of the relaxed answer and fails.
pub fn explained(relaxed_gain: f64, work: f64, allowance: f64) -> f64 {
    relaxed_gain.max(0.0) + BUDGET_FACTOR * work + allowance
}

/// Where an island's answer ended on the ladder.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Rung {
    /// The rigid answer, within its allowance (J).
    Rigid(f64),
    /// A rigid answer that gained more than its allowance.
    Suspect,
    /// Solved by a fallback formulation.
    Fell(Fallback),
    /// No rung has solved it (yet).
    Unsolved,
}

/// Solves the step's LCP (right-hand side already formed with
/// [`Offsets::Full`]) island by island (`split.rs`) into `m.z`, the rigid
/// problem first from `guess` (the last step's support by contact
/// identity, where there is one), and recovers `nu'` into `nu`, climbing
/// the ladder of the module notes island by island: the energy check is
/// each island's, and an island that falls back does so alone (its rows'
/// offsets relaxed by [`Offsets::Islands`]), so another island's answer
/// keeps its bits. On a fallback, `m`'s right-hand side is left as the
/// answer's. The error is the rigid problem's, returned only when every
/// rung failed on some island; then `m` holds the rigid problem again.
pub fn solve(
    lemke: &mut Lemke,
    m: &mut Mlcp,
    guess: Option<&[bool]>,
    step: Step,
    nu: &mut Vec<f64>,
    scratch: &mut Scratch,
) -> Result<Solved, LemkeError> {
    let Step {
        nu_free,
        contacts,
        params: p,
        groups,
        ..
    } = step;
    let split = &mut scratch.split;
    split.index(m, groups);
    lemke.first_rung_only = step.escape;
    let rigid = split.lemke(lemke, m, guess, None);
    lemke.first_rung_only = false;
    if !p.fallback {
        // Rigid only: the answer as it is, or the failure.
        let info = rigid?;
        m.recover(nu_free, nu);
        return Ok(Solved {
            info,
            fallback: None,
            energy_refused: false,
            allowance: f64::INFINITY,
        });
    }
    let first_error = match rigid {
        Err(e) if step.escape => return Err(e),
        Err(e) => Some(e),
        Ok(_) => None,
    };
    let mut info = split.solved();
    m.recover(nu_free, nu);
    // Each island's rigid answer against its allowance.
    let islands = groups.len();
    m.kinetic_change_by_island(groups, nu_free, nu, &mut scratch.gain);
    allowances(
        m,
        &scratch.gain,
        step,
        &mut scratch.budget,
        &mut scratch.allow,
    );
    scratch.rung.clear();
    for g in 0..islands {
        scratch.rung.push(if split.failed()[g] {
            Rung::Unsolved
        } else if scratch.gain[g] <= scratch.allow[g] {
            Rung::Rigid(scratch.allow[g])
        } else {
            Rung::Suspect
        });
    }
    if scratch.rung.iter().all(|r| matches!(r, Rung::Rigid(_))) {
        return Ok(Solved {
            info,
            fallback: None,
            energy_refused: false,
            allowance: total_allowance(&scratch.rung, 0.0),
        });
    }
    // The relaxed problem on the other islands; the rigid answer and its
    // offsets kept aside.
    scratch.z.clear();
    scratch.z.extend_from_slice(&m.z);
    scratch.offset.clear();
    scratch.offset.extend_from_slice(&m.offset);
    scratch.mask.clear();
    scratch
        .mask
        .extend(scratch.rung.iter().map(|r| !matches!(r, Rung::Rigid(_))));
    m.relax_islands(groups, &scratch.mask);
    m.rhs(nu_free, contacts, p, Offsets::Islands);
    let split = &mut scratch.split;
    let _ = split.lemke(lemke, m, None, Some(&scratch.mask));
    add_work(&mut info, split.solved());
    m.recover(nu_free, nu);
    m.kinetic_change_by_island(groups, nu_free, nu, &mut scratch.relaxed_gain);
    m.offset_work_by_island(&scratch.offset, groups, &mut scratch.work);
    let mut energy_refused = false;
    for g in 0..islands {
        let rung = scratch.rung[g];
        if matches!(rung, Rung::Rigid(_)) {
            continue;
        }
        let suspect = rung == Rung::Suspect;
        let rung = if split.failed()[g] {
            Rung::Unsolved
        } else if suspect {
            // As one problem: the rigid answer stands where the relaxed
            // impulses explain its gain.
            let bound = explained(scratch.relaxed_gain[g], scratch.work[g], scratch.allow[g]);
            match scratch.gain[g] <= bound {
                true => Rung::Rigid(bound),
                false => Rung::Fell(Fallback::Relaxed),
            }
        } else {
            Rung::Fell(Fallback::Relaxed)
        };
        // A rigid answer refused for its energy (not one that stood).
        energy_refused |= suspect && !matches!(rung, Rung::Rigid(_));
        scratch.rung[g] = rung;
    }
    let unsolved = |r: &[Rung]| r.contains(&Rung::Unsolved);
    // Under `escape` the caller goes on with PGS at once.
    if !step.escape && unsolved(&scratch.rung) {
        compliant(lemke, m, &mut info, scratch);
    }
    if unsolved(&scratch.rung) {
        // The caller may go on with another solver: give it the rigid
        // problem.
        m.rhs(nu_free, contacts, p, Offsets::Full);
        return Err(first_error.unwrap_or(LemkeError::NumericalBreakdown {
            pivots: info.work,
            residual: info.residual,
        }));
    }
    // The answer: each island's rung, on the right-hand side that has the
    // fallen islands' rows relaxed; a rigid island's unknowns as its rigid
    // solve left them.
    let mut fallback = None;
    scratch.mask.clear();
    for (g, &rung) in scratch.rung.iter().enumerate() {
        match rung {
            Rung::Fell(f) => fallback = Fallback::max(fallback, Some(f)),
            _ => {
                for &a in scratch.split.unknowns_of(g) {
                    m.z[a as usize] = scratch.z[a as usize];
                }
            }
        }
        scratch.mask.push(matches!(rung, Rung::Fell(_)));
    }
    m.relax_islands(groups, &scratch.mask);
    m.rhs(nu_free, contacts, p, Offsets::Islands);
    m.recover(nu_free, nu);
    let motors = if fallback.is_some() {
        m.motor_work() + m.rotor_work_of(nu_free, groups, |g| scratch.mask[g])
    } else {
        0.0
    };
    Ok(Solved {
        info,
        fallback,
        energy_refused,
        allowance: total_allowance(&scratch.rung, motors),
    })
}

/// The compliant rung on the islands still [`Rung::Unsolved`]: each gets
/// the least compliance of [`COMPLIANCE`] for which Lemke's answer
/// verifies, on the relaxed right-hand side already formed.
fn compliant(lemke: &mut Lemke, m: &mut Mlcp, info: &mut SolveInfo, scratch: &mut Scratch) {
    let n = m.lcp_size();
    // NOTE: not below the contact rows' own scale before the joints are
    // eliminated: where the joints hold every contact (a contact between
    // two jointed spheres whose anchor lies on their line of centres, or
    // such a sphere and one welded to the world), the reduced matrix is
    // round-off, and a compliance relative to it would be round-off too.
    let scale = m
        .lcp_m
        .iter()
        .fold(m.contact_scale(), |a, &b| a.max(b.abs()));
    scratch.diagonal.clear();
    scratch.diagonal.extend((0..n).map(|i| m.lcp_m[i * n + i]));
    for rel in COMPLIANCE {
        let eps = rel * scale;
        scratch.mask.clear();
        scratch
            .mask
            .extend(scratch.rung.iter().map(|&r| r == Rung::Unsolved));
        if !scratch.mask.contains(&true) {
            break;
        }
        for i in 0..n {
            m.lcp_m[i * n + i] = scratch.diagonal[i] + eps;
        }
        let split = &mut scratch.split;
        let _ = split.lemke(lemke, m, None, Some(&scratch.mask));
        for i in 0..n {
            m.lcp_m[i * n + i] = scratch.diagonal[i];
        }
        add_work(info, split.solved());
        for (g, rung) in scratch.rung.iter_mut().enumerate() {
            if scratch.mask[g] && !split.failed()[g] {
                *rung = Rung::Fell(Fallback::Compliant { eps });
            }
        }
    }
}

/// `info` with the work and the worst rung of `more` added.
fn add_work(info: &mut SolveInfo, more: SolveInfo) {
    info.work += more.work;
    info.rung = info.rung.max_by_ladder(more.rung);
    info.refined |= more.refined;
    info.residual = info.residual.max(more.residual);
}

/// What the step's answer was allowed: the rigid islands' allowances and
/// the motors' work where an island fell back.
fn total_allowance(rungs: &[Rung], motors: f64) -> f64 {
    let rigid: f64 = rungs
        .iter()
        .map(|r| match r {
            Rung::Rigid(a) => *a,
            _ => 0.0,
        })
        .sum();
    rigid + motors
}

//! The solve stage with the iterative solver (prox PGS): the warm start by
//! contact identity, the solve on the mixed problem, and the relaxed retry
//! where the answer cannot be trusted.
//!
//! PGS never fails outright: on a rigid LCP without a solution it runs to
//! its iteration cap and returns an answer that may push the bodies with
//! any energy (seen: a random scene of three jointed spheres among five
//! planes went from 5.7 J to 1,645 J in 15 steps, every one at the cap).
//! So, as with Lemke (`engine::fallback`), an answer, converged or not, is
//! taken as it is when it gains no more kinetic energy than the energy
//! check allows (`fallback::allowance`); otherwise the step is solved
//! again with [`Offsets::Relaxed`]:
//!
//! 1. from the same warm start; a converged relaxed answer is taken (a
//!    converged rigid one stands against it when its gain is explained by
//!    the relaxed impulses, as in `fallback::solve`);
//! 2. else from zero impulses, in plain sweeps (no momentum step). The
//!    relaxed problem has no offset that asks for motion, so its PGS
//!    objective is `K(nu(lambda)) - K(nu_free)` plus
//!    the nonnegative gap terms, zero at the start. Every joint and normal
//!    update minimises it exactly along its row, and a friction block's
//!    update does so over its cone when the cone did not shrink since the
//!    block's last update (its normal impulse did not fall); so the answer
//!    gives, up to that, no more kinetic energy than the free motion even
//!    at the iteration cap. Measured: no such answer gained energy in
//!    `bench robust --solver pgs` (whose check would say). It replaces a
//!    rigid answer that failed the energy check and is reported as not
//!    converged.
//!
//! As with Lemke, island by island (issue 48): the energy check weighs
//! each island's rows, and only the islands it refuses are solved again
//! relaxed; every run starts each island from the same warm start, so
//! the others come out to the rigid run's bits. A converged relaxed
//! answer is taken only where it gains no more than its motors' work
//! (converged means within PGS's tolerance, which can still gain);
//! otherwise its islands descend from zero.

use crate::constraint::contact::Contact;
use crate::model::state::{State, WarmContact, WarmCursor};
use crate::solver::fallback::{self, explained, Fallback, Step};
use crate::solver::island::Groups;
use crate::solver::mlcp::{Mlcp, Offsets};
use crate::solver::split::{self, Split};
use crate::solver::Lemke;
use crate::solver::{pgs, Lcp, Pgs, PgsInfo, PgsParams, PgsProblem};
use cosim_shared::FrictionCone;

/// The warm start, the offsets in use and the rigid answer, kept while a
/// relaxed retry runs.
#[derive(Debug, Default)]
pub struct Scratch {
    warm: Vec<f64>,
    offset: Vec<f64>,
    full_offset: Vec<f64>,
    lambda: Vec<f64>,
    nu: Vec<f64>,
    z: Vec<f64>,
    /// The islands: which go to Lemke, which to PGS.
    split: Split,
    /// What Lemke did on its islands over the step's runs (the islands of
    /// the last run).
    done: split::Exact,
    /// The last solve's impulses by contact identity (ascending id) and
    /// its joints' and motors' (as `State::warm_joint`): the warm start of
    /// a re-solve within the step ([`Solvers::from_attempt`]).
    attempt: Vec<WarmContact>,
    attempt_joint: Vec<f64>,
    /// Per island, whether it starts from the attempt (`Attempt::dirty`).
    dirty: Vec<bool>,
    /// Per island: the rigid answer's gain and allowance, the
    /// stabilisation budget, whether the energy check suspects it, the
    /// relaxed answer's gain, the offsets' work at its impulses, and
    /// whether it fell back.
    gain: Vec<f64>,
    allow: Vec<f64>,
    budget: Vec<f64>,
    suspect: Vec<bool>,
    relaxed_gain: Vec<f64>,
    work: Vec<f64>,
    fallen: Vec<bool>,
}

impl Scratch {
    /// Whether island `g` of the last solve fell back (valid when its
    /// answer was a fallback's).
    pub fn fell(&self, g: usize) -> bool {
        self.fallen.get(g) == Some(&true)
    }

    /// The islands Lemke solved in the last solve's last run, and the
    /// pivots, highest rung and refinement over its runs.
    pub fn exact(&self) -> split::Exact {
        self.done
    }

    /// The islands PGS iterated in the last solve's last run.
    pub fn iterated(&self) -> usize {
        self.split.rest.len()
    }

    /// Keeps the answer in `m` (its contacts indexing `contacts`) as the
    /// warm start of a re-solve of the same step.
    pub fn keep_attempt(&mut self, m: &Mlcp, contacts: &[Contact]) {
        self.attempt_joint.clear();
        self.attempt_joint.extend_from_slice(&m.p_b);
        self.attempt_joint
            .extend((0..m.nm).map(|k| m.motor_impulse(k)));
        self.attempt.clear();
        self.attempt
            .extend(m.contact_impulses(contacts).map(|(_, w, _)| w));
    }
}

/// The solvers of the stage: PGS with its parameters, and, with `exact`,
/// Lemke for the small islands.
pub struct Solvers<'a> {
    pub pgs: &'a mut Pgs,
    pub params: &'a PgsParams,
    pub exact: Option<Exact<'a>>,
    /// Warm start from the step's last solve ([`Scratch::keep_attempt`])
    /// where it has the contact, else from the last step: a re-solve
    /// after the pruning's check added contacts starts next to the answer
    /// it extends instead of from as far as the first solve did.
    pub from_attempt: bool,
}

/// Lemke for the small islands (`split.rs`): the solver and the last
/// step's support by contact identity, where there is one.
pub struct Exact<'a> {
    pub lemke: &'a mut Lemke,
    pub guess: Option<&'a [bool]>,
}

/// What the iterative solve gave.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solved {
    pub info: PgsInfo,
    pub fallback: Option<Fallback>,
    /// A rigid answer failed the energy check and was replaced.
    pub energy_refused: bool,
    /// As `fallback::Solved::allowance`.
    pub allowance: f64,
}

/// Solves the step's mixed problem (right-hand side formed with
/// [`Offsets::Full`]) with PGS into `m.lambda`, `m.z`, `m.p_b` and `nu`,
/// island by island; with `exact`, the small islands without joints by
/// Lemke (`split.rs`) in every run.
pub fn solve(
    solvers: &mut Solvers,
    m: &mut Mlcp,
    state: &State,
    step: Step,
    nu: &mut Vec<f64>,
    scratch: &mut Scratch,
) -> Solved {
    m.add_friction_rows(step.contacts);
    if solvers.exact.is_some() {
        scratch.split.index(m, step.groups);
    }
    scratch.done = split::Exact::default();
    let p = step.params;
    if solvers.from_attempt {
        Attempt::mark(
            m,
            step.contacts,
            step.groups,
            &scratch.attempt,
            &mut scratch.dirty,
        );
    }
    let attempt = solvers.from_attempt.then_some(Attempt {
        joint: &scratch.attempt_joint,
        contacts: &scratch.attempt,
        dirty: &scratch.dirty,
    });
    warm_start(m, state, attempt, step);
    scratch.warm.clone_from(&m.lambda);
    scratch.full_offset.clear();
    scratch.full_offset.extend_from_slice(&m.offset);
    let islands = (&mut scratch.split, &mut scratch.done);
    let rigid = run(solvers, m, &scratch.full_offset, step, nu, islands, &[]);
    set_joint_impulses(m);
    if !p.fallback {
        return Solved {
            info: rigid,
            fallback: None,
            energy_refused: false,
            allowance: f64::INFINITY,
        };
    }
    // Each island's answer against its own allowance (`fallback.rs`).
    let groups = step.groups;
    let g_count = groups.len();
    m.kinetic_change_rows_by_island(groups, &m.lambda, step.nu_free, nu, &mut scratch.gain);
    fallback::allowances(
        m,
        &scratch.gain,
        step,
        &mut scratch.budget,
        &mut scratch.allow,
    );
    scratch.suspect.clear();
    (scratch.suspect).extend(scratch.gain.iter().zip(&scratch.allow).map(|(g, a)| g > a));
    // NOTE: the trigger is the energy alone, not convergence: PGS stops at
    // its cap on a jointed chain in contact for want of sweeps, not of a
    // solution (joints.toml: 21 of 1000 steps), and relaxing those steps
    // drops the joints' drift correction, so the drift grows and the next
    // steps fail the check too (measured: 41 % of joints.toml's steps
    // relaxed, 16x the time, when convergence was a trigger).
    if !scratch.suspect.contains(&true) {
        return Solved {
            info: rigid,
            fallback: None,
            energy_refused: false,
            allowance: scratch.allow.iter().sum(),
        };
    }
    // The rigid answer aside; the suspect islands solved again on the
    // relaxed offsets, every island from the same warm start (an island's
    // run depends on its own rows alone, so the others come out to the
    // rigid run's bits).
    scratch.lambda.clone_from(&m.lambda);
    scratch.nu.clone_from(nu);
    scratch.z.clone_from(&m.z);
    let relaxed = relaxed_run(solvers, m, step, nu, scratch, Relax::Suspect, false);
    let mut iterations = rigid.iterations + relaxed.iterations;
    // The rigid answer stands where the relaxed impulses explain its gain
    // (as in `fallback::solve`; an unconverged relaxed answer still gives
    // the impulses' scale).
    m.offset_work_by_island(&scratch.full_offset, groups, &mut scratch.work);
    scratch.fallen.clear();
    let mut allowance = 0.0;
    for g in 0..g_count {
        let bound = explained(scratch.relaxed_gain[g], scratch.work[g], scratch.allow[g]);
        let fell = scratch.suspect[g] && scratch.gain[g] > bound;
        scratch.fallen.push(fell);
        if !fell {
            allowance += if scratch.suspect[g] {
                bound
            } else {
                scratch.allow[g]
            };
        }
    }
    if !scratch.fallen.contains(&true) {
        restore_rigid(m, step, nu, scratch);
        return Solved {
            info: PgsInfo {
                iterations,
                ..rigid
            },
            fallback: None,
            energy_refused: false,
            allowance,
        };
    }
    allowance += m.motor_work();
    let mut relaxed = relaxed;
    if scratch.fallen != scratch.suspect {
        // Some suspects' rigid answers stand: those islands solved as the
        // rigid run did, the fallen ones relaxed.
        relaxed = relaxed_run(solvers, m, step, nu, scratch, Relax::Fallen, false);
        iterations += relaxed.iterations;
    }
    // A converged relaxed answer is taken where it gains no more than the
    // motors' work: converged means within PGS's tolerance, and at a loose
    // one (the residual rule's, relative to the fastest approach) the
    // answer can still gain (joint_torques with PGS, step 7712: 9.8e-3 J
    // on a relaxed answer of 61 sweeps).
    m.motor_work_by_island(groups, &mut scratch.work);
    m.add_rotor_work(step.nu_free, groups, &mut scratch.work);
    let round_off = fallback::round_off(step);
    let gains = (0..g_count)
        .any(|g| scratch.fallen[g] && scratch.relaxed_gain[g] > scratch.work[g] + round_off);
    let rotors = |m: &Mlcp, fallen: &[bool]| m.rotor_work_of(step.nu_free, groups, |g| fallen[g]);
    if relaxed.converged && !gains {
        return Solved {
            info: PgsInfo {
                iterations,
                ..relaxed
            },
            fallback: Some(Fallback::Relaxed),
            energy_refused: true,
            allowance: allowance + rotors(m, &scratch.fallen),
        };
    }
    // The fallen islands from zero impulses: a descent of the kinetic
    // energy at every update, without the momentum step, which moves
    // every impulse at once along its last change and so can climb (seed
    // 1725 with PGS, two joints on one pair: 8.6e-9 J over the bound).
    let cold = relaxed_run(solvers, m, step, nu, scratch, Relax::Fallen, true);
    m.settle_rotors(step.minv, nu, groups, &scratch.fallen);
    set_joint_impulses(m);
    Solved {
        info: PgsInfo {
            iterations: iterations + cold.iterations,
            ..cold
        },
        fallback: Some(Fallback::Relaxed),
        energy_refused: true,
        allowance: allowance + rotors(m, &scratch.fallen),
    }
}

/// Which islands [`relaxed_run`] relaxes.
#[derive(Clone, Copy, PartialEq)]
enum Relax {
    Suspect,
    Fallen,
}

/// A run with the islands `which` names on the relaxed offsets (no joint
/// drift term, no separation asked) and the rest on the full ones, every
/// island from the step's warm start, or with `cold` the relaxed islands
/// from zero impulses in plain sweeps; each island's kinetic energy gain
/// into `scratch.relaxed_gain`.
fn relaxed_run(
    solvers: &mut Solvers,
    m: &mut Mlcp,
    step: Step,
    nu: &mut Vec<f64>,
    scratch: &mut Scratch,
    which: Relax,
    cold: bool,
) -> PgsInfo {
    let groups = step.groups;
    let mask = match which {
        Relax::Suspect => &scratch.suspect,
        Relax::Fallen => &scratch.fallen,
    };
    m.relax_islands(groups, mask);
    m.rhs(step.nu_free, step.contacts, step.params, Offsets::Islands);
    // PGS reads the joint drift term from the joint rows' offsets.
    scratch.offset.clear();
    scratch.offset.extend_from_slice(&m.offset);
    for k in 0..m.nb {
        if m.drifts(k) && mask[groups.island_of_row(k)] {
            scratch.offset[k] = 0.0;
        }
    }
    m.lambda.clone_from(&scratch.warm);
    if cold {
        for k in 0..m.lambda.len() {
            if mask[m.row_island(groups, k)] {
                m.lambda[k] = 0.0;
            }
        }
    }
    let descend: &[bool] = if cold { mask } else { &[] };
    let islands = (&mut scratch.split, &mut scratch.done);
    let info = run(solvers, m, &scratch.offset, step, nu, islands, descend);
    set_joint_impulses(m);
    m.kinetic_change_rows_by_island(
        groups,
        &m.lambda,
        step.nu_free,
        nu,
        &mut scratch.relaxed_gain,
    );
    info
}

fn set_joint_impulses(m: &mut Mlcp) {
    m.p_b.clear();
    m.p_b.extend_from_slice(&m.lambda[..m.nb]);
}

/// Puts the rigid answer kept in `scratch` back, with its right-hand side.
fn restore_rigid(m: &mut Mlcp, step: Step, nu: &mut Vec<f64>, scratch: &Scratch) {
    m.rhs(step.nu_free, step.contacts, step.params, Offsets::Full);
    m.lambda.clone_from(&scratch.lambda);
    nu.clone_from(&scratch.nu);
    m.z.clone_from(&scratch.z);
    set_joint_impulses(m);
}

/// This step's last solve as a warm start: its joints' and motors'
/// impulses (as `State::warm_joint`), its contacts' (ascending id), and
/// which of this solve's islands take them.
#[derive(Clone, Copy)]
struct Attempt<'a> {
    joint: &'a [f64],
    contacts: &'a [WarmContact],
    /// Per island: it holds a contact the attempt did not (one the
    /// pruning's check added). NOTE: only those islands start from the
    /// attempt. Every other island is an island of the last solve, row
    /// for row, and starts where that solve started, so it comes out to
    /// the same bits: an island's motion does not depend on whether
    /// another island's contacts were added (tests/tests/islands.rs).
    dirty: &'a [bool],
}

impl<'a> Attempt<'a> {
    /// Marks in `dirty` the islands of `m` (grouped as `groups`) that
    /// hold a contact `contacts` does not.
    fn mark(
        m: &Mlcp,
        contacts: &[Contact],
        groups: &Groups,
        kept: &[WarmContact],
        dirty: &mut Vec<bool>,
    ) {
        dirty.clear();
        dirty.resize(groups.len(), false);
        for (i, &ci) in m.lcp_contacts.iter().enumerate() {
            let id = contacts[ci].id;
            if WarmContact::find(kept, id).is_none() {
                dirty[groups.island_of_row(m.nb + i)] = true;
            }
        }
    }
}

/// Joint impulses and normal impulses by contact identity from the last
/// step, or from `attempt` in the islands it marks dirty (where it has
/// the contact); friction as the world impulse on this step's tangent
/// plane, inside this step's cone.
fn warm_start(m: &mut Mlcp, state: &State, attempt: Option<Attempt>, step: Step) {
    let p = step.params;
    m.lambda.clear();
    m.lambda.resize(m.rows.len(), 0.0);
    if !p.skips.warm_start {
        return;
    }
    let groups = step.groups;
    // The attempt where row `k`'s island takes it.
    let from = |k: usize| attempt.filter(|a| a.dirty[groups.island_of_row(k)]);
    // Each pass below asks for its contacts in ascending id (`WarmCursor`).
    let warm_in = |(tried, kept): &(WarmCursor, WarmCursor), k: usize, id: usize| {
        from(k)
            .and_then(|_| tried.find(id))
            .or_else(|| kept.find(id))
            .copied()
    };
    let cursors = || {
        (
            WarmCursor::new(attempt.map_or(&[][..], |a| a.contacts)),
            WarmCursor::new(&state.warm_contacts),
        )
    };
    for k in 0..m.nb {
        m.lambda[k] = from(k).map_or(state.warm_joint[k], |a| a.joint[k]);
    }
    // The motors' impulses follow the joints' in the state, and their
    // rows the friction rows here.
    let motors = m.motor_rows();
    for (k, &row) in m.motor_row.iter().enumerate() {
        let at = m.nb + k;
        m.lambda[motors + k] = from(row).map_or(state.warm_joint[at], |a| a.joint[at]);
    }
    let normals = cursors();
    for (i, &ci) in m.lcp_contacts.iter().enumerate() {
        if m.held.get(i) != Some(&true) {
            let id = step.contacts[ci].id;
            m.lambda[m.nb + i] = warm_in(&normals, m.nb + i, id).map_or(0.0, |w| w.normal);
        }
    }
    let frictions = cursors();
    for (f, &i) in m.friction_of.iter().enumerate() {
        let c = &step.contacts[m.lcp_contacts[i]];
        let Some(w) = warm_in(&frictions, m.nb + i, c.id).map(|w| w.friction) else {
            continue;
        };
        let base = m.nb + m.nc + f * m.nd;
        pgs::warm_friction(
            [w.dot(&c.t1), w.dot(&c.t2)],
            m.mu[f] * m.lambda[m.nb + i],
            p.friction_cone == FrictionCone::Circular,
            &mut m.lambda[base..base + m.nd],
        );
    }
}

/// One run on `m`'s rows with the row offsets `offset`: Lemke's islands
/// first (their impulses then stand in the warm start), then PGS on the
/// rest.
fn run(
    solvers: &mut Solvers,
    m: &mut Mlcp,
    offset: &[f64],
    step: Step,
    nu: &mut Vec<f64>,
    (split, done): (&mut Split, &mut split::Exact),
    descend: &[bool],
) -> PgsInfo {
    match solvers.exact.as_mut() {
        Some(exact) => {
            let now = split.exact_islands(exact.lemke, m, step.minv, exact.guess);
            *done = split::Exact {
                pivots: done.pivots + now.pivots,
                rung: done.rung.max_by_ladder(now.rung),
                refined: done.refined | now.refined,
                islands: now.islands,
            };
        }
        None => split.all_iterative(step.groups.len()),
    }
    let problem = PgsProblem {
        rows: &m.rows,
        tails: crate::constraint::coupling::Tails {
            first: m.nb - m.ng,
            rows: &m.tails,
        },
        offset,
        cfm: &m.cfm,
        nb: m.nb,
        nc: m.nc,
        nd: m.nd,
        friction_of: &m.friction_of,
        mu: &m.mu,
        held: &m.held,
        minv: step.minv,
        nu_free: step.nu_free,
        lcp: Lcp {
            n: m.lcp_size(),
            m: &m.lcp_m,
            q: &m.lcp_q,
        },
        circular: step.params.friction_cone == FrictionCone::Circular,
        groups: step.groups,
        iterate: &split.rest,
        descend,
        motor_row: &m.motor_row,
        motor_cap: &m.motor_cap,
        motor_cfm: &m.motor_cfm,
    };
    solvers
        .pgs
        .solve(&problem, solvers.params, &mut m.lambda, nu, &mut m.z)
}

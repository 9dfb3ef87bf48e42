//! The physics engine: a pure library. No files, no sockets, no iceoryx2;
//! bad numbers are reported in the [`StepReport`], never panicked on.
//!
//! One step (formulation.md) is split around the control input, as MuJoCo's
//! `mj_step1`/`mj_step2`:
//!
//! - [`Engine::prepare`]: collision, contact set, inverse masses: everything
//!   that does not depend on the controllers' inputs;
//! - [`Engine::finish`]: applied impulses, pruning, mLCP, solver, recovery,
//!   position update, measurements.
//!
//! [`Engine::step`] is both. Each stage is a file of its own.

pub mod applied;
pub mod collision;
pub mod contact;
pub mod fallback;
pub mod integrate;
pub mod island;
pub mod iterative;
pub mod joint;
pub mod limit;
pub mod measure;
pub mod mlcp;
pub mod model;
pub mod motor;
pub mod project;
pub mod prune;
pub mod report;
pub mod rows;
pub mod sleep;
pub mod solver;
pub mod split;
pub mod state;
#[cfg(test)]
mod testing;

pub use applied::{InputError, Inputs};
pub use fallback::Fallback;
pub use model::{Attachment, Model, Skips, Turning};
pub use report::{LadderCounts, Lap, StepError, StepReport, Timings};
pub use state::{BodyState, State, WarmContact};

use applied::InvMass;
use collision::{Counterpart, Geometry};
use contact::Contact;
use cosim_shared::SolverChoice;
use mlcp::Offsets;
use mlcp::{Assembly, Mlcp};
use nalgebra::Vector3;
use solver::{pgs::Stop, Lemke, LemkeError, Pgs, PgsParams, Rung};

/// With `solver = "auto"`, LCPs larger than this go to PGS alone. Measured
/// on piles of spheres in a box (h = 5e-3, n_d = 8, 200 steps, this
/// machine), PGS at its default tolerance against Lemke: 9.0 ms against
/// 1.1 ms per step at n = 150, 71 ms against 75 ms at n = 590. Lemke grows
/// like n^3 (the tableau), matrix-free PGS like its sweeps times n: they
/// cross near n = 600.
pub const AUTO_PGS_SIZE: usize = 600;

/// Whether the step's solver works without the reduced LCP's matrix: PGS,
/// and `auto` where it will pick PGS (the LCP's size, `nc + nf (n_d + 1)`,
/// above [`AUTO_PGS_SIZE`]). The dense matrix of a large LCP is what is
/// slow: measured on the 4,000-sphere pile with `auto`, 21 s of assembly
/// for a step of 35,000 unknowns, then 8 ms of PGS.
fn matrix_free(p: &model::Params, contacts: &[Contact]) -> bool {
    match p.solver {
        SolverChoice::Pgs => true,
        SolverChoice::Lemke => false,
        SolverChoice::Auto => mlcp::lcp_size_of(contacts, p) > AUTO_PGS_SIZE,
    }
}

/// Lemke's guess for this step's LCP from the last step's final one, by
/// contact identity (as PGS's warm start): each contact that was in it with
/// the same rows keeps its normal, friction and slack flags; a new contact
/// starts inactive. Into `guess`; false when nothing carries over.
///
/// By identity rather than only for an identical layout, so that pruned and
/// full runs stay bit-identical (prune.rs): the full LCP of a run with
/// `full = true` holds the pruned one's contacts plus inactive ones, and
/// gets the same support, hence the same answer, where the guess holds.
fn carry_guess(state: &State, m: &Mlcp, contacts: &[Contact], guess: &mut Vec<bool>) -> bool {
    let (nc, nd, nm) = (m.nc, m.nd, m.nm);
    guess.clear();
    guess.resize(m.lcp_size(), false);
    let prev = &state.warm_lcp;
    let prev_nf = prev.iter().filter(|&&(_, f)| f).count();
    // The last LCP: [p_n; p_f; p_m; s; s_m], the motors the same ones.
    let prev_rows = prev.len() + prev_nf * nd + 2 * nm;
    if state.warm_active.len() != prev_rows + prev_nf + nm || prev.len() + nm == 0 {
        return false;
    }
    // Every motor is in every step's LCP: its pair and slack carry over.
    for k in 0..nm {
        let (src, dst) = (prev.len() + prev_nf * nd + 2 * k, m.motor_pair(k));
        guess[dst..dst + 2].copy_from_slice(&state.warm_active[src..src + 2]);
        guess[m.contact_rows() + m.nf + k] = state.warm_active[prev_rows + prev_nf + k];
    }
    let mut any = nm > 0;
    let mut friction = m.friction_of.iter().enumerate().peekable();
    // Both lists ascend by id (the LCP's contacts are in the contact
    // list's canonical order): one merge, O(n), where a search per contact
    // was O(n^2) (measured: 3 ms a step on the 1,000 pile). `pf` counts
    // the friction contacts of `prev[..j]`.
    let (mut j, mut pf) = (0, 0);
    for (i, &ci) in m.lcp_contacts.iter().enumerate() {
        let f = friction.next_if(|(_, &row)| row == i).map(|(f, _)| f);
        let id = contacts[ci].id;
        while j < prev.len() && prev[j].0 < id {
            pf += usize::from(prev[j].1);
            j += 1;
        }
        if prev
            .get(j)
            .is_none_or(|&(pid, fr)| pid != id || fr != f.is_some())
        {
            continue;
        }
        guess[i] = state.warm_active[j];
        if let Some(f) = f {
            // The last step's friction block of contact j.
            let (src, dst) = (prev.len() + pf * nd, nc + f * nd);
            guess[dst..dst + nd].copy_from_slice(&state.warm_active[src..src + nd]);
            let (src_s, dst_s) = (prev_rows + pf, m.contact_rows() + f);
            guess[dst_s] = state.warm_active[src_s];
        }
        any = true;
    }
    any
}

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

/// One side of an impulse: a body, a plane or the world.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Party {
    World,
    Body(usize),
    Plane(usize),
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

/// Scratch space reused from step to step: after the largest problem has
/// been seen once, a step allocates nothing.
#[derive(Default)]
struct Workspace {
    geoms: Vec<Geometry>,
    contacts: Vec<Contact>,
    minv: Vec<InvMass>,
    nu_free: Vec<f64>,
    nu: Vec<f64>,
    mlcp: Mlcp,
    impulses: Vec<ImpulseRecord>,
    measure: Vec<Geometry>,
    /// The next step's geometry, listed by the measurement
    /// (`look_ahead`), and whether it is still that of the state.
    ahead: Vec<Geometry>,
    ahead_listed: bool,
    /// The penetration of the sleeping bodies' contacts, kept while asleep.
    asleep: measure::Asleep,
    projection: project::Projection,
    /// Bodies in an impact this step (the trapezoid update skips them).
    impulsive: Vec<bool>,
    /// The new poses, checked before they are written.
    poses: Vec<integrate::Pose>,
    /// The broad phase: its scratch, each body's covered reach (m) this
    /// step, and `(id, in_lcp)` of the contacts while it widens.
    collision: collision::Scratch,
    reach: Vec<f64>,
    kept: Vec<(usize, bool)>,
    /// The awake bodies, and the listings at which `reach`, `minv` and
    /// `nu_free` were last written for every body (a sleeping body's entry
    /// is a constant, a zero and zeros: kept while no body sleeps or wakes).
    awake: sleep::Awake,
    reach_written: sleep::Written,
    minv_written: sleep::Written,
    nu_free_written: sleep::Written,
    /// The warm starts of sleeping islands' contacts, kept while they are
    /// not listed (`record_impulses`), and the listing of `awake` they were
    /// picked at (a restored state moves it: picked again from its list).
    sleeping_warm: Vec<WarmContact>,
    sleeping_picked: sleep::Written,
    /// Scratch of `record_impulses` while some contacts sleep: the listed
    /// contacts' warm starts, and where the last merge put them among the
    /// sleeping ones' in the state's list (valid while `merged` holds).
    listed_warm: Vec<WarmContact>,
    listed_at: Vec<u32>,
    merged: bool,
    islands: island::Islands,
    /// The step's rows by island, solved each on its own, and the last
    /// solve's islands (the step report's, once the step succeeded).
    groups: island::Groups,
    summary: island::Summary,
    /// Lemke's guess for this step's LCP (see `carry_guess`).
    guess: Vec<bool>,
    fallback: fallback::Scratch,
    iterative: iterative::Scratch,
}

/// The geometry the collision stage lists for `state` into `out`, with
/// each body's `reach` (m). A contact with no awake body is not listed
/// (`sleep::unlisted`). `awake`: the awake bodies as listed for `state`
/// (see `collision::Still`: the sleeping ones, and their reach, are the
/// same while the listing stands).
fn list(
    model: &Model,
    state: &State,
    reach: &[f64],
    awake: &sleep::Awake,
    scratch: &mut collision::Scratch,
    out: &mut Vec<Geometry>,
) {
    let p = &model.params;
    let listing = if p.broad_phase() {
        collision::Listing::Within {
            reach,
            margin: p.contact_margin,
            still: Some(collision::Still {
                key: awake.listing(),
                active: awake.bodies(),
            }),
        }
    } else {
        collision::Listing::All
    };
    collision::detect(model, state, listing, collision::Keep::Awake, scratch, out);
}

/// The speed bound of a body over the step that the broad phase must
/// cover: the start or the free speed (what `prune::select` uses), or the
/// new speed after a solve (what `prune::check_left_out` uses).
#[derive(Debug, Clone, Copy)]
enum Speeds {
    Free,
    New,
}

impl Workspace {
    /// Collision, contact set and inverse masses of `state`. The broad
    /// phase covers, for each body, the distance it travels in the step at
    /// its start speed plus twice what gravity adds in a step (a body at
    /// rest then needs no widening); `widen` grows that when the free or
    /// the new velocities reach farther.
    fn contact_set(&mut self, model: &Model, state: &State) {
        if std::mem::take(&mut self.ahead_listed) {
            // `look_ahead` listed this very state's geometry (same reach,
            // kept in `reach` since; same listing, same sleep): taken,
            // not detected again.
            std::mem::swap(&mut self.geoms, &mut self.ahead);
            // The two grow together: swapped every step, the smaller one
            // would be the step's every other step, and a widening then
            // reallocated it (tests/tests/no_allocation.rs found it).
            let cap = self.geoms.capacity().max(self.ahead.capacity());
            self.geoms.reserve(cap - self.geoms.len());
            self.ahead.clear();
            self.ahead.reserve(cap);
            self.build(model, state);
        } else {
            self.reach_of(model, state);
            self.detect(model, state);
        }
        // Zero for a sleeping body: static for the step.
        let only = self.awake.only(state, &mut self.minv_written);
        applied::inverse_masses(model, state, only, &mut self.minv);
    }

    /// Each body's reach over the step from `state` (see `contact_set`).
    /// A sleeping body's is that of a body at rest, the same at every
    /// step: written again only when a body slept or woke.
    fn reach_of(&mut self, model: &Model, state: &State) {
        let p = &model.params;
        let g = p.gravity.norm();
        let of = |i: usize| {
            let (b, m) = (&state.bodies[i], &model.bodies[i]);
            p.h * (b.v.norm() + b.w.norm() * m.shape.spin_reach() + 2.0 * p.h * g)
        };
        match self.awake.only(state, &mut self.reach_written) {
            Some(awake) => {
                for &i in awake {
                    self.reach[i as usize] = of(i as usize);
                }
            }
            None => {
                self.reach.clear();
                self.reach.extend((0..state.bodies.len()).map(of));
            }
        }
    }

    /// The geometry the next `contact_set` lists for `state`, into
    /// `ahead`, which it then takes instead of detecting again; returns
    /// the deepest penetration among those with an awake body. Why: the
    /// step's measurement needs every overlapping contact of the new
    /// poses, and the next step's collision stage lists a superset of
    /// those at the same poses: one detection serves both (measured on the
    /// 10,000 pile: the measurement, mostly its own detection, took 2.9 ms
    /// of a 58 ms step). Only `Engine::set_state` and a wake by an input
    /// change the state in between: they drop it (`ahead_listed`).
    fn look_ahead(&mut self, model: &Model, state: &State) -> f64 {
        self.reach_of(model, state);
        list(
            model,
            state,
            &self.reach,
            &self.awake,
            &mut self.collision,
            &mut self.ahead,
        );
        self.ahead_listed = true;
        measure::deepest(&self.ahead)
    }

    fn detect(&mut self, model: &Model, state: &State) {
        self.awake.refresh(state);
        list(
            model,
            state,
            &self.reach,
            &self.awake,
            &mut self.collision,
            &mut self.geoms,
        );
        self.build(model, state);
    }

    /// The contacts of the listed geometry, and the joint limits'.
    fn build(&mut self, model: &Model, state: &State) {
        contact::build(model, state, &self.geoms, &mut self.contacts);
        limit::limits(model, state, &mut self.contacts);
    }

    /// Grows the broad phase's reach where a body's speed bound `speed(i)`
    /// (m/s, over the step) goes past it, and lists the contacts that adds;
    /// the contacts listed before keep their `in_lcp`, the new ones are left
    /// out (`prune::check_left_out` then tests them). Returns whether the
    /// list changed. Without the broad phase every pair is listed already.
    fn widen(&mut self, model: &Model, state: &State, speeds: Speeds) -> bool {
        let p = &model.params;
        if !p.broad_phase() {
            return false;
        }
        let mut grown = false;
        // A sleeping body does not move: its speed is zero.
        self.awake.refresh(state);
        for &i in self.awake.bodies() {
            let (i, r) = (i as usize, &mut self.reach[i as usize]);
            let speed = match speeds {
                Speeds::Free => prune::surface_speed(model, i, Some(state), &self.nu_free),
                Speeds::New => prune::surface_speed(model, i, None, &self.nu),
            };
            let need = p.h * speed;
            if need > *r {
                // Twice what is needed: one widening per step, not one per
                // re-solve.
                *r = 2.0 * need;
                grown = true;
            }
        }
        if !grown {
            return false;
        }
        let before = self.contacts.len();
        self.kept.clear();
        self.kept
            .extend(self.contacts.iter().map(|c| (c.id, c.in_lcp)));
        self.detect(model, state);
        // Both lists are sorted by id (canonical order): merge.
        let mut k = self.kept.iter().peekable();
        for c in self.contacts.iter_mut() {
            while k.next_if(|&&(id, _)| id < c.id).is_some() {}
            c.in_lcp = k.next_if(|&&(id, _)| id == c.id).is_some_and(|&(_, f)| f);
        }
        self.contacts.len() != before
    }

    /// The free velocity under `inputs` and the contacts it selects for
    /// the LCP: `prepare` with the inputs held so far, `solve` with the
    /// step's own.
    fn select(&mut self, model: &Model, state: &State, inputs: &Inputs) {
        // Zero for a sleeping body: static for the step.
        let only = self.awake.only(state, &mut self.nu_free_written);
        applied::free_velocity(model, state, inputs, &self.minv, only, &mut self.nu_free);
        if self.widen(model, state, Speeds::Free) {
            // The contact indices changed: a matrix made for the old list
            // would be taken for the new one.
            self.mlcp.invalidate();
        }
        prune::select(&mut self.contacts, model, state, &self.nu_free);
    }
}

pub struct Engine {
    model: Model,
    state: State,
    inputs: Inputs,
    ws: Workspace,
    lemke: Lemke,
    pgs: Pgs,
    pgs_params: PgsParams,
    prepared: bool,
    collision_time: f64,
    /// Time `prepare` spent on the matrix part, counted as assembly.
    early_assembly: f64,
    /// Contacts projected out of deep penetration by this step's prepare.
    projected: usize,
    /// A body impulse waits for the next step (`add_body_impulse`).
    impulse_pending: bool,
    /// Every body was asleep when the last step ended.
    all_asleep: bool,
    /// The report of the last step that began and ended with every body
    /// asleep and had no input, while nothing has changed since: the
    /// report of every such step until then (see [`Engine::idle_step`]).
    idle: Option<StepReport>,
    /// `prepare` ran before this idle step.
    idle_prepared: bool,
}

impl Engine {
    pub fn new(model: Model) -> Engine {
        let max_pivots = model.params.lemke_max_pivots;
        let state = State::initial(&model);
        let inputs = Inputs::new(&model);
        Engine {
            pgs: Pgs::default(),
            pgs_params: model.params.pgs,
            model,
            state,
            inputs,
            ws: Workspace::default(),
            lemke: Lemke::with_max_pivots(max_pivots),
            prepared: false,
            collision_time: 0.0,
            early_assembly: 0.0,
            projected: 0,
            impulse_pending: false,
            all_asleep: false,
            idle: None,
            idle_prepared: false,
        }
    }

    pub fn model(&self) -> &Model {
        &self.model
    }

    pub fn state(&self) -> &State {
        &self.state
    }

    /// Restores a state (a snapshot taken with `state().clone()`).
    pub fn set_state(&mut self, mut state: State) {
        // The guess buffers change length from step to step: keep the ones
        // that grew during warm-up, so that a restore does not make the
        // next steps allocate.
        let mine = &mut self.state;
        mine.warm_active.clear();
        mine.warm_active.extend_from_slice(&state.warm_active);
        mine.warm_lcp.clear();
        mine.warm_lcp.extend_from_slice(&state.warm_lcp);
        mine.warm_contacts.clear();
        mine.warm_contacts.extend_from_slice(&state.warm_contacts);
        std::mem::swap(&mut mine.warm_active, &mut state.warm_active);
        std::mem::swap(&mut mine.warm_lcp, &mut state.warm_lcp);
        std::mem::swap(&mut mine.warm_contacts, &mut state.warm_contacts);
        self.state = state;
        self.prepared = false;
        self.ws.ahead_listed = false;
        self.all_asleep = false;
        self.idle = None;
        // Its sleeping bodies need not be at rest where the kept entries
        // (`Workspace::awake`) were written, nor its warm starts be those
        // the sleeping part was picked from (`sleeping_warm`).
        self.ws.awake.forget();
    }

    /// Tolerance, iteration cap and relaxation of the iterative solver.
    pub fn set_pgs_params(&mut self, params: PgsParams) {
        self.pgs_params = params;
        self.idle = None;
    }

    pub fn inputs(&self) -> &Inputs {
        &self.inputs
    }

    /// Sets the held effort of joint `joint` until changed: a torque
    /// (N m), `+torque` on body_b and `-torque` on body_a; for a slider a
    /// force (N) on body_b at its anchor and its opposite on body_a there
    /// (its part along the axis drives the slide). ROS's `effort`,
    /// MuJoCo's generalised force.
    pub fn set_joint_torque(
        &mut self,
        joint: usize,
        torque: Vector3<f64>,
    ) -> Result<(), InputError> {
        let joints = self.model.joints.len();
        if joint >= joints {
            return Err(InputError::UnknownJoint {
                index: joint,
                joints,
            });
        }
        if !torque.iter().all(|x| x.is_finite()) {
            return Err(InputError::NonFinite {
                what: "torque of joint",
                index: joint,
            });
        }
        self.inputs.joint_torque[joint] = torque;
        self.idle = None;
        Ok(())
    }

    /// Sets the target rate of joint `joint`'s motor until changed (rad/s
    /// for a hinge, m/s for a slider; `motor.rs`): Rapier's
    /// `set_motor_velocity`, ODE's `dParamVel`.
    pub fn set_motor_speed(&mut self, joint: usize, speed: f64) -> Result<(), InputError> {
        let joints = self.model.joints.len();
        if joint >= joints {
            return Err(InputError::UnknownJoint {
                index: joint,
                joints,
            });
        }
        if self.model.joints[joint].motor.is_none() {
            return Err(InputError::NoMotor { index: joint });
        }
        if !speed.is_finite() {
            return Err(InputError::NonFinite {
                what: "motor speed of joint",
                index: joint,
            });
        }
        self.inputs.motor_speed[joint] = speed;
        self.idle = None;
        Ok(())
    }

    /// Adds a world-frame impulse (N s) and angular impulse (N m s) to body
    /// `body` for the next step only.
    pub fn add_body_impulse(
        &mut self,
        body: usize,
        linear: Vector3<f64>,
        angular: Vector3<f64>,
    ) -> Result<(), InputError> {
        let bodies = self.model.bodies.len();
        if body >= bodies {
            return Err(InputError::UnknownBody {
                index: body,
                bodies,
            });
        }
        if !(linear.iter().chain(angular.iter()).all(|x| x.is_finite())) {
            return Err(InputError::NonFinite {
                what: "impulse on body",
                index: body,
            });
        }
        let imp = &mut self.inputs.body_impulse[body];
        imp.0 += linear;
        imp.1 += angular;
        self.impulse_pending = true;
        Ok(())
    }

    /// The impulses of the last step (normal, friction, joint).
    pub fn impulses(&self) -> &[ImpulseRecord] {
        &self.ws.impulses
    }

    /// The velocities `[v_i, w_i]` per body that the last step's solve gave
    /// and the position update used: the state's, except that an island
    /// the step put to sleep has zero in the state (`sleep::update`).
    pub fn solved_velocities(&self) -> &[f64] {
        &self.ws.nu
    }

    /// The contact set of the last step, every potential contact included.
    pub fn contacts(&self) -> &[Contact] {
        &self.ws.contacts
    }

    /// The last step's pure LCP `(n, M row-major, q)`, for tests and tools.
    pub fn last_lcp(&self) -> (usize, &[f64], &[f64]) {
        let m = &self.ws.mlcp;
        (m.lcp_size(), &m.lcp_m, &m.lcp_q)
    }

    /// One whole step.
    pub fn step(&mut self) -> StepReport {
        if let Some(report) = self.idle_step() {
            return report;
        }
        self.prepare_contacts();
        self.finish()
    }

    /// Whether the next step is idle (see [`Engine::idle_step`]).
    fn idles(&self) -> bool {
        self.model.params.skips.idle && !self.impulse_pending && self.idle.is_some()
    }

    /// A step of a world asleep whole, with no input: what it changes is
    /// the clock. A sleeping body keeps its pose and zero velocity to the
    /// bit, nothing is listed (every contact has no awake body, and no
    /// body is on a joint: such bodies never sleep), so no impulse, warm
    /// start or measurement changes; the first such step runs every stage
    /// and its report is kept (`idle`) as the report of those that follow,
    /// with their step, time and timings. `None` where the step must run:
    /// an input (a body impulse wakes its island; torques, motor targets
    /// and solver parameters drop the kept report), a restored state, or
    /// `Skips::idle` off.
    ///
    /// Why: a sleeping 1,000-sphere pile's step cost about 50 us, in ten
    /// passes over the bodies that each found every body asleep (reach,
    /// inverse masses, free velocity, the pose copy, the sleep update, the
    /// energy, the sleeping poses' comparison); Box2D and Rapier step a
    /// world asleep in constant time.
    fn idle_step(&mut self) -> Option<StepReport> {
        if !self.idles() {
            return None;
        }
        let kept = self.idle.as_ref()?;
        let lap = Lap::start();
        self.state.step += 1;
        self.state.t = self.state.step as f64 * self.model.params.h;
        let report = StepReport {
            step: self.state.step,
            t: self.state.t,
            early_matrix: std::mem::take(&mut self.idle_prepared),
            timings: Timings {
                total: lap.total(),
                ..Timings::default()
            },
            ..*kept
        };
        Some(report)
    }

    /// The part of the step that needs no input, for a caller that has
    /// time before the inputs arrive (the lockstep server, while the
    /// controllers compute): collision, contact set, inverse masses, and the
    /// matrix part of the mLCP for the contacts that the inputs held so far
    /// would select (see `Mlcp::matrix_for`). `finish` keeps that matrix
    /// when the actual inputs select the same contacts, cuts it down when
    /// they select fewer, and builds afresh otherwise: the step's bits are
    /// the same as `step`'s either way. Idempotent until the state changes.
    pub fn prepare(&mut self) {
        if self.idles() {
            // An idle step prepares nothing (`idle_step`), but says, as
            // the full one would, that its (empty) matrix was made early.
            self.idle_prepared = true;
            return;
        }
        let Some(mut lap) = self.prepare_contacts() else {
            return;
        };
        let _span = tracing::trace_span!("assemble_early").entered();
        let (model, ws) = (&self.model, &mut self.ws);
        ws.select(model, &self.state, &self.inputs);
        // A failure here is the step's to report: finish builds again.
        let _ = ws.mlcp.matrix_for(
            model,
            &self.state,
            &ws.contacts,
            &ws.minv,
            matrix_free(&model.params, &ws.contacts),
        );
        self.early_assembly = lap.lap();
    }

    /// Collision, contact set and inverse masses (and the projection out of
    /// deep penetration), once per state: `None` when done already, else
    /// the clock at its end.
    fn prepare_contacts(&mut self) -> Option<Lap> {
        if self.prepared {
            return None;
        }
        let mut lap = Lap::start();
        self.ws.mlcp.invalidate();
        self.early_assembly = 0.0;
        let _span = tracing::trace_span!("collision").entered();
        let ws = &mut self.ws;
        ws.contact_set(&self.model, &self.state);
        // Islands an awake body touches wake; their own contacts were left
        // out, so the set is listed again (each round can reach another
        // sleeping island; at most one round per island).
        if self.model.params.sleep.is_some() {
            let reach = sleep::Reach::of(&self.model, &self.pgs_params);
            while sleep::wake_touched(&mut self.state, &ws.contacts, reach) {
                ws.contact_set(&self.model, &self.state);
            }
        }
        let depth = project::Depth::of(&self.model.params, &self.pgs_params);
        self.projected = match depth.map(|depth| {
            project::deep_penetration(
                &ws.contacts,
                &ws.minv,
                &self.model.jointed,
                depth,
                &mut self.state,
                &mut self.lemke,
                &mut ws.projection,
            )
        }) {
            None => 0,
            Some(Ok(n)) => n,
            Some(Err(e)) => {
                // The velocity stabilisation still acts on the contacts.
                tracing::warn!("projection out of deep penetration failed: {e}");
                0
            }
        };
        if self.projected > 0 {
            // The bodies moved: their contacts are those of the new positions.
            ws.contact_set(&self.model, &self.state);
        }
        self.collision_time = lap.lap();
        self.prepared = true;
        Some(lap)
    }

    /// The rest of the step, with the inputs as they are now. On failure the
    /// state is left unchanged and the report says why.
    pub fn finish(&mut self) -> StepReport {
        if let Some(report) = self.idle_step() {
            return report;
        }
        // The step may be idle (see `idle_step`): it began with every body
        // asleep and has no input.
        let pending = std::mem::take(&mut self.impulse_pending);
        let began_idle = self.all_asleep && !pending;
        self.idle = None;
        self.idle_prepared = false;
        if pending && self.wake_on_inputs() {
            self.prepared = false;
            self.ws.ahead_listed = false;
        }
        self.prepare_contacts();
        let mut lap = Lap::start();
        let mut timings = Timings {
            collision: self.collision_time,
            assemble: self.early_assembly,
            // The wall time of prepare, then (in `measure`) of finish.
            total: self.collision_time + std::mem::take(&mut self.early_assembly),
            ..Timings::default()
        };
        let p = &self.model.params;
        let mut report = StepReport {
            step: self.state.step + 1,
            t: (self.state.step + 1) as f64 * p.h,
            solver: p.solver.as_str(),
            error: None,
            pivots: 0,
            residual: 0.0,
            lcp_size: 0,
            contacts_in_lcp: 0,
            active_contacts: 0,
            resolves: 0,
            left_out: 0,
            not_converged: false,
            regularized: 0,
            refined: 0,
            rung: Rung::Other,
            fallback: None,
            energy_refused: false,
            energy_allowance: 0.0,
            projected: std::mem::take(&mut self.projected),
            early_matrix: false,
            max_penetration: 0.0,
            max_joint_error: 0.0,
            max_joint_angle_error: 0.0,
            islands: 0,
            largest_island: 0,
            lemke_islands: 0,
            pgs_islands: 0,
            sleeping: 0,
            energy: Default::default(),
            timings,
        };

        let mut solved = self.solve(&mut report, &mut timings, &mut lap);
        if solved.is_ok() {
            let _span = tracing::trace_span!("integrate").entered();
            self.mark_impulsive();
            let p = &self.model.params;
            let ws = &mut self.ws;
            ws.awake.refresh(&self.state);
            solved = integrate::positions(
                &mut self.state,
                &ws.nu,
                p.h,
                p.position_update,
                &ws.impulsive,
                ws.awake.bodies(),
                &mut ws.poses,
            )
            .map_err(|body| StepError::NonFinitePose { body });
        }
        if pending {
            self.inputs.clear_impulses();
        }
        if let Err(e) = solved {
            report.error = Some(e);
            self.ws.impulses.clear();
            self.prepared = true; // the state did not change
            report.step = self.state.step;
            report.t = self.state.t;
            return self.measure(report, timings, lap);
        }

        {
            self.state.step += 1;
            self.state.t = self.state.step as f64 * self.model.params.h;
            self.prepared = false;
        }
        self.record_impulses();
        let summary = self.ws.summary;
        report.islands = summary.count;
        report.largest_island = summary.largest;
        if let Some(params) = self.model.params.sleep {
            let _span = tracing::trace_span!("sleep").entered();
            sleep::update(
                &self.model,
                &params,
                &self.pgs_params,
                &mut self.state,
                &self.ws.contacts,
                &mut self.ws.awake,
                &mut self.ws.islands,
            );
        }
        report.sleeping = sleep::count(&self.state);
        report.active_contacts = self
            .ws
            .impulses
            .iter()
            .filter(|r| r.kind == ImpulseKind::Normal)
            .count();
        timings.integrate = lap.lap();
        let report = self.measure(report, timings, lap);
        self.all_asleep = report.sleeping > 0 && report.sleeping == self.model.bodies.len();
        if began_idle && self.all_asleep {
            self.idle = Some(report);
        }
        report
    }

    /// Applied impulses, pruning, mLCP, solver and recovery, repeated while
    /// the velocity check adds left-out contacts. Leaves `nu'` in `ws.nu`.
    fn solve(
        &mut self,
        report: &mut StepReport,
        timings: &mut Timings,
        lap: &mut Lap,
    ) -> Result<(), StepError> {
        let model = &self.model;
        let ws = &mut self.ws;
        ws.select(model, &self.state, &self.inputs);
        let p = &model.params;
        let mut canonical = false;
        let mut pgs_settled;
        // The last solve was PGS's (whole or by island).
        let mut pgs_solved;
        // PGS's cap bounds the step's sweeps over all its solves: each
        // re-solve gets what the earlier ones left. Measured without it: a
        // settling 10,000 pile re-solved 35 times in one step, each solve
        // to the cap (172,618 sweeps, 396 s), because every unconverged
        // answer closes a few more of the contacts pruning left out.
        let mut sweeps_left = self.pgs_params.max_iterations;
        // The next solve starts from the last one's answer
        // (`iterative::Scratch::keep_attempt`).
        let mut from_attempt = false;
        // The last solve's answer is of a fallback formulation.
        let mut relaxed = false;
        loop {
            {
                let _span = tracing::trace_span!("assemble").entered();
                // Kept from `prepare` when these inputs select the same
                // contacts; cut down for the canonical re-solve.
                let how = ws
                    .mlcp
                    .matrix_for(
                        model,
                        &self.state,
                        &ws.contacts,
                        &ws.minv,
                        matrix_free(p, &ws.contacts),
                    )
                    .map_err(StepError::Mlcp)?;
                report.early_matrix |= report.resolves == 0 && !canonical && how != Assembly::Built;
                ws.mlcp.set_motor_speeds(model, &self.inputs.motor_speed);
                ws.mlcp.rhs(&ws.nu_free, &ws.contacts, p, Offsets::Full);
                report.regularized += usize::from(ws.mlcp.joint_regularized);
            }
            // Pruning, the velocity checks and the cuts count as assembly.
            timings.assemble += lap.lap();
            {
                let _span = tracing::trace_span!("solve").entered();
                let m = &mut ws.mlcp;
                ws.summary =
                    ws.islands
                        .group(model.bodies.len(), &m.rows[..m.nb + m.nc], &mut ws.groups);
                let step = fallback::Step {
                    nu_free: &ws.nu_free,
                    contacts: &ws.contacts,
                    params: p,
                    minv: &ws.minv,
                    awake: ws.awake.bodies(),
                    groups: &ws.groups,
                };
                let n = m.lcp_size();
                m.z.clear();
                m.z.resize(n, 0.0);
                report.lcp_size = report.lcp_size.max(n);
                report.contacts_in_lcp = report.contacts_in_lcp.max(m.nc);
                let mut use_pgs = match p.solver {
                    SolverChoice::Lemke => false,
                    SolverChoice::Pgs => true,
                    SolverChoice::Auto => n > AUTO_PGS_SIZE,
                };
                report.solver = match (p.solver, use_pgs) {
                    (SolverChoice::Auto, true) => "pgs (auto: size)",
                    (SolverChoice::Auto, false) => "lemke (auto)",
                    (s, _) => s.as_str(),
                };
                if !use_pgs {
                    // The last step's support first, carried over by
                    // contact identity: a resting or steadily sliding
                    // contact keeps it, and then no pivoting is needed.
                    let guess = (p.skips.lemke_guess
                        && carry_guess(&self.state, m, &ws.contacts, &mut ws.guess))
                    .then_some(&ws.guess[..]);
                    let solved = fallback::solve(
                        &mut self.lemke,
                        m,
                        guess,
                        step,
                        &mut ws.nu,
                        &mut ws.fallback,
                    );
                    match solved {
                        Ok(s) => {
                            relaxed = report.took(s.fallback, s.energy_refused, s.allowance);
                            report.lemke_islands = ws.fallback.islands();
                            report.pgs_islands = 0;
                            let info = s.info;
                            report.pivots += info.work;
                            report.regularized += usize::from(info.regularized());
                            report.refined += usize::from(info.refined);
                            report.rung = report.rung.max_by_ladder(info.rung);
                            report.residual = report.residual.max(info.residual);
                        }
                        // auto: the fallback the step report names.
                        Err(
                            LemkeError::RayTermination { .. }
                            | LemkeError::PivotLimit { .. }
                            | LemkeError::NumericalBreakdown { .. },
                        ) if p.solver == SolverChoice::Auto => {
                            use_pgs = true;
                            report.solver = "pgs (auto: lemke failed)";
                        }
                        Err(e) => return Err(StepError::Lemke(e)),
                    }
                }
                // Whether a PGS answer is final without the canonical
                // re-solve (see the NOTE below).
                pgs_settled = false;
                pgs_solved = use_pgs;
                if use_pgs {
                    // auto on a large step: Lemke still takes the small
                    // islands (split.rs), from the last support.
                    let by_size = p.solver == SolverChoice::Auto && n > AUTO_PGS_SIZE;
                    let exact = by_size.then(|| iterative::Exact {
                        guess: (p.skips.lemke_guess
                            && carry_guess(&self.state, m, &ws.contacts, &mut ws.guess))
                        .then_some(&ws.guess[..]),
                        lemke: &mut self.lemke,
                    });
                    let budget = PgsParams {
                        max_iterations: sweeps_left,
                        ..self.pgs_params
                    };
                    let mut solvers = iterative::Solvers {
                        pgs: &mut self.pgs,
                        params: &budget,
                        exact,
                        from_attempt,
                    };
                    let solved = iterative::solve(
                        &mut solvers,
                        m,
                        &self.state,
                        step,
                        &mut ws.nu,
                        &mut ws.iterative,
                    );
                    relaxed = report.took(solved.fallback, solved.energy_refused, solved.allowance);
                    let exact = ws.iterative.exact();
                    report.lemke_islands = exact.islands;
                    report.pgs_islands = ws.iterative.iterated();
                    if exact.islands > 0 {
                        report.solver = if report.pgs_islands > 0 {
                            "lemke+pgs (auto: by island)"
                        } else {
                            "lemke (auto: by island)"
                        };
                        report.rung = report.rung.max_by_ladder(exact.rung);
                        report.refined += usize::from(exact.refined);
                    }
                    sweeps_left = sweeps_left.saturating_sub(solved.info.iterations);
                    report.pivots += solved.info.iterations + exact.pivots;
                    report.residual = report.residual.max(solved.info.residual);
                    report.not_converged |= !solved.info.converged;
                    pgs_settled = solved.info.converged
                        && solved.fallback.is_none()
                        && self.pgs_params.stop == Stop::Residual;
                }
            }
            timings.solve += lap.lap();
            // A sleeping body's velocities are its free velocity, zero,
            // plus its zero inverse mass times impulses that are finite
            // where the awake bodies' velocities are.
            let finite = |&i: &u32| {
                ws.nu[6 * i as usize..6 * i as usize + 6]
                    .iter()
                    .all(|x| x.is_finite())
            };
            if !ws.awake.bodies().iter().all(finite) {
                return Err(StepError::NonFinite);
            }
            // Pairs the new velocities could bring into reach are listed
            // first, left out, so that the check below tests them too. The
            // list's indices then changed: the LCP's contacts are found
            // again by id, and its matrix and answer stand (the same rows;
            // solving it again gave the same bits and cost a whole solve:
            // measured, a third of a settling pile's sweeps).
            if ws.widen(model, &self.state, Speeds::New) {
                let kept = &ws.kept;
                ws.mlcp.remap(|ci| kept[ci].0, &ws.contacts);
            }
            let added = prune::check_left_out(&mut ws.contacts, &ws.nu, p.h, relaxed);
            if added > 0 {
                if sweeps_left == 0 {
                    // The answer stands, short of the contacts it would
                    // close: they enter the next step's LCP, as
                    // penetrating contacts if they close within this one.
                    report.not_converged = true;
                    report.left_out = added;
                    return Ok(());
                }
                report.resolves += 1;
                // Not for the canonical re-solve below: its answer must
                // depend on its contact set alone (prune.rs).
                from_attempt = pgs_solved;
                if pgs_solved {
                    ws.iterative.keep_attempt(&ws.mlcp, &ws.contacts);
                }
                continue;
            }
            from_attempt = false;
            // NOTE: once, after the first accepted solve: re-solve on the
            // active contacts only, so that the answer depends on the active
            // set alone (see prune.rs). Not after a converged rigid PGS
            // answer under the residual rule (piles): that answer is defined
            // to a loose tolerance only, and the re-solve cost as many
            // sweeps again (the 1,000 pile, 300 steps: 12.4 s against 6.1
            // s). Under the distance rule it stays: pruned and full runs
            // then give the same bits, and on the reference scene's
            // closed-loop steps, without it, the energy check relaxed 733
            // steps in a row (10 s: 2.5 million sweeps against 0.2).
            if canonical || pgs_settled || sweeps_left == 0 {
                return Ok(());
            }
            canonical = true;
            if !prune::keep_active(&mut ws.contacts, &ws.mlcp, &ws.nu) {
                return Ok(());
            }
        }
    }

    /// Wakes the sleeping islands that this step's body impulses push;
    /// true when one woke (its contacts must then be listed). Only called
    /// with an impulse pending (`impulse_pending`): the pass over every
    /// body's impulse, and the one that clears them, are for such steps.
    fn wake_on_inputs(&mut self) -> bool {
        if !sleep::any_asleep(&self.state) {
            return false;
        }
        let mut woke = false;
        for (i, (l, a)) in self.inputs.body_impulse.iter().enumerate() {
            if *l != Vector3::zeros() || *a != Vector3::zeros() {
                woke |= sleep::wake_body(&mut self.state, i);
            }
        }
        woke
    }

    /// For the trapezoid update, the bodies that keep the Euler update: the
    /// bodies of every contact that carried an impulse while approaching
    /// faster than the restitution threshold (an impact), and every body on
    /// a joint.
    fn mark_impulsive(&mut self) {
        let ws = &mut self.ws;
        ws.impulsive.clear();
        ws.impulsive.resize(self.model.bodies.len(), false);
        if self.model.params.position_update != cosim_shared::PositionUpdate::Trapezoid {
            return;
        }
        let m = &ws.mlcp;
        for (i, &ci) in m.lcp_contacts.iter().enumerate() {
            let c = &ws.contacts[ci];
            if m.z[i] > 0.0 && c.v_n < -self.model.params.restitution_threshold {
                ws.impulsive[c.geom.a] = true;
                if let Counterpart::Body(j) = c.geom.b {
                    ws.impulsive[j] = true;
                }
            }
        }
        // Jointed bodies keep the Euler update: the joint rows constrain v'
        // at the start-of-step positions, and the mean with v (which met
        // them at the previous positions) drifts off the joint manifold.
        // Measured: the S4 chain gained energy without bound.
        for j in &self.model.joints {
            for a in [j.a, j.b] {
                if let Attachment::Body(i) = a {
                    ws.impulsive[i] = true;
                }
            }
        }
    }

    /// The step's impulses as records, from the solved mLCP; also keeps
    /// them as the next step's warm start.
    fn record_impulses(&mut self) {
        let party = |a: Attachment| match a {
            Attachment::World => Party::World,
            Attachment::Body(i) => Party::Body(i),
        };
        let ws = &mut self.ws;
        let m = &ws.mlcp;
        ws.impulses.clear();
        self.state.warm_joint[..m.nb].copy_from_slice(&m.p_b);
        for (k, &j) in self.model.motors.iter().enumerate() {
            let p = m.motor_impulse(k);
            self.state.warm_joint[m.nb + k] = p;
            if p != 0.0 {
                let joint = &self.model.joints[j];
                ws.impulses.push(ImpulseRecord {
                    kind: ImpulseKind::JointMotor,
                    index: j,
                    a: party(joint.a),
                    b: party(joint.b),
                    impulse: motor::impulse_on_a(&m.motor_axis[k], p),
                });
            }
        }
        self.state.warm_lcp.clear();
        self.state.warm_active.clear();
        self.state
            .warm_active
            .extend(m.z[..m.lcp_size()].iter().map(|&x| x > 0.0));
        // A sleeping island's contacts are not listed: their warm starts
        // stay (ascending id), merged back below, so that a woken island
        // starts from its impulses, not from zero. While no body slept or
        // woke since they were picked, they are the ones picked last step:
        // the last step's listed contacts each had an awake body and still
        // have, the unlisted ones still have none. (Picking them again
        // looked up every contact's bodies: a fifth of the step of a
        // sleeping pile.)
        let listing = ws.awake.refresh(&self.state);
        if ws.sleeping_picked.every_body(listing) {
            // Picked again: the state's list is merged afresh below.
            ws.merged = false;
            ws.sleeping_warm.clear();
            if sleep::any_asleep(&self.state) {
                let (model, state) = (&self.model, &self.state);
                ws.sleeping_warm
                    .extend(state.warm_contacts.iter().filter(|w| {
                        let (a, b) = model.contact_bodies(w.id);
                        sleep::unlisted(state, a, b)
                    }));
            }
        }
        // Filled below in the LCP's contact order, which is ascending id:
        // the state's list itself when no contact sleeps, else the listed
        // part, then merged with the sleeping one.
        let alone = ws.sleeping_warm.is_empty();
        if alone {
            self.state.warm_contacts.clear();
        }
        ws.listed_warm.clear();
        for (j, joint) in self.model.joints.iter().enumerate() {
            // The anchor's force impulse and, for a joint with rotation
            // rows, their torque impulse.
            let first = self.model.joint_start[j];
            let (p, tau) = joint::impulses_on_a(joint, &m.rows[first..], &m.p_b[first..]);
            let record = |kind, impulse| ImpulseRecord {
                kind,
                index: j,
                a: party(joint.a),
                b: party(joint.b),
                impulse,
            };
            ws.impulses.push(record(ImpulseKind::Joint, p));
            if joint.rows() > joint.anchor_rows() {
                ws.impulses.push(record(ImpulseKind::JointTorque, tau));
            }
        }
        for (i, warm, block) in m.contact_impulses(&ws.contacts) {
            let c = &ws.contacts[m.lcp_contacts[i]];
            let b = match c.geom.b {
                Counterpart::Plane(p) => Party::Plane(p),
                Counterpart::Body(j) => Party::Body(j),
                Counterpart::World => Party::World,
            };
            let record = |kind, impulse| ImpulseRecord {
                kind,
                index: c.id,
                a: Party::Body(c.geom.a),
                b,
                impulse,
            };
            if let Some(limit) = c.limit {
                // The row's first side is A's, or B's when A is the world
                // (limit.rs); on it the row's impulse is the normal times
                // z (a force along an along-row, a couple about a turning
                // one).
                let joint = &self.model.joints[limit.joint];
                let on_a = match joint.a {
                    Attachment::Body(_) => c.geom.normal * m.z[i],
                    Attachment::World => -c.geom.normal * m.z[i],
                };
                if m.z[i] > 0.0 {
                    ws.impulses.push(ImpulseRecord {
                        kind: ImpulseKind::JointLimit,
                        index: limit.joint,
                        a: party(joint.a),
                        b: party(joint.b),
                        impulse: on_a,
                    });
                }
            } else if m.z[i] > 0.0 {
                ws.impulses
                    .push(record(ImpulseKind::Normal, c.geom.normal * m.z[i]));
            }
            self.state.warm_lcp.push((c.id, block));
            if warm.friction != Vector3::zeros() {
                ws.impulses
                    .push(record(ImpulseKind::Friction, warm.friction));
            }
            match alone {
                true => self.state.warm_contacts.push(warm),
                false => ws.listed_warm.push(warm),
            }
        }
        if !alone {
            let list = &mut self.state.warm_contacts;
            let (listed, asleep) = (&ws.listed_warm, &ws.sleeping_warm);
            // The same listed contacts as at the last merge, beside the
            // same sleeping ones: the merge would lay the list out as it
            // is, so the listed entries are written where they stand (a
            // robot beside a sleeping heap copied every sleeping contact's
            // warm start each step).
            let same = ws.merged
                && ws.listed_at.len() == listed.len()
                && (listed.iter().zip(&ws.listed_at))
                    .all(|(w, &k)| list.get(k as usize).is_some_and(|v| v.id == w.id));
            if same {
                for (w, &k) in listed.iter().zip(&ws.listed_at) {
                    list[k as usize] = *w;
                }
            } else {
                // Both ascending, with distinct ids (a listed contact has
                // an awake body): merged.
                list.clear();
                ws.listed_at.clear();
                let (mut i, mut j) = (0, 0);
                while i < listed.len() && j < asleep.len() {
                    if listed[i].id < asleep[j].id {
                        ws.listed_at.push(list.len() as u32);
                        list.push(listed[i]);
                        i += 1;
                    } else {
                        list.push(asleep[j]);
                        j += 1;
                    }
                }
                for w in &listed[i..] {
                    ws.listed_at.push(list.len() as u32);
                    list.push(*w);
                }
                list.extend_from_slice(&asleep[j..]);
                ws.merged = true;
            }
        }
    }

    fn measure(
        &mut self,
        mut report: StepReport,
        mut timings: Timings,
        mut lap: Lap,
    ) -> StepReport {
        let _span = tracing::trace_span!("measure").entered();
        report.energy = measure::energy(&self.model, &self.state);
        let (model, state, ws) = (&self.model, &self.state, &mut self.ws);
        let listing = ws.awake.refresh(state);
        let asleep = (ws.asleep).deepest(
            model,
            state,
            Some(listing),
            &mut ws.collision,
            &mut ws.measure,
        );
        report.max_penetration = ws.look_ahead(model, state).max(asleep);
        report.max_joint_error = measure::max_joint_error(&self.model, &self.state);
        report.max_joint_angle_error = measure::max_joint_angle_error(&self.model, &self.state);
        timings.measure = lap.lap();
        timings.total += lap.total();
        report.timings = timings;
        report
    }
}

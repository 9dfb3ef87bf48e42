//! The step's scratch space and the collision stage's bookkeeping over it:
//! the contact set of a state (from the broad phase's listing, or the one
//! the last measurement listed ahead), each body's reach, the widening
//! when velocities reach farther, and the free velocity's selection.

use crate::collision::{self, Geometry};
use crate::constraint::applied::{self, Inputs, InvMass};
use crate::constraint::contact::{self, Contact};
use crate::constraint::limit;
use crate::integrate::{self, project};
use crate::measure::{self, report::ImpulseRecord};
use crate::model::islands::{Islands, Summary};
use crate::model::{Model, State, WarmContact};
use crate::sleep;
use crate::solver::island::Groups;
use crate::solver::mlcp::Mlcp;
use crate::solver::{fallback, iterative, prune};

/// Scratch space reused from step to step: after the largest problem has
/// been seen once, a step allocates nothing.
#[derive(Default)]
pub(super) struct Workspace {
    pub(super) geoms: Vec<Geometry>,
    pub(super) contacts: Vec<Contact>,
    pub(super) minv: Vec<InvMass>,
    pub(super) nu_free: Vec<f64>,
    pub(super) nu: Vec<f64>,
    pub(super) mlcp: Mlcp,
    pub(super) impulses: Vec<ImpulseRecord>,
    pub(super) measure: Vec<Geometry>,
    /// The next step's geometry, listed by the measurement
    /// (`look_ahead`), and whether it is still that of the state.
    pub(super) ahead: Vec<Geometry>,
    pub(super) ahead_listed: bool,
    /// The penetration of the sleeping bodies' contacts, kept while asleep.
    pub(super) asleep: measure::Asleep,
    pub(super) projection: project::Projection,
    /// Bodies in an impact this step (the trapezoid update skips them).
    pub(super) impulsive: Vec<bool>,
    /// The new poses, checked before they are written.
    pub(super) poses: Vec<integrate::Pose>,
    /// The broad phase: its scratch, each body's covered reach (m) this
    /// step, and `(id, in_lcp)` of the contacts while it widens.
    pub(super) collision: collision::Scratch,
    pub(super) reach: Vec<f64>,
    pub(super) kept: Vec<(usize, bool)>,
    /// The awake bodies, and the listings at which `reach`, `minv` and
    /// `nu_free` were last written for every body (a sleeping body's entry
    /// is a constant, a zero and zeros: kept while no body sleeps or wakes).
    pub(super) awake: sleep::Awake,
    pub(super) reach_written: sleep::Written,
    pub(super) minv_written: sleep::Written,
    pub(super) nu_free_written: sleep::Written,
    /// The warm starts of sleeping islands' contacts, kept while they are
    /// not listed (`record_impulses`), and the listing of `awake` they were
    /// picked at (a restored state moves it: picked again from its list).
    pub(super) sleeping_warm: Vec<WarmContact>,
    pub(super) sleeping_picked: sleep::Written,
    /// The sleeping contacts' impulses as the step reports them (their
    /// kept warm starts: at rest, what holds the island up), made when
    /// `sleeping_warm` is picked, with the contact geometry's scratch.
    pub(super) sleeping_records: Vec<ImpulseRecord>,
    pub(super) geometries: Vec<collision::Geometry>,
    /// Scratch of `record_impulses` while some contacts sleep: the listed
    /// contacts' warm starts, and where the last merge put them among the
    /// sleeping ones' in the state's list (valid while `merged` holds).
    pub(super) listed_warm: Vec<WarmContact>,
    pub(super) listed_at: Vec<u32>,
    pub(super) merged: bool,
    pub(super) islands: Islands,
    /// The step's rows by island, solved each on its own, and the last
    /// solve's islands (the step report's, once the step succeeded).
    pub(super) groups: Groups,
    pub(super) summary: Summary,
    /// Lemke's guess for this step's LCP (see `carry_guess`).
    pub(super) guess: Vec<bool>,
    pub(super) fallback: fallback::Scratch,
    pub(super) iterative: iterative::Scratch,
    /// Per body: its island fell back in this step's solve (copied into
    /// `State::drifted` when the step succeeds).
    pub(super) drifted: Vec<bool>,
    /// The smooth islands' RATTLE step (`integrate.rs`).
    pub(super) smooth: Smooth,
}

/// Scratch of the smooth islands' step: per island whether it takes
/// RATTLE, each body's island, the bodies and the joints by island
/// (`island_bodies[body_start[g]..body_start[g + 1]]`, likewise the
/// joints), and the bodies stepped with their new states.
#[derive(Default)]
pub(super) struct Smooth {
    pub(super) ok: Vec<bool>,
    pub(super) island_of: Vec<u32>,
    pub(super) island_bodies: Vec<u32>,
    pub(super) body_start: Vec<u32>,
    pub(super) island_joints: Vec<u32>,
    pub(super) joint_start: Vec<u32>,
    pub(super) out: Vec<crate::model::state::BodyState>,
    pub(super) bodies: Vec<u32>,
    pub(super) states: Vec<crate::model::state::BodyState>,
    pub(super) rattle: crate::integrate::rattle::Rattle,
}

/// The geometry the collision stage lists for `state` into `out`, with
/// each body's `reach` (m). A contact with no awake body is not listed
/// (`model::state::unlisted`). `awake`: the awake bodies as listed for `state`
/// (see `collision::Still`: the sleeping ones, and their reach, are the
/// same while the listing stands).
pub(super) fn list(
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
pub(super) enum Speeds {
    Free,
    New,
}

impl Workspace {
    /// Collision, contact set and inverse masses of `state`. The broad
    /// phase covers, for each body, the distance it travels in the step at
    /// its start speed plus twice what gravity adds in a step (a body at
    /// rest then needs no widening); `widen` grows that when the free or
    /// the new velocities reach farther.
    pub(super) fn contact_set(&mut self, model: &Model, state: &State) {
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
    pub(super) fn reach_of(&mut self, model: &Model, state: &State) {
        let p = &model.params;
        let g = p.gravity.norm();
        let of = |i: usize| {
            let (b, m) = (&state.bodies[i], &model.bodies[i]);
            p.h * (b.v.norm() + b.w.norm() * m.spin_reach + 2.0 * p.h * g)
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
    pub(super) fn look_ahead(&mut self, model: &Model, state: &State) -> f64 {
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

    pub(super) fn detect(&mut self, model: &Model, state: &State) {
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
    pub(super) fn build(&mut self, model: &Model, state: &State) {
        contact::build(model, state, &self.geoms, &mut self.contacts);
        limit::limits(model, state, &mut self.contacts);
    }

    /// Grows the broad phase's reach where a body's speed bound `speed(i)`
    /// (m/s, over the step) goes past it, and lists the contacts that adds;
    /// the contacts listed before keep their `in_lcp`, the new ones are left
    /// out (`prune::check_left_out` then tests them). Returns whether the
    /// list changed. Without the broad phase every pair is listed already.
    pub(super) fn widen(&mut self, model: &Model, state: &State, speeds: Speeds) -> bool {
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
    pub(super) fn select(&mut self, model: &Model, state: &State, inputs: &Inputs) {
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

//! Sleeping (issue 14, point 4): an island of bodies that has been at rest
//! for a while leaves the step until something touches it.
//!
//! As in Box2D and Rapier: a body is at rest while its speed, and the
//! speed its spin gives its bounding sphere's surface (or its angular
//! speed), stay below the scene's thresholds (raised to the solver's
//! resolution where PGS's residual rule solves: see [`update`]); an
//! island (the bodies
//! the last step's touching contacts tie together, `island.rs`, with
//! touching as in [`Reach`]) whose bodies have all been at rest for `after` seconds falls asleep as one: its
//! velocities are set to zero and its bodies keep one tag, the island's.
//! While asleep its bodies are static for the step (no gravity, zero
//! inverse mass, no position update), and the contacts among them and
//! with the planes are not listed (left out before their narrow phase,
//! `collision::Keep`), and its state does not change by a bit. The passes
//! over bodies that a sleeping body has no part in (reach, inverse masses,
//! free velocity, position update, rest counts) walk the awake bodies
//! ([`Awake`]), and what they keep for the sleeping ones, like the
//! penetration of their contacts (`measure::Asleep`), is written again
//! only when a body sleeps or wakes or a state is restored. What the
//! island still costs is a few reads per body and step: its sleep tags,
//! its potential energy and its bodies in the union-find of the islands;
//! the awake bodies find their partners among it in a grid of the
//! sleeping bodies kept while the listing stands (`collision::Still`). A
//! world asleep whole steps idle: the clock alone (`Engine::idle_step`,
//! `Skips::idle`).
//!
//! It wakes, as one island, in the step where
//!
//! - an awake body's contact with one of its bodies comes within touching
//!   reach by the end of the step (in the contact set before the solve;
//!   the island's contacts are then listed again in the same step, so an
//!   impact moves it at once),
//! - an input (a body impulse) is applied to one of its bodies,
//! - or, after the solve, a contact that the step closed (or that the
//!   broad phase listed late, a fast body's widened reach) touches it: it
//!   was static for that step and is awake in the next.
//!
//! A listed contact further away than touching reach neither wakes an
//! island nor ties it to its neighbour: a body spinning or rolling slowly
//! beside a sleeping stack leaves it asleep.
//!
//! Bodies on joints never sleep (the joint rows would need to leave the
//! step with them; the robots of issue 17 will make joints islands of
//! their own). Everything sleeping depends on is in the state (`rest`,
//! `sleep_tag`), so a snapshot, a restore and a replay repeat its bits.

use crate::constraint::contact::{relative_velocity, Contact};
use crate::integrate::project::{resolution, slop};
use crate::model::islands::Islands;
use crate::model::state::{asleep, State, AWAKE};
use crate::model::Counterpart;
use crate::model::Model;
use crate::model::Sleep;
use crate::solver::pgs::PgsParams;
use nalgebra::Vector3;

/// The awake bodies in ascending order, listed again only when the sleep
/// tags change, so that the passes a sleeping body has no part in walk
/// them instead of every body (a robot beside a sleeping pile, whose
/// bodies on joints never sleep, paid for each pile body in each of them).
///
/// A pass that keeps what it wrote for the sleeping bodies from one step
/// to the next (a zero, a constant) writes every body again when
/// [`Awake::listing`] moved: see [`Written`].
#[derive(Debug, Clone, Default)]
pub struct Awake {
    /// The tags the list was made from, while `listed` (not before the
    /// first listing, nor after [`Awake::forget`]).
    tags: Vec<u32>,
    listed: bool,
    list: Vec<u32>,
    listing: u64,
}

impl Awake {
    /// Lists the awake bodies of `state` again if its tags are not those
    /// listed (a comparison of the tags: a few microseconds at 10,000
    /// bodies); the listing's number.
    pub fn refresh(&mut self, state: &State) -> u64 {
        if !self.listed || self.tags != state.sleep_tag {
            self.tags.clone_from(&state.sleep_tag);
            self.listed = true;
            self.list.clear();
            self.list.extend(
                (self.tags.iter().enumerate())
                    .filter(|&(_, &t)| t == AWAKE)
                    .map(|(i, _)| i as u32),
            );
            self.listing += 1;
        }
        self.listing
    }

    /// The awake bodies as of the last [`Awake::refresh`].
    pub fn bodies(&self) -> &[u32] {
        &self.list
    }

    /// The awake bodies of `state` where `written` stands at the present
    /// listing (a pass may write them alone), else `None` (it must write
    /// every body, and `written` now stands).
    pub fn only(&mut self, state: &State, written: &mut Written) -> Option<&[u32]> {
        let listing = self.refresh(state);
        (!written.every_body(listing)).then_some(&self.list[..])
    }

    /// The last [`Awake::refresh`]'s listing number.
    pub fn listing(&self) -> u64 {
        self.listing
    }

    /// The next refresh lists again, and moves the listing, whatever the
    /// tags: a restored state may have the same tags and other poses or
    /// velocities for its sleeping bodies.
    pub fn forget(&mut self) {
        self.listed = false;
    }
}

/// Which listing of [`Awake`] a pass last wrote every body at: while it
/// stands, the sleeping bodies' entries are as written then and the pass
/// may write the awake ones alone.
#[derive(Debug, Clone, Copy, Default)]
pub struct Written(Option<u64>);

impl Written {
    /// Whether the pass must write every body at `listing` (and from now
    /// on need not, while the listing stands).
    pub fn every_body(&mut self, listing: u64) -> bool {
        let every = self.0 != Some(listing);
        self.0 = Some(listing);
        every
    }
}

/// Wakes every body with tag `tag`; true when one woke.
fn wake_tag(state: &mut State, tag: u32) -> bool {
    let mut woke = false;
    for (t, r) in state.sleep_tag.iter_mut().zip(state.rest.iter_mut()) {
        if *t == tag {
            *t = AWAKE;
            *r = 0;
            woke = true;
        }
    }
    woke
}

/// Wakes the island of body `i` if it sleeps; true when it did.
pub fn wake_body(state: &mut State, i: usize) -> bool {
    match state.sleep_tag.get(i).copied() {
        Some(tag) if tag != AWAKE => wake_tag(state, tag),
        _ => false,
    }
}

/// How close a contact's surfaces come by the end of a step at the
/// bodies' present velocities: its gap, less what its approach closes in
/// `h` (a separating contact keeps its gap).
fn reach(state: &State, c: &Contact, h: f64) -> f64 {
    let v_n = relative_velocity(state, &c.geom).dot(&c.geom.normal);
    c.geom.gap + h * v_n.min(0.0)
}

/// The distances at which contacts tie bodies for sleeping: where PGS's
/// residual rule solves, bodies at rest sit up to the projection's slop
/// deep and drift by up to `h` times its tolerance a step, so a contact
/// touches within that slop. Islands are tied by contacts within twice
/// that and woken by contacts within it: a neighbour jittering at the
/// solver's resolution between the two neither joins nor wakes an island.
#[derive(Debug, Clone, Copy)]
pub struct Reach {
    pub h: f64,
    pub touch: f64,
}

impl Reach {
    pub fn of(model: &Model, pgs: &PgsParams) -> Reach {
        Reach {
            h: model.params.h,
            touch: slop(&model.params, pgs),
        }
    }
}

/// Wakes the islands that a contact within touching reach ties to an
/// awake body; true when one woke (then the contact set must be listed
/// again: the woken islands' own contacts were left out). A contact
/// further away leaves the sleeping body static for the step: an awake
/// body that closes it meets a still body, and wakes it after the step.
pub fn wake_touched(state: &mut State, contacts: &[Contact], at: Reach) -> bool {
    let mut woke = false;
    for c in contacts {
        let Counterpart::Body(j) = c.geom.b else {
            continue;
        };
        let a = c.geom.a;
        let sleeper = match (asleep(state, a), asleep(state, j)) {
            (true, false) => a,
            (false, true) => j,
            _ => continue,
        };
        if reach(state, c, at.h) <= at.touch {
            woke |= wake_body(state, sleeper);
        }
    }
    woke
}

/// After the step: counts each awake body's steps at rest and puts the
/// islands whose bodies have all been at rest long enough to sleep.
/// `contacts` is the step's contact set, `islands` scratch space, `pgs`
/// the iterative solver's parameters (its resolution). Sleeping bodies
/// that an awake body touched this step wake first. `awake` lists the
/// bodies the counts and the verdict visit (a sleeping body has neither).
pub fn update(
    model: &Model,
    params: &Sleep,
    pgs: &PgsParams,
    state: &mut State,
    contacts: &[Contact],
    awake: &mut Awake,
    islands: &mut Islands,
) {
    let n = state.bodies.len();
    let h = model.params.h;
    // Contacts the step closed (late ones too, listed after the solve
    // began) wake the next step.
    let at = Reach::of(model, pgs);
    wake_touched(state, contacts, at);
    awake.refresh(state);
    // At rest to the solver's resolution: where a step's answer may leave
    // constraint velocities of up to a tolerance (PGS's residual rule),
    // bodies at rest move at up to about that, step after step, and a
    // threshold below it is never met. Measured on the 100 pile at 1e-2
    // m/s (1,000 steps): it never slept at 1e-2 m/s and 0.05 rad/s; the
    // bodies that kept it awake moved at up to 1.2e-2 m/s and spun at up
    // to 0.36 rad/s, 1.8e-2 m/s at their surface. So the speed is held to
    // at least twice the tolerance.
    //
    // A spin is judged by the speed it gives the body's bounding sphere
    // (as Box2D v3 and Jolt judge it): at rest below `linear` there too,
    // or below `angular` whatever the size. NOTE: measured on the 1,000
    // pile (10 layers, `bench pile --sleep`, 1,500 steps) with the spin
    // held to 0.4 rad/s (twice the tolerance at its surface, 0.02 m/s):
    // spheres wedged on the floor spin about their contact normals (no
    // torsional friction stops them) at 0.1-0.6 rad/s, 10 to 30 of them
    // in every half second, and the pile never slept (about 10 of 1,000
    // bodies asleep); at Box2D v3's 0.05 m/s (1 rad/s) it sleeps whole.
    let floor = 2.0 * resolution(&model.params, pgs);
    let linear = params.linear.max(floor);
    for &i in awake.bodies() {
        let i = i as usize;
        let b = &state.bodies[i];
        let reach = model.bodies[i].bound;
        let angular = match reach > 0.0 {
            true => params.angular.max(linear / reach),
            false => params.angular,
        };
        // Bodies on joints are awake, and stay so.
        let resting = b.v.norm() < linear && b.w.norm() < angular && !model.jointed[i];
        state.rest[i] = if resting {
            state.rest[i].saturating_add(1)
        } else {
            0
        };
    }
    // Steps at rest an island needs: `after` seconds, at least one step.
    let need = ((params.after / h).ceil() as u32).max(1);
    // NOTE: the islands of the contacts within twice the touching reach,
    // not the step's (which ties bodies by the contacts in its final LCP,
    // the active ones): a part of a pile whose contacts to the rest carry
    // no force would sleep alone, and the touching contact to its awake
    // neighbour wake it in the next step, again and again (measured: the
    // 100 pile never slept). Nor every listed contact: measured on the
    // 1,000 pile, a sphere rolling slowly on its neighbours (no rolling
    // resistance stops it) was tied to the whole pile by listed contacts
    // a few tenths of a millimetre apart, and nothing slept. Closed
    // under what wakes an island (with a margin: see `Reach`), an island
    // cannot be woken by its own neighbours at rest.
    let state_ro: &State = state;
    islands.partition(
        n,
        contacts
            .iter()
            .filter(|c| reach(state_ro, c, at.h) <= 2.0 * at.touch)
            .map(|c| (c.geom.a, c.geom.b)),
    );
    // The least rest of each island, kept at its root; then the verdict.
    islands.least_rest(&state.rest, &state.sleep_tag, AWAKE);
    for &i in awake.bodies() {
        let i = i as usize;
        let (root, least) = islands.least_of(i);
        if least >= need {
            state.sleep_tag[i] = root as u32;
            let b = &mut state.bodies[i];
            b.v = Vector3::zeros();
            b.w = Vector3::zeros();
        }
    }
}

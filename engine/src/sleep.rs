//! Sleeping (issue 14, point 4): an island of bodies that has been at rest
//! for a while leaves the step until something touches it.
//!
//! As in Box2D and Rapier: a body is at rest while its speed and its
//! angular speed stay below the scene's thresholds (raised to the
//! solver's resolution where PGS's residual rule solves: see
//! [`update`]); an island (the bodies
//! the last step's contacts tie together, `island.rs`) whose bodies have
//! all been at rest for `after` seconds falls asleep as one: its
//! velocities are set to zero and its bodies keep one tag, the island's.
//! While asleep its bodies are static for the step (no gravity, zero
//! inverse mass, no position update), and the contacts among them and
//! with the planes are not listed: the island costs its share of the
//! broad phase and nothing else, and its state does not change by a bit.
//!
//! It wakes, as one island, in the step where
//!
//! - an awake body comes within a listed contact of one of its bodies (in
//!   the contact set before the solve; the island's contacts are then
//!   listed again in the same step, so an impact moves it at once),
//! - an input (a body impulse) is applied to one of its bodies,
//! - or, after the solve, a contact the broad phase listed late (a fast
//!   body's widened reach) touches it: it was static for that step and is
//!   awake in the next.
//!
//! Bodies on joints never sleep (the joint rows would need to leave the
//! step with them; the robots of issue 17 will make joints islands of
//! their own). Everything sleeping depends on is in the state (`rest`,
//! `sleep_tag`), so a snapshot, a restore and a replay repeat its bits.

use super::collision::Counterpart;
use super::contact::Contact;
use super::island::Islands;
use super::model::Model;
use super::project::resolution;
use super::solver::pgs::PgsParams;
use super::state::State;
use nalgebra::Vector3;

/// The scene's sleeping thresholds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sleep {
    /// Seconds at rest before an island sleeps.
    pub after: f64,
    /// Speed (m/s) and angular speed (rad/s) below which a body is at rest.
    pub linear: f64,
    pub angular: f64,
}

/// The tag of an awake body.
pub const AWAKE: u32 = u32::MAX;

/// Whether body `i` is asleep.
pub fn asleep(state: &State, i: usize) -> bool {
    state.sleep_tag.get(i).is_some_and(|&t| t != AWAKE)
}

/// Whether any body is asleep (the step's filters are skipped otherwise).
pub fn any_asleep(state: &State) -> bool {
    state.sleep_tag.iter().any(|&t| t != AWAKE)
}

/// How many bodies are asleep.
pub fn count(state: &State) -> usize {
    state.sleep_tag.iter().filter(|&&t| t != AWAKE).count()
}

/// Whether the contact of body `a` with `b` has no awake body (between two
/// sleeping bodies, or a sleeping body and a plane): it is not listed.
pub fn unlisted(state: &State, a: usize, b: Counterpart) -> bool {
    asleep(state, a)
        && match b {
            Counterpart::Body(j) => asleep(state, j),
            Counterpart::Plane(_) | Counterpart::World => true,
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

/// Wakes the islands that a listed contact ties to an awake body; true
/// when one woke (then the contact set must be listed again: the woken
/// islands' own contacts were left out).
pub fn wake_touched(state: &mut State, contacts: &[Contact]) -> bool {
    let mut woke = false;
    for c in contacts {
        let Counterpart::Body(j) = c.geom.b else {
            continue;
        };
        let a = c.geom.a;
        match (asleep(state, a), asleep(state, j)) {
            (true, false) => woke |= wake_body(state, a),
            (false, true) => woke |= wake_body(state, j),
            _ => {}
        }
    }
    woke
}

/// Drops the contacts with no awake body ([`unlisted`]).
pub fn drop_sleeping(state: &State, contacts: &mut Vec<Contact>) {
    contacts.retain(|c| !unlisted(state, c.geom.a, c.geom.b));
}

/// After the step: counts each awake body's steps at rest and puts the
/// islands whose bodies have all been at rest long enough to sleep.
/// `contacts` is the step's contact set, `islands` scratch space, `pgs`
/// the iterative solver's parameters (its resolution). Sleeping bodies
/// that an awake body touched this step wake first.
pub fn update(
    model: &Model,
    params: &Sleep,
    pgs: &PgsParams,
    state: &mut State,
    contacts: &[Contact],
    islands: &mut Islands,
) {
    let n = state.bodies.len();
    let h = model.params.h;
    // Late contacts (listed after the solve began) wake the next step.
    wake_touched(state, contacts);
    // At rest to the solver's resolution: where a step's answer may leave
    // constraint velocities of up to a tolerance (PGS's residual rule),
    // bodies at rest move at up to about that, step after step, and a
    // threshold below it is never met. Measured on the 100 pile at 1e-2
    // m/s (1,000 steps): it never slept at 1e-2 m/s and 0.05 rad/s; the
    // bodies that kept it awake moved at up to 1.2e-2 m/s and spun at up
    // to 0.36 rad/s, 1.8e-2 m/s at their surface. So the speed is held to
    // at least twice the tolerance, and the spin to at least what moves
    // the body's surface at that (as Jolt's rule bounds the speed of the
    // points of a body's bounding sphere).
    let floor = 2.0 * resolution(&model.params, pgs);
    let linear = params.linear.max(floor);
    for i in 0..n {
        if asleep(state, i) {
            continue;
        }
        let b = &state.bodies[i];
        let reach = model.bodies[i].shape.bounding_radius();
        let angular = match reach > 0.0 {
            true => params.angular.max(floor / reach),
            false => params.angular,
        };
        let resting = b.v.norm() < linear && b.w.norm() < angular;
        state.rest[i] = if resting {
            state.rest[i].saturating_add(1)
        } else {
            0
        };
    }
    for (rest, _) in state
        .rest
        .iter_mut()
        .zip(&model.jointed)
        .filter(|(_, &j)| j)
    {
        *rest = 0;
    }
    // Steps at rest an island needs: `after` seconds, at least one step.
    let need = ((params.after / h).ceil() as u32).max(1);
    // NOTE: the islands of every listed contact, not the step's (which
    // ties bodies by the contacts in its final LCP, the active ones): a
    // part of a pile whose contacts to the rest carry no force would sleep
    // alone, and the listed contact to its awake neighbour wake it in the
    // next step, again and again (measured: the 100 pile never slept).
    // Closed under what wakes an island, an island cannot be woken by its
    // own neighbours at rest.
    islands.partition(n, contacts.iter().map(|c| (c.geom.a, c.geom.b)));
    // The least rest of each island, kept at its root; then the verdict.
    islands.least_rest(&state.rest, &state.sleep_tag, AWAKE);
    for i in 0..n {
        if asleep(state, i) {
            continue;
        }
        let (root, least) = islands.least_of(i);
        if least >= need {
            state.sleep_tag[i] = root as u32;
            let b = &mut state.bodies[i];
            b.v = Vector3::zeros();
            b.w = Vector3::zeros();
        }
    }
}

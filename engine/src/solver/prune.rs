//! Pruning stage: which potential contacts enter this step's LCP.
//!
//! A contact whose gap cannot close within the step gets no rows. The bound
//! uses start-of-step and free speeds, which is not safe on its own: within
//! one step a body hit by another can be thrown into a third contact that was
//! left out. So after every solve [`check_left_out`] tests each left-out
//! contact against the new velocities (`psi / h + G_n^T nu' >= 0`) and the
//! step is solved again with any that fail (formulation.md, "Sizes to
//! expect").
//!
//! That check makes the pruned and the full problem agree in exact
//! arithmetic, but not to the bit: a contact kept in the LCP with zero
//! impulse still changes Lemke's pivot sequence (a far contact's slack `s`
//! becomes basic at its sliding speed) and so the round-off of the active
//! impulses, and a chaotic trajectory amplifies 1e-16 into O(1) within a
//! second. So once the first solve is accepted, [`keep_active`] drops every
//! contact that is not closed (no normal impulse and a separating normal
//! row) and the step is solved once more on the closed contacts alone: the
//! final LCP then depends only on that set, whatever was pruned, and
//! pruned and full runs give the same bits.
//! The velocity check still runs after that solve.

use crate::constraint::contact::Contact;
use crate::constraint::rows::Row;
use crate::model::state::State;
use crate::model::Counterpart;
use crate::model::Model;
use nalgebra::Vector3;

/// The largest speed (m/s) of body `i`'s surface that the velocities `nu`
/// (6 per body) and, where given, the start state's allow over the step:
/// linear, plus for a box or capsule its spin times its reach
/// (`Shape::spin_reach`; the gap of a sphere depends on its centre only,
/// so spin does not enter). The pruning's bound, and the broad phase's
/// (`Workspace::widen`).
pub fn surface_speed(model: &Model, i: usize, start: Option<&State>, nu: &[f64]) -> f64 {
    let at = |k: usize| Vector3::new(nu[k], nu[k + 1], nu[k + 2]).norm();
    let (mut linear, mut spin) = (at(6 * i), at(6 * i + 3));
    if let Some(s) = start {
        let b = &s.bodies[i];
        (linear, spin) = (b.v.norm().max(linear), b.w.norm().max(spin));
    }
    linear + spin * model.bodies[i].spin_reach
}

/// Marks the contacts that enter the LCP before the first solve: all of
/// them with `--full`, else those that could close within the step.
pub fn select(contacts: &mut [Contact], model: &Model, state: &State, nu_free: &[f64]) {
    let p = &model.params;
    // Largest speed of each body's surface over the step (start or free).
    let speed = |i: usize| surface_speed(model, i, Some(state), nu_free);
    for c in contacts.iter_mut() {
        if c.limit.is_some() {
            // A limit's gap is a coordinate's (rad or m): its own rate
            // bounds it, at the start (`v_n`) and free.
            let free = Row::contact(c, c.geom.normal).velocity(nu_free);
            c.in_lcp =
                p.full || c.geom.gap <= p.h * (-c.v_n).max(-free).max(0.0) + p.contact_margin;
            continue;
        }
        c.in_lcp = p.full || {
            let mut s = speed(c.geom.a);
            if let Counterpart::Body(j) = c.geom.b {
                s += speed(j);
            }
            c.geom.gap <= p.h * s + p.contact_margin
        };
    }
}

/// Adds every left-out contact that the new velocities `nu` would close
/// within the step; returns how many were added. `relaxed`: the answer is
/// of the relaxed formulation (`mlcp::Offsets::Relaxed`), which asks no
/// penetrating contact to separate, so a left-out contact fails only if
/// it would approach (its gap counts as at most zero).
pub fn check_left_out(contacts: &mut [Contact], nu: &[f64], h: f64, relaxed: bool) -> usize {
    let mut added = 0;
    for c in contacts.iter_mut().filter(|c| !c.in_lcp) {
        let v_n = Row::contact(c, c.geom.normal).velocity(nu);
        let gap = if relaxed {
            c.geom.gap.max(0.0)
        } else {
            c.geom.gap
        };
        if gap / h + v_n < 0.0 {
            c.in_lcp = true;
            added += 1;
        }
    }
    added
}

/// A normal row's residual `w` (m/s) at most this counts as closed: its
/// contact is kept for the canonical re-solve with or without impulse.
pub const CLOSED: f64 = 1e-9;

/// Keeps in the LCP only the contacts that are closed in the solution of
/// `m` with velocities `nu`: a positive normal impulse, or a normal row
/// whose residual `w = G_n^T nu' + a_n` is at most [`CLOSED`]; returns
/// whether any contact was dropped.
///
/// Why the closed ones without impulse too: where the support is
/// statically indeterminate (a box on four vertices, one rigid plane)
/// Lemke answers a vertex of the solution set, three vertices carrying
/// the weight, and which three depends on its pivot order, so on what
/// else the first LCP held: a set of the active contacts alone would
/// differ between the pruned and the full run. The closed set does not:
/// `z > 0` implies `w = 0`, and the velocities, so `w`, are the same
/// whichever vertex was answered.
pub fn keep_active(contacts: &mut [Contact], m: &crate::solver::mlcp::Mlcp, nu: &[f64]) -> bool {
    let mut dropped = false;
    for (i, &ci) in m.lcp_contacts.iter().enumerate() {
        let row = m.nb + i;
        let w = m.rows[row].velocity(nu) + m.offset[row];
        if m.z[i] <= 0.0 && w > CLOSED {
            contacts[ci].in_lcp = false;
            dropped = true;
        }
    }
    dropped
}

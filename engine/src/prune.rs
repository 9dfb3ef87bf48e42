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
//! contact without normal impulse and the step is solved once more on the
//! active contacts alone: the final LCP then depends only on the active set,
//! whatever was pruned, and pruned and full runs give the same bits.
//! The velocity check still runs after that solve.

use super::collision::Counterpart;
use super::contact::Contact;
use super::model::Params;
use super::rows::Row;
use super::state::State;
use nalgebra::Vector3;

/// Marks the contacts that enter the LCP before the first solve: all of
/// them with `--full`, else those that could close within the step.
pub fn select(contacts: &mut [Contact], state: &State, nu_free: &[f64], p: &Params) {
    // Largest linear speed of each body over the step (start or free). The
    // gap of a sphere depends on its centre only, so spin does not enter.
    let speed = |i: usize| {
        let free = Vector3::new(nu_free[6 * i], nu_free[6 * i + 1], nu_free[6 * i + 2]);
        state.bodies[i].v.norm().max(free.norm())
    };
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

/// Keeps in the LCP only the contacts with a positive normal impulse in the
/// solution `z` (normal row `i` belongs to `contacts[lcp_contacts[i]]`);
/// returns whether any contact was dropped.
pub fn keep_active(contacts: &mut [Contact], lcp_contacts: &[usize], z: &[f64]) -> bool {
    let mut dropped = false;
    for (i, &ci) in lcp_contacts.iter().enumerate() {
        if z[i] <= 0.0 {
            contacts[ci].in_lcp = false;
            dropped = true;
        }
    }
    dropped
}

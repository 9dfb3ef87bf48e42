//! Pruning stage: which potential contacts enter this step's LCP.
//!
//! A contact whose gap cannot close within the step gets no rows. The bound
//! uses start-of-step and free speeds, which is not safe on its own: within
//! one step a body hit by another can be thrown into a third contact that was
//! left out. So after every solve [`check_left_out`] tests each left-out
//! contact against the new velocities (`psi / h + G_n^T nu' >= 0`) and the
//! step is solved again with any that fail (formulation.md, "Sizes to
//! expect"). With that check the pruned and the full problem agree.

use super::contact::Contact;
use super::model::Params;
use super::rows::Row;
use super::state::State;
use nalgebra::Vector3;

/// Marks the contacts that enter the LCP before the first solve.
pub fn select(contacts: &mut [Contact], state: &State, nu_free: &[f64], p: &Params) {
    // Largest linear speed of each body over the step (start or free). The
    // gap of a sphere depends on its centre only, so spin does not enter.
    let speed = |i: usize| {
        let free = Vector3::new(nu_free[6 * i], nu_free[6 * i + 1], nu_free[6 * i + 2]);
        state.bodies[i].v.norm().max(free.norm())
    };
    for c in contacts.iter_mut() {
        c.in_lcp = p.full || {
            let mut s = speed(c.geom.a);
            if let super::collision::Counterpart::Body(j) = c.geom.b {
                s += speed(j);
            }
            c.geom.gap <= p.h * s + p.contact_margin
        };
    }
}

/// Adds every left-out contact that the new velocities `nu` would close
/// within the step; returns how many were added.
pub fn check_left_out(contacts: &mut [Contact], nu: &[f64], h: f64) -> usize {
    let mut added = 0;
    for c in contacts.iter_mut().filter(|c| !c.in_lcp) {
        let v_n = Row::contact(c, c.geom.normal).velocity(nu);
        if c.geom.gap / h + v_n < 0.0 {
            c.in_lcp = true;
            added += 1;
        }
    }
    added
}

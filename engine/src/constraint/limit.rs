//! Joint limits: a hinge's angle or a slider's offset kept within its
//! `[lower, upper]` by one unilateral row per side, listed as a contact.
//!
//! A limit is complementarity like a contact's normal row: the gap is the
//! coordinate's distance to the limit (`x - lower`, `upper - x`, in rad or
//! m), the row's velocity is the gap's rate, and the impulse only pushes
//! the coordinate back into its range. Listed among the contacts (mu = 0,
//! no friction rows), it gets everything a contact has with no code of its
//! own: the normal offset (`mlcp::normal_offset`: a gap that may close
//! exactly, the stabilisation of a violation, Newton restitution), the
//! pruning and the velocity check, the warm start by id, the islands, both
//! solvers, and the fallback ladder with its energy check. Its id is past
//! every shape contact's (`Model::limit_id`), so the list stays in
//! ascending id.
//!
//! The lower limit's row is the coordinate's rate row (`motor::rate_row`,
//! derived there: a turning row about `-u` for a hinge, a row along `-u`
//! with A's lever arm at B's anchor for a slider), written as a contact's
//! geometry; the upper limit's is its negative.
//!
//! A joint of a body to the world: the contact's first side must be a
//! body, so B takes it with the row negated (`Row::along(dir, None, B)`
//! is `Row::along(-dir, B, None)`, and likewise a turning row).

use crate::collision::Geometry;
use crate::constraint::contact::{Contact, Limit};
use crate::constraint::joint::{axis, coordinate};
use crate::constraint::rows::Row;
use crate::model::kinematics::anchor;
use crate::model::state::State;
use crate::model::Counterpart;
use crate::model::Model;
use nalgebra::Vector3;

/// A hinge's angle (in (-pi, pi]) taken a turn up or down where that
/// puts it nearer its range `[lower, upper]`: the angle is read on the
/// circle, so one that passed a limit at pi reads near -pi, and without
/// this the lower limit would see it a whole turn deep (the Panda's
/// joint 6, its upper limit held at pi, falling past it: a gap of -3.12
/// rad, every later step refused by the energy check and relaxed).
fn nearest_turn(x: f64, lower: f64, upper: f64) -> f64 {
    use std::f64::consts::TAU;
    let outside = |c: f64| (lower - c).max(c - upper).max(0.0);
    [x, x + TAU, x - TAU].into_iter().fold(
        x,
        |best, c| if outside(c) < outside(best) { c } else { best },
    )
}

/// Appends a contact for each side of each limited joint, in joint order
/// (ascending id).
pub fn limits(model: &Model, state: &State, out: &mut Vec<Contact>) {
    for (j, joint) in model.joints.iter().enumerate() {
        // `coordinate` and `axis` give none for spherical and fixed joints.
        let (Some(lim), Some((x, _)), Some(u)) =
            (joint.limits, coordinate(joint, state), axis(joint, state))
        else {
            continue;
        };
        let angular = joint.slide.is_none();
        let x = if angular {
            nearest_turn(x, lim.lower, lim.upper)
        } else {
            x
        };
        let (pa, ra) = anchor(joint.a, &joint.local_a, state);
        let (pb, rb) = anchor(joint.b, &joint.local_b, state);
        // A's lever arm at B's anchor (the slider's rows'); unused by a
        // turning row.
        let ra = ra.map(|(i, r)| (i, r + (pb - pa)));
        let (first, other) = model.limit_bodies(j);
        for upper in [false, true] {
            let (gap, dir) = if upper {
                (lim.upper - x, u)
            } else {
                (x - lim.lower, -u)
            };
            // The row with A as the contact's first side, or negated with
            // B first (see the module's note).
            let (normal, r_a, r_b) = match (ra, rb) {
                (Some((_, r_a)), rb) => (dir, r_a, rb.map_or_else(Vector3::zeros, |(_, r)| r)),
                (None, Some((_, r_b))) => (-dir, r_b, Vector3::zeros()),
                (None, None) => continue,
            };
            let mut c = Contact {
                id: model.limit_id(j, upper),
                geom: Geometry {
                    a: first,
                    b: other,
                    feature: 0,
                    gap,
                    normal,
                    point: pb,
                    r_a,
                    r_b,
                },
                mu: 0.0,
                e: lim.restitution,
                t1: crate::model::kinematics::perpendicular(&normal),
                t2: Vector3::zeros(),
                v_n: 0.0,
                in_lcp: false,
                limit: Some(Limit {
                    joint: j,
                    upper,
                    angular,
                }),
            };
            c.t2 = normal.cross(&c.t1);
            c.v_n = Row::contact(&c, normal).state_velocity(state);
            debug_assert!(matches!(other, Counterpart::Body(_) | Counterpart::World));
            out.push(c);
        }
    }
}

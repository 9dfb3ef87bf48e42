//! Joint rows: what each kind of joint holds, as Jacobian rows with their
//! stabilisation offsets (the joint block `G_b`, `b_b` of formulation.md).
//!
//! Every joint pins its anchors: three rows along the world axes,
//! `psi = x_A + R_A a_A - x_B - R_B a_B`, offset `beta psi_k / h`, so the
//! solved velocity gives `psi' = -beta psi / h`.
//!
//! The rotation rows are angular only: `p . (w_A - w_B)` along a world
//! direction `p`. With `theta` the small rotation that takes B from where
//! the joint wants it to where it is (world frame), `theta' = w_B - w_A`,
//! so the row's velocity is `-p . theta'`; the offset `-beta (theta . p)
//! / h` gives `theta' = -beta theta / h` along `p`, the anchors' rule.
//! - Hinge (`Turning::Axis`): B may turn about the axis only. With the
//!   axis `u_A` as A holds it and `u_B` as B does (world frame), the error
//!   is `theta = u_A x u_B` (to first order, the rotation taking `u_A` to
//!   `u_B`: `u_B = u_A + theta x u_A` gives `u_A x u_B = theta` less its
//!   part along `u_A`), held to zero on the two directions normal to
//!   `u_A`: `d/dt (u_A x u_B) = (w_B - w_A)` less its part along the axis,
//!   at `u_A = u_B`.
//! - Fixed (`Turning::Locked`): `q_err = q_B (q_A rel)^-1`, `theta` its
//!   rotation vector, on the three world axes.

use crate::mlcp::anchor;
use crate::model::{Attachment, Joint, Turning};
use crate::rows::Row;
use crate::state::State;
use nalgebra::{UnitQuaternion, Vector3};

/// A side's orientation (the world's: the identity).
fn orientation(att: Attachment, state: &State) -> UnitQuaternion<f64> {
    match att {
        Attachment::World => UnitQuaternion::identity(),
        Attachment::Body(i) => state.bodies[i].q,
    }
}

fn body(att: Attachment) -> Option<usize> {
    match att {
        Attachment::World => None,
        Attachment::Body(i) => Some(i),
    }
}

/// Two unit directions normal to unit `u` and to each other.
fn normals(u: &Vector3<f64>) -> [Vector3<f64>; 2] {
    let t1 = crate::contact::perpendicular(u);
    [t1, u.cross(&t1)]
}

/// The directions of a joint's turning rows (`None`: no row).
type TurningRows = [Option<Vector3<f64>>; 3];

/// The joint's rotation error `theta` (world frame) and the directions
/// of its turning rows (two for a hinge, three for a fixed joint); `None`
/// for a spherical joint.
fn turning(joint: &Joint, state: &State) -> Option<(Vector3<f64>, TurningRows)> {
    let (qa, qb) = (orientation(joint.a, state), orientation(joint.b, state));
    match joint.turning {
        Turning::Free => None,
        Turning::Axis { a, b } => {
            let (ua, ub) = (qa * a, qb * b);
            let [n1, n2] = normals(&ua);
            Some((ua.cross(&ub), [Some(n1), Some(n2), None]))
        }
        Turning::Locked { rel } => {
            let err = qb * (qa * rel).inverse();
            let axes = [Some(Vector3::x()), Some(Vector3::y()), Some(Vector3::z())];
            Some((err.scaled_axis(), axes))
        }
    }
}

/// Appends the joint's rows and offsets (`factor`: the stabilisation,
/// `beta` or the compliance's ERP; `h` the step).
pub fn push_rows(
    joint: &Joint,
    state: &State,
    factor: f64,
    h: f64,
    rows: &mut Vec<Row>,
    offset: &mut Vec<f64>,
) {
    let (pa, ra) = anchor(joint.a, &joint.local_a, state);
    let (pb, rb) = anchor(joint.b, &joint.local_b, state);
    let psi = pa - pb;
    for k in 0..3 {
        rows.push(Row::along(Vector3::ith(k, 1.0), ra, rb));
        offset.push(factor * psi[k] / h);
    }
    let Some((theta, dirs)) = turning(joint, state) else {
        return;
    };
    for p in dirs.into_iter().flatten() {
        rows.push(Row::turning(p, body(joint.a), body(joint.b)));
        offset.push(-factor * theta.dot(&p) / h);
    }
}

/// The joint's rotation error (rad): the angle between the axes as the
/// two sides hold them (hinge), or of B's orientation from where A holds
/// it (fixed); zero for a spherical joint.
pub fn angle_error(joint: &Joint, state: &State) -> f64 {
    match turning(joint, state) {
        None => 0.0,
        Some((theta, _)) => match joint.turning {
            // |u_A x u_B| is the sine of the angle between the axes.
            Turning::Axis { .. } => theta.norm().min(1.0).asin(),
            _ => theta.norm(),
        },
    }
}

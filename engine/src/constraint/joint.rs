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
//!
//! A slider (prismatic: `Turning::Locked` and a `slide` axis `u`, fixed in
//! A) keeps the anchors together only along the two directions `n_k`
//! normal to `u`: `psi . n_k = 0`, the anchors free to part along `u`.
//! As `n_k` turns with A, the row is the exact rate of `n_k . psi`:
//! `d/dt (n . psi) = (w_A x n) . psi + n . (v_A + w_A x r_A - v_B - w_B x
//! r_B) = n . (v_A + w_A x (r_A - psi) - v_B - w_B x r_B)`, using
//! `(w x n) . psi = n . (w x (-psi))`; so A's lever arm is `r_A - psi =
//! p_B - x_A`, B's anchor seen from A's centre (ODE's slider does the
//! same). Without it the rows would miss `w_A . (n x psi)`, which grows
//! with the slide's travel.

use crate::constraint::rows::Row;
use crate::model::kinematics::anchor;
use crate::model::state::State;
use crate::model::{Attachment, Joint, Turning};
use nalgebra::{UnitQuaternion, Vector3};

/// A side's orientation (the world's: the identity).
fn orientation(att: Attachment, state: &State) -> UnitQuaternion<f64> {
    match att {
        Attachment::World => UnitQuaternion::identity(),
        Attachment::Body(i) => state.bodies[i].q,
    }
}

/// A hinge's or slider's axis in the world, as A holds it (`None` for
/// spherical and fixed joints): the axis of its coordinate, limits and
/// motor.
pub fn axis(joint: &Joint, state: &State) -> Option<Vector3<f64>> {
    match (joint.slide, joint.turning) {
        (Some(u), _) | (None, Turning::Axis { a: u, .. }) => Some(orientation(joint.a, state) * u),
        _ => None,
    }
}

/// A side's body (none for the world).
pub fn body(att: Attachment) -> Option<usize> {
    match att {
        Attachment::World => None,
        Attachment::Body(i) => Some(i),
    }
}

/// Two unit directions normal to unit `u` and to each other.
fn normals(u: &Vector3<f64>) -> [Vector3<f64>; 2] {
    let t1 = crate::model::kinematics::perpendicular(u);
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
        Turning::Axis { a, b, .. } => {
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
    match joint.slide {
        None => {
            for k in 0..3 {
                rows.push(Row::along(Vector3::ith(k, 1.0), ra, rb));
                offset.push(factor * psi[k] / h);
            }
        }
        Some(axis) => {
            let u = orientation(joint.a, state) * axis;
            let ra = ra.map(|(i, r)| (i, r - psi));
            for n in normals(&u) {
                rows.push(Row::along(n, ra, rb));
                offset.push(factor * psi.dot(&n) / h);
            }
        }
    }
    let Some((theta, dirs)) = turning(joint, state) else {
        return;
    };
    for p in dirs.into_iter().flatten() {
        rows.push(Row::turning(p, body(joint.a), body(joint.b)));
        offset.push(-factor * theta.dot(&p) / h);
    }
}

/// The rows of `joints` and their position errors `psi` (m, or rad on a
/// turning row: the offsets of [`push_rows`] with no stabilisation factor
/// and no step), into `rows` and `psi`, cleared first: the position-level
/// problems' (`integrate::project`, `integrate::rattle`), where
/// `G^T dx + psi = 0` closes the joints.
pub fn position_rows<'a>(
    joints: impl IntoIterator<Item = &'a Joint>,
    state: &State,
    rows: &mut Vec<Row>,
    psi: &mut Vec<f64>,
) {
    rows.clear();
    psi.clear();
    for joint in joints {
        push_rows(joint, state, 1.0, 1.0, rows, psi);
    }
}

/// The joint's anchor error (m): the distance between its anchors, or
/// for a slider their distance off its axis.
pub fn anchor_error(joint: &Joint, state: &State) -> f64 {
    let (pa, _) = anchor(joint.a, &joint.local_a, state);
    let (pb, _) = anchor(joint.b, &joint.local_b, state);
    let psi = pa - pb;
    match joint.slide {
        None => psi.norm(),
        Some(axis) => {
            let u = orientation(joint.a, state) * axis;
            (psi - u * u.dot(&psi)).norm()
        }
    }
}

/// The impulses the joint's rows put on A (world frame), from its rows
/// and their impulses: the anchor rows' force impulse (N s) and the
/// rotation rows' torque impulse (N m s, a pure couple: the rows are
/// `[0 ; p]` on A). B gets their opposites (the force at its anchor).
pub fn impulses_on_a(
    joint: &Joint,
    rows: &[Row],
    impulses: &[f64],
) -> (Vector3<f64>, Vector3<f64>) {
    let on_a = |row: &Row| match (&row.a, &row.b) {
        (Some(a), _) => (a.lin, a.ang),
        (None, Some(b)) => (-b.lin, -b.ang),
        (None, None) => (Vector3::zeros(), Vector3::zeros()),
    };
    let anchors = joint.anchor_rows();
    let mut out = (Vector3::zeros(), Vector3::zeros());
    for (k, (row, p)) in rows.iter().zip(impulses).take(joint.rows()).enumerate() {
        let (lin, ang) = on_a(row);
        if k < anchors {
            out.0 += lin * *p;
        } else {
            out.1 += ang * *p;
        }
    }
    out
}

/// A hinge's or slider's coordinate and its rate: the hinge's angle
/// (rad) of B about the axis from where it was at t = 0 and its angular
/// rate (rad/s), or the slider's offset (m) of B's anchor from A's along
/// the axis and its rate (m/s); `None` for spherical and fixed joints
/// (no single coordinate). Signs follow the axis as given in the scene,
/// B relative to A (MuJoCo's hinge and slide `qpos`, `qvel`); the angle
/// is in (-pi, pi] (a figure unwraps it).
pub fn coordinate(joint: &Joint, state: &State) -> Option<(f64, f64)> {
    // A side's angular velocity, and the velocity of its anchor (lever
    // arm `r` from `anchor`; the world's: zero).
    let spin = |att: Attachment| body(att).map_or_else(Vector3::zeros, |i| state.bodies[i].w);
    let point = |r: Option<(usize, Vector3<f64>)>| {
        r.map_or_else(Vector3::zeros, |(i, r)| {
            crate::model::kinematics::point_velocity(&state.bodies[i], &r)
        })
    };
    let (wa, wb) = (spin(joint.a), spin(joint.b));
    if let Some(axis) = joint.slide {
        let u = orientation(joint.a, state) * axis;
        let (pa, ra) = anchor(joint.a, &joint.local_a, state);
        let (pb, rb) = anchor(joint.b, &joint.local_b, state);
        let d = pb - pa;
        // d/dt (u . d) = (w_A x u) . d + u . (v_pB - v_pA), u turning
        // with A; the first term is w_A . (u x d), zero while the slider
        // keeps d along u.
        return Some((
            u.dot(&d),
            wa.cross(&u).dot(&d) + u.dot(&(point(rb) - point(ra))),
        ));
    }
    let Turning::Axis {
        a, zero_a, zero_b, ..
    } = joint.turning
    else {
        return None;
    };
    let (qa, qb) = (orientation(joint.a, state), orientation(joint.b, state));
    let u = qa * a;
    // The angle from A's zero direction to B's about the axis: the two
    // coincided at t = 0 and are normal to the axis in each frame.
    let (ea, eb) = (qa * zero_a, qb * zero_b);
    let angle = u.dot(&ea.cross(&eb)).atan2(ea.dot(&eb));
    Some((angle, u.dot(&(wb - wa))))
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

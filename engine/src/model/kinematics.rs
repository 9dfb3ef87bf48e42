//! Where a body's points are and how fast they move: the few kinematic
//! functions of a state that the stages above share (a joint's anchor, a
//! point's velocity, a deterministic perpendicular).

use super::state::{BodyState, State};
use super::Attachment;
use nalgebra::Vector3;

/// World position of a joint's anchor on one side, and its lever arm.
pub fn anchor(
    att: Attachment,
    local: &Vector3<f64>,
    state: &State,
) -> (Vector3<f64>, Option<(usize, Vector3<f64>)>) {
    match att {
        Attachment::World => (*local, None),
        Attachment::Body(i) => {
            let b = &state.bodies[i];
            let r = b.q.transform_vector(local);
            (b.x + r, Some((i, r)))
        }
    }
}

/// Velocity of the material point at lever arm `r` of a body.
pub fn point_velocity(b: &BodyState, r: &Vector3<f64>) -> Vector3<f64> {
    b.v + b.w.cross(r)
}

/// A unit vector perpendicular to `n`, chosen deterministically.
pub fn perpendicular(n: &Vector3<f64>) -> Vector3<f64> {
    // Cross with the axis least aligned with n: never near-parallel.
    let a = n.abs();
    let axis = if a.x <= a.y && a.x <= a.z {
        Vector3::x()
    } else if a.y <= a.z {
        Vector3::y()
    } else {
        Vector3::z()
    };
    n.cross(&axis).normalize()
}

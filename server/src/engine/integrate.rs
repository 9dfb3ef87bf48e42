//! Position update: `u' = u + V(u) nu' h`, then unit quaternions.
//!
//! Positions advance with the end-of-step velocity (semi-implicit Euler). The
//! rotation uses the exponential map `q' = exp(h w / 2) q` for the
//! world-frame angular velocity `w`, which formulation.md names as the exact
//! alternative to the linear quaternion rate `e_dot = 1/2 G(e)^T w`: it
//! rotates by exactly `|w| h` about `w`, where the linear update rotates by
//! `atan(|w| h / 2) * 2` and needs the normalisation to stay a rotation. The
//! quaternion is normalised all the same, so round-off cannot accumulate.

use super::state::State;
use nalgebra::{UnitQuaternion, Vector3};

/// Advances every body with the new velocities `nu` (`[v_i, w_i]` per body).
pub fn positions(state: &mut State, nu: &[f64], h: f64) {
    for (i, b) in state.bodies.iter_mut().enumerate() {
        let k = 6 * i;
        b.v = Vector3::new(nu[k], nu[k + 1], nu[k + 2]);
        b.w = Vector3::new(nu[k + 3], nu[k + 4], nu[k + 5]);
        b.x += b.v * h;
        let q = UnitQuaternion::from_scaled_axis(b.w * h) * b.q;
        b.q = UnitQuaternion::new_normalize(q.into_inner());
    }
}

//! Position update: `u' = u + V(u) nu' h`, then unit quaternions.
//!
//! Positions advance with the end-of-step velocity (semi-implicit Euler). The
//! rotation uses the exponential map `q' = exp(h w / 2) q` for the
//! world-frame angular velocity `w`, which formulation.md names as the exact
//! alternative to the linear quaternion rate `e_dot = 1/2 G(e)^T w`: it
//! rotates by exactly `|w| h` about `w`, where the linear update rotates by
//! `atan(|w| h / 2) * 2` and needs the normalisation to stay a rotation. The
//! quaternion is normalised all the same, so round-off cannot accumulate.

//!
//! With `position_update = "trapezoid"` a body whose velocity changed
//! smoothly this step advances with the mean of its start and end
//! velocities, `x' = x + h (v + v') / 2`: exact when the acceleration is
//! constant over the step (flight, sliding, rolling: the end-of-step
//! update is off by `h^2 a / 2` per step, `h t a / 2` in all, the first
//! order error of S1), second order in smooth motion. A body in an impact
//! this step, or on a joint (`impulsive`, see `Engine::mark_impulsive`),
//! keeps `x' = x + h v'`: averaging across a velocity jump would carry it
//! half a step into the surface it hit.

pub mod project;
pub mod rattle;
pub mod skyline;

use crate::model::state::State;
use cosim_shared::PositionUpdate;
use nalgebra::{UnitQuaternion, Vector3};

/// A body's pose after the step: position and orientation.
pub type Pose = (Vector3<f64>, UnitQuaternion<f64>);

/// Advances the `awake` bodies (ascending; a sleeping body keeps its pose
/// and zero velocity) with the new velocities `nu` (`[v_i, w_i]` per body).
/// The new poses are computed into `poses` first and written only when every
/// one is finite: finite but huge velocities (an input of 1e308 N m, a scene
/// spun at 1e308 rad/s) overflow here, and the step must then fail with the
/// state as it was (issue 15, point 12: the fuzzer found steps that said ok
/// and left infinite positions). `Err(body)` names the first body at fault.
pub fn positions(
    state: &mut State,
    nu: &[f64],
    h: f64,
    mode: PositionUpdate,
    impulsive: &[bool],
    awake: &[u32],
    poses: &mut Vec<Pose>,
) -> Result<(), usize> {
    poses.clear();
    for &i in awake {
        let i = i as usize;
        let b = &state.bodies[i];
        let k = 6 * i;
        let v = Vector3::new(nu[k], nu[k + 1], nu[k + 2]);
        let w = Vector3::new(nu[k + 3], nu[k + 4], nu[k + 5]);
        let (dx, dw) = match mode {
            PositionUpdate::Trapezoid if !impulsive.get(i).copied().unwrap_or(false) => {
                ((b.v + v) * (0.5 * h), (b.w + w) * (0.5 * h))
            }
            _ => (v * h, w * h),
        };
        let x = b.x + dx;
        let q = UnitQuaternion::from_scaled_axis(dw) * b.q;
        let q = UnitQuaternion::new_normalize(q.into_inner());
        if !(x.iter().all(|c| c.is_finite()) && q.coords.iter().all(|c| c.is_finite())) {
            return Err(i);
        }
        poses.push((x, q));
    }
    for (&i, &(x, q)) in awake.iter().zip(poses.iter()) {
        let i = i as usize;
        let b = &mut state.bodies[i];
        let k = 6 * i;
        b.v = Vector3::new(nu[k], nu[k + 1], nu[k + 2]);
        b.w = Vector3::new(nu[k + 3], nu[k + 4], nu[k + 5]);
        b.x = x;
        b.q = q;
    }
    Ok(())
}

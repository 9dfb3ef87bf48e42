//! Joint motors: a hinge's or slider's coordinate rate driven to a target
//! speed `v*` by an effort of at most `F`, one bounded row per motor
//! (Rapier's and ODE's joint motor; MuJoCo's velocity actuator with a
//! force range). Over a step the row reads
//!
//! ```text
//! x' = v*      with |p| < F h,
//! x' >= v*     with p = -F h,      x' <= v*  with p = F h,
//! ```
//!
//! `x'` the coordinate's rate after the step (`rate_row`) and `p` the
//! row's impulse: the mixed complementarity of a box `[-F h, F h]`.
//! Lemke sees it as a friction block of two directions with a cap that is
//! a constant instead of `mu p_n` (`p = p+ - p-`, derivation at
//! `Mlcp::form_matrix`); PGS projects on the box. The bound is a constant
//! in the LCP's `q`, so the matrix stays the one `prepare` made before
//! the inputs, whatever speed a controller sets.
//!
//! A motor with gains (`Gains`) is the same row made compliant, `x' + eps
//! p = v` (`drive`): its effort is the gains' law evaluated at the step's
//! end, so a stiff servo holds at any step (MuJoCo's implicit actuators;
//! ODE's ERP and CFM in physical units):
//! - velocity actuator, effort `kv (v* - x')`: `p = h kv (v* - x')`, so
//!   `eps = 1 / (h kv)` and `v = v*`;
//! - position servo, effort `kp (q* - q_end) - kd x'` with `q_end = q + h
//!   x'`: `p = h kp (q* - q) - (h^2 kp + h kd) x'`, so with `c = h^2 kp +
//!   h kd`, `eps = 1 / c` and `v = h kp (q* - q) / c`.
//!
//! Inside the box the row is the law exactly; at the bound the effort is
//! the bound. `eps` is constant over a run (gains and `h`), so it sits in
//! the matrix beside the Delassus diagonal; `v` moves with `q` in `q`.

use crate::constraint::joint::{axis, body};
use crate::constraint::rows::Row;
use crate::model::kinematics::anchor;
use crate::model::state::State;
use crate::model::{Gains, Joint, Motor};
use nalgebra::Vector3;

/// The row whose velocity is the coordinate's rate `x'`
/// (`joint::coordinate`), for a hinge or slider:
/// - hinge: `x' = u . (w_B - w_A)`, the turning row about `-u`
///   (`Row::turning(p)` reads `p . (w_A - w_B)`);
/// - slider: `x' = d/dt (u . (p_B - p_A))`, with `u` turning with A,
///   `= -(u . (v_A + w_A x (p_B - x_A)) - u . v_pB)`: the row along `-u`
///   with A's lever arm at B's anchor, as the slider's own rows (joint.rs
///   derives the rate of such a product).
pub fn rate_row(joint: &Joint, state: &State) -> Option<Row> {
    let u = axis(joint, state)?;
    if joint.slide.is_none() {
        return Some(Row::turning(-u, body(joint.a), body(joint.b)));
    }
    let (pa, ra) = anchor(joint.a, &joint.local_a, state);
    let (pb, rb) = anchor(joint.b, &joint.local_b, state);
    let ra = ra.map(|(i, r)| (i, r + (pb - pa)));
    Some(Row::along(-u, ra, rb))
}

/// The impulse a motor row's `p` puts on A (world frame): `-u p`, a
/// couple (N m s) about a hinge's axis or a force impulse (N s) along a
/// slider's. The rate row has `-u` as A's part (`ang` or `lin`), or, with
/// A the world, `+u` as B's, whose opposite A takes.
pub fn impulse_on_a(axis: &Vector3<f64>, p: f64) -> Vector3<f64> {
    -axis * p
}

/// The row a motor drives over a step of `h` (see the module's notes):
/// `(v, eps)`, its target rate and compliance, from its `target` (a rate,
/// or a servo's coordinate) and the coordinate `q` at the step's start. A
/// hinge's position error is taken the short way round.
pub fn drive(motor: &Motor, target: f64, q: f64, h: f64, hinge: bool) -> (f64, f64) {
    let eps = compliance(motor, h);
    match motor.gains {
        Gains::Rigid | Gains::Velocity { .. } => (target, eps),
        Gains::Position { kp, kd } => {
            let mut e = target - q;
            if hinge {
                use std::f64::consts::{PI, TAU};
                e = (e + PI).rem_euclid(TAU) - PI;
            }
            // Divided, not times eps: the servo's bits as they were.
            (h * kp * e / (h * h * kp + h * kd), eps)
        }
    }
}

/// A motor's compliance `eps` (constant over a run): 0 when rigid,
/// `1 / (h kv)` for a velocity actuator, `1 / (h^2 kp + h kd)` for a
/// servo.
pub fn compliance(motor: &Motor, h: f64) -> f64 {
    match motor.gains {
        Gains::Rigid => 0.0,
        Gains::Velocity { kv } => 1.0 / (h * kv),
        Gains::Position { kp, kd } => 1.0 / (h * h * kp + h * kd),
    }
}

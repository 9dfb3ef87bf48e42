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

use crate::constraint::joint::{axis, body};
use crate::constraint::rows::Row;
use crate::model::kinematics::anchor;
use crate::model::state::State;
use crate::model::Joint;
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

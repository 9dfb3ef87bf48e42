//! Armature: a rotor of inertia `I_a` geared to a joint's coordinate
//! (MuJoCo's joint `armature`, a motor's reflected inertia), kinetic
//! energy `I_a x'^2 / 2` on the coordinate's rate `x'` (on each of a
//! spherical joint's three relative spin components). In reduced
//! coordinates it is `I_a` on the mass matrix's diagonal; here, where
//! each body keeps its own mass matrix, it is a row beside the joint's.
//!
//! The rotor turns with the coordinate, so its momentum `I_a x'` changes
//! only by the impulse `-p` it takes from the bodies: over a step
//! `I_a (x'_{n+1} - x'_n) = -p`. With `x' = G^T nu` the row reads
//!
//! ```text
//! G^T nu' + p / I_a - x'_n = 0,
//! ```
//!
//! a bilateral row with compliance `1 / I_a` and constant term `-x'_n`
//! (the rate at the step's start): the implicit step of `(M + I_a G G^T)
//! nu' = ...`, so a stiff drive on a light link holds as it does in
//! MuJoCo. Its constant is no drift: it is never relaxed, asks no energy
//! budget, and the row's impulse moves energy between the rotor and the
//! bodies: the energy check counts both (`Mlcp::rotor_change`).

use crate::constraint::joint::body;
use crate::constraint::motor::rate_row;
use crate::constraint::rows::Row;
use crate::model::state::State;
use crate::model::{Joint, Turning};
use nalgebra::Vector3;

/// Appends the rotor's rows of `joint` (`Joint::armature_rows` of them)
/// and their constant terms `-x'_n`.
pub fn push_rows(joint: &Joint, state: &State, rows: &mut Vec<Row>, offset: &mut Vec<f64>) {
    let n = joint.armature_rows();
    if n == 0 {
        return;
    }
    let mut push = |row: Row| {
        offset.push(-row.state_velocity(state));
        rows.push(row);
    };
    if matches!(joint.turning, Turning::Free) {
        for k in 0..3 {
            push(Row::turning(
                Vector3::ith(k, 1.0),
                body(joint.a),
                body(joint.b),
            ));
        }
    } else if let Some(row) = rate_row(joint, state) {
        push(row);
    }
}

/// The compliance of the rotor's rows, `1 / I_a`.
pub fn compliance(joint: &Joint) -> f64 {
    1.0 / joint.armature
}

/// The rotor's kinetic energy in `state`, `I_a |x'|^2 / 2` (J).
pub fn energy(joint: &Joint, state: &State) -> f64 {
    if joint.armature_rows() == 0 {
        return 0.0;
    }
    let rate2 = if matches!(joint.turning, Turning::Free) {
        let w = |side| body(side).map_or(Vector3::zeros(), |i| state.bodies[i].w);
        (w(joint.b) - w(joint.a)).norm_squared()
    } else {
        rate_row(joint, state).map_or(0.0, |row| row.state_velocity(state).powi(2))
    };
    0.5 * joint.armature * rate2
}

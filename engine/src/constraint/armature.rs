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
    each_row(joint, state, |row| {
        offset.push(-row.state_velocity(state));
        rows.push(row);
    });
}

/// The compliance of the rotor's rows, `1 / I_a`.
pub fn compliance(joint: &Joint) -> f64 {
    1.0 / joint.armature
}

/// The rotor's kinetic energy in `state`, `I_a |x'|^2 / 2` (J), its rate
/// read on its rows, as the energy check reads it (`Mlcp::rotor_change`).
pub fn energy(joint: &Joint, state: &State) -> f64 {
    let mut rate2 = 0.0;
    each_row(joint, state, |row| {
        rate2 += row.state_velocity(state).powi(2)
    });
    0.5 * joint.armature * rate2
}

/// Each of the rotor's rows (none without armature): the coordinate's
/// rate row, or a spherical joint's three relative spin rows.
fn each_row(joint: &Joint, state: &State, mut f: impl FnMut(Row)) {
    if joint.armature_rows() == 0 {
        return;
    }
    if matches!(joint.turning, Turning::Free) {
        for k in 0..3 {
            f(Row::turning(
                Vector3::ith(k, 1.0),
                body(joint.a),
                body(joint.b),
            ));
        }
    } else if let Some(row) = rate_row(joint, state) {
        f(row);
    }
}

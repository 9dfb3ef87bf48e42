//! The state: small, `Clone`, complete. A snapshot is a copy of it, so
//! rollback and bit-exact replay need nothing else.

use super::model::Model;
use nalgebra::{UnitQuaternion, Vector3};

/// Pose and twist of one body; velocities in the world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyState {
    pub x: Vector3<f64>,
    pub q: UnitQuaternion<f64>,
    pub v: Vector3<f64>,
    pub w: Vector3<f64>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// Steps taken since the initial state.
    pub step: u64,
    /// Simulated time (s): `step * h`, kept as a product so it never drifts.
    pub t: f64,
    pub bodies: Vec<BodyState>,
    /// Warm start of the iterative solver, part of the state so that a
    /// snapshot is complete and a restored PGS run repeats its bits: the
    /// last step's normal impulse of every potential contact (by canonical
    /// index), its friction impulse as a world vector (the tangent basis
    /// turns with the slip from step to step, the world vector does not),
    /// and joint impulses (3 per joint).
    pub warm_normal: Vec<f64>,
    pub warm_friction: Vec<Vector3<f64>>,
    pub warm_joint: Vec<f64>,
    /// Lemke's guess: the last step's final LCP layout (contact id, whether
    /// it had friction rows, per normal row) and which unknowns were
    /// positive. Part of the state for the same reason as the impulses.
    pub warm_lcp: Vec<(usize, bool)>,
    pub warm_active: Vec<bool>,
}

impl State {
    pub fn initial(model: &Model) -> State {
        State {
            step: 0,
            t: 0.0,
            bodies: model
                .initial
                .iter()
                .map(|b| BodyState {
                    x: b.position,
                    q: b.orientation,
                    v: b.velocity,
                    w: b.angular_velocity,
                })
                .collect(),
            warm_normal: vec![0.0; model.potential_contacts()],
            warm_friction: vec![Vector3::zeros(); model.potential_contacts()],
            warm_joint: vec![0.0; 3 * model.joints.len()],
            warm_lcp: Vec::new(),
            warm_active: Vec::new(),
        }
    }
}

//! A controller for examples/scenes/push.toml that pushes its box across
//! the floor to a target point by body impulses (protocol's one-step
//! impulses, at the box's centre of mass): a velocity servo, as a
//! Rapier or Bullet user moves a body by impulses. Per step it reads the
//! box's position and velocity from the state frame, asks for the speed
//! `v* = k (x* - x)` (clipped to `MAX_SPEED`, horizontal) and sends the
//! impulse `m (v* - v)` that would give it. Friction takes `mu m g h` of
//! that each step while the box slides, so it lags by `mu g h` (4 mm/s);
//! near the target the impulse falls below what static friction holds
//! and the box stops within `mu g h / k` (0.8 mm) of it. The examples
//! crate's `push_controller` runs it in a process of its own;
//! examples/python/push_controller.py is the same law in Python.

use crate::{ClientError, InputFrame, StateFrame};
use std::time::Duration;

/// The box's body index in push.toml and its mass (kg).
pub const BODY: usize = 0;
pub const MASS: f64 = 2.0;
/// Per second: the position error's decay rate while the box slides.
pub const GAIN: f64 = 5.0;
/// The largest speed asked for (m/s).
pub const MAX_SPEED: f64 = 0.5;

/// The impulse (N s, world frame) that asks for the servo's speed
/// towards `target` (x, y; m) at `frame`, and the box's position.
pub fn impulse(frame: &StateFrame, target: [f64; 2]) -> ([f64; 3], [f64; 3]) {
    let b = &frame.bodies()[BODY];
    let mut p = [0.0; 3];
    let (mut want, mut norm) = ([0.0; 2], 0.0f64);
    for k in 0..2 {
        want[k] = GAIN * (target[k] - b.position[k]);
        norm += want[k] * want[k];
    }
    let scale = (MAX_SPEED / norm.sqrt().max(f64::MIN_POSITIVE)).min(1.0);
    for k in 0..2 {
        p[k] = MASS * (want[k] * scale - b.linear_velocity[k]);
    }
    (p, b.position)
}

/// What a run did: steps answered and the box's last position (m).
#[derive(Debug, Clone, Copy, Default)]
pub struct Outcome {
    pub steps: u64,
    pub position: [f64; 3],
}

/// Joins server `name` and pushes the box to `target` until the server
/// shuts down.
pub fn run(name: &str, target: [f64; 2], timeout: Duration) -> Result<Outcome, ClientError> {
    let mut position = [f64::NAN; 3];
    let steps = crate::answer_each(name, timeout, |frame| {
        let (p, at) = impulse(frame, target);
        position = at;
        let mut input = InputFrame::default();
        input.push_impulse(BODY as u32, p, [0.0; 3]);
        input
    })?;
    Ok(Outcome { steps, position })
}

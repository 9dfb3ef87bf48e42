//! A position controller for examples/scenes/arm.toml by its joints'
//! velocity motors (protocol 4's motor targets): per step it reads the
//! shoulder's and elbow's angles from the state frame and sets each motor's
//! target rate to `k (q* - q)`, clipped to `MAX_RATE`. This is how a Rapier
//! or ODE user drives a joint to a position with a velocity motor: while
//! the motors stay within their effort bounds the rate is the target
//! exactly, so each angle error decays by `1 - k h` a step, with no steady
//! error under gravity (the motor carries the load). The examples crate's
//! `arm_controller` runs it in a process of its own;
//! examples/python/arm_controller.py is the same law in Python.

use crate::{ClientError, Connection, InputFrame, Names, StateFrame};
use std::time::Duration;

/// The arm's joints with motors, by name (their indices are looked up in
/// the server's scene: `Names`).
pub const JOINTS: [&str; 2] = ["shoulder", "elbow"];
/// Per second: the angle error's decay rate within the motors' bounds.
pub const GAIN: f64 = 5.0;
/// The largest target rate (rad/s).
pub const MAX_RATE: f64 = 2.0;

/// The motor targets (rad/s) for the angles `target` (rad) of `joints`
/// at `frame`, and the angles read.
pub fn rates(frame: &StateFrame, joints: [u32; 2], target: [f64; 2]) -> ([f64; 2], [f64; 2]) {
    let angles = joints.map(|j| frame.joint_coordinates[j as usize][0]);
    let rate = |k: usize| (GAIN * (target[k] - angles[k])).clamp(-MAX_RATE, MAX_RATE);
    ([rate(0), rate(1)], angles)
}

/// What a run did: steps answered and the last angles read (rad).
#[derive(Debug, Clone, Copy, Default)]
pub struct Outcome {
    pub steps: u64,
    pub angles: [f64; 2],
}

/// Joins server `name` and steers the arm to `target` (shoulder, elbow;
/// rad) until the server shuts down.
pub fn run(name: &str, target: [f64; 2], timeout: Duration) -> Result<Outcome, ClientError> {
    let names = Names::fetch(&Connection::connect(name)?)?;
    let joints = [names.joint(JOINTS[0])?, names.joint(JOINTS[1])?];
    let mut angles_read = [f64::NAN; 2];
    let steps = crate::answer_each(name, timeout, |frame| {
        let (rates, angles) = rates(frame, joints, target);
        angles_read = angles;
        let mut input = InputFrame::default();
        for (j, v) in joints.into_iter().zip(rates) {
            input.push_motor(j, v);
        }
        input
    })?;
    Ok(Outcome {
        steps,
        angles: angles_read,
    })
}

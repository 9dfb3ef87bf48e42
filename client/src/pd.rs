//! A PD controller that holds the reference scene's double pendulum: the
//! upper arm at a target elevation, the lower arm hanging straight down.
//! It is the controller of `cosim-server demo` and a worked example of the
//! client API: join, then per step read the state and answer with torques.
//!
//! The controller knows the reference scene's geometry (anchors, masses)
//! as constants below; the wire carries poses, not the model.

use crate::{ClientError, Controller, InputFrame, StateFrame, WaitMode};
use nalgebra::{UnitQuaternion, Vector3};
use std::time::Duration;

/// The reference scene (examples/scenes/reference.toml): shoulder anchor in
/// the world, elbow anchor in the upper sphere's frame, masses.
pub const SHOULDER: [f64; 3] = [0.0, 0.0, 0.45];
pub const ELBOW_IN_UPPER: [f64; 3] = [0.12, 0.0, 0.0];
pub const MASS_UPPER: f64 = 1.0;
pub const MASS_LOWER: f64 = 0.5;
pub const GRAVITY: [f64; 3] = [0.0, 0.0, -9.81];

#[derive(Debug, Clone, Copy)]
pub struct Gains {
    /// Target elevation of the upper arm above the horizontal (degrees).
    pub elevation_deg: f64,
    /// Target azimuth of the upper arm from +x towards +y (degrees).
    pub azimuth_deg: f64,
    /// Shoulder stiffness (N m/rad) and damping (N m s/rad). About the
    /// shoulder the chain has an inertia near 0.18 kg m^2: 20 and 3 give a
    /// natural frequency near 10 rad/s, damping ratio near 0.8.
    pub kp: f64,
    pub kd: f64,
    /// Elbow stiffness and damping (the lower sphere: about 0.022 kg m^2).
    pub kp_elbow: f64,
    pub kd_elbow: f64,
    /// A strike: from step `from` to step `to` the target elevation is
    /// `elevation_deg` instead (the demo swings the arm down until the
    /// lower sphere hits the floor and presses on it, then lifts it).
    pub strike: Option<Strike>,
}

/// A stretch of steps with another target elevation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Strike {
    pub from: u64,
    pub to: u64,
    pub elevation_deg: f64,
}

impl Default for Gains {
    fn default() -> Gains {
        Gains {
            elevation_deg: 10.0,
            azimuth_deg: 0.0,
            kp: 20.0,
            kd: 3.0,
            kp_elbow: 2.0,
            kd_elbow: 0.3,
            strike: None,
        }
    }
}

impl Gains {
    /// Unit vector of the target arm direction.
    pub fn target(&self) -> Vector3<f64> {
        self.target_at(0)
    }

    /// The target elevation at step `step` (degrees).
    pub fn elevation_at(&self, step: u64) -> f64 {
        match self.strike {
            Some(s) if (s.from..s.to).contains(&step) => s.elevation_deg,
            _ => self.elevation_deg,
        }
    }

    /// Unit vector of the target arm direction at step `step`.
    pub fn target_at(&self, step: u64) -> Vector3<f64> {
        let (e, a) = (
            self.elevation_at(step).to_radians(),
            self.azimuth_deg.to_radians(),
        );
        Vector3::new(e.cos() * a.cos(), e.cos() * a.sin(), e.sin())
    }
}

/// The elevation of the upper arm above the horizontal (degrees).
pub fn elevation_deg(frame: &StateFrame) -> f64 {
    let x = Vector3::from(frame.bodies[0].position) - Vector3::from(SHOULDER);
    (x.z / x.norm()).asin().to_degrees()
}

/// The torques `(shoulder, elbow)` for one state: PD on the direction of
/// each arm plus gravity compensation.
pub fn torques(frame: &StateFrame, g: &Gains) -> (Vector3<f64>, Vector3<f64>) {
    let upper = &frame.bodies[0];
    let lower = &frame.bodies[1];
    let gravity = Vector3::from(GRAVITY);
    let shoulder = Vector3::from(SHOULDER);
    let x_u = Vector3::from(upper.position);
    let x_l = Vector3::from(lower.position);
    let [w, i, j, k] = upper.orientation;
    let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, i, j, k));
    let elbow = x_u + q * Vector3::from(ELBOW_IN_UPPER);
    let w_u = Vector3::from(upper.angular_velocity);
    let w_l = Vector3::from(lower.angular_velocity);

    // Elbow: lower arm straight down. Its torque acts +tau on the lower
    // sphere and -tau on the upper one.
    let d_e = (x_l - elbow).normalize();
    let tau_e = g.kp_elbow * d_e.cross(&-Vector3::z())
        - g.kd_elbow * (w_l - w_u)
        - (x_l - elbow).cross(&(MASS_LOWER * gravity));
    // Shoulder: the whole chain's gravity moment about the shoulder, which
    // is what the shoulder carries at rest, plus the elbow's reaction.
    let d = (x_u - shoulder).normalize();
    let tau_s = g.kp * d.cross(&g.target_at(frame.step))
        - g.kd * w_u
        - (x_u - shoulder).cross(&(MASS_UPPER * gravity))
        - (x_l - shoulder).cross(&(MASS_LOWER * gravity))
        + tau_e;
    (tau_s, tau_e)
}

/// What a controller run did.
#[derive(Debug, Clone, Copy, Default)]
pub struct Outcome {
    pub steps: u64,
    pub final_elevation_deg: f64,
}

/// Joins server `name` and controls it until `steps` answers were sent (then
/// leaves) or the server shuts down.
pub fn run(
    name: &str,
    gains: &Gains,
    wait: WaitMode,
    steps: Option<u64>,
    timeout: Duration,
) -> Result<Outcome, ClientError> {
    let mut c = Controller::join(name, wait)?;
    let mut out = Outcome::default();
    loop {
        let frame = match c.next_state(timeout) {
            Ok(f) => f,
            Err(ClientError::Shutdown) => break,
            Err(e) => return Err(e),
        };
        out.final_elevation_deg = elevation_deg(&frame);
        if steps.is_some_and(|n| out.steps >= n) {
            c.leave()?;
            return Ok(out);
        }
        let (s, e) = torques(&frame, gains);
        let mut input = InputFrame::default();
        input.push_torque(0, s.into());
        input.push_torque(1, e.into());
        c.send(input)?;
        out.steps += 1;
    }
    Ok(out)
}

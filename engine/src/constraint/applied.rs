//! Applied-impulse stage: gravity, constant forces, joint torques, client
//! impulses and the gyroscopic term, and the free velocity they give,
//! `nu_free = nu + M^-1 p_app` with `p_app = h (F_ext + tau - w x J w)`.

use crate::model::state::State;
use crate::model::{Attachment, Joint, Model};
use nalgebra::{Matrix3, Vector3};

/// What the controllers (and the scene's constants) apply.
///
/// Joint torques are held until changed (a zero-order hold, as a controller
/// expects of a torque command); body impulses act on the next step only.
#[derive(Debug, Clone, PartialEq)]
pub struct Inputs {
    /// Per joint, its effort: `+torque` on body_b, `-torque` on body_a
    /// (N m); for a slider a force (N) at B's anchor (`free_velocity`).
    pub joint_torque: Vec<Vector3<f64>>,
    /// Per body: linear and angular impulse (N s, N m s), world frame.
    pub body_impulse: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// Per joint, its motor's target: a rate (rad/s or m/s), or a position
    /// servo's coordinate (rad or m); held until changed, the scene's at
    /// first; 0 and unread without a motor.
    pub motor_speed: Vec<f64>,
}

impl Inputs {
    pub fn new(model: &Model) -> Inputs {
        Inputs {
            joint_torque: model.joints.iter().map(|j| j.effort).collect(),
            body_impulse: vec![(Vector3::zeros(), Vector3::zeros()); model.bodies.len()],
            motor_speed: model
                .joints
                .iter()
                .map(|j| j.motor.map_or(0.0, |m| m.speed))
                .collect(),
        }
    }

    /// Forgets the one-step impulses once a step has used them.
    pub fn clear_impulses(&mut self) {
        for imp in &mut self.body_impulse {
            *imp = (Vector3::zeros(), Vector3::zeros());
        }
    }
}

/// A bad input, refused before it reaches the step.
#[derive(Debug, Clone, PartialEq)]
pub enum InputError {
    UnknownJoint {
        index: usize,
        joints: usize,
    },
    UnknownBody {
        index: usize,
        bodies: usize,
    },
    /// A motor target for a joint without a motor.
    NoMotor {
        index: usize,
    },
    NonFinite {
        what: &'static str,
        index: usize,
    },
}

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            InputError::UnknownJoint { index, joints } => {
                write!(f, "unknown joint index {index} (the scene has {joints})")
            }
            InputError::UnknownBody { index, bodies } => {
                write!(f, "unknown body index {index} (the scene has {bodies})")
            }
            InputError::NoMotor { index } => {
                write!(f, "joint {index} has no motor (the scene gives it none)")
            }
            InputError::NonFinite { what, index } => {
                write!(f, "{what} {index} is not finite (NaN or infinite)")
            }
        }
    }
}

impl std::error::Error for InputError {}

/// Per-body inverse mass in the world frame: `M_i^-1 = diag(1/m, R J^-1 R^T)`.
#[derive(Debug, Clone, Copy)]
pub struct InvMass {
    pub inv_m: f64,
    pub inv_i: Matrix3<f64>,
}

/// World-frame inverse masses of all bodies, for this step's orientations.
/// A sleeping body's are zero: it is static for the step, and a late
/// contact with an awake body (`sleep.rs`) cannot move it. With `only`
/// (the awake bodies, where the sleeping ones' entries are zero already:
/// `sleep::Written`), those alone are written.
pub fn inverse_masses(model: &Model, state: &State, only: Option<&[u32]>, out: &mut Vec<InvMass>) {
    let of = |i: usize| {
        let r = state.bodies[i].q.to_rotation_matrix();
        let b = &model.bodies[i];
        InvMass {
            inv_m: b.inv_mass,
            inv_i: r.matrix() * b.inv_inertia * r.matrix().transpose(),
        }
    };
    if let Some(awake) = only {
        debug_assert_eq!(out.len(), model.bodies.len());
        for &i in awake {
            out[i as usize] = of(i as usize);
        }
        return;
    }
    out.clear();
    out.extend(
        (0..model.bodies.len()).map(|i| match crate::model::state::asleep(state, i) {
            true => InvMass {
                inv_m: 0.0,
                inv_i: Matrix3::zeros(),
            },
            false => of(i),
        }),
    );
}

/// A joint's held effort within its bound (`Joint::max_effort`), and
/// whether it was clamped: a hinge's or slider's part along its axis (the
/// rest the joint holds, and it is kept), a spherical joint's length.
pub fn bounded(joint: &Joint, state: &State, effort: &Vector3<f64>) -> (Vector3<f64>, bool) {
    let bound = joint.max_effort;
    if bound == f64::INFINITY {
        return (*effort, false);
    }
    match super::joint::axis(joint, state) {
        Some(u) => {
            let along = u.dot(effort);
            if along.abs() <= bound {
                return (*effort, false);
            }
            (effort - u * (along - bound.copysign(along)), true)
        }
        None => {
            let n = effort.norm();
            if n <= bound {
                return (*effort, false);
            }
            (effort * (bound / n), true)
        }
    }
}

/// How many joints' held efforts their bounds clamp in `state`.
pub fn clamped(model: &Model, state: &State, inputs: &Inputs) -> usize {
    model
        .joints
        .iter()
        .zip(&inputs.joint_torque)
        .filter(|(j, e)| bounded(j, state, e).1)
        .count()
}

/// `nu_free = nu + M^-1 p_app`, laid out `[v_0, w_0, v_1, w_1, ...]`;
/// zero for a sleeping body. With `only` (the awake bodies, where the
/// sleeping ones' entries are zero already: `sleep::Written`), those alone
/// are written.
pub fn free_velocity(
    model: &Model,
    state: &State,
    inputs: &Inputs,
    minv: &[InvMass],
    only: Option<&[u32]>,
    nu_free: &mut Vec<f64>,
) {
    let h = model.params.h;
    let write = |i: usize, nu_free: &mut [f64]| {
        let (b, s) = (&model.bodies[i], &state.bodies[i]);
        let (imp_lin, imp_ang) = inputs.body_impulse[i];
        let p_lin = h * (model.params.gravity * b.mass + b.force) + imp_lin;
        // Gyroscopic term w x J w with the world-frame inertia (zero for a
        // sphere, kept so that another shape needs no change here).
        let r = s.q.to_rotation_matrix();
        let j_world = r.matrix() * b.inertia * r.matrix().transpose();
        let p_ang = -h * s.w.cross(&(j_world * s.w)) + imp_ang;
        let v = s.v + p_lin * minv[i].inv_m;
        let w = s.w + minv[i].inv_i * p_ang;
        nu_free[6 * i..6 * i + 3].copy_from_slice(v.as_slice());
        nu_free[6 * i + 3..6 * i + 6].copy_from_slice(w.as_slice());
    };
    // Every body on a joint is awake: its entries, to which the efforts
    // below add, are written first either way.
    match only {
        Some(awake) => {
            debug_assert_eq!(nu_free.len(), 6 * model.bodies.len());
            for &i in awake {
                write(i as usize, nu_free);
            }
        }
        None => {
            nu_free.clear();
            nu_free.resize(6 * model.bodies.len(), 0.0);
            // A sleeping body's stays zero: it is static for the step (and
            // not on a joint, whose efforts are added below; with its zero
            // inverse mass they would add zero).
            for i in 0..model.bodies.len() {
                if !crate::model::state::asleep(state, i) {
                    write(i, nu_free);
                }
            }
        }
    }
    for (joint, effort) in model.joints.iter().zip(&inputs.joint_torque) {
        let p = bounded(joint, state, effort).0 * h;
        effort_on(joint, state, p, |i, force, torque| {
            let (dv, dw) = (force * minv[i].inv_m, minv[i].inv_i * torque);
            for k in 0..3 {
                nu_free[6 * i + k] += dv[k];
                nu_free[6 * i + 3 + k] += dw[k];
            }
        });
    }
}

/// Where a joint's `effort` (held and bounded; or its impulse over a
/// step) acts: `on(body, force, torque)` for B and, opposite, for A. A
/// slider's effort is a force at B's anchor, on both sides at that one
/// point (so it has no moment of its own), its torque about each body's
/// centre; any other joint's a torque.
pub fn effort_on(
    joint: &Joint,
    state: &State,
    effort: Vector3<f64>,
    mut on: impl FnMut(usize, Vector3<f64>, Vector3<f64>),
) {
    let at = joint
        .slide
        .map(|_| crate::model::kinematics::anchor(joint.b, &joint.local_b, state).0);
    for (att, sign) in [(joint.b, 1.0), (joint.a, -1.0)] {
        if let Attachment::Body(i) = att {
            let e = effort * sign;
            match at {
                Some(at) => on(i, e, (at - state.bodies[i].x).cross(&e)),
                None => on(i, Vector3::zeros(), e),
            }
        }
    }
}

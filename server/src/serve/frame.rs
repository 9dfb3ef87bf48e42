//! The state frame of the wire from the engine, and the per-step state
//! hash of replay.

use crate::engine::{solver::LemkeError, StepError};
use crate::engine::{Engine, ImpulseKind, Model, Party, StepReport};
use cosim_shared::wire::*;

/// The contacts a state frame of this model carries at most.
pub fn contact_capacity(model: &Model) -> usize {
    cosim_shared::wire::contact_capacity(model.bodies.len(), model.potential_contacts())
}

/// The most payload words a state frame of this model takes.
pub fn max_words(model: &Model) -> usize {
    state_words(
        model.bodies.len(),
        model.joints.len(),
        contact_capacity(model),
    )
}

/// Fills `f` with the engine's state and last impulses, carrying up to
/// `capacity` contacts. Status bits and controller slots are the server's
/// to set. The frame's buffers are reused: after the first frame of the
/// largest size, filling allocates nothing.
pub fn fill(f: &mut StateFrame, engine: &Engine, report: Option<&StepReport>, capacity: usize) {
    let s = engine.state();
    let model = engine.model();
    f.version = PROTOCOL_VERSION;
    f.step = s.step;
    f.sim_time = s.t;
    f.dt = model.params.h;
    f.bodies.clear();
    f.bodies.extend(s.bodies.iter().map(|b| {
        let q = b.q.quaternion();
        BodyFrame {
            position: b.x.into(),
            orientation: [q.w, q.i, q.j, q.k],
            linear_velocity: b.v.into(),
            angular_velocity: b.w.into(),
        }
    }));
    f.joint_impulses.clear();
    f.joint_impulses.resize(model.joints.len(), [0.0; 3]);
    f.joint_coordinates.clear();
    f.joint_coordinates.extend(model.joints.iter().map(|j| {
        crate::engine::constraint::joint::coordinate(j, engine.state())
            .map_or([f64::NAN; 2], |(x, v)| [x, v])
    }));
    f.contacts.clear();
    let mut contacts = 0usize;
    let mut last_id = None;
    for r in engine.impulses() {
        match r.kind {
            ImpulseKind::Joint => {
                if let Some(j) = f.joint_impulses.get_mut(r.index) {
                    *j = r.impulse.into();
                }
            }
            // Not on the wire (protocol.md: a joint's anchor impulse only).
            ImpulseKind::JointTorque | ImpulseKind::JointLimit | ImpulseKind::JointMotor => {}
            ImpulseKind::Normal | ImpulseKind::Friction => {
                // The records of one contact are consecutive: normal, then
                // friction.
                if last_id != Some(r.index) {
                    last_id = Some(r.index);
                    contacts += 1;
                    if contacts <= capacity {
                        f.contacts.push(ContactFrame::default());
                    }
                }
                if contacts > capacity {
                    continue;
                }
                let Some(c) = f.contacts.last_mut() else {
                    continue;
                };
                c.id = r.index as u32;
                if let Party::Body(a) = r.a {
                    c.body_a = a as u32;
                }
                (c.kind_b, c.index_b) = match r.b {
                    Party::Body(b) => (CONTACT_BODY, b as u32),
                    Party::Plane(p) => (CONTACT_PLANE, p as u32),
                    Party::World => (CONTACT_PLANE, u32::MAX),
                };
                if r.kind == ImpulseKind::Normal {
                    c.normal = r.impulse.into();
                } else {
                    c.friction = r.impulse.into();
                }
            }
        }
    }
    f.contact_count = contacts as u32;
    if contacts > capacity {
        f.status |= STATUS_CONTACTS_TRUNCATED;
    }
    if let Some(r) = report {
        f.lcp_size = r.lcp_size as u32;
        f.residual = r.residual;
        f.solver_status = match r.error {
            None if r.not_converged => SOLVER_NOT_CONVERGED,
            None => SOLVER_OK,
            Some(StepError::Lemke(LemkeError::RayTermination { .. })) => SOLVER_RAY_TERMINATION,
            Some(StepError::Lemke(LemkeError::PivotLimit { .. })) => SOLVER_PIVOT_LIMIT,
            Some(StepError::Mlcp(_)) => SOLVER_SINGULAR,
            Some(_) => SOLVER_OTHER,
        };
        if r.error.is_some() {
            f.status |= STATUS_SOLVER_FAILED;
        }
        if r.fallback.is_some() {
            f.status |= cosim_shared::wire::STATUS_FELL_BACK;
        }
    }
}

/// FNV-1a over the step number and every body's pose and twist, bit for
/// bit: two runs agree on a step exactly when these hashes do (up to
/// collisions, 2^-64).
pub fn state_hash(engine: &Engine) -> u64 {
    let s = engine.state();
    let mut bytes = [0u8; 8 + 13 * 8];
    let mut h = fnv1a(&s.step.to_le_bytes());
    for b in &s.bodies {
        let q = b.q.quaternion();
        let vals = [
            b.x.x, b.x.y, b.x.z, q.w, q.i, q.j, q.k, b.v.x, b.v.y, b.v.z, b.w.x, b.w.y, b.w.z,
        ];
        bytes[..8].copy_from_slice(&h.to_le_bytes());
        for (i, v) in vals.iter().enumerate() {
            bytes[8 + 8 * i..16 + 8 * i].copy_from_slice(&v.to_bits().to_le_bytes());
        }
        h = fnv1a(&bytes);
    }
    h
}

//! The state stream: one frame per step, its header, entries and codes.

use iceoryx2::prelude::ZeroCopySend;

use super::words::{f3, pair, put_f64s, split, WordSink};
use super::*;

/// Pose and twist of one body, world frame: [`BODY_WORDS`] words, all
/// `f64`, in this order.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BodyFrame {
    /// Position of the centre of mass (m).
    pub position: [f64; 3],
    /// Unit quaternion body-to-world, `[w, x, y, z]`.
    pub orientation: [f64; 4],
    /// m/s.
    pub linear_velocity: [f64; 3],
    /// rad/s, world frame.
    pub angular_velocity: [f64; 3],
}

/// What the other side of a contact is.
pub const CONTACT_PLANE: u32 = 0;
pub const CONTACT_BODY: u32 = 1;

/// The impulses of one contact over the step, world frame, on `body_a`
/// (the other side receives the opposite): [`CONTACT_WORDS`] words, the
/// first two holding `body_a | kind_b << 32` and `index_b | id << 32`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactFrame {
    pub body_a: u32,
    /// [`CONTACT_PLANE`] or [`CONTACT_BODY`].
    pub kind_b: u32,
    /// Plane or body index of the other side.
    pub index_b: u32,
    /// Canonical contact id (stable across steps).
    pub id: u32,
    /// Normal impulse (N s).
    pub normal: [f64; 3],
    /// Friction impulse (N s).
    pub friction: [f64; 3],
}

/// `ControllerSlot::flags`.
pub const SLOT_JOINED: u32 = 1;
/// The controller's input for the last step did not arrive in time.
pub const SLOT_MISSED: u32 = 2;
/// The server holds this controller's answer to the frame's step. A frame
/// with `STATUS_SOLVER_FAILED` lacks it: the failed step asks every
/// controller for a new answer (issue 15, found by fuzzing: a held torque
/// that made the step fail made every retry fail too).
pub const SLOT_ANSWERED: u32 = 4;

/// A joined controller as the state frame reports it.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("cosim::ControllerSlot.v4")]
pub struct ControllerSlot {
    /// Controller id given at join (0: slot unused).
    pub id: u32,
    /// `SLOT_*` bits.
    pub flags: u32,
    /// `REJECT_*` bits of the inputs rejected during the last step.
    pub rejected: u32,
    /// Deadline misses in a row.
    pub misses: u32,
    /// Last step this controller answered.
    pub last_step: u64,
}

/// `StateFrame::status` bits.
pub const STATUS_PAUSED: u32 = 1;
/// The last step's solver failed; the state did not advance.
pub const STATUS_SOLVER_FAILED: u32 = 2;
/// Some input of the last step was rejected (see the controller slots).
pub const STATUS_INPUT_REJECTED: u32 = 4;
/// Some controller missed the deadline of the last step.
pub const STATUS_DEADLINE_MISSED: u32 = 8;
/// The server is shutting down: this is the last frame.
pub const STATUS_SHUTDOWN: u32 = 16;
/// The server waits for controllers to join before the first step.
pub const STATUS_WAITING: u32 = 32;
/// More contacts had impulses than the frame has room for
/// ([`contact_capacity`]).
pub const STATUS_CONTACTS_TRUNCATED: u32 = 64;
/// The server busy-polls for inputs (`--wait spin`): a controller need not
/// notify the wake event after its input (a system call saved per step).
pub const STATUS_SERVER_SPINS: u32 = 128;
/// The last step's rigid LCP had no solution the solver found (or its
/// answer added energy): the step went on with the relaxed or compliant
/// formulation (the server's `--on-failure continue`).
pub const STATUS_FELL_BACK: u32 = 256;
/// The user header of a state message: everything but the entries, which
/// follow in the payload words: `body_count` bodies, `joint_count` joint
/// impulses, `contacts_carried` contacts.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("cosim::StateHeader.v4")]
pub struct StateHeader {
    /// [`PROTOCOL_VERSION`].
    pub version: u32,
    /// `STATUS_*` bits.
    pub status: u32,
    /// Steps taken; controllers answer with this number.
    pub step: u64,
    /// Simulated time (s).
    pub sim_time: f64,
    /// Frames published by this server, counting from 1.
    pub sequence: u64,
    /// Hash of the scene as run (FNV-1a of its TOML); equal hashes, same model.
    pub model_hash: u64,
    pub body_count: u32,
    pub joint_count: u32,
    /// Contacts with a non-zero impulse in the last step (may exceed
    /// `contacts_carried`).
    pub contact_count: u32,
    /// Contacts in the payload.
    pub contacts_carried: u32,
    /// Controllers joined.
    pub controller_count: u32,
    /// `SOLVER_*` code of the last step.
    pub solver_status: u32,
    /// Unknowns of the last step's LCP.
    pub lcp_size: u32,
    pub _pad: u32,
    /// Residual of the last step's LCP (natural map, see docs/solvers.md).
    pub residual: f64,
    /// Step size (s).
    pub dt: f64,
    pub controllers: [ControllerSlot; MAX_CONTROLLERS],
}

impl StateHeader {
    /// The slot of controller `id`, if joined.
    pub fn controller(&self, id: u32) -> Option<&ControllerSlot> {
        self.controllers
            .iter()
            .find(|s| s.id == id && s.flags & SLOT_JOINED != 0)
    }
}

/// The state after step `step`, published once per step (and again after
/// reset, restore and join, with the same step): a [`StateHeader`]'s
/// fields with its entries read out of the payload. Readers reuse one
/// (`read`) so that a frame costs no allocation after the first.
#[derive(Debug, Clone, PartialEq)]
pub struct StateFrame {
    /// [`PROTOCOL_VERSION`].
    pub version: u32,
    /// `STATUS_*` bits.
    pub status: u32,
    /// Steps taken; controllers answer with this number.
    pub step: u64,
    /// Simulated time (s).
    pub sim_time: f64,
    /// Frames published by this server, counting from 1.
    pub sequence: u64,
    /// Hash of the scene as run (FNV-1a of its TOML); equal hashes, same model.
    pub model_hash: u64,
    /// Contacts with a non-zero impulse in the last step (may exceed
    /// `contacts.len()`: see [`STATUS_CONTACTS_TRUNCATED`]).
    pub contact_count: u32,
    /// Controllers joined.
    pub controller_count: u32,
    /// `SOLVER_*` code of the last step.
    pub solver_status: u32,
    /// Unknowns of the last step's LCP.
    pub lcp_size: u32,
    /// Residual of the last step's LCP (natural map, see docs/solvers.md).
    pub residual: f64,
    /// Step size (s).
    pub dt: f64,
    /// Every body, in the scene's order.
    pub bodies: Vec<BodyFrame>,
    /// Joint impulses over the step (N s), world frame, on body a of each
    /// joint (body b receives the opposite), as in impulses.csv.
    pub joint_impulses: Vec<[f64; 3]>,
    /// Per joint, beside its impulse: a hinge's angle (rad, zero at t = 0,
    /// in (-pi, pi]) and rate (rad/s), or a slider's offset (m) and speed
    /// (m/s), body b relative to body a (joints.csv's `position`, `rate`);
    /// NaN for spherical and fixed joints. A joint missing here is sent
    /// as NaN.
    pub joint_coordinates: Vec<[f64; 2]>,
    /// The contacts with a non-zero impulse, as many as the frame carries.
    pub contacts: Vec<ContactFrame>,
    pub controllers: [ControllerSlot; MAX_CONTROLLERS],
}

impl Default for StateFrame {
    fn default() -> StateFrame {
        StateFrame {
            version: PROTOCOL_VERSION,
            status: 0,
            step: 0,
            sim_time: 0.0,
            sequence: 0,
            model_hash: 0,
            contact_count: 0,
            controller_count: 0,
            solver_status: 0,
            lcp_size: 0,
            residual: 0.0,
            dt: 0.0,
            bodies: Vec::new(),
            joint_impulses: Vec::new(),
            joint_coordinates: Vec::new(),
            contacts: Vec::new(),
            controllers: [ControllerSlot::default(); MAX_CONTROLLERS],
        }
    }
}

impl BodyFrame {
    pub(crate) fn encode(&self, sink: &mut impl WordSink) {
        put_f64s(sink, &self.position);
        put_f64s(sink, &self.orientation);
        put_f64s(sink, &self.linear_velocity);
        put_f64s(sink, &self.angular_velocity);
    }
    /// From exactly [`BODY_WORDS`] words.
    pub(crate) fn decode(w: &[u64]) -> BodyFrame {
        BodyFrame {
            position: f3(&w[0..3]),
            orientation: [
                f64::from_bits(w[3]),
                f64::from_bits(w[4]),
                f64::from_bits(w[5]),
                f64::from_bits(w[6]),
            ],
            linear_velocity: f3(&w[7..10]),
            angular_velocity: f3(&w[10..13]),
        }
    }
}

impl ContactFrame {
    pub(crate) fn encode(&self, sink: &mut impl WordSink) {
        sink.put(pair(self.body_a, self.kind_b));
        sink.put(pair(self.index_b, self.id));
        put_f64s(sink, &self.normal);
        put_f64s(sink, &self.friction);
    }
    /// From exactly [`CONTACT_WORDS`] words.
    pub(crate) fn decode(w: &[u64]) -> ContactFrame {
        let (body_a, kind_b) = split(w[0]);
        let (index_b, id) = split(w[1]);
        ContactFrame {
            body_a,
            kind_b,
            index_b,
            id,
            normal: f3(&w[2..5]),
            friction: f3(&w[5..8]),
        }
    }
}

impl StateFrame {
    /// The bodies.
    pub fn bodies(&self) -> &[BodyFrame] {
        &self.bodies
    }
    /// The contacts carried.
    pub fn contacts(&self) -> &[ContactFrame] {
        &self.contacts
    }
    /// The slot of controller `id`, if joined.
    pub fn controller(&self, id: u32) -> Option<&ControllerSlot> {
        self.controllers
            .iter()
            .find(|s| s.id == id && s.flags & SLOT_JOINED != 0)
    }

    /// The header of this frame (counts from the entries).
    pub fn header(&self) -> StateHeader {
        // Exhaustive: a field added to the frame must be added here.
        let &StateFrame {
            version,
            status,
            step,
            sim_time,
            sequence,
            model_hash,
            contact_count,
            controller_count,
            solver_status,
            lcp_size,
            residual,
            dt,
            ref bodies,
            ref joint_impulses,
            joint_coordinates: _,
            ref contacts,
            controllers,
        } = self;
        StateHeader {
            version,
            status,
            step,
            sim_time,
            sequence,
            model_hash,
            body_count: bodies.len() as u32,
            joint_count: joint_impulses.len() as u32,
            contact_count,
            contacts_carried: contacts.len() as u32,
            controller_count,
            solver_status,
            lcp_size,
            _pad: 0,
            residual,
            dt,
            controllers,
        }
    }

    /// Payload words of this frame.
    pub fn words(&self) -> usize {
        state_words(
            self.bodies.len(),
            self.joint_impulses.len(),
            self.contacts.len(),
        )
    }

    /// Writes the payload: bodies, joints (impulse, coordinate, rate),
    /// contacts.
    pub fn encode(&self, sink: &mut impl WordSink) {
        for b in &self.bodies {
            b.encode(sink);
        }
        for (k, j) in self.joint_impulses.iter().enumerate() {
            put_f64s(sink, j);
            let c = self.joint_coordinates.get(k).copied();
            put_f64s(sink, &c.unwrap_or([f64::NAN; 2]));
        }
        for c in &self.contacts {
            c.encode(sink);
        }
    }

    /// Makes `self` the frame of `header` and `words`, reusing its
    /// buffers. On a length mismatch the header's fields are taken, the
    /// entries left empty, and the error says what was missing.
    pub fn read(&mut self, header: &StateHeader, words: &[u64]) -> Result<(), WireError> {
        let &StateHeader {
            version,
            status,
            step,
            sim_time,
            sequence,
            model_hash,
            body_count,
            joint_count,
            contact_count,
            contacts_carried,
            controller_count,
            solver_status,
            lcp_size,
            _pad: _,
            residual,
            dt,
            controllers,
        } = header;
        self.version = version;
        self.status = status;
        self.step = step;
        self.sim_time = sim_time;
        self.sequence = sequence;
        self.model_hash = model_hash;
        self.contact_count = contact_count;
        self.controller_count = controller_count;
        self.solver_status = solver_status;
        self.lcp_size = lcp_size;
        self.residual = residual;
        self.dt = dt;
        self.controllers = controllers;
        self.bodies.clear();
        self.joint_impulses.clear();
        self.joint_coordinates.clear();
        self.contacts.clear();
        let (nb, nj, nc) = (
            body_count as usize,
            joint_count as usize,
            contacts_carried as usize,
        );
        // In u128: counts from outside must not overflow the sum.
        let expected = BODY_WORDS as u128 * nb as u128
            + JOINT_WORDS as u128 * nj as u128
            + CONTACT_WORDS as u128 * nc as u128;
        if expected != words.len() as u128 {
            return Err(WireError::Length {
                what: "state frame",
                expected: usize::try_from(expected).unwrap_or(usize::MAX),
                got: words.len(),
            });
        }
        let (b, rest) = words.split_at(BODY_WORDS * nb);
        let (j, c) = rest.split_at(JOINT_WORDS * nj);
        self.bodies
            .extend(b.chunks_exact(BODY_WORDS).map(BodyFrame::decode));
        for w in j.chunks_exact(JOINT_WORDS) {
            self.joint_impulses.push(f3(&w[..3]));
            self.joint_coordinates
                .push([f64::from_bits(w[3]), f64::from_bits(w[4])]);
        }
        self.contacts
            .extend(c.chunks_exact(CONTACT_WORDS).map(ContactFrame::decode));
        Ok(())
    }

    /// The frame of `header` and `words`.
    pub fn decode(header: &StateHeader, words: &[u64]) -> Result<StateFrame, WireError> {
        let mut f = StateFrame::default();
        f.read(header, words)?;
        Ok(f)
    }
}

/// `StateFrame::solver_status`.
pub const SOLVER_OK: u32 = 0;
pub const SOLVER_RAY_TERMINATION: u32 = 1;
pub const SOLVER_PIVOT_LIMIT: u32 = 2;
pub const SOLVER_SINGULAR: u32 = 3;
pub const SOLVER_NOT_CONVERGED: u32 = 4;
pub const SOLVER_OTHER: u32 = 5;

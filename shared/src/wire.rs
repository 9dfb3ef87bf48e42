//! The co-simulation contract: service names, wire types, their limits and
//! codes. `docs/protocol.md` describes the same bytes for other languages;
//! change both together and bump the version in the type names.
//!
//! Protocol 2 sizes the frames to the scene (issue 14): a state or input
//! message is a fixed `#[repr(C)]` user header (the counts, the step, the
//! controller slots) and an iceoryx2 slice of 8-byte words holding the
//! entries the counts say, in a fixed order. Words, not typed slices,
//! because one message holds entries of several kinds; 8-byte words keep
//! every `f64` aligned, and on a little-endian machine the words of an
//! entry are the bytes of its `#[repr(C)]` struct below, so a reader in C
//! or Python may view them as an array of those structs. The header types
//! are 8-byte aligned without implicit padding (explicit `_pad` fields
//! fill the gaps). The `type_name` carries the version: a client built
//! against another version fails when it opens the service, with
//! iceoryx2's "incompatible types" error, instead of misreading bytes.

use core::mem::MaybeUninit;
use iceoryx2::prelude::ZeroCopySend;

/// Version of the wire types (also in every `type_name`).
pub const PROTOCOL_VERSION: u32 = 4;

/// Controllers that can be joined at once.
pub const MAX_CONTROLLERS: usize = 8;

/// Words of one [`BodyFrame`] in a state payload.
pub const BODY_WORDS: usize = 13;
/// Words of one joint in a state payload: its impulse (`[f64; 3]`), then
/// its coordinate and rate (`[f64; 2]`, NaN for a joint without one).
pub const JOINT_WORDS: usize = 5;
/// Words of one [`ContactFrame`] in a state payload.
pub const CONTACT_WORDS: usize = 8;
/// Words of one [`JointTorque`] in an input payload.
pub const TORQUE_WORDS: usize = 4;
/// Words of one [`BodyImpulse`] in an input payload.
pub const IMPULSE_WORDS: usize = 7;
/// Words of one [`MotorTarget`] in an input payload.
pub const MOTOR_WORDS: usize = 2;

/// Contacts a state frame carries at most, for a scene of `bodies` bodies
/// with `potential` potential contacts: four per body (a sphere in a
/// settled pile touches about six others, each contact shared by two,
/// plus the floor for the lowest layer) and 64 more for small scenes,
/// never more than can exist. The rest are counted in `contact_count` but
/// left out (`STATUS_CONTACTS_TRUNCATED`). Fixed per scene, so that the
/// state publisher's memory is allocated once.
pub fn contact_capacity(bodies: usize, potential: usize) -> usize {
    potential.min(4 * bodies + 64)
}

/// Words of a state payload with these counts.
pub fn state_words(bodies: usize, joints: usize, contacts: usize) -> usize {
    BODY_WORDS * bodies + JOINT_WORDS * joints + CONTACT_WORDS * contacts
}

/// Bytes a served scene's state frame (header and words) may take: a
/// scene of about 40,000 spheres. The state stream's memory holds at
/// least two frames per subscriber ([`services::state_buffer`]).
pub const MAX_FRAME_BYTES: usize = 16 << 20;

/// Words of an input payload with these counts.
pub fn input_words(torques: usize, impulses: usize, motors: usize) -> usize {
    TORQUE_WORDS * torques + IMPULSE_WORDS * impulses + MOTOR_WORDS * motors
}

/// Service names: one function per service, no string literals elsewhere.
/// Everything of server `NAME` lives under `cosim/NAME/`.
pub mod services {
    /// Prefix of every service of every server.
    pub const ROOT: &str = "cosim/";

    /// Publish-subscribe, server to all: one state frame per step
    /// ([`super::StateHeader`] and its words).
    pub fn state(name: &str) -> String {
        format!("{ROOT}{name}/state")
    }
    /// Publish-subscribe, controllers to server: input frames
    /// ([`super::InputHeader`] and its words).
    pub fn input(name: &str) -> String {
        format!("{ROOT}{name}/input")
    }
    /// Request-response: [`super::ControlRequest`] and
    /// [`super::ControlResponse`].
    pub fn control(name: &str) -> String {
        format!("{ROOT}{name}/control")
    }
    /// Event, server to all: "a state frame was published".
    pub fn state_ready(name: &str) -> String {
        format!("{ROOT}{name}/state-ready")
    }
    /// Publish-subscribe, server to monitors, with `serve --publish-every
    /// N`: the frames of every N-th step (and the last), for monitors that
    /// want fewer frames than the lockstep's.
    pub fn state_every(name: &str) -> String {
        format!("{ROOT}{name}/state-every")
    }
    /// Event, server to the decimated stream's readers: "a frame of it".
    pub fn state_every_ready(name: &str) -> String {
        format!("{ROOT}{name}/state-every-ready")
    }
    /// Event, clients to server: "an input or a request was sent".
    pub fn wake(name: &str) -> String {
        format!("{ROOT}{name}/wake")
    }
    /// The server name of a control service name, if it is one.
    pub fn server_of(service: &str) -> Option<&str> {
        service.strip_prefix(ROOT)?.strip_suffix("/control")
    }

    /// Subscribers of the state service (controllers, monitors, recorders).
    pub const MAX_STATE_SUBSCRIBERS: usize = 32;
    /// Buffer a state subscriber may ask for (a recorder wants every
    /// frame), in a scene whose frames are small; see [`state_buffer`].
    pub const MAX_STATE_BUFFER: usize = 1024;
    /// Shared memory the samples of one state stream may take: the
    /// publisher holds room for every subscriber's whole buffer.
    pub const STATE_STREAM_BYTES: usize = 256 << 20;
    /// Publishers of the input service.
    pub const MAX_INPUT_PUBLISHERS: usize = 2 * super::MAX_CONTROLLERS;
    /// The server's input buffer: several inputs per controller and step.
    pub const INPUT_BUFFER: usize = 8 * super::MAX_CONTROLLERS;
    /// Clients of the control service.
    pub const MAX_CONTROL_CLIENTS: usize = 32;
    /// Listeners and notifiers of each event service.
    pub const MAX_EVENT_PORTS: usize = 48;

    /// The largest buffer a state subscriber may ask for when a frame has
    /// `words` payload words: [`MAX_STATE_BUFFER`] for small scenes, fewer
    /// where that many frames for every subscriber would pass
    /// [`STATE_STREAM_BYTES`] (a 4,000-body frame is 1.5 MB), never fewer
    /// than 2.
    pub fn state_buffer(words: usize) -> usize {
        let frame = core::mem::size_of::<super::StateHeader>() + 8 * words.max(1);
        (STATE_STREAM_BYTES / (frame * MAX_STATE_SUBSCRIBERS)).clamp(2, MAX_STATE_BUFFER)
    }
}

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

/// Why a message's words do not match its header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WireError {
    /// The header's counts need `expected` words; the payload has `got`.
    Length {
        what: &'static str,
        expected: usize,
        got: usize,
    },
}

impl core::fmt::Display for WireError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            WireError::Length {
                what,
                expected,
                got,
            } => write!(
                f,
                "{what}: the header's counts need {expected} payload words, the payload has {got}"
            ),
        }
    }
}

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

/// Where encoded words go: a `Vec`, or a loaned sample's memory.
pub trait WordSink {
    fn put(&mut self, word: u64);
}

impl WordSink for Vec<u64> {
    fn put(&mut self, word: u64) {
        self.push(word);
    }
}

/// Writes words into uninitialised memory, counting them: `filled` tells
/// whether every word was written (and no more were offered).
pub struct UninitWords<'a> {
    out: &'a mut [MaybeUninit<u64>],
    at: usize,
    overrun: bool,
}

impl<'a> UninitWords<'a> {
    pub fn new(out: &'a mut [MaybeUninit<u64>]) -> Self {
        UninitWords {
            out,
            at: 0,
            overrun: false,
        }
    }
    /// Every word of the memory written, and none offered past it.
    pub fn filled(&self) -> bool {
        self.at == self.out.len() && !self.overrun
    }
}

impl WordSink for UninitWords<'_> {
    fn put(&mut self, word: u64) {
        match self.out.get_mut(self.at) {
            Some(w) => {
                w.write(word);
                self.at += 1;
            }
            None => self.overrun = true,
        }
    }
}

fn put_f64s(sink: &mut impl WordSink, xs: &[f64]) {
    for x in xs {
        sink.put(x.to_bits());
    }
}

fn pair(lo: u32, hi: u32) -> u64 {
    u64::from(lo) | (u64::from(hi) << 32)
}

fn split(w: u64) -> (u32, u32) {
    (w as u32, (w >> 32) as u32)
}

fn f3(w: &[u64]) -> [f64; 3] {
    [
        f64::from_bits(w[0]),
        f64::from_bits(w[1]),
        f64::from_bits(w[2]),
    ]
}

impl BodyFrame {
    fn encode(&self, sink: &mut impl WordSink) {
        put_f64s(sink, &self.position);
        put_f64s(sink, &self.orientation);
        put_f64s(sink, &self.linear_velocity);
        put_f64s(sink, &self.angular_velocity);
    }
    /// From exactly [`BODY_WORDS`] words.
    fn decode(w: &[u64]) -> BodyFrame {
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
    fn encode(&self, sink: &mut impl WordSink) {
        sink.put(pair(self.body_a, self.kind_b));
        sink.put(pair(self.index_b, self.id));
        put_f64s(sink, &self.normal);
        put_f64s(sink, &self.friction);
    }
    /// From exactly [`CONTACT_WORDS`] words.
    fn decode(w: &[u64]) -> ContactFrame {
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

/// A held joint effort (world frame): a torque (N m), `+torque` on body
/// b and `-torque` on body a; for a prismatic joint a force (N) on body b
/// at its anchor and its opposite on body a there. [`TORQUE_WORDS`]
/// words: `joint` (the low half of the first word), then the effort.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct JointTorque {
    pub joint: u32,
    pub _pad: u32,
    pub torque: [f64; 3],
}

/// A one-step impulse on a body (N s and N m s, world frame, through the
/// centre of mass). [`IMPULSE_WORDS`] words: `body` (the low half of the
/// first word), then linear and angular.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BodyImpulse {
    pub body: u32,
    pub _pad: u32,
    pub linear: [f64; 3],
    pub angular: [f64; 3],
}

/// The user header of an input message; `torque_count` torques and then
/// `impulse_count` impulses follow in the payload words.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("cosim::InputHeader.v4")]
pub struct InputHeader {
    /// [`PROTOCOL_VERSION`].
    pub version: u32,
    /// Id given by the join response.
    pub controller_id: u32,
    /// The `step` of the state frame this input answers.
    pub step: u64,
    /// The controller's own counter (logged; not checked).
    pub sequence: u64,
    pub torque_count: u32,
    pub impulse_count: u32,
    pub motor_count: u32,
    pub _pad: u32,
}

/// A joint motor's target rate (rad/s for a hinge, m/s for a slider),
/// held until changed. [`MOTOR_WORDS`] words: `joint` (the low half of the
/// first word), then the speed.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MotorTarget {
    pub joint: u32,
    pub _pad: u32,
    pub speed: f64,
}

/// A controller's answer to state frame `step`.
///
/// Torques listed are held by this controller until it sends another
/// value for the joint; the server applies the sum over controllers.
/// Motor targets are held likewise; where several controllers hold one
/// for the same joint, the lowest controller id's applies. Impulses act
/// on the next step only.
#[derive(Debug, Clone, PartialEq)]
pub struct InputFrame {
    /// [`PROTOCOL_VERSION`].
    pub version: u32,
    /// Id given by the join response.
    pub controller_id: u32,
    /// The `step` of the state frame this input answers.
    pub step: u64,
    /// The controller's own counter (logged; not checked).
    pub sequence: u64,
    pub torques: Vec<JointTorque>,
    pub impulses: Vec<BodyImpulse>,
    pub motors: Vec<MotorTarget>,
}

impl Default for InputFrame {
    fn default() -> InputFrame {
        InputFrame {
            version: PROTOCOL_VERSION,
            controller_id: 0,
            step: 0,
            sequence: 0,
            torques: Vec::new(),
            impulses: Vec::new(),
            motors: Vec::new(),
        }
    }
}

impl InputFrame {
    /// Appends a joint torque.
    pub fn push_torque(&mut self, joint: u32, torque: [f64; 3]) {
        self.torques.push(JointTorque {
            joint,
            _pad: 0,
            torque,
        });
    }
    /// Appends a motor target.
    pub fn push_motor(&mut self, joint: u32, speed: f64) {
        self.motors.push(MotorTarget {
            joint,
            _pad: 0,
            speed,
        });
    }
    /// Appends a body impulse.
    pub fn push_impulse(&mut self, body: u32, linear: [f64; 3], angular: [f64; 3]) {
        self.impulses.push(BodyImpulse {
            body,
            _pad: 0,
            linear,
            angular,
        });
    }

    /// The header of this frame (counts from the entries).
    pub fn header(&self) -> InputHeader {
        InputHeader {
            version: self.version,
            controller_id: self.controller_id,
            step: self.step,
            sequence: self.sequence,
            torque_count: self.torques.len() as u32,
            impulse_count: self.impulses.len() as u32,
            motor_count: self.motors.len() as u32,
            _pad: 0,
        }
    }

    /// Payload words of this frame.
    pub fn words(&self) -> usize {
        input_words(self.torques.len(), self.impulses.len(), self.motors.len())
    }

    /// Writes the payload: torques, then impulses, then motor targets.
    pub fn encode(&self, sink: &mut impl WordSink) {
        for t in &self.torques {
            sink.put(pair(t.joint, 0));
            put_f64s(sink, &t.torque);
        }
        for b in &self.impulses {
            sink.put(pair(b.body, 0));
            put_f64s(sink, &b.linear);
            put_f64s(sink, &b.angular);
        }
        for m in &self.motors {
            sink.put(pair(m.joint, 0));
            put_f64s(sink, &[m.speed]);
        }
    }

    /// Makes `self` the frame of `header` and `words`, reusing its
    /// buffers. On a length mismatch the header's fields are taken, the
    /// entries left empty, and the error says what was missing.
    pub fn read(&mut self, header: &InputHeader, words: &[u64]) -> Result<(), WireError> {
        let &InputHeader {
            version,
            controller_id,
            step,
            sequence,
            torque_count,
            impulse_count,
            motor_count,
            _pad,
        } = header;
        self.version = version;
        self.controller_id = controller_id;
        self.step = step;
        self.sequence = sequence;
        self.torques.clear();
        self.impulses.clear();
        self.motors.clear();
        let (nt, ni, nm) = (
            torque_count as usize,
            impulse_count as usize,
            motor_count as usize,
        );
        let expected = TORQUE_WORDS as u128 * nt as u128
            + IMPULSE_WORDS as u128 * ni as u128
            + MOTOR_WORDS as u128 * nm as u128;
        if expected != words.len() as u128 {
            return Err(WireError::Length {
                what: "input frame",
                expected: usize::try_from(expected).unwrap_or(usize::MAX),
                got: words.len(),
            });
        }
        let (t, rest) = words.split_at(TORQUE_WORDS * nt);
        let (b, m) = rest.split_at(IMPULSE_WORDS * ni);
        self.torques
            .extend(t.chunks_exact(TORQUE_WORDS).map(|w| JointTorque {
                joint: split(w[0]).0,
                _pad: 0,
                torque: f3(&w[1..4]),
            }));
        self.impulses
            .extend(b.chunks_exact(IMPULSE_WORDS).map(|w| BodyImpulse {
                body: split(w[0]).0,
                _pad: 0,
                linear: f3(&w[1..4]),
                angular: f3(&w[4..7]),
            }));
        self.motors
            .extend(m.chunks_exact(MOTOR_WORDS).map(|w| MotorTarget {
                joint: split(w[0]).0,
                _pad: 0,
                speed: f64::from_bits(w[1]),
            }));
        Ok(())
    }

    /// The frame of `header` and `words`.
    pub fn decode(header: &InputHeader, words: &[u64]) -> Result<InputFrame, WireError> {
        let mut f = InputFrame::default();
        f.read(header, words)?;
        Ok(f)
    }
}

/// Sends a message of `header` and `len` words that `encode` writes into
/// the loaned sample (no copy on the way). Fails with
/// [`SendError::Incomplete`] if `encode` did not write exactly `len` words.
pub fn send_words<H: core::fmt::Debug + Default + ZeroCopySend>(
    publisher: &iceoryx2::port::publisher::Publisher<iceoryx2::prelude::ipc::Service, [u64], H>,
    header: H,
    len: usize,
    encode: impl FnOnce(&mut UninitWords<'_>),
) -> Result<usize, SendError> {
    let mut sample = publisher.loan_slice_uninit(len).map_err(SendError::Loan)?;
    *sample.user_header_mut() = header;
    let mut words = UninitWords::new(sample.payload_mut());
    encode(&mut words);
    if !words.filled() {
        return Err(SendError::Incomplete { words: len });
    }
    // SAFETY: `filled` says every one of the sample's `len` words was
    // written above (`UninitWords` writes each word it is given into the
    // next place and counts them), so the payload is initialised.
    let sample = unsafe { sample.assume_init() };
    sample.send().map_err(SendError::Send)
}

/// Why a message could not be sent.
#[derive(Debug)]
pub enum SendError {
    /// The publisher could not loan a sample of that many words.
    Loan(iceoryx2::port::LoanError),
    /// The encoder wrote more or fewer words than the sample holds.
    Incomplete {
        words: usize,
    },
    Send(iceoryx2::port::SendError),
}

impl core::fmt::Display for SendError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SendError::Loan(e) => write!(f, "cannot loan a sample: {e:?}"),
            SendError::Incomplete { words } => {
                write!(f, "the message did not fill its {words} words")
            }
            SendError::Send(e) => write!(f, "cannot send: {e:?}"),
        }
    }
}

/// Why an input was rejected: bits of `ControllerSlot::rejected`, and the
/// keys of `inputs_rejected` in `summary.json`.
pub const REJECT_NON_FINITE: u32 = 1;
pub const REJECT_UNKNOWN_INDEX: u32 = 2;
pub const REJECT_WRONG_STEP: u32 = 4;
pub const REJECT_DUPLICATE: u32 = 8;
pub const REJECT_UNKNOWN_CONTROLLER: u32 = 16;
pub const REJECT_BAD_COUNT: u32 = 32;
pub const REJECT_VERSION: u32 = 64;
/// Sent with a joined controller's id by a publisher that is not the
/// one of the process that joined (the server reads a sample's origin).
pub const REJECT_FOREIGN_SENDER: u32 = 128;

/// Every reason, with its name in logs and summaries.
pub const REJECT_REASONS: [(u32, &str); 8] = [
    (REJECT_NON_FINITE, "non_finite"),
    (REJECT_UNKNOWN_INDEX, "unknown_index"),
    (REJECT_WRONG_STEP, "wrong_step"),
    (REJECT_DUPLICATE, "duplicate"),
    (REJECT_UNKNOWN_CONTROLLER, "unknown_controller"),
    (REJECT_BAD_COUNT, "bad_count"),
    (REJECT_VERSION, "version"),
    (REJECT_FOREIGN_SENDER, "foreign_sender"),
];

/// The chunks of the scene TOML (`MESSAGE_LEN` bytes each) the server
/// sends for one `CMD_SCENE` request, from byte `count` on: fewer than the
/// control service's response buffer (256), so that none is lost. A client
/// asks again from where it got to until it has `value` bytes.
pub const SCENE_CHUNKS_PER_REQUEST: usize = 200;

/// `ControlRequest::command`.
pub const CMD_JOIN: u32 = 1;
pub const CMD_LEAVE: u32 = 2;
pub const CMD_PAUSE: u32 = 3;
pub const CMD_RESUME: u32 = 4;
/// Take `count` steps, then pause.
pub const CMD_STEP: u32 = 5;
/// Back to the initial state (step 0); joined controllers stay joined.
pub const CMD_RESET: u32 = 6;
/// Keep the current state; the response's `snapshot` names it.
pub const CMD_SNAPSHOT: u32 = 7;
/// Go back to snapshot `count`.
pub const CMD_RESTORE: u32 = 8;
pub const CMD_INFO: u32 = 9;
pub const CMD_SHUTDOWN: u32 = 10;
/// The scene as run, as TOML: a stream of responses, each carrying up to
/// [`MESSAGE_LEN`] bytes in `message`; `value` holds the total length.
pub const CMD_SCENE: u32 = 11;

/// `ControlRequest::role` of a join.
pub const ROLE_CONTROLLER: u32 = 1;
pub const ROLE_MONITOR: u32 = 2;

#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("cosim::ControlRequest.v4")]
pub struct ControlRequest {
    /// [`PROTOCOL_VERSION`].
    pub version: u32,
    /// `CMD_*`.
    pub command: u32,
    /// `ROLE_*` for a join.
    pub role: u32,
    /// The controller a leave is for.
    pub controller_id: u32,
    /// Steps of `CMD_STEP`, snapshot id of `CMD_RESTORE`.
    pub count: u64,
    /// The client's iceoryx2 node id (low and high 64 bits), so that the
    /// server can tell a dead controller from a slow one.
    pub node_id_lo: u64,
    pub node_id_hi: u64,
    /// The client's process id (informational).
    pub pid: u64,
}

/// `ControlResponse::status`.
pub const RESP_OK: u32 = 0;
pub const RESP_FULL: u32 = 1;
pub const RESP_UNKNOWN_COMMAND: u32 = 2;
pub const RESP_UNKNOWN_CONTROLLER: u32 = 3;
pub const RESP_UNKNOWN_SNAPSHOT: u32 = 4;
pub const RESP_BAD_REQUEST: u32 = 5;

/// Bytes of `ControlResponse::message`.
pub const MESSAGE_LEN: usize = 120;

#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("cosim::ControlResponse.v4")]
pub struct ControlResponse {
    pub version: u32,
    /// `RESP_*`.
    pub status: u32,
    /// Id of a joined controller.
    pub controller_id: u32,
    /// 1 when the simulation is paused after the command.
    pub paused: u32,
    /// The server's step after the command.
    pub step: u64,
    pub sim_time: f64,
    pub dt: f64,
    pub model_hash: u64,
    pub body_count: u32,
    pub joint_count: u32,
    pub controller_count: u32,
    pub monitor_count: u32,
    /// Snapshot id of `CMD_SNAPSHOT`; total bytes of `CMD_SCENE`.
    pub value: u64,
    /// The server's process id.
    pub pid: u64,
    /// UTF-8, NUL-padded: a human-readable answer (errors say why).
    pub message: [u8; MESSAGE_LEN],
}

impl Default for ControlResponse {
    fn default() -> ControlResponse {
        ControlResponse {
            version: PROTOCOL_VERSION,
            status: RESP_OK,
            controller_id: 0,
            paused: 0,
            step: 0,
            sim_time: 0.0,
            dt: 0.0,
            model_hash: 0,
            body_count: 0,
            joint_count: 0,
            controller_count: 0,
            monitor_count: 0,
            value: 0,
            pid: 0,
            message: [0; MESSAGE_LEN],
        }
    }
}

impl ControlResponse {
    /// Sets the message, cut at a character boundary to fit.
    pub fn set_message(&mut self, text: &str) {
        self.message = [0; MESSAGE_LEN];
        let mut end = text.len().min(MESSAGE_LEN);
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        self.message[..end].copy_from_slice(&text.as_bytes()[..end]);
    }
    /// The message's bytes up to the NUL padding.
    pub fn message_bytes(&self) -> &[u8] {
        let end = self
            .message
            .iter()
            .position(|&b| b == 0)
            .unwrap_or(MESSAGE_LEN);
        &self.message[..end]
    }
    pub fn message(&self) -> String {
        String::from_utf8_lossy(self.message_bytes()).into_owned()
    }
}

/// FNV-1a, 64 bits: a stable hash for the model (and per-step state hashes
/// of replay), the same on every build and machine.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::{align_of, size_of};

    fn state(k: usize, nb: usize, nj: usize, nc: usize) -> StateFrame {
        let mut x = k as f64;
        let mut next = || {
            x += 1.25;
            x
        };
        let mut f = StateFrame {
            step: k as u64,
            status: STATUS_CONTACTS_TRUNCATED,
            contact_count: nc as u32 + 3,
            residual: next(),
            ..StateFrame::default()
        };
        for _ in 0..nb {
            let v = next();
            f.bodies.push(BodyFrame {
                position: [v, -v, 0.5 * v],
                orientation: [1.0, 0.0, -0.0, v],
                linear_velocity: [f64::MIN_POSITIVE, v, 3.0],
                angular_velocity: [-v, 1e300, 0.0],
            });
        }
        for k in 0..nj {
            f.joint_impulses.push([next(); 3]);
            // A joint without a coordinate carries NaN.
            let c = if k % 2 == 0 {
                [next(), -next()]
            } else {
                [f64::NAN; 2]
            };
            f.joint_coordinates.push(c);
        }
        for i in 0..nc {
            let v = next();
            f.contacts.push(ContactFrame {
                body_a: i as u32,
                kind_b: CONTACT_BODY,
                index_b: u32::MAX - i as u32,
                id: 7 * i as u32,
                normal: [0.0, 0.0, v],
                friction: [v, -v, 0.0],
            });
        }
        f.controllers[k % MAX_CONTROLLERS].id = k as u32 + 1;
        f
    }

    /// Encoded and read back into a reused frame, every frame comes back
    /// to the bit, whatever the sizes of the frames read into it before.
    #[test]
    fn frames_come_back_from_their_words() {
        let mut back = StateFrame::default();
        let mut input_back = InputFrame::default();
        for (k, &(nb, nj, nc)) in [
            (2, 2, 5),
            (3, 1, 0),
            (4000, 0, 16064),
            (1, 0, 70),
            (0, 0, 0),
        ]
        .iter()
        .enumerate()
        {
            let f = state(k, nb, nj, nc);
            let mut words = Vec::new();
            f.encode(&mut words);
            assert_eq!(words.len(), f.words());
            assert_eq!(words.len(), state_words(nb, nj, nc));
            back.read(&f.header(), &words).expect("well formed");
            // To the bit: NaN (a joint without a coordinate) is not equal
            // to itself, so the read frame is compared by its words.
            let mut again = Vec::new();
            back.encode(&mut again);
            assert_eq!(again, words, "frame {k}");
            assert_eq!(back.header(), f.header(), "frame {k}");
            assert_eq!(back.joint_coordinates.len(), nj);
            assert!(nj < 2 || back.joint_coordinates[1][0].is_nan());

            let mut input = InputFrame {
                step: k as u64,
                controller_id: 3,
                ..InputFrame::default()
            };
            for i in 0..nj {
                input.push_torque(i as u32, [1.5, 0.0, -(k as f64)]);
            }
            for i in 0..nb.min(50) {
                input.push_impulse(u32::MAX - i as u32, [0.5; 3], [-0.25; 3]);
            }
            for i in 0..nj.min(3) {
                input.push_motor(i as u32, -(k as f64) * 0.5);
            }
            let mut words = Vec::new();
            input.encode(&mut words);
            assert_eq!(words.len(), input.words());
            input_back
                .read(&input.header(), &words)
                .expect("well formed");
            assert_eq!(input_back, input, "input {k}");
        }
    }

    /// A header whose counts the words do not match is refused with both
    /// lengths, its header fields kept (the server names the controller),
    /// also for counts whose word total overflows.
    #[test]
    fn counts_that_do_not_match_the_words_are_refused() {
        let f = state(1, 2, 1, 3);
        let mut words = Vec::new();
        f.encode(&mut words);
        let mut h = f.header();
        h.contacts_carried += 1;
        let err = StateFrame::decode(&h, &words).unwrap_err();
        assert_eq!(
            err,
            WireError::Length {
                what: "state frame",
                expected: words.len() + CONTACT_WORDS,
                got: words.len()
            }
        );
        h.body_count = u32::MAX;
        h.contacts_carried = u32::MAX;
        assert!(StateFrame::decode(&h, &words).is_err());

        let mut input = InputFrame {
            controller_id: 5,
            step: 9,
            ..InputFrame::default()
        };
        input.push_torque(0, [1.0; 3]);
        let mut words = Vec::new();
        input.encode(&mut words);
        let mut h = input.header();
        h.torque_count = 1000;
        let mut back = InputFrame::default();
        assert!(back.read(&h, &words).is_err());
        assert_eq!((back.controller_id, back.step), (5, 9));
        assert!(back.torques.is_empty());
    }

    /// On a little-endian machine an entry's words are the bytes of its
    /// `#[repr(C)]` struct, which is what lets C and Python readers view
    /// the payload as arrays of them (protocol.md).
    #[test]
    fn an_entrys_words_are_its_structs_bytes() {
        let c = ContactFrame {
            body_a: 1,
            kind_b: CONTACT_PLANE,
            index_b: 2,
            id: 3,
            normal: [0.5, -1.0, 2.0],
            friction: [4.0, 0.0, -0.0],
        };
        let mut words = Vec::new();
        c.encode(&mut words);
        let mut bytes = Vec::new();
        for v in [c.body_a, c.kind_b, c.index_b, c.id] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        for v in c.normal.iter().chain(&c.friction) {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        let from_words: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        assert_eq!(from_words, bytes);
        assert_eq!(size_of::<ContactFrame>(), bytes.len());
    }

    // The sizes docs/protocol.md states: a change here is a protocol change.
    #[test]
    fn layouts_match_the_protocol_document() {
        assert_eq!(size_of::<BodyFrame>(), 8 * BODY_WORDS);
        assert_eq!(
            size_of::<[f64; 3]>() + size_of::<[f64; 2]>(),
            8 * JOINT_WORDS
        );
        assert_eq!(size_of::<ContactFrame>(), 8 * CONTACT_WORDS);
        assert_eq!(size_of::<JointTorque>(), 8 * TORQUE_WORDS);
        assert_eq!(size_of::<BodyImpulse>(), 8 * IMPULSE_WORDS);
        assert_eq!(size_of::<ControllerSlot>(), 24);
        assert_eq!(size_of::<StateHeader>(), 88 + 24 * MAX_CONTROLLERS);
        assert_eq!(size_of::<MotorTarget>(), 8 * MOTOR_WORDS);
        assert_eq!(size_of::<InputHeader>(), 40);
        assert_eq!(size_of::<ControlRequest>(), 48);
        assert_eq!(size_of::<ControlResponse>(), 80 + MESSAGE_LEN);
        for a in [
            align_of::<StateHeader>(),
            align_of::<InputHeader>(),
            align_of::<ControlRequest>(),
            align_of::<ControlResponse>(),
        ] {
            assert_eq!(a, 8);
        }
    }

    #[test]
    fn a_big_scenes_state_buffer_fits_the_stream_budget() {
        assert_eq!(
            services::state_buffer(state_words(2, 1, 7)),
            services::MAX_STATE_BUFFER
        );
        let big = state_words(4000, 0, contact_capacity(4000, usize::MAX));
        let n = services::state_buffer(big);
        assert!((2..16).contains(&n), "{n}");
        assert!(
            n * services::MAX_STATE_SUBSCRIBERS * 8 * big <= services::STATE_STREAM_BYTES,
            "{n}"
        );
    }

    #[test]
    fn type_names_carry_the_version() {
        use iceoryx2::prelude::ZeroCopySend;
        // SAFETY: type_name only returns the static name given by the derive.
        let names = unsafe {
            [
                StateHeader::type_name(),
                InputHeader::type_name(),
                ControlRequest::type_name(),
                ControlResponse::type_name(),
            ]
        };
        for n in names {
            assert!(
                n.starts_with("cosim::") && n.ends_with(&format!(".v{PROTOCOL_VERSION}")),
                "{n}"
            );
        }
    }

    #[test]
    fn message_is_cut_at_a_character_boundary() {
        let mut r = ControlResponse::default();
        let long = "é".repeat(100);
        r.set_message(&long);
        assert_eq!(r.message().chars().count(), MESSAGE_LEN / 2);
        r.set_message("ok");
        assert_eq!(r.message(), "ok");
    }

    #[test]
    fn server_names_come_back_from_control_services() {
        assert_eq!(services::server_of(&services::control("lab")), Some("lab"));
        assert_eq!(services::server_of(&services::state("lab")), None);
    }
}

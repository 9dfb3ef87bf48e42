//! The co-simulation contract: service names, wire types, their limits and
//! codes. `docs/protocol.md` describes the same bytes for other languages;
//! change both together and bump the version in the type names.
//!
//! Every type is `#[repr(C)]` with fixed-width fields, 8-byte aligned and
//! without implicit padding (explicit `_pad` fields fill the gaps), so that a
//! `ctypes.Structure` written from the protocol document has the same
//! layout. The `type_name` carries the version: a client built against
//! another version fails when it opens the service, with iceoryx2's
//! "incompatible types" error, instead of misreading bytes.

use iceoryx2::prelude::{ipc, IceoryxSend, ZeroCopySend};

/// Version of the wire types (also in every `type_name`).
pub const PROTOCOL_VERSION: u32 = 1;

/// Bodies a state frame can carry; larger scenes are refused by `serve`.
pub const MAX_BODIES: usize = 32;
/// Joints a state frame (and an input) can carry.
pub const MAX_JOINTS: usize = 32;
/// Contacts with a non-zero impulse a state frame can carry; the rest are
/// counted in `contact_count` but left out (`STATUS_CONTACTS_TRUNCATED`).
pub const MAX_CONTACTS: usize = 64;
/// Controllers that can be joined at once.
pub const MAX_CONTROLLERS: usize = 8;

/// Service names: one function per service, no string literals elsewhere.
/// Everything of server `NAME` lives under `cosim/NAME/`.
pub mod services {
    /// Prefix of every service of every server.
    pub const ROOT: &str = "cosim/";

    /// Publish-subscribe, server to all: one [`super::StateFrame`] per step.
    pub fn state(name: &str) -> String {
        format!("{ROOT}{name}/state")
    }
    /// Publish-subscribe, controllers to server: [`super::InputFrame`].
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
    /// Buffer a state subscriber may ask for (a recorder wants every frame).
    pub const MAX_STATE_BUFFER: usize = 1024;
    /// Publishers of the input service.
    pub const MAX_INPUT_PUBLISHERS: usize = 2 * super::MAX_CONTROLLERS;
    /// The server's input buffer: several inputs per controller and step.
    pub const INPUT_BUFFER: usize = 8 * super::MAX_CONTROLLERS;
    /// Clients of the control service.
    pub const MAX_CONTROL_CLIENTS: usize = 32;
    /// Listeners and notifiers of each event service.
    pub const MAX_EVENT_PORTS: usize = 48;
}

/// Pose and twist of one body, world frame.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("cosim::BodyFrame.v1")]
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
/// (the other side receives the opposite).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("cosim::ContactFrame.v1")]
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
#[type_name("cosim::ControllerSlot.v1")]
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
/// More contacts than [`MAX_CONTACTS`] had impulses.
pub const STATUS_CONTACTS_TRUNCATED: u32 = 64;
/// The server busy-polls for inputs (`--wait spin`): a controller need not
/// notify the wake event after its input (a system call saved per step).
pub const STATUS_SERVER_SPINS: u32 = 128;
/// The last step's rigid LCP had no solution the solver found (or its
/// answer added energy): the step went on with the relaxed or compliant
/// formulation (the server's `--on-failure continue`).
pub const STATUS_FELL_BACK: u32 = 256;

/// The state after step `step`, published once per step (and again after
/// reset, restore and join, with the same step).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("cosim::StateFrame.v1")]
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
    pub body_count: u32,
    pub joint_count: u32,
    /// Contacts with a non-zero impulse in the last step (may exceed the
    /// array).
    pub contact_count: u32,
    /// Controllers joined.
    pub controller_count: u32,
    /// `SOLVER_*` code of the last step.
    pub solver_status: u32,
    /// Unknowns of the last step's LCP.
    pub lcp_size: u32,
    /// Residual of the last step's LCP (natural map, see README).
    pub residual: f64,
    /// Step size (s).
    pub dt: f64,
    pub bodies: [BodyFrame; MAX_BODIES],
    /// Joint impulses over the step (N s), world frame, on body a of each
    /// joint (body b receives the opposite), as in impulses.csv.
    pub joint_impulses: [[f64; 3]; MAX_JOINTS],
    pub contacts: [ContactFrame; MAX_CONTACTS],
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
            body_count: 0,
            joint_count: 0,
            contact_count: 0,
            controller_count: 0,
            solver_status: 0,
            lcp_size: 0,
            residual: 0.0,
            dt: 0.0,
            bodies: [BodyFrame::default(); MAX_BODIES],
            joint_impulses: [[0.0; 3]; MAX_JOINTS],
            contacts: [ContactFrame::default(); MAX_CONTACTS],
            controllers: [ControllerSlot::default(); MAX_CONTROLLERS],
        }
    }
}

impl StateFrame {
    /// The bodies in use.
    pub fn bodies(&self) -> &[BodyFrame] {
        &self.bodies[..(self.body_count as usize).min(MAX_BODIES)]
    }
    /// The contacts carried.
    pub fn contacts(&self) -> &[ContactFrame] {
        &self.contacts[..(self.contact_count as usize).min(MAX_CONTACTS)]
    }
    /// The slot of controller `id`, if joined.
    pub fn controller(&self, id: u32) -> Option<&ControllerSlot> {
        self.controllers
            .iter()
            .find(|s| s.id == id && s.flags & SLOT_JOINED != 0)
    }
}

/// High-water marks of the entries written into the frames of one pool of
/// samples (one publisher's, or one local frame): see
/// [`UsedEntries::write_used`].
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Written {
    pub bodies: usize,
    pub joints: usize,
    pub contacts: usize,
}

/// `dst[..n] = src[..n]`, and `dst[n..mark]` back to the default; then
/// raises `mark` to `n`.
fn write_prefix<T: Copy + Default>(dst: &mut [T], src: &[T], n: usize, mark: &mut usize) {
    let len = dst.len();
    let n = n.min(len);
    dst[..n].copy_from_slice(&src[..n]);
    if *mark > n {
        dst[n..(*mark).min(len)].fill(T::default());
    }
    *mark = (*mark).max(n);
}

/// A frame whose arrays are used up to its counts (the state and input
/// frames), copied by the entries in use.
pub trait UsedEntries: Default + Sized {
    /// Makes `self` equal to `src` where `src`'s entries past its counts
    /// are zero (every frame this crate builds), writing only the header,
    /// the entries in use and the stale entries `written` says earlier
    /// frames left (its marks cover every frame ever written into this
    /// memory, which started zeroed). Why: a full state frame is 8.5 KB,
    /// 133 cache lines; a reader on another core that copied the last frame
    /// holds them all, and writing them back costs a cross-core transfer
    /// each (measured: 5.3 us of a 7 us publish on this machine).
    fn write_used(&mut self, src: &Self, written: &mut Written);

    /// A local copy of the entries in use (the rest default): what a
    /// reader needs, without pulling the whole frame across cores.
    fn used_copy(&self) -> Self {
        let mut f = Self::default();
        f.write_used(self, &mut Written::default());
        f
    }
}

/// Sends `frame` on `publisher`, writing only its entries in use into the
/// loaned sample ([`UsedEntries::write_used`]); `written` holds the marks
/// of that publisher's samples.
pub fn send_used<T: UsedEntries + IceoryxSend + ZeroCopySend + core::fmt::Debug>(
    publisher: &iceoryx2::port::publisher::Publisher<ipc::Service, T, ()>,
    frame: &T,
    written: &mut Written,
) -> Result<usize, iceoryx2::port::SendError> {
    let mut sample = publisher.loan_uninit()?;
    // SAFETY: the sample's bytes are initialised: the publisher's data
    // segment is shared memory the OS hands out zero-filled (POSIX
    // ftruncate), and since then only frames of this publisher were written
    // into it. The frames are #[repr(C)] plain numbers (u32, u64, f64,
    // explicit padding: the layout test below), valid for every bit
    // pattern. `write_used` then writes every entry that differs from
    // `frame` (the marks in `written` cover what earlier frames left), so
    // the sample holds exactly `frame`.
    let sample = unsafe {
        sample
            .payload_mut()
            .assume_init_mut()
            .write_used(frame, written);
        sample.assume_init()
    };
    sample.send()
}

impl UsedEntries for StateFrame {
    fn write_used(&mut self, src: &StateFrame, written: &mut Written) {
        // Exhaustive: a field added to the frame must be added here.
        let &StateFrame {
            version,
            status,
            step,
            sim_time,
            sequence,
            model_hash,
            body_count,
            joint_count,
            contact_count,
            controller_count,
            solver_status,
            lcp_size,
            residual,
            dt,
            bodies: _,
            joint_impulses: _,
            contacts: _,
            controllers,
        } = src;
        self.version = version;
        self.status = status;
        self.step = step;
        self.sim_time = sim_time;
        self.sequence = sequence;
        self.model_hash = model_hash;
        self.body_count = body_count;
        self.joint_count = joint_count;
        self.contact_count = contact_count;
        self.controller_count = controller_count;
        self.solver_status = solver_status;
        self.lcp_size = lcp_size;
        self.residual = residual;
        self.dt = dt;
        self.controllers = controllers;
        write_prefix(
            &mut self.bodies,
            &src.bodies,
            body_count as usize,
            &mut written.bodies,
        );
        write_prefix(
            &mut self.joint_impulses,
            &src.joint_impulses,
            joint_count as usize,
            &mut written.joints,
        );
        write_prefix(
            &mut self.contacts,
            &src.contacts,
            contact_count as usize,
            &mut written.contacts,
        );
    }
}

/// `StateFrame::solver_status`.
pub const SOLVER_OK: u32 = 0;
pub const SOLVER_RAY_TERMINATION: u32 = 1;
pub const SOLVER_PIVOT_LIMIT: u32 = 2;
pub const SOLVER_SINGULAR: u32 = 3;
pub const SOLVER_NOT_CONVERGED: u32 = 4;
pub const SOLVER_OTHER: u32 = 5;

/// A held joint torque (N m, world frame): `+torque` on body b, `-torque`
/// on body a.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("cosim::JointTorque.v1")]
pub struct JointTorque {
    pub joint: u32,
    pub _pad: u32,
    pub torque: [f64; 3],
}

/// A one-step impulse on a body (N s and N m s, world frame, through the
/// centre of mass).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("cosim::BodyImpulse.v1")]
pub struct BodyImpulse {
    pub body: u32,
    pub _pad: u32,
    pub linear: [f64; 3],
    pub angular: [f64; 3],
}

/// A controller's answer to state frame `step`.
///
/// Torques listed are held by this controller until it sends another
/// value for the joint; the server applies the sum over controllers.
/// Impulses act on the next step only.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("cosim::InputFrame.v1")]
pub struct InputFrame {
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
    pub torques: [JointTorque; MAX_JOINTS],
    pub impulses: [BodyImpulse; MAX_BODIES],
}

impl Default for InputFrame {
    fn default() -> InputFrame {
        InputFrame {
            version: PROTOCOL_VERSION,
            controller_id: 0,
            step: 0,
            sequence: 0,
            torque_count: 0,
            impulse_count: 0,
            torques: [JointTorque::default(); MAX_JOINTS],
            impulses: [BodyImpulse::default(); MAX_BODIES],
        }
    }
}

impl UsedEntries for InputFrame {
    /// The header and the torques and impulses in use (`written.joints`
    /// and `written.bodies` mark them).
    fn write_used(&mut self, src: &InputFrame, written: &mut Written) {
        let &InputFrame {
            version,
            controller_id,
            step,
            sequence,
            torque_count,
            impulse_count,
            torques: _,
            impulses: _,
        } = src;
        self.version = version;
        self.controller_id = controller_id;
        self.step = step;
        self.sequence = sequence;
        self.torque_count = torque_count;
        self.impulse_count = impulse_count;
        write_prefix(
            &mut self.torques,
            &src.torques,
            torque_count as usize,
            &mut written.joints,
        );
        write_prefix(
            &mut self.impulses,
            &src.impulses,
            impulse_count as usize,
            &mut written.bodies,
        );
    }
}

impl InputFrame {
    /// Appends a joint torque; false when the frame is full.
    pub fn push_torque(&mut self, joint: u32, torque: [f64; 3]) -> bool {
        let i = self.torque_count as usize;
        if i >= MAX_JOINTS {
            return false;
        }
        self.torques[i] = JointTorque {
            joint,
            _pad: 0,
            torque,
        };
        self.torque_count += 1;
        true
    }
    /// Appends a body impulse; false when the frame is full.
    pub fn push_impulse(&mut self, body: u32, linear: [f64; 3], angular: [f64; 3]) -> bool {
        let i = self.impulse_count as usize;
        if i >= MAX_BODIES {
            return false;
        }
        self.impulses[i] = BodyImpulse {
            body,
            _pad: 0,
            linear,
            angular,
        };
        self.impulse_count += 1;
        true
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
#[type_name("cosim::ControlRequest.v1")]
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
#[type_name("cosim::ControlResponse.v1")]
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

    // The sizes docs/protocol.md states: a change here is a protocol change.
    /// A frame written entry by entry into reused memory equals its source,
    /// whatever the counts of the frames written there before.
    #[test]
    fn writing_the_used_entries_equals_a_full_copy() {
        let mut slots = [StateFrame::default(), StateFrame::default()];
        let mut inputs = [InputFrame::default(), InputFrame::default()];
        let (mut w, mut wi) = (Written::default(), Written::default());
        let mut x = 1.0f64;
        for (k, &(nb, nj, nc)) in [
            (2, 2, 5),
            (3, 1, 0),
            (2, 2, 64),
            (1, 0, 70),
            (2, 2, 3),
            (0, 0, 0),
        ]
        .iter()
        .enumerate()
        {
            let mut src = StateFrame {
                step: k as u64,
                body_count: nb,
                joint_count: nj,
                contact_count: nc,
                residual: x,
                ..StateFrame::default()
            };
            for b in &mut src.bodies[..nb as usize] {
                x += 1.0;
                b.position = [x, -x, 0.5 * x];
            }
            for j in &mut src.joint_impulses[..nj as usize] {
                x += 1.0;
                *j = [x; 3];
            }
            for c in &mut src.contacts[..(nc as usize).min(MAX_CONTACTS)] {
                x += 1.0;
                c.id = x as u32;
                c.normal = [0.0, 0.0, x];
            }
            src.controllers[k % MAX_CONTROLLERS].id = k as u32 + 1;
            let dst = &mut slots[k % 2];
            dst.write_used(&src, &mut w);
            assert_eq!(*dst, src, "frame {k}");
            assert_eq!(src.used_copy(), src);

            let mut input = InputFrame {
                step: k as u64,
                ..InputFrame::default()
            };
            for i in 0..nj {
                input.push_torque(i, [x, 0.0, -x]);
            }
            for i in 0..nc.min(MAX_BODIES as u32) {
                input.push_impulse(i, [x; 3], [-x; 3]);
            }
            let dst = &mut inputs[k % 2];
            dst.write_used(&input, &mut wi);
            assert_eq!(*dst, input, "input {k}");
            assert_eq!(input.used_copy(), input);
        }
        assert_eq!(w.contacts, MAX_CONTACTS);
    }

    #[test]
    fn layouts_match_the_protocol_document() {
        assert_eq!(size_of::<BodyFrame>(), 104);
        assert_eq!(size_of::<ContactFrame>(), 64);
        assert_eq!(size_of::<ControllerSlot>(), 24);
        assert_eq!(size_of::<JointTorque>(), 32);
        assert_eq!(size_of::<BodyImpulse>(), 56);
        assert_eq!(
            size_of::<StateFrame>(),
            80 + 104 * MAX_BODIES + 24 * MAX_JOINTS + 64 * MAX_CONTACTS + 24 * MAX_CONTROLLERS
        );
        assert_eq!(
            size_of::<InputFrame>(),
            32 + 32 * MAX_JOINTS + 56 * MAX_BODIES
        );
        assert_eq!(size_of::<ControlRequest>(), 48);
        assert_eq!(size_of::<ControlResponse>(), 80 + MESSAGE_LEN);
        for a in [
            align_of::<StateFrame>(),
            align_of::<InputFrame>(),
            align_of::<ControlRequest>(),
            align_of::<ControlResponse>(),
        ] {
            assert_eq!(a, 8);
        }
    }

    #[test]
    fn type_names_carry_the_version() {
        use iceoryx2::prelude::ZeroCopySend;
        // SAFETY: type_name only returns the static name given by the derive.
        let names = unsafe {
            [
                StateFrame::type_name(),
                InputFrame::type_name(),
                ControlRequest::type_name(),
                ControlResponse::type_name(),
            ]
        };
        for n in names {
            assert!(n.starts_with("cosim::") && n.ends_with(".v1"), "{n}");
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

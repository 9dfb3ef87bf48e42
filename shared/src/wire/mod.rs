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

mod control;
mod input;
pub mod services;
mod state;
mod words;

pub use control::*;
pub use input::*;
pub use state::*;
pub use words::*;

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
mod tests;

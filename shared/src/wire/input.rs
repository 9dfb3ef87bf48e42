//! The input stream: a controller's answer to a frame, and why one is refused.

use iceoryx2::prelude::ZeroCopySend;

use super::words::{f3, pair, put_f64s, split, WordSink};
use super::*;

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

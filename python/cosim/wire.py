"""The wire types of protocol 4 (docs/protocol.md), as ctypes structures
whose layouts and type names match the Rust definitions
(shared/src/wire.rs), and their numpy views."""

import ctypes

import numpy as np

PROTOCOL_VERSION = 4
MAX_CONTROLLERS = 8
MESSAGE_LEN = 120

CMD_JOIN, CMD_LEAVE, CMD_PAUSE, CMD_RESUME, CMD_STEP = 1, 2, 3, 4, 5
CMD_RESET, CMD_SNAPSHOT, CMD_RESTORE, CMD_INFO, CMD_SHUTDOWN = 6, 7, 8, 9, 10
CMD_SCENE = 11
# Chunks of the scene TOML the server sends per CMD_SCENE request.
SCENE_CHUNKS_PER_REQUEST = 200
ROLE_CONTROLLER, ROLE_MONITOR = 1, 2

STATUS_PAUSED = 1
STATUS_SOLVER_FAILED = 2
STATUS_INPUT_REJECTED = 4
STATUS_DEADLINE_MISSED = 8
STATUS_SHUTDOWN = 16
STATUS_WAITING = 32
STATUS_CONTACTS_TRUNCATED = 64
STATUS_SERVER_SPINS = 128
STATUS_FELL_BACK = 256

SLOT_JOINED, SLOT_MISSED, SLOT_ANSWERED = 1, 2, 4

# Words (8 bytes) of each entry in a payload.
BODY_WORDS, JOINT_WORDS, CONTACT_WORDS = 13, 5, 8
TORQUE_WORDS, IMPULSE_WORDS, MOTOR_WORDS = 4, 7, 2


class ControllerSlot(ctypes.Structure):
    _fields_ = [
        ("id", ctypes.c_uint32),
        ("flags", ctypes.c_uint32),
        ("rejected", ctypes.c_uint32),
        ("misses", ctypes.c_uint32),
        ("last_step", ctypes.c_uint64),
    ]


class StateHeader(ctypes.Structure):
    _fields_ = [
        ("version", ctypes.c_uint32),
        ("status", ctypes.c_uint32),
        ("step", ctypes.c_uint64),
        ("sim_time", ctypes.c_double),
        ("sequence", ctypes.c_uint64),
        ("model_hash", ctypes.c_uint64),
        ("body_count", ctypes.c_uint32),
        ("joint_count", ctypes.c_uint32),
        ("contact_count", ctypes.c_uint32),
        ("contacts_carried", ctypes.c_uint32),
        ("controller_count", ctypes.c_uint32),
        ("solver_status", ctypes.c_uint32),
        ("lcp_size", ctypes.c_uint32),
        ("_pad", ctypes.c_uint32),
        ("residual", ctypes.c_double),
        ("dt", ctypes.c_double),
        ("controllers", ControllerSlot * MAX_CONTROLLERS),
    ]

    @staticmethod
    def type_name() -> str:
        return "cosim::StateHeader.v4"


class JointTorque(ctypes.Structure):
    _fields_ = [
        ("joint", ctypes.c_uint32),
        ("_pad", ctypes.c_uint32),
        ("torque", ctypes.c_double * 3),
    ]


class BodyImpulse(ctypes.Structure):
    _fields_ = [
        ("body", ctypes.c_uint32),
        ("_pad", ctypes.c_uint32),
        ("linear", ctypes.c_double * 3),
        ("angular", ctypes.c_double * 3),
    ]


class MotorTarget(ctypes.Structure):
    _fields_ = [
        ("joint", ctypes.c_uint32),
        ("_pad", ctypes.c_uint32),
        ("speed", ctypes.c_double),
    ]


class InputHeader(ctypes.Structure):
    _fields_ = [
        ("version", ctypes.c_uint32),
        ("controller_id", ctypes.c_uint32),
        ("step", ctypes.c_uint64),
        ("sequence", ctypes.c_uint64),
        ("torque_count", ctypes.c_uint32),
        ("impulse_count", ctypes.c_uint32),
        ("motor_count", ctypes.c_uint32),
        ("_pad", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "cosim::InputHeader.v4"


class ControlRequest(ctypes.Structure):
    _fields_ = [
        ("version", ctypes.c_uint32),
        ("command", ctypes.c_uint32),
        ("role", ctypes.c_uint32),
        ("controller_id", ctypes.c_uint32),
        ("count", ctypes.c_uint64),
        ("node_id_lo", ctypes.c_uint64),
        ("node_id_hi", ctypes.c_uint64),
        ("pid", ctypes.c_uint64),
    ]

    @staticmethod
    def type_name() -> str:
        return "cosim::ControlRequest.v4"


class ControlResponse(ctypes.Structure):
    _fields_ = [
        ("version", ctypes.c_uint32),
        ("status", ctypes.c_uint32),
        ("controller_id", ctypes.c_uint32),
        ("paused", ctypes.c_uint32),
        ("step", ctypes.c_uint64),
        ("sim_time", ctypes.c_double),
        ("dt", ctypes.c_double),
        ("model_hash", ctypes.c_uint64),
        ("body_count", ctypes.c_uint32),
        ("joint_count", ctypes.c_uint32),
        ("controller_count", ctypes.c_uint32),
        ("monitor_count", ctypes.c_uint32),
        ("value", ctypes.c_uint64),
        ("pid", ctypes.c_uint64),
        ("message", ctypes.c_uint8 * MESSAGE_LEN),
    ]

    @staticmethod
    def type_name() -> str:
        return "cosim::ControlResponse.v4"

    def text(self) -> str:
        return bytes(self.message).split(b"\0")[0].decode("utf-8", "replace")


# The sizes docs/protocol.md states.
assert ctypes.sizeof(StateHeader) == 280
assert ctypes.sizeof(InputHeader) == 40
assert ctypes.sizeof(MotorTarget) == 8 * MOTOR_WORDS
assert ctypes.sizeof(JointTorque) == 8 * TORQUE_WORDS
assert ctypes.sizeof(BodyImpulse) == 8 * IMPULSE_WORDS
assert ctypes.sizeof(ControlRequest) == 48
assert ctypes.sizeof(ControlResponse) == 200

# A ContactFrame's 8 words as numpy reads them (little-endian).
CONTACT_DTYPE = np.dtype(
    [
        ("body_a", "<u4"),
        ("kind_b", "<u4"),
        ("index_b", "<u4"),
        ("id", "<u4"),
        ("normal", "<f8", (3,)),
        ("friction", "<f8", (3,)),
    ]
)
assert CONTACT_DTYPE.itemsize == 8 * CONTACT_WORDS


class BadFrameError(ValueError):
    pass


class State:
    """A state frame copied out of shared memory: the header's fields and
    numpy arrays of the entries (protocol.md: the payload words are, in
    order, body_count bodies of 13 words, joint_count joints of 5,
    contacts_carried contacts of 8).

    Arrays, one row per body: `positions` (m), `orientations` (unit
    quaternions, w, x, y, z), `linear_velocities` (m/s),
    `angular_velocities` (rad/s, world frame); `joint_impulses` (N s, on
    each joint's body a over the last step); `joint_positions` and
    `joint_rates` (a hinge's angle in rad and rate, a slider's offset in m
    and speed; NaN for spherical and fixed joints); `contacts`
    (CONTACT_DTYPE)."""

    def __init__(self, header: StateHeader, words: int, address: int):
        self.header = StateHeader.from_buffer_copy(header)
        h = self.header
        need = (
            BODY_WORDS * h.body_count
            + JOINT_WORDS * h.joint_count
            + CONTACT_WORDS * h.contacts_carried
        )
        if words != need:
            raise BadFrameError(
                f"state frame: the header's counts need {need} words, the payload has {words}"
            )
        raw = np.frombuffer(
            (ctypes.c_uint8 * (8 * words)).from_address(address), dtype=np.uint8
        ).copy()
        nb, nj = h.body_count, h.joint_count
        f = raw[: 8 * (BODY_WORDS * nb + JOINT_WORDS * nj)].view("<f8")
        bodies = f[: BODY_WORDS * nb].reshape(nb, BODY_WORDS)
        self.positions = bodies[:, 0:3]
        self.orientations = bodies[:, 3:7]
        self.linear_velocities = bodies[:, 7:10]
        self.angular_velocities = bodies[:, 10:13]
        joints = f[BODY_WORDS * nb :].reshape(nj, JOINT_WORDS)
        self.joint_impulses = joints[:, 0:3]
        self.joint_positions = joints[:, 3]
        self.joint_rates = joints[:, 4]
        self.contacts = raw[8 * (BODY_WORDS * nb + JOINT_WORDS * nj) :].view(CONTACT_DTYPE)

    @property
    def step(self) -> int:
        return self.header.step

    @property
    def t(self) -> float:
        return self.header.sim_time

    @property
    def dt(self) -> float:
        return self.header.dt

    @property
    def status(self) -> int:
        return self.header.status

    @property
    def sequence(self) -> int:
        return self.header.sequence

    def slot(self, controller_id: int):
        """This frame's slot of a joined controller, or None."""
        h = self.header
        for s in h.controllers[: h.controller_count]:
            if s.id == controller_id and s.flags & SLOT_JOINED:
                return s
        return None

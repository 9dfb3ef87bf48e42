#!/usr/bin/env python3
"""A cosim controller in Python, written from docs/protocol.md alone.

It uses only the official `iceoryx2` package (pip install iceoryx2==0.10.0)
and ctypes structures mirroring the wire types. It joins the server NAME,
answers STEPS steps with a PD torque that holds the reference scene's upper
arm at a target elevation (gravity compensated), then leaves.

    cosim-server serve --controllers 1 --name lab &
    python3 examples/python/controller.py --name lab --steps 2000
"""

import argparse
import atexit
import ctypes
import math
import os
import sys
import time

import iceoryx2 as iox2

MAX_CONTROLLERS = 8
MESSAGE_LEN = 120
VERSION = 2
CMD_JOIN, CMD_LEAVE, CMD_INFO = 1, 2, 9
ROLE_CONTROLLER = 1
STATUS_SOLVER_FAILED, STATUS_SHUTDOWN, STATUS_WAITING = 2, 16, 32
SLOT_JOINED, SLOT_ANSWERED = 1, 4
# Words (8 bytes) of each entry in a payload.
BODY_WORDS, JOINT_WORDS, CONTACT_WORDS = 13, 3, 8
TORQUE_WORDS, IMPULSE_WORDS = 4, 7


class BodyFrame(ctypes.Structure):
    _fields_ = [
        ("position", ctypes.c_double * 3),
        ("orientation", ctypes.c_double * 4),
        ("linear_velocity", ctypes.c_double * 3),
        ("angular_velocity", ctypes.c_double * 3),
    ]


class ContactFrame(ctypes.Structure):
    _fields_ = [
        ("body_a", ctypes.c_uint32),
        ("kind_b", ctypes.c_uint32),
        ("index_b", ctypes.c_uint32),
        ("id", ctypes.c_uint32),
        ("normal", ctypes.c_double * 3),
        ("friction", ctypes.c_double * 3),
    ]


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
        return "cosim::StateHeader.v2"


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


class InputHeader(ctypes.Structure):
    _fields_ = [
        ("version", ctypes.c_uint32),
        ("controller_id", ctypes.c_uint32),
        ("step", ctypes.c_uint64),
        ("sequence", ctypes.c_uint64),
        ("torque_count", ctypes.c_uint32),
        ("impulse_count", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "cosim::InputHeader.v2"


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
        return "cosim::ControlRequest.v2"


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
        return "cosim::ControlResponse.v2"


# The sizes docs/protocol.md states.
assert ctypes.sizeof(StateHeader) == 280
assert ctypes.sizeof(InputHeader) == 32
assert ctypes.sizeof(BodyFrame) == 8 * BODY_WORDS
assert ctypes.sizeof(ContactFrame) == 8 * CONTACT_WORDS
assert ctypes.sizeof(JointTorque) == 8 * TORQUE_WORDS
assert ctypes.sizeof(BodyImpulse) == 8 * IMPULSE_WORDS
assert ctypes.sizeof(ControlRequest) == 48
assert ctypes.sizeof(ControlResponse) == 200


class State:
    """A state frame copied out of shared memory: the header and the
    entries its counts say (protocol.md: the payload words are, in order,
    body_count BodyFrames, joint_count joint impulses, contacts_carried
    ContactFrames; on a little-endian machine the words are the bytes of
    these structs)."""

    def __init__(self, sample):
        self.header = StateHeader.from_buffer_copy(sample.user_header().contents)
        h = self.header
        # The words in the payload: iceoryx2's sample header counts them
        # (the Python binding's Slice.len() of 0.10 counts bytes instead).
        words = sample.header.number_of_elements
        need = BODY_WORDS * h.body_count + JOINT_WORDS * h.joint_count \
            + CONTACT_WORDS * h.contacts_carried
        if words != need:
            raise ValueError(f"state frame: the header's counts need {need} words, "
                             f"the payload has {words}")
        at = sample.payload_ptr
        self.bodies = (BodyFrame * h.body_count).from_buffer_copy(
            (ctypes.c_uint8 * (8 * BODY_WORDS * h.body_count)).from_address(at))
        at += 8 * BODY_WORDS * h.body_count
        joints = (ctypes.c_double * (3 * h.joint_count)).from_address(at)
        self.joint_impulses = [tuple(joints[3 * j:3 * j + 3]) for j in range(h.joint_count)]
        at += 8 * JOINT_WORDS * h.joint_count
        self.contacts = (ContactFrame * h.contacts_carried).from_buffer_copy(
            (ctypes.c_uint8 * (8 * CONTACT_WORDS * h.contacts_carried)).from_address(at))

    def __getattr__(self, name):
        return getattr(self.header, name)


class Client:
    def __init__(self, name: str):
        self.node = iox2.NodeBuilder.new().create(iox2.ServiceType.Ipc)
        svc = lambda s: iox2.ServiceName.new(f"cosim/{name}/{s}")
        control = (
            self.node.service_builder(svc("control"))
            .request_response(ControlRequest, ControlResponse)
            .open()
        )
        self.control = control.client_builder().create()
        self.wake = self.node.service_builder(svc("wake")).event().open().notifier_builder().create()
        self.ready = (
            self.node.service_builder(svc("state-ready")).event().open().listener_builder().create()
        )
        # Subscribe before joining (protocol.md, Lockstep 1).
        self.state = (
            self.node.service_builder(svc("state"))
            .publish_subscribe(iox2.Slice[ctypes.c_uint64])
            .user_header(StateHeader)
            .open()
            .subscriber_builder()
            .create()
        )
        # Room for a torque on every joint and a few impulses; a larger
        # input grows the publisher's memory (power-of-two strategy).
        joints = self.request(CMD_INFO).joint_count
        self.input = (
            self.node.service_builder(svc("input"))
            .publish_subscribe(iox2.Slice[ctypes.c_uint64])
            .user_header(InputHeader)
            .open()
            .publisher_builder()
            .initial_max_slice_len(max(1, TORQUE_WORDS * joints + IMPULSE_WORDS * 8))
            .allocation_strategy(iox2.AllocationStrategy.PowerOfTwo)
            .create()
        )
        self.id = 0
        self.joined = False

    def join(self) -> "ControlResponse":
        """Joins the lockstep; the controller leaves again at interpreter exit
        if it has not left (the server also notices a process that is gone,
        within about 10 ms, but a leave is immediate and logged as one)."""
        joined = self.request(CMD_JOIN, role=ROLE_CONTROLLER)
        self.id = joined.controller_id
        self.joined = True
        atexit.register(self.leave)
        return joined

    def leave(self):
        """Leaves the lockstep once; a server that is gone is not an error."""
        if not self.joined:
            return
        self.joined = False
        try:
            self.request(CMD_LEAVE, controller_id=self.id, timeout=0.5)
        except (RuntimeError, TimeoutError):
            pass

    def request(self, command: int, timeout: float = 5.0, **fields) -> ControlResponse:
        node_id = self.node.id.value
        req = ControlRequest(
            version=VERSION,
            command=command,
            node_id_lo=node_id & (2**64 - 1),
            node_id_hi=node_id >> 64,
            pid=os.getpid(),
            **fields,
        )
        pending = self.control.send_copy(req)
        self.wake.notify()
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            response = pending.receive()
            if response is not None:
                r = response.payload().contents
                if r.status != 0:
                    msg = bytes(r.message).split(b"\0")[0].decode()
                    raise RuntimeError(f"server refused (status {r.status}): {msg}")
                return ControlResponse.from_buffer_copy(r)
            self.node.wait(iox2.Duration.from_micros(100))
        raise TimeoutError("no answer from the server")

    def next_state(self, answered, timeout=10.0) -> State:
        """The newest frame to answer (or the last one): of a step not yet
        answered, or of a failed step that asks for a new answer.
        `answered` is (step, sequence) of the frame answered last, or None."""
        step, sequence = answered if answered else (None, 0)
        deadline = time.monotonic() + timeout
        while True:
            newest = None
            while True:
                sample = self.state.receive()
                if sample is None:
                    break
                newest = State(sample)
            if newest is not None:
                if newest.status & STATUS_SHUTDOWN:
                    return newest
                # A frame that does not list this controller predates the
                # join (protocol.md, Lockstep 2): the server waits for no
                # answer to it.
                mine = [s for s in newest.controllers[:newest.controller_count]
                        if s.id == self.id and s.flags & SLOT_JOINED]
                # A failed step's frame asks for a new answer to the same step
                # (protocol.md, Lockstep): its slot lacks SLOT_ANSWERED.
                again = (mine and newest.status & STATUS_SOLVER_FAILED
                         and not mine[0].flags & SLOT_ANSWERED and newest.sequence > sequence)
                if (not newest.status & STATUS_WAITING and mine
                        and (newest.step != step or again)):
                    return newest
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("no state frame")
            # The frame is published before the event: a frame that landed
            # after the poll above leaves the event pending.
            self.ready.timed_wait(iox2.Duration.from_secs_f64(min(left, 0.1)))

    def send(self, header: InputHeader, torques=(), impulses=()):
        """Sends an input: the header (its counts set here) and the
        entries, as payload words (protocol.md, Input frames)."""
        header.torque_count, header.impulse_count = len(torques), len(impulses)
        words = TORQUE_WORDS * len(torques) + IMPULSE_WORDS * len(impulses)
        sample = self.input.loan_slice_uninit(words)
        ctypes.memmove(sample.user_header_ptr, ctypes.byref(header), ctypes.sizeof(header))
        at = sample.payload_ptr
        for entry in list(torques) + list(impulses):
            ctypes.memmove(at, ctypes.byref(entry), ctypes.sizeof(entry))
            at += ctypes.sizeof(entry)
        sample.assume_init().send()
        self.wake.notify()


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def pd_torque(frame: State, elevation_deg: float):
    """Shoulder torque: PD on the arm direction, plus the chain's gravity moment."""
    shoulder = (0.0, 0.0, 0.45)
    masses = (1.0, 0.5)
    g = (0.0, 0.0, -9.81)
    kp, kd = 20.0, 3.0
    upper = frame.bodies[0]
    r = [upper.position[i] - shoulder[i] for i in range(3)]
    n = math.sqrt(sum(x * x for x in r))
    d = [x / n for x in r]
    e = math.radians(elevation_deg)
    target = [math.cos(e), 0.0, math.sin(e)]
    tau = [kp * c for c in cross(d, target)]
    tau = [tau[i] - kd * upper.angular_velocity[i] for i in range(3)]
    for b, m in zip(frame.bodies[:2], masses):
        arm = [b.position[i] - shoulder[i] for i in range(3)]
        moment = cross(arm, [m * x for x in g])
        tau = [tau[i] - moment[i] for i in range(3)]
    return tau, math.degrees(math.asin(d[2]))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--name", default="default")
    p.add_argument("--steps", type=int, default=1000)
    p.add_argument("--elevation", type=float, default=10.0)
    p.add_argument("--exit-without-leave", type=int, metavar="N",
                   help="answer N steps, then end the process at once, skipping "
                        "leave and every cleanup (as a crashed controller would)")
    args = p.parse_args()
    iox2.set_log_level(iox2.LogLevel.Error)

    client = Client(args.name)
    joined = client.join()
    print(f"joined '{args.name}' as controller {client.id}: "
          f"{joined.body_count} bodies, {joined.joint_count} joints, dt {joined.dt}")
    answered, elevation, sent, shutdown = None, float("nan"), 0, False
    while sent < args.steps:
        frame = client.next_state(answered)
        if frame.status & STATUS_SHUTDOWN:
            shutdown = True
            break
        tau, elevation = pd_torque(frame, args.elevation)
        out = InputHeader(version=VERSION, controller_id=client.id, step=frame.step,
                          sequence=sent + 1)
        client.send(out, torques=[JointTorque(joint=0, torque=(ctypes.c_double * 3)(*tau))])
        answered = (frame.step, frame.sequence)
        sent += 1
        if sent == args.exit_without_leave:
            print(f"answered {sent} steps; exiting without leave", flush=True)
            os._exit(0)
    if not shutdown:
        client.leave()
    print(f"{'server shut down; ' if shutdown else ''}answered {sent} steps; elevation {elevation:.3f} deg (target {args.elevation})")
    return 0


if __name__ == "__main__":
    sys.exit(main())

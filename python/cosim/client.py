"""Connection, Controller and Monitor: the Rust client's three roles in
Python (docs/protocol.md, "Lockstep")."""

import atexit
import ctypes
import os
import time
import weakref
from typing import Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

try:  # Python 3.11 and later
    import tomllib as _toml
except ImportError:  # pragma: no cover - older Pythons (the tomli dependency)
    import tomli as _toml

import iceoryx2 as iox2
import numpy as np

from .wire import (
    CMD_INFO,
    CMD_JOIN,
    CMD_LEAVE,
    CMD_PAUSE,
    CMD_RESUME,
    CMD_SHUTDOWN,
    CMD_STEP,
    IMPULSE_WORDS,
    PROTOCOL_VERSION,
    ROLE_CONTROLLER,
    SLOT_ANSWERED,
    STATUS_SERVER_SPINS,
    STATUS_SHUTDOWN,
    STATUS_SOLVER_FAILED,
    STATUS_WAITING,
    TORQUE_WORDS,
    BadFrameError,
    BodyImpulse,
    ControlRequest,
    ControlResponse,
    InputHeader,
    JointTorque,
    MotorTarget,
    MOTOR_WORDS,
    State,
    StateHeader,
    CMD_SCENE,
    MESSAGE_LEN,
    SCENE_CHUNKS_PER_REQUEST,
)


class CosimError(Exception):
    """Every error of this package."""


class NoServer(CosimError):
    """No server of this name runs on this machine."""


class Refused(CosimError):
    """The server answered with an error status."""

    def __init__(self, status: int, message: str):
        super().__init__(f"the server refused (status {status}): {message}")
        self.status = status
        self.message = message


class Timeout(CosimError, TimeoutError):
    """No answer or frame within the timeout."""


class Shutdown(CosimError):
    """The server announced its shutdown (its last frame)."""


class BadFrame(CosimError):
    """A state frame whose words do not match its header."""


_LOGS_QUIET = False


def _quiet():
    global _LOGS_QUIET
    if not _LOGS_QUIET:
        iox2.set_log_level(iox2.LogLevel.Error)
        _LOGS_QUIET = True


def _service(name: str, what: str) -> "iox2.ServiceName":
    return iox2.ServiceName.new(f"cosim/{name}/{what}")


def _open(name: str, what: str, open_fn):
    try:
        return open_fn()
    except Exception as e:  # iceoryx2 raises its own error types
        if "DoesNotExist" in repr(e) or "DoesNotExist" in str(e):
            raise NoServer(
                f"no cosim server named '{name}' is running "
                f"(start one that waits for a controller: "
                f"`cosim-server serve --name {name} --controllers 1`)"
            ) from None
        raise CosimError(f"cannot open cosim/{name}/{what}: {e}") from e


def _node():
    """An iceoryx2 node in the domain `COSIM_DOMAIN` names (the Rust
    client's rule: the global configuration when unset or empty, else one
    whose file prefix is `cosim_<domain>_`, so that processes of one
    domain see only one another)."""
    domain = os.environ.get("COSIM_DOMAIN", "")
    builder = iox2.NodeBuilder.new()
    if domain:
        ok = len(domain) <= 64 and all(c.isascii() and (c.isalnum() or c in "-_") for c in domain)
        if not ok:
            raise CosimError(
                f"COSIM_DOMAIN={domain!r}: a domain is 1 to 64 letters, digits, '-' or '_'"
            )
        config = iox2.config.default()
        config.global_cfg.prefix = iox2.FileName.new(f"cosim_{domain}_")
        builder = builder.config(config)
    return builder.create(iox2.ServiceType.Ipc)


class Connection:
    """The control service of server `name`: info, pause, resume, step,
    shutdown. Controllers and monitors have one (`.connection`)."""

    def __init__(self, name: str = "default"):
        _quiet()
        self.name = name
        self.node = _node()
        control = _open(
            name,
            "control",
            lambda: self.node.service_builder(_service(name, "control"))
            .request_response(ControlRequest, ControlResponse)
            .open(),
        )
        self._client = control.client_builder().create()
        self._wake = _open(
            name,
            "wake",
            lambda: self.node.service_builder(_service(name, "wake")).event().open(),
        ).notifier_builder().create()

    def notify(self):
        self._wake.notify()

    def _responses(self, command: int, timeout: float, what: str, **fields):
        """Sends a control request; yields its responses (a status other
        than 0 raises `Refused`) until the caller stops, or raises
        `Timeout` when none comes within `timeout` of the request."""
        node_id = self.node.id.value
        req = ControlRequest(
            version=PROTOCOL_VERSION,
            command=command,
            node_id_lo=node_id & (2**64 - 1),
            node_id_hi=node_id >> 64,
            pid=os.getpid(),
            **fields,
        )
        pending = self._client.send_copy(req)
        self._wake.notify()
        deadline = time.monotonic() + timeout
        while True:
            response = pending.receive()
            if response is None:
                if time.monotonic() > deadline:
                    raise Timeout(f"no {what} from the server '{self.name}' within {timeout} s")
                self.node.wait(iox2.Duration.from_micros(100))
                continue
            r = response.payload().contents
            if r.status != 0:
                raise Refused(r.status, r.text())
            yield r

    def request(self, command: int, timeout: float = 5.0, **fields) -> ControlResponse:
        """Sends a control request and waits for its answer."""
        r = next(self._responses(command, timeout, "answer", **fields))
        return ControlResponse.from_buffer_copy(r)

    def info(self) -> ControlResponse:
        return self.request(CMD_INFO)

    def pause(self) -> ControlResponse:
        return self.request(CMD_PAUSE)

    def resume(self) -> ControlResponse:
        return self.request(CMD_RESUME)

    def step(self, n: int) -> ControlResponse:
        return self.request(CMD_STEP, count=n)

    def shutdown(self) -> ControlResponse:
        return self.request(CMD_SHUTDOWN)

    def scene_toml(self, timeout: float = 5.0) -> str:
        """The scene the server runs, as TOML text (its scene.toml): asked
        for in pages of chunks of MESSAGE_LEN bytes, from the byte reached
        on (docs/protocol.md)."""
        data = bytearray()
        while True:
            chunks, total = 0, 0
            for r in self._responses(CMD_SCENE, timeout, "scene", count=len(data)):
                total = r.value
                take = max(0, min(MESSAGE_LEN, total - len(data)))
                data += bytes(r.message[:take])
                chunks += 1
                if len(data) >= total or chunks == SCENE_CHUNKS_PER_REQUEST:
                    break
            if len(data) >= total:
                return data.decode("utf-8")

    def scene(self) -> Dict[str, Any]:
        """The scene the server runs, parsed: `scene["body"]`, `scene["joint"]`
        (lists of tables, in index order), `scene["sim"]`, ..."""
        return _toml.loads(self.scene_toml())


class _Named:
    """`bodies`, `joints` and `motors` of a client's `names`."""

    names: "Names"

    @property
    def bodies(self) -> List[str]:
        return self.names.bodies

    @property
    def joints(self) -> List[str]:
        return self.names.joints

    @property
    def motors(self) -> List[str]:
        return self.names.motors


class Names:
    """Bodies, joints and motors of a server's scene by name, in the index
    order of the state arrays and of `Controller.send`."""

    def __init__(self, scene: Dict[str, Any]):
        self.scene = scene
        self.bodies: List[str] = [b["name"] for b in scene.get("body", [])]
        self.joints: List[str] = [j["name"] for j in scene.get("joint", [])]
        # The joints a motor target drives (the actuators of the scene).
        self.motors: List[str] = [j["name"] for j in scene.get("joint", []) if "motor" in j]
        self._body = {n: i for i, n in enumerate(self.bodies)}
        self._joint = {n: i for i, n in enumerate(self.joints)}
        # Named frames fixed in bodies ([[body.frame]]: a robot's links
        # merged into their parents by fixed joints): (body index,
        # position, orientation scalar first) in the body's frame.
        self.frames: Dict[str, Tuple[int, List[float], List[float]]] = {}
        for i, b in enumerate(scene.get("body", [])):
            for f in b.get("frame", []):
                self.frames[f["name"]] = (
                    i,
                    list(f.get("position", [0.0, 0.0, 0.0])),
                    list(f.get("orientation", [1.0, 0.0, 0.0, 0.0])),
                )

    def body(self, name: Union[str, int]) -> int:
        """The index of body `name` (an index passes through)."""
        return _index(name, self._body, "body", "bodies", self.bodies)

    def joint(self, name: Union[str, int]) -> int:
        """The index of joint `name` (an index passes through)."""
        return _index(name, self._joint, "joint", "joints", self.joints)

    def frame(self, name: str) -> Tuple[int, List[float], List[float]]:
        """Frame `name` as (body index, position, orientation scalar first)
        in the body's frame: a body's own (at its centre of mass) or a
        named frame fixed in one (a robot's link merged into its parent)."""
        if name in self._body:
            return (self._body[name], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0])
        try:
            return self.frames[name]
        except KeyError:
            known = self.bodies + list(self.frames)
            raise KeyError(f"no frame named {name!r}; the frames are {known}") from None


def _index(name: Union[str, int], table: Dict[str, int], kind: str, kinds: str, names: List[str]) -> int:
    """`name`'s index in `table` (an index passes through), or a KeyError
    that lists the names there are."""
    if isinstance(name, int):
        return name
    try:
        return table[name]
    except KeyError:
        raise KeyError(f"no {kind} named {name!r}; the {kinds} are {names}") from None


class _StateReader:
    def __init__(self, conn: Connection, what: str = "state", buffer: int = 2):
        name = conn.name
        service = _open(
            name,
            what,
            lambda: conn.node.service_builder(_service(name, what))
            .publish_subscribe(iox2.Slice[ctypes.c_uint64])
            .user_header(StateHeader)
            .open(),
        )
        self._sub = service.subscriber_builder().buffer_size(buffer).create()
        ready = "state-ready" if what == "state" else f"{what}-ready"
        self._ready = _open(
            name,
            ready,
            lambda: conn.node.service_builder(_service(name, ready)).event().open(),
        ).listener_builder().create()

    def receive(self, newest: bool) -> Optional[State]:
        """The next frame in the buffer, or with `newest` the newest one
        (older ones dropped unread)."""
        got = None
        while True:
            sample = self._sub.receive()
            if sample is None:
                break
            got = sample
            if not newest:
                break
        if got is None:
            return None
        # The words in the payload: iceoryx2's sample header counts them
        # (the binding's Slice.len() of 0.10 counts bytes instead).
        try:
            return State(
                got.user_header().contents,
                got.header.number_of_elements,
                got.payload_ptr,
            )
        except BadFrameError as e:
            raise BadFrame(str(e)) from None

    def wait(self, seconds: float):
        # A frame published before the event leaves the event pending.
        self._ready.timed_wait(iox2.Duration.from_secs_f64(max(seconds, 0.0)))


class Controller(_Named):
    """A controller in the lockstep of server `name`: `next_state()`, then
    `send(...)`, each step. Leaves on `leave()`, at the end of a `with`
    block, or at interpreter exit."""

    def __init__(self, name: str = "default", timeout: float = 10.0, wait: str = "block"):
        """`wait`: "block" sleeps on the server's event between polls;
        "spin" busy-polls (the fastest wake-up when the controller has a
        core of its own, the slowest when it shares one)."""
        if wait not in ("block", "spin"):
            raise ValueError(f'wait = {wait!r}: "block" or "spin"')
        self.connection = Connection(name)
        self.name = name
        self.timeout = timeout
        self.spin = wait == "spin"
        # Subscribe and publish before joining (protocol.md, Lockstep 1).
        self._reader = _StateReader(self.connection)
        joints = self.connection.info().joint_count
        node = self.connection.node
        self._input = _open(
            name,
            "input",
            lambda: node.service_builder(_service(name, "input"))
            .publish_subscribe(iox2.Slice[ctypes.c_uint64])
            .user_header(InputHeader)
            .open(),
        ).publisher_builder().initial_max_slice_len(
            max(1, (TORQUE_WORDS + MOTOR_WORDS) * joints + IMPULSE_WORDS * 8)
        ).allocation_strategy(iox2.AllocationStrategy.PowerOfTwo).create()
        # The scene before the join: its names for `send` and the user.
        self.scene = self.connection.scene()
        self.names = Names(self.scene)
        self.info = self.connection.request(CMD_JOIN, role=ROLE_CONTROLLER)
        self.id = self.info.controller_id
        self.joined = True
        self._answered: Optional[Tuple[int, int]] = None
        self._sequence = 0
        self.last: Optional[State] = None
        me = weakref.ref(self)
        atexit.register(lambda: me() is not None and me().leave())

    def __enter__(self) -> "Controller":
        return self

    def __exit__(self, *exc):
        self.leave()
        return False

    def leave(self):
        """Leaves the lockstep once; a server that is gone is not an error."""
        if not self.joined:
            return
        self.joined = False
        try:
            self.connection.request(CMD_LEAVE, controller_id=self.id, timeout=0.5)
        except CosimError:
            pass

    def next_state(self, timeout: Optional[float] = None) -> State:
        """The newest frame to answer: of a step not yet answered, or of a
        failed step that asks for a new answer. Raises `Shutdown` at the
        server's last frame (kept in `.last`)."""
        timeout = self.timeout if timeout is None else timeout
        step, sequence = self._answered if self._answered else (None, 0)
        deadline = time.monotonic() + timeout
        while True:
            newest = self._reader.receive(newest=True)
            if newest is not None:
                if newest.status & STATUS_SHUTDOWN:
                    self.last = newest
                    raise Shutdown(f"the server '{self.name}' shut down")
                # A frame that does not list this controller predates the
                # join (protocol.md, Lockstep 2).
                mine = newest.slot(self.id)
                again = (
                    mine is not None
                    and newest.status & STATUS_SOLVER_FAILED
                    and not mine.flags & SLOT_ANSWERED
                    and newest.sequence > sequence
                )
                if (
                    not newest.status & STATUS_WAITING
                    and mine is not None
                    and (newest.step != step or again)
                ):
                    self.last = newest
                    return newest
            left = deadline - time.monotonic()
            if left <= 0:
                raise Timeout(f"no state frame from '{self.name}' within {timeout} s")
            if not self.spin:
                self._reader.wait(min(left, 0.1))

    def states(self) -> Iterator[State]:
        """Every state to answer, until the server shuts down."""
        while True:
            try:
                yield self.next_state()
            except Shutdown:
                return

    def send(
        self,
        torques: Mapping[Union[int, str], Sequence[float]] = {},
        impulses: Mapping[Union[int, str], Tuple[Sequence[float], Sequence[float]]] = {},
        motors: Mapping[Union[int, str], float] = {},
    ):
        """Answers the last state: joint efforts (world frame, held until
        changed) by joint index, a torque in N m, or for a prismatic joint
        a force in N at its body_b's anchor; one-step body impulses
        (linear N s, angular N m s) by body index; and motor targets (rad/s
        or m/s, held until changed) by the index of a joint with a
        motor. Joints and bodies may be named instead of indexed
        (`torques={"shoulder": ...}`)."""
        torques = {self.names.joint(j): t for j, t in torques.items()}
        impulses = {self.names.body(b): v for b, v in impulses.items()}
        motors = {self.names.joint(j): v for j, v in motors.items()}
        state = self.last
        step = state.step if state is not None else 0
        self._sequence += 1
        header = InputHeader(
            version=PROTOCOL_VERSION,
            controller_id=self.id,
            step=step,
            sequence=self._sequence,
            torque_count=len(torques),
            impulse_count=len(impulses),
            motor_count=len(motors),
        )
        entries = [
            JointTorque(joint=j, torque=(ctypes.c_double * 3)(*np.asarray(t, float)))
            for j, t in torques.items()
        ] + [
            BodyImpulse(
                body=b,
                linear=(ctypes.c_double * 3)(*np.asarray(lin, float)),
                angular=(ctypes.c_double * 3)(*np.asarray(ang, float)),
            )
            for b, (lin, ang) in impulses.items()
        ] + [MotorTarget(joint=j, speed=float(v)) for j, v in motors.items()]
        words = (
            TORQUE_WORDS * len(torques)
            + IMPULSE_WORDS * len(impulses)
            + MOTOR_WORDS * len(motors)
        )
        sample = self._input.loan_slice_uninit(words)
        ctypes.memmove(sample.user_header_ptr, ctypes.byref(header), ctypes.sizeof(header))
        at = sample.payload_ptr
        for entry in entries:
            ctypes.memmove(at, ctypes.byref(entry), ctypes.sizeof(entry))
            at += ctypes.sizeof(entry)
        sample.assume_init().send()
        if state is None or not state.status & STATUS_SERVER_SPINS:
            self.connection.notify()
        if state is not None:
            self._answered = (state.step, state.sequence)


class Monitor(_Named):
    """Reads the state without joining: it never slows the server. With
    `every=True`, the decimated stream of a server started with
    `--publish-every N`."""

    def __init__(self, name: str = "default", buffer: int = 1, every: bool = False):
        self.connection = Connection(name)
        self.name = name
        self.scene = self.connection.scene()
        self.names = Names(self.scene)
        self._reader = _StateReader(
            self.connection, "state-every" if every else "state", buffer
        )

    def latest(self) -> Optional[State]:
        """The newest frame, without waiting (None when there is none)."""
        return self._reader.receive(newest=True)

    def next(self, timeout: float = 10.0) -> State:
        """The next frame in order."""
        deadline = time.monotonic() + timeout
        while True:
            state = self._reader.receive(newest=False)
            if state is not None:
                return state
            left = deadline - time.monotonic()
            if left <= 0:
                raise Timeout(f"no state frame from '{self.name}' within {timeout} s")
            self._reader.wait(min(left, 0.1))


__all__ = [
    "BadFrame",
    "Connection",
    "Controller",
    "CosimError",
    "Monitor",
    "NoServer",
    "Refused",
    "Shutdown",
    "Timeout",
]

//! Client library for controllers and monitors of a `cosim-server`.
//!
//! - [`Connection`]: the control service of a named server (info, pause,
//!   resume, step, reset, snapshot, restore, shutdown).
//! - [`Controller`]: joins the lockstep; per step, [`Controller::next_state`]
//!   then [`Controller::send`].
//! - [`Monitor`]: reads the state without joining; it never slows the
//!   server (the state service overwrites the oldest frame of a slow
//!   reader).
//!
//! The bytes on the wire are described in `docs/protocol.md`.

pub mod arm;
pub mod cli;
pub mod pd;
pub mod push;
pub mod view;

pub use cosim_shared as shared;
pub use cosim_shared::wire::*;

use iceoryx2::node::NodeView;
use iceoryx2::port::client::Client as RrClient;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use std::fmt;
use std::time::{Duration, Instant};

/// How to wait for the next message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Default)]
pub enum WaitMode {
    /// Busy-poll: the fastest wake-up when each process has a core of its
    /// own, and the slowest when they share one.
    Spin,
    /// Sleep on an iceoryx2 event until woken.
    Block,
    /// Spin for a bounded time ([`HYBRID_SPIN`]), then block.
    #[default]
    Hybrid,
}

impl WaitMode {
    pub fn as_str(self) -> &'static str {
        match self {
            WaitMode::Spin => "spin",
            WaitMode::Block => "block",
            WaitMode::Hybrid => "hybrid",
        }
    }
}

/// Spinning time of [`WaitMode::Hybrid`] before it blocks: a few step
/// computations of the reference scene (about 20 us each), so that a
/// controller on its own core wakes at spinning speed while one sharing a
/// core yields soon.
pub const HYBRID_SPIN: Duration = Duration::from_micros(200);

/// What went wrong, with the server or service named.
#[derive(Debug, Clone, PartialEq)]
pub enum ClientError {
    /// No server of this name runs on this machine.
    NoServer { name: String },
    /// iceoryx2 refused an operation.
    Ipc { what: String, detail: String },
    /// No answer within the timeout.
    Timeout { what: &'static str, after: Duration },
    /// The server answered with an error status.
    Refused { status: u32, message: String },
    /// The server announced its shutdown.
    Shutdown,
    /// SIGINT or SIGTERM arrived while waiting.
    Interrupted,
    /// The server went away without a shutdown frame: killed, or its
    /// process ended (told within [`SERVER_CHECK`] of a wait).
    ServerGone { name: String },
    /// A state frame whose words did not match its header.
    BadFrame(WireError),
}

/// How often a wait checks that the server is still there (a read of its
/// ports and, if they are left, of its node's liveness): a killed server is
/// told as [`ClientError::ServerGone`] after two such checks in a row, not
/// at the timeout.
pub const SERVER_CHECK: Duration = Duration::from_millis(100);

/// The server checks of one wait: every [`SERVER_CHECK`] of it, and gone
/// after two verdicts in a row (a node list read while other processes
/// create and remove nodes can miss a live node once).
struct GoneCheck {
    next: Duration,
    verdicts: u32,
}

impl GoneCheck {
    fn new() -> GoneCheck {
        GoneCheck {
            next: SERVER_CHECK,
            verdicts: 0,
        }
    }

    /// True when the wait, `elapsed` into it, has found the server gone:
    /// `alive` is asked at each check.
    fn gone(&mut self, elapsed: Duration, alive: impl FnOnce() -> bool) -> bool {
        if elapsed < self.next {
            return false;
        }
        self.next += SERVER_CHECK;
        self.verdicts = if alive() { 0 } else { self.verdicts + 1 };
        self.verdicts >= 2
    }
}

/// Whether the node of a server's port (`None`: no port left) lives.
fn port_alive(node: Option<u128>) -> bool {
    node.is_some_and(|n| node_alive(n) != Some(false))
}

impl fmt::Display for ClientError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ClientError::NoServer { name } => write!(
                f,
                "no cosim server named '{name}' is running (start one with `cosim-server serve --name {name}`; `cosim list` shows the running ones)"
            ),
            ClientError::Ipc { what, detail } => write!(f, "{what}: {detail}"),
            ClientError::Timeout { what, after } => {
                write!(f, "no {what} within {:.3} s", after.as_secs_f64())
            }
            ClientError::Refused { status, message } => {
                write!(f, "the server refused (status {status}): {message}")
            }
            ClientError::Shutdown => write!(f, "the server shut down"),
            ClientError::Interrupted => write!(f, "interrupted"),
            ClientError::ServerGone { name } => write!(
                f,
                "the server '{name}' is gone (killed, or it ended without a shutdown frame)"
            ),
            ClientError::BadFrame(e) => write!(f, "a malformed state frame: {e}"),
        }
    }
}

impl std::error::Error for ClientError {}

fn ipc(what: impl Into<String>) -> impl FnOnce(&dyn fmt::Debug) -> ClientError {
    let what = what.into();
    move |e| ClientError::Ipc {
        what,
        detail: format!("{e:?}"),
    }
}

/// An error of opening a service that can say the service does not exist.
trait OpenError: fmt::Debug {
    fn does_not_exist(&self) -> bool;
}

impl OpenError for iceoryx2::service::builder::event::EventOpenError {
    fn does_not_exist(&self) -> bool {
        matches!(self, Self::DoesNotExist)
    }
}

impl OpenError for iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenError {
    fn does_not_exist(&self) -> bool {
        matches!(self, Self::DoesNotExist)
    }
}

impl OpenError for iceoryx2::service::builder::request_response::RequestResponseOpenError {
    fn does_not_exist(&self) -> bool {
        matches!(self, Self::DoesNotExist)
    }
}

/// An open error: a missing service means no (complete) server yet, since
/// a starting server creates its services one after the other.
fn missing(server: &str, service: &str, e: impl OpenError) -> ClientError {
    if e.does_not_exist() {
        ClientError::NoServer {
            name: server.into(),
        }
    } else {
        ClientError::Ipc {
            what: format!("cannot open {service}"),
            detail: format!("{e:?}"),
        }
    }
}

fn service_name(s: &str) -> Result<ServiceName, ClientError> {
    s.try_into()
        .map_err(|e| ipc(format!("bad service name '{s}'"))(&e))
}

/// A node and the control service of one server.
pub struct Connection {
    name: String,
    node: Node<ipc::Service>,
    control_service: iceoryx2::service::port_factory::request_response::PortFactory<
        ipc::Service,
        ControlRequest,
        (),
        ControlResponse,
        (),
    >,
    control: RrClient<ipc::Service, ControlRequest, (), ControlResponse, ()>,
    wake: Notifier<ipc::Service>,
}

/// Default time to wait for a control answer.
pub const CONTROL_TIMEOUT: Duration = Duration::from_secs(5);

impl Connection {
    /// Connects to the server `name`: fails with [`ClientError::NoServer`]
    /// when none runs.
    pub fn connect(name: &str) -> Result<Connection, ClientError> {
        let node = NodeBuilder::new()
            .create::<ipc::Service>()
            .map_err(|e| ipc("cannot create an iceoryx2 node")(&e))?;
        let control_service = node
            .service_builder(&service_name(&services::control(name))?)
            .request_response::<ControlRequest, ControlResponse>()
            .open()
            .map_err(|e| missing(name, &services::control(name), e))?;
        let control = control_service
            .client_builder()
            .create()
            .map_err(|e| ipc("cannot create a control client")(&e))?;
        let wake = node
            .service_builder(&service_name(&services::wake(name))?)
            .event()
            .open()
            .map_err(|e| missing(name, &services::wake(name), e))?
            .notifier_builder()
            .create()
            .map_err(|e| ipc("cannot create a notifier")(&e))?;
        Ok(Connection {
            name: name.into(),
            node,
            control_service,
            control,
            wake,
        })
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    pub fn node(&self) -> &Node<ipc::Service> {
        &self.node
    }

    /// Whether a live server holds the control service.
    pub fn server_alive(&self) -> bool {
        let mut node = None;
        self.control_service.dynamic_config().list_servers(|d| {
            node = Some(d.node_id.value());
            CallbackProgression::Stop
        });
        port_alive(node)
    }

    fn gone(&self) -> ClientError {
        ClientError::ServerGone {
            name: self.name.clone(),
        }
    }

    /// Sends one request and waits for its answer; an error status becomes
    /// [`ClientError::Refused`].
    pub fn request(
        &self,
        req: ControlRequest,
        timeout: Duration,
    ) -> Result<ControlResponse, ClientError> {
        self.exchange(req, timeout, "answer from the server", Some)
    }

    /// Sends `req` and feeds its responses to `take` until it returns a
    /// value; an error status becomes [`ClientError::Refused`].
    fn exchange<T>(
        &self,
        mut req: ControlRequest,
        timeout: Duration,
        what: &'static str,
        mut take: impl FnMut(ControlResponse) -> Option<T>,
    ) -> Result<T, ClientError> {
        req.version = PROTOCOL_VERSION;
        let id = self.node.id().value();
        req.node_id_lo = id as u64;
        req.node_id_hi = (id >> 64) as u64;
        req.pid = u64::from(std::process::id());
        let start = Instant::now();
        let mut check = GoneCheck::new();
        // A request no server took (its buffer full, or the server between
        // ports) is sent again while the server lives; only a server found
        // gone by the two-check rule ends the exchange.
        let pending = loop {
            let pending = self
                .control
                .send_copy(req)
                .map_err(|e| ipc("cannot send a control request")(&e))?;
            // Waking the server is an optimisation: it also polls.
            let _ = self.wake.notify();
            if pending.number_of_server_connections() > 0 {
                break pending;
            }
            if check.gone(start.elapsed(), || self.server_alive()) || start.elapsed() > timeout {
                return Err(self.gone());
            }
            if self.node.wait(Duration::from_micros(50)).is_err() {
                return Err(ClientError::Interrupted);
            }
        };
        loop {
            // NOTE: read whether the server still holds the request before
            // draining: a server that answers and drops the request between
            // a drain and the check leaves its answer in the buffer, and
            // the drain after the check finds it.
            let connected = pending.is_connected();
            while let Some(r) = pending
                .receive()
                .map_err(|e| ipc("cannot receive a control response")(&e))?
            {
                let r = *r.payload();
                if r.status != RESP_OK {
                    return Err(ClientError::Refused {
                        status: r.status,
                        message: r.message(),
                    });
                }
                if let Some(t) = take(r) {
                    return Ok(t);
                }
            }
            if start.elapsed() > timeout {
                return Err(ClientError::Timeout {
                    what,
                    after: timeout,
                });
            }
            // The server let the request go unanswered (it ended), or it
            // was killed with the request in its queue.
            if !connected {
                return Err(self.gone());
            }
            if check.gone(start.elapsed(), || self.server_alive()) {
                return Err(self.gone());
            }
            if self.node.wait(Duration::from_micros(50)).is_err() {
                return Err(ClientError::Interrupted);
            }
        }
    }

    /// Sends a command without data.
    pub fn command(&self, command: u32) -> Result<ControlResponse, ClientError> {
        self.request(
            ControlRequest {
                command,
                ..Default::default()
            },
            CONTROL_TIMEOUT,
        )
    }

    pub fn info(&self) -> Result<ControlResponse, ClientError> {
        self.command(CMD_INFO)
    }
    pub fn pause(&self) -> Result<ControlResponse, ClientError> {
        self.command(CMD_PAUSE)
    }
    pub fn resume(&self) -> Result<ControlResponse, ClientError> {
        self.command(CMD_RESUME)
    }
    pub fn reset(&self) -> Result<ControlResponse, ClientError> {
        self.command(CMD_RESET)
    }
    pub fn snapshot(&self) -> Result<ControlResponse, ClientError> {
        self.command(CMD_SNAPSHOT)
    }
    pub fn shutdown(&self) -> Result<ControlResponse, ClientError> {
        self.command(CMD_SHUTDOWN)
    }
    /// The scene as the server runs it (TOML), streamed in chunks of
    /// `MESSAGE_LEN` bytes, `SCENE_CHUNKS_PER_REQUEST` per request.
    pub fn scene_toml(&self) -> Result<String, ClientError> {
        let mut bytes = Vec::new();
        loop {
            let req = ControlRequest {
                command: CMD_SCENE,
                count: bytes.len() as u64,
                ..Default::default()
            };
            let mut chunks = 0;
            let total = self.exchange(req, CONTROL_TIMEOUT, "scene from the server", |r| {
                // Chunks are cut at byte boundaries (a UTF-8 character may
                // span two): join the bytes, then decode.
                let total = r.value as usize;
                let take = total.saturating_sub(bytes.len()).min(MESSAGE_LEN);
                bytes.extend_from_slice(&r.message[..take]);
                chunks += 1;
                (bytes.len() >= total || chunks == SCENE_CHUNKS_PER_REQUEST).then_some(total)
            })?;
            if bytes.len() >= total {
                break;
            }
        }
        String::from_utf8(bytes).map_err(|e| ClientError::Ipc {
            what: "the scene is not UTF-8".into(),
            detail: e.to_string(),
        })
    }

    /// Takes `n` steps, then pauses.
    pub fn step(&self, n: u64) -> Result<ControlResponse, ClientError> {
        self.request(
            ControlRequest {
                command: CMD_STEP,
                count: n,
                ..Default::default()
            },
            CONTROL_TIMEOUT,
        )
    }
    pub fn restore(&self, snapshot: u64) -> Result<ControlResponse, ClientError> {
        self.request(
            ControlRequest {
                command: CMD_RESTORE,
                count: snapshot,
                ..Default::default()
            },
            CONTROL_TIMEOUT,
        )
    }
}

/// A state message in shared memory: its header and payload words.
type StateSample = iceoryx2::sample::Sample<ipc::Service, [u64], StateHeader>;

/// The state subscription with its wake-up event.
struct StateReader {
    name: String,
    service: iceoryx2::service::port_factory::publish_subscribe::PortFactory<
        ipc::Service,
        [u64],
        StateHeader,
    >,
    sub: Subscriber<ipc::Service, [u64], StateHeader>,
    /// None for a polling reader: the server's event then has one listener
    /// less to notify every step.
    ready: Option<Listener<ipc::Service>>,
}

impl StateReader {
    fn open(
        node: &Node<ipc::Service>,
        name: &str,
        buffer: usize,
        wake: bool,
    ) -> Result<Self, ClientError> {
        Self::open_stream(
            node,
            name,
            buffer,
            wake,
            (services::state(name), services::state_ready(name)),
        )
    }

    /// Subscribes to the state stream `(service, event)` of server `name`:
    /// every frame, or the decimated stream. The buffer is cut to the
    /// largest the server allows for its scene's frame size
    /// (`services::state_buffer`).
    fn open_stream(
        node: &Node<ipc::Service>,
        name: &str,
        buffer: usize,
        wake: bool,
        (state, ready): (String, String),
    ) -> Result<Self, ClientError> {
        let service = node
            .service_builder(&service_name(&state)?)
            .publish_subscribe::<[u64]>()
            .user_header::<StateHeader>()
            .open()
            .map_err(|e| missing(name, &state, e))?;
        let most = service.static_config().subscriber_max_buffer_size();
        let sub = service
            .subscriber_builder()
            .buffer_size(buffer.clamp(1, most.max(1)))
            .create()
            .map_err(|e| ipc("cannot subscribe to the state")(&e))?;
        let ready = if wake {
            Some(
                node.service_builder(&service_name(&ready)?)
                    .event()
                    .open()
                    .map_err(|e| missing(name, &ready, e))?
                    .listener_builder()
                    .create()
                    .map_err(|e| ipc("cannot listen for state frames")(&e))?,
            )
        } else {
            None
        };
        Ok(StateReader {
            name: name.into(),
            service,
            sub,
            ready,
        })
    }

    /// Whether the state has a publisher whose node lives: a server that
    /// ends removes its publisher; a killed one leaves it behind a dead
    /// node.
    fn server_alive(&self) -> bool {
        let mut node = None;
        self.service.dynamic_config().list_publishers(|p| {
            node = Some(p.node_id.value());
            CallbackProgression::Stop
        });
        port_alive(node)
    }

    /// The newest frame in the buffer, if any (older ones are dropped
    /// unread).
    fn latest(&self) -> Result<Option<StateFrame>, ClientError> {
        match self.receive(true)? {
            Some(s) => StateFrame::decode(s.user_header(), s.payload())
                .map(Some)
                .map_err(ClientError::BadFrame),
            None => Ok(None),
        }
    }

    /// The next sample in the buffer, or with `newest` the newest one (the
    /// older ones dropped unread), read in place in shared memory.
    fn receive(&self, newest: bool) -> Result<Option<StateSample>, ClientError> {
        let mut got = None;
        while let Some(s) = self
            .sub
            .receive()
            .map_err(|e| ipc("cannot receive the state")(&e))?
        {
            got = Some(s);
            if !newest {
                break;
            }
        }
        Ok(got)
    }

    /// Waits for a frame that `accept` takes, in the given mode.
    fn wait(
        &self,
        node: &Node<ipc::Service>,
        mode: WaitMode,
        timeout: Duration,
        newest: bool,
        accept: impl FnMut(&StateHeader) -> bool,
    ) -> Result<StateFrame, ClientError> {
        let mut out = StateFrame::default();
        self.wait_with(node, mode, timeout, newest, accept, &mut out)?;
        Ok(out)
    }

    /// Waits for a frame whose header `accept` takes, in the given mode,
    /// and reads it into `into` (whose buffers are reused).
    fn wait_with(
        &self,
        node: &Node<ipc::Service>,
        mode: WaitMode,
        timeout: Duration,
        newest: bool,
        mut accept: impl FnMut(&StateHeader) -> bool,
        into: &mut StateFrame,
    ) -> Result<(), ClientError> {
        let start = Instant::now();
        let spin_for = match mode {
            WaitMode::Spin => timeout,
            WaitMode::Block => Duration::ZERO,
            WaitMode::Hybrid => HYBRID_SPIN.min(timeout),
        };
        let mut spins = 0u32;
        let mut check = GoneCheck::new();
        loop {
            if let Some(sample) = self.receive(newest)? {
                if accept(sample.user_header()) {
                    return into
                        .read(sample.user_header(), sample.payload())
                        .map_err(ClientError::BadFrame);
                }
                continue;
            }
            let elapsed = start.elapsed();
            if elapsed >= timeout {
                return Err(ClientError::Timeout {
                    what: "state frame",
                    after: timeout,
                });
            }
            // Frames the server sent before it went are read first.
            if check.gone(elapsed, || {
                self.server_alive() || self.sub.has_samples().unwrap_or(false)
            }) {
                return Err(ClientError::ServerGone {
                    name: self.name.clone(),
                });
            }
            if elapsed < spin_for {
                spins = spins.wrapping_add(1);
                std::hint::spin_loop();
                // A termination request must still end a spinning wait.
                if spins.is_multiple_of(4096)
                    && iceoryx2_bb_posix::signal::SignalHandler::termination_requested()
                {
                    return Err(ClientError::Interrupted);
                }
                continue;
            }
            // NOTE: the frame is published before the event, so a frame
            // that arrived after the poll above leaves the event pending
            // and this wait returns at once.
            let left = timeout - elapsed;
            match &self.ready {
                Some(ready) => match ready.timed_wait(|_| {}, left.min(Duration::from_millis(100)))
                {
                    // A signal ends the wait; termination is checked below.
                    Ok(_) | Err(iceoryx2::port::listener::ListenerWaitError::InterruptSignal) => {}
                    Err(e) => return Err(ipc("cannot wait for the state event")(&e)),
                },
                // A polling reader sleeps a little between polls.
                None => {
                    if node.wait(left.min(Duration::from_millis(1))).is_err() {
                        return Err(ClientError::Interrupted);
                    }
                }
            }
            if node.wait(Duration::ZERO).is_err() {
                return Err(ClientError::Interrupted);
            }
        }
    }
}

/// A controller in the lockstep.
pub struct Controller {
    conn: Connection,
    id: u32,
    reader: StateReader,
    input: Publisher<ipc::Service, [u64], InputHeader>,
    wait: WaitMode,
    /// The step answered last, so that a frame published again for the same
    /// step (after a join or a pause) is not answered twice.
    answered: Option<u64>,
    /// The sequence of the frame answered last (a failed step's frame asks
    /// again only if it is newer).
    answered_sequence: u64,
    /// The last frame received (valid once `has_last`), read into the
    /// same buffers each step.
    last: StateFrame,
    has_last: bool,
    sequence: u64,
    info: ControlResponse,
    /// `leave` was called (a drop then sends no second one).
    left: bool,
}

impl Controller {
    /// Connects to server `name` and joins its lockstep.
    pub fn join(name: &str, wait: WaitMode) -> Result<Controller, ClientError> {
        let conn = Connection::connect(name)?;
        // Subscribe before joining: the server republishes the state when a
        // controller joins, and the history keeps the last frame anyway.
        // A spinning controller polls: without a listener, the server's
        // state event has nobody to wake for it (a system call saved per
        // step when every reader polls).
        let reader = StateReader::open(&conn.node, name, 2, wait != WaitMode::Spin)?;
        let info = conn.info()?;
        // Room for a torque and a motor target on every joint and a few
        // impulses; a larger input grows the publisher's memory
        // (power-of-two strategy), once.
        let joints = info.joint_count as usize;
        let words = input_words(joints, 8, joints);
        let input = conn
            .node
            .service_builder(&service_name(&services::input(name))?)
            .publish_subscribe::<[u64]>()
            .user_header::<InputHeader>()
            .open()
            .map_err(|e| missing(name, &services::input(name), e))?
            .publisher_builder()
            .initial_max_slice_len(words.max(1))
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(|e| ipc("cannot publish inputs")(&e))?;
        let info = conn.request(
            ControlRequest {
                command: CMD_JOIN,
                role: ROLE_CONTROLLER,
                ..Default::default()
            },
            CONTROL_TIMEOUT,
        )?;
        Ok(Controller {
            id: info.controller_id,
            conn,
            reader,
            input,
            wait,
            answered: None,
            answered_sequence: 0,
            last: StateFrame::default(),
            has_last: false,
            sequence: 0,
            info,
            left: false,
        })
    }

    pub fn id(&self) -> u32 {
        self.id
    }

    /// The join answer: step size, counts, model hash.
    pub fn info(&self) -> &ControlResponse {
        &self.info
    }

    pub fn connection(&self) -> &Connection {
        &self.conn
    }

    /// The last frame received.
    pub fn last_state(&self) -> Option<&StateFrame> {
        self.has_last.then_some(&self.last)
    }

    /// Waits for the state of a step not yet answered. A frame with
    /// `STATUS_SHUTDOWN` ends the session with [`ClientError::Shutdown`].
    pub fn next_state(&mut self, timeout: Duration) -> Result<StateFrame, ClientError> {
        self.next_state_ref(timeout).cloned()
    }

    /// [`Controller::next_state`] without the copy: the frame stays in the
    /// controller (also [`Controller::last_state`]) until the next call,
    /// read into the same buffers every step.
    pub fn next_state_ref(&mut self, timeout: Duration) -> Result<&StateFrame, ClientError> {
        let answered = self.answered;
        let answered_sequence = self.answered_sequence;
        let id = self.id;
        let Controller {
            reader,
            conn,
            wait,
            last,
            ..
        } = self;
        reader.wait_with(
            &conn.node,
            *wait,
            timeout,
            true,
            // A frame that does not list this controller was published
            // before the join took effect (it may still sit in the buffer):
            // the server does not wait for this controller's answer to it.
            //
            // A frame of a failed step asks for a new answer to the same
            // step when its slot lacks SLOT_ANSWERED (protocol.md).
            |f| {
                let Some(slot) = f.controller(id) else {
                    return f.status & STATUS_SHUTDOWN != 0;
                };
                let again = f.status & STATUS_SOLVER_FAILED != 0
                    && slot.flags & SLOT_ANSWERED == 0
                    && f.sequence > answered_sequence;
                f.status & STATUS_SHUTDOWN != 0
                    || (f.status & STATUS_WAITING == 0 && (Some(f.step) != answered || again))
            },
            last,
        )?;
        self.has_last = true;
        if self.last.status & STATUS_SHUTDOWN != 0 {
            return Err(ClientError::Shutdown);
        }
        Ok(&self.last)
    }

    /// Sends `input` as the answer to the last state received.
    pub fn send(&mut self, mut input: InputFrame) -> Result<(), ClientError> {
        self.send_ref(&mut input)
    }

    /// [`Controller::send`] of a frame the caller keeps (and reuses).
    pub fn send_ref(&mut self, input: &mut InputFrame) -> Result<(), ClientError> {
        let step = if self.has_last { self.last.step } else { 0 };
        input.version = PROTOCOL_VERSION;
        input.controller_id = self.id;
        input.step = step;
        self.sequence += 1;
        input.sequence = self.sequence;
        self.send_raw(input)?;
        self.answered = Some(step);
        self.answered_sequence = if self.has_last { self.last.sequence } else { 0 };
        Ok(())
    }

    /// Sends a frame as it is (tests use it to send bad inputs).
    pub fn send_raw(&mut self, input: &InputFrame) -> Result<(), ClientError> {
        self.send_words(input.header(), input.words(), |w| input.encode(w))
    }

    /// Sends a header and `len` words that `encode` writes, as they are:
    /// tests and the fuzzer use it for headers whose counts do not match.
    pub fn send_words(
        &mut self,
        header: InputHeader,
        len: usize,
        encode: impl FnOnce(&mut UninitWords<'_>),
    ) -> Result<(), ClientError> {
        send_words(&self.input, header, len, encode)
            .map_err(|e| ipc("cannot send the input")(&e))?;
        // A spinning server needs no wake-up.
        if !self.has_last || self.last.status & STATUS_SERVER_SPINS == 0 {
            let _ = self.conn.wake.notify();
        }
        Ok(())
    }

    /// Leaves the lockstep; the server removes this controller's torques.
    /// A controller dropped without it leaves too (issue 15, defect 5).
    pub fn leave(mut self) -> Result<(), ClientError> {
        self.left = true;
        self.request_leave(CONTROL_TIMEOUT)
    }

    fn request_leave(&self, timeout: Duration) -> Result<(), ClientError> {
        self.conn
            .request(
                ControlRequest {
                    command: CMD_LEAVE,
                    controller_id: self.id,
                    ..Default::default()
                },
                timeout,
            )
            .map(|_| ())
    }
}

/// How long a dropped controller waits for the server to take its leave:
/// the server answers between steps, and a server that is gone must not
/// hold up the drop for long.
const LEAVE_ON_DROP: Duration = Duration::from_millis(500);

impl Drop for Controller {
    fn drop(&mut self) {
        if !self.left {
            // A server that is gone or already let this controller go
            // has nothing to answer: the error changes nothing here.
            let _ = self.request_leave(LEAVE_ON_DROP);
        }
    }
}

/// A reader of the state outside the lockstep.
pub struct Monitor {
    node: Node<ipc::Service>,
    reader: StateReader,
}

impl Monitor {
    /// Subscribes to server `name` with room for `buffer` frames (1 for a
    /// live view; more for a recorder that wants every frame).
    pub fn open(name: &str, buffer: usize) -> Result<Monitor, ClientError> {
        Monitor::create(name, buffer, true)
    }

    /// A monitor that only polls ([`Monitor::latest`]): it adds nothing to
    /// the server's step, not even an event to deliver. `next` still works,
    /// sleeping a millisecond between polls.
    pub fn polling(name: &str) -> Result<Monitor, ClientError> {
        Monitor::create(name, 1, false)
    }

    /// Subscribes to the decimated stream of a server started with
    /// `--publish-every N`: every N-th step's frame and the last. A server
    /// without it has no such stream ([`ClientError::NoServer`] names it).
    pub fn open_every(name: &str, buffer: usize) -> Result<Monitor, ClientError> {
        let node = NodeBuilder::new()
            .create::<ipc::Service>()
            .map_err(|e| ipc("cannot create an iceoryx2 node")(&e))?;
        let stream = (
            services::state_every(name),
            services::state_every_ready(name),
        );
        let reader = StateReader::open_stream(&node, name, buffer, true, stream)?;
        Ok(Monitor { node, reader })
    }

    fn create(name: &str, buffer: usize, wake: bool) -> Result<Monitor, ClientError> {
        let node = NodeBuilder::new()
            .create::<ipc::Service>()
            .map_err(|e| ipc("cannot create an iceoryx2 node")(&e))?;
        let exists = ipc::Service::does_exist(
            &service_name(&services::state(name))?,
            Config::global_config(),
            MessagingPattern::PublishSubscribe,
        )
        .map_err(|e| ipc("cannot look up the state service")(&e))?;
        if !exists {
            return Err(ClientError::NoServer { name: name.into() });
        }
        let reader = StateReader::open(&node, name, buffer, wake)?;
        Ok(Monitor { node, reader })
    }

    /// The newest frame, without waiting.
    pub fn latest(&self) -> Result<Option<StateFrame>, ClientError> {
        self.reader.latest()
    }

    /// The next frame in order (blocking up to `timeout`).
    pub fn next(&self, timeout: Duration) -> Result<StateFrame, ClientError> {
        self.reader
            .wait(&self.node, WaitMode::Block, timeout, false, |_| true)
    }

    pub fn node(&self) -> &Node<ipc::Service> {
        &self.node
    }
}

/// Calls `connect` again while it finds no server, for up to `patience`:
/// for a client started beside a server that is still creating its
/// services. Other errors end it at once.
/// Joins server `name` as a controller and answers each state frame
/// with the input `answer` makes of it, until the server shuts down;
/// returns how many steps it answered. The lockstep loop of the example
/// controllers (`arm`, `push`).
pub fn answer_each(
    name: &str,
    timeout: Duration,
    mut answer: impl FnMut(&StateFrame) -> InputFrame,
) -> Result<u64, ClientError> {
    let mut c = Controller::join(name, WaitMode::Block)?;
    let mut steps = 0;
    loop {
        let frame = match c.next_state(timeout) {
            Ok(f) => f,
            Err(ClientError::Shutdown) => return Ok(steps),
            Err(e) => return Err(e),
        };
        c.send(answer(&frame))?;
        steps += 1;
    }
}

pub fn when_up<T>(
    patience: Duration,
    mut connect: impl FnMut() -> Result<T, ClientError>,
) -> Result<T, ClientError> {
    let start = Instant::now();
    loop {
        match connect() {
            Err(ClientError::NoServer { .. }) if start.elapsed() < patience => {
                std::thread::sleep(Duration::from_millis(5))
            }
            other => return other,
        }
    }
}

/// The servers running on this machine: the names of their control
/// services whose owner is alive.
pub fn list_servers() -> Result<Vec<String>, ClientError> {
    let mut names = Vec::new();
    ipc::Service::list(Config::global_config(), |details| {
        let s = details.static_details.name().to_string();
        if let Some(n) = services::server_of(&s) {
            names.push(n.to_string());
        }
        CallbackProgression::Continue
    })
    .map_err(|e| ipc("cannot list the iceoryx2 services")(&e))?;
    names.sort();
    names.dedup();
    Ok(names)
}

/// Whether the node with this id is alive: `Some(true)` alive,
/// `Some(false)` dead or gone, `None` when it cannot be told.
pub fn node_alive(id: u128) -> Option<bool> {
    let mut found = None;
    let listed = Node::<ipc::Service>::list(Config::global_config(), |state| {
        if state.node_id().value() == id {
            found = Some(match &state {
                NodeState::Alive(_) => Some(true),
                NodeState::Dead(_) => Some(false),
                NodeState::Inaccessible(_) | NodeState::Undefined(_) => None,
            });
            return CallbackProgression::Stop;
        }
        CallbackProgression::Continue
    });
    match (listed, found) {
        (Err(_), _) => None,
        (Ok(()), None) => Some(false),
        (Ok(()), Some(s)) => s,
    }
}

/// The pid of a node, for messages.
pub fn node_pid(id: u128) -> Option<u32> {
    let mut pid = None;
    let _ = Node::<ipc::Service>::list(Config::global_config(), |state| {
        if state.node_id().value() == id {
            if let NodeState::Alive(v) = &state {
                pid = v.details().as_ref().map(|d| d.process_id().value() as u32);
            }
            return CallbackProgression::Stop;
        }
        CallbackProgression::Continue
    });
    pid
}

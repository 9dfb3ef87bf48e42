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
pub mod sweep;
pub mod view;

mod connection;
mod controller;
pub mod domain;
mod monitor;
mod names;
mod reader;
mod spin;

pub use connection::{Connection, CONTROL_TIMEOUT};
pub use controller::Controller;
pub use monitor::Monitor;
pub use names::{Frame, Names};
use reader::StateReader;
pub use spin::{SpinRule, HYBRID_SPIN};

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
    /// Spin while spinning pays, then block ([`SpinRule`]): at most
    /// twice the recent waits and [`HYBRID_SPIN`], and not at all for a
    /// while after a spin was preempted (processes outnumber cores).
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
    /// A body or joint name the scene does not have (`Names`).
    UnknownName {
        kind: &'static str,
        name: String,
        known: Vec<String>,
    },
    /// The server's scene did not read back.
    BadScene(String),
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
                "no cosim server named '{name}' is running (start one that waits for a controller: `cosim-server serve --name {name} --controllers 1`; `cosim list` shows the running ones)"
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
            ClientError::UnknownName { kind, name, known } => {
                write!(f, "no {kind} named {name:?} in the scene (its {kind} names: {known:?})")
            }
            ClientError::BadScene(e) => write!(f, "the server's scene: {e}"),
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
    ipc::Service::list(domain::config()?, |details| {
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
    let listed = Node::<ipc::Service>::list(domain::config().ok()?, |state| {
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
    let _ = Node::<ipc::Service>::list(domain::config().ok()?, |state| {
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

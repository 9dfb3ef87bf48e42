//! The server's iceoryx2 services, all created here from the one
//! definition in `cosim_shared::wire::services`, so that their limits are
//! the server's to fix.

use cosim_shared::wire::{
    send_used, services, ControlRequest, ControlResponse, InputFrame, StateFrame, UsedEntries,
    Written,
};
use iceoryx2::active_request::ActiveRequest;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::server::Server;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use std::fmt;
use std::time::Duration;

/// Why the services could not be set up.
#[derive(Debug, Clone, PartialEq)]
pub enum ServiceError {
    /// Another live server has this name.
    AlreadyRunning { name: String, pid: Option<u64> },
    /// iceoryx2 refused, with the service named.
    Ipc { what: String, detail: String },
}

impl fmt::Display for ServiceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ServiceError::AlreadyRunning { name, pid } => {
                write!(f, "a server named '{name}' is already running")?;
                if let Some(p) = pid {
                    write!(f, " (pid {p})")?;
                }
                write!(
                    f,
                    "; choose another --name or stop it with `cosim --name {name} shutdown`"
                )
            }
            ServiceError::Ipc { what, detail } => write!(f, "{what}: {detail}"),
        }
    }
}

pub type Request = ActiveRequest<ipc::Service, ControlRequest, (), ControlResponse, ()>;

pub struct Services {
    pub node: Node<ipc::Service>,
    pub state: Publisher<ipc::Service, StateFrame, ()>,
    pub input: Subscriber<ipc::Service, InputFrame, ()>,
    pub control: Server<ipc::Service, ControlRequest, (), ControlResponse, ()>,
    pub state_ready: Notifier<ipc::Service>,
    pub wake: Listener<ipc::Service>,
    /// What earlier frames left in the state publisher's samples.
    written: Written,
}

fn name(s: &str) -> Result<ServiceName, ServiceError> {
    s.try_into().map_err(|e| ServiceError::Ipc {
        what: format!("'{s}' is not a valid service name"),
        detail: format!("{e:?}"),
    })
}

fn err(what: String) -> impl FnOnce(&dyn fmt::Debug) -> ServiceError {
    move |e| ServiceError::Ipc {
        what,
        detail: format!("{e:?}"),
    }
}

impl Services {
    /// Creates every service of server `server`. Stale resources of dead
    /// processes are removed first, so that a server killed without
    /// cleanup does not block its name.
    pub fn create(server: &str) -> Result<Services, ServiceError> {
        let node_name: NodeName = format!("cosim-server-{server}")
            .as_str()
            .try_into()
            .map_err(|e| err("bad node name".into())(&e))?;
        let node = NodeBuilder::new()
            .name(&node_name)
            .create::<ipc::Service>()
            .map_err(|e| err("cannot create the iceoryx2 node".into())(&e))?;
        let cleaned = node.try_cleanup_dead_nodes();
        if cleaned.cleanups > 0 {
            tracing::info!(
                "removed the resources of {} dead processes",
                cleaned.cleanups
            );
        }

        // The control service first: if it exists, a live server owns it.
        let control = node
            .service_builder(&name(&services::control(server))?)
            .request_response::<ControlRequest, ControlResponse>()
            .max_clients(services::MAX_CONTROL_CLIENTS)
            .max_servers(1)
            .max_active_requests_per_client(4)
            .max_response_buffer_size(256)
            .max_nodes(services::MAX_CONTROL_CLIENTS + 2)
            .create();
        let control = match control {
            Ok(c) => c,
            Err(iceoryx2::service::builder::request_response::RequestResponseCreateError::AlreadyExists) => {
                let pid = cosim_client::Connection::connect(server)
                    .and_then(|c| c.info())
                    .ok()
                    .map(|r| r.pid);
                return Err(ServiceError::AlreadyRunning {
                    name: server.into(),
                    pid,
                });
            }
            Err(e) => return Err(err(format!("cannot create {}", services::control(server)))(&e)),
        };
        let control = control
            .server_builder()
            .create()
            .map_err(|e| err("cannot create the control server".into())(&e))?;

        // NOTE: overflow stays enabled on the state: a reader that stops
        // reading loses old frames instead of blocking the server.
        let state = node
            .service_builder(&name(&services::state(server))?)
            .publish_subscribe::<StateFrame>()
            .enable_safe_overflow(true)
            .history_size(1)
            .subscriber_max_buffer_size(services::MAX_STATE_BUFFER)
            .subscriber_max_borrowed_samples(2)
            .max_subscribers(services::MAX_STATE_SUBSCRIBERS)
            .max_publishers(1)
            .max_nodes(services::MAX_STATE_SUBSCRIBERS + 2)
            .create()
            .map_err(|e| err(format!("cannot create {}", services::state(server)))(&e))?
            .publisher_builder()
            .create()
            .map_err(|e| err("cannot publish the state".into())(&e))?;
        let input = node
            .service_builder(&name(&services::input(server))?)
            .publish_subscribe::<InputFrame>()
            .enable_safe_overflow(true)
            .subscriber_max_buffer_size(services::INPUT_BUFFER)
            .max_subscribers(2)
            .max_publishers(services::MAX_INPUT_PUBLISHERS)
            .max_nodes(services::MAX_INPUT_PUBLISHERS + 2)
            .create()
            .map_err(|e| err(format!("cannot create {}", services::input(server)))(&e))?
            .subscriber_builder()
            .buffer_size(services::INPUT_BUFFER)
            .create()
            .map_err(|e| err("cannot subscribe to the inputs".into())(&e))?;
        let event = |s: String| -> Result<_, ServiceError> {
            node.service_builder(&name(&s)?)
                .event()
                .max_listeners(services::MAX_EVENT_PORTS)
                .max_notifiers(services::MAX_EVENT_PORTS)
                .max_nodes(services::MAX_EVENT_PORTS + 2)
                .create()
                .map_err(|e| err(format!("cannot create {s}"))(&e))
        };
        let state_ready = event(services::state_ready(server))?
            .notifier_builder()
            .create()
            .map_err(|e| err("cannot create the state notifier".into())(&e))?;
        let wake = event(services::wake(server))?
            .listener_builder()
            .create()
            .map_err(|e| err("cannot create the wake-up listener".into())(&e))?;
        Ok(Services {
            node,
            state,
            input,
            control,
            state_ready,
            wake,
            written: Written::default(),
        })
    }

    /// Publishes a frame and wakes the blocked readers.
    pub fn publish(&mut self, frame: &StateFrame) -> Result<(), ServiceError> {
        send_used(&self.state, frame, &mut self.written)
            .map_err(|e| err("cannot publish the state".into())(&e))?;
        // NOTE: after the send: a reader that polled before the frame
        // landed finds the event pending.
        self.state_ready
            .notify()
            .map_err(|e| err("cannot notify the state readers".into())(&e))?;
        Ok(())
    }

    /// The next input in the buffer.
    pub fn receive_input(&self) -> Result<Option<InputFrame>, ServiceError> {
        Ok(self
            .input
            .receive()
            .map_err(|e| err("cannot receive inputs".into())(&e))?
            .map(|s| s.payload().used_copy()))
    }

    /// The next control request.
    pub fn receive_request(&self) -> Result<Option<Request>, ServiceError> {
        self.control
            .receive()
            .map_err(|e| err("cannot receive control requests".into())(&e))
    }

    /// Sleeps until a client notifies (an input or a request) or `timeout`.
    pub fn block(&self, timeout: Duration) -> Result<(), ServiceError> {
        match self.wake.timed_wait(|_| {}, timeout) {
            // Any signal ends the wait (SIGCHLD of a controller the demo
            // started, too): the loop checks for termination itself.
            Ok(_) | Err(iceoryx2::port::listener::ListenerWaitError::InterruptSignal) => Ok(()),
            Err(e) => Err(err("cannot wait for the wake-up event".into())(&e)),
        }
    }
}

//! The server's iceoryx2 services, all created here from the one
//! definition in `cosim_shared::wire::services`, so that their limits are
//! the server's to fix.

use cosim_shared::wire::{
    send_words, services, ControlRequest, ControlResponse, InputFrame, InputHeader, StateFrame,
    StateHeader, WireError,
};
use iceoryx2::active_request::ActiveRequest;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::server::Server;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::server::ServerCreateError;
use iceoryx2::service::Service;
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

/// An input read: the publisher that sent it, and whether its words
/// matched its header.
pub type Received = (u128, Result<(), WireError>);

/// A state stream's publisher: a [`StateHeader`] and the frame's words.
type StatePublisher<S> = Publisher<S, [u64], StateHeader>;

/// The decimated stream's publisher and its event.
type Decimated<S> = (StatePublisher<S>, Notifier<S>);

pub type Request<S = ipc::Service> = ActiveRequest<S, ControlRequest, (), ControlResponse, ()>;
type InputService<S> =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<S, [u64], InputHeader>;
type ControlService<S> = iceoryx2::service::port_factory::request_response::PortFactory<
    S,
    ControlRequest,
    (),
    ControlResponse,
    (),
>;

/// The services, on iceoryx2's `ipc` ports for the server;
/// `cosim-link`'s mirror of them takes `ipc_threadsafe` ports (the same
/// shared memory, locked for use from Zenoh's threads).
pub struct Services<S: Service = ipc::Service> {
    pub node: Node<S>,
    pub state: StatePublisher<S>,
    pub input: Subscriber<S, [u64], InputHeader>,
    pub control: Server<S, ControlRequest, (), ControlResponse, ()>,
    pub state_ready: Notifier<S>,
    pub wake: Listener<S>,
    /// The decimated stream, with `--publish-every N`.
    every: Option<Decimated<S>>,
    /// The services whose ports tell who sent an input or a request.
    input_service: InputService<S>,
    control_service: ControlService<S>,
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

impl<S: Service> Services<S> {
    /// Creates every service of server `server`, whose state frames hold
    /// at most `frame_words` payload words. Stale resources of dead
    /// processes are removed first, so that a server killed without
    /// cleanup does not block its name.
    pub fn create(
        server: &str,
        decimated: bool,
        frame_words: usize,
    ) -> Result<Services<S>, ServiceError> {
        let node_name: NodeName = format!("cosim-server-{server}")
            .as_str()
            .try_into()
            .map_err(|e| err("bad node name".into())(&e))?;
        let node = cosim_client::domain::node()
            .map_err(|e| err("cannot read the domain".into())(&e))?
            .name(&node_name)
            .create::<S>()
            .map_err(|e| err("cannot create the iceoryx2 node".into())(&e))?;
        let cleaned = node.try_cleanup_dead_nodes();
        if cleaned.cleanups > 0 {
            tracing::info!(
                "removed the resources of {} dead processes",
                cleaned.cleanups
            );
        }

        // The control service first. It outlives a killed server while any
        // client of it is attached (issue 15, defect 2), so it is opened
        // when it exists: a live server is one that still has its server
        // port after the dead nodes' ports were removed above.
        let control_service = node
            .service_builder(&name(&services::control(server))?)
            .request_response::<ControlRequest, ControlResponse>()
            .max_clients(services::MAX_CONTROL_CLIENTS)
            .max_servers(1)
            .max_active_requests_per_client(4)
            .max_response_buffer_size(256)
            .max_nodes(services::MAX_CONTROL_CLIENTS + 2)
            .open_or_create()
            .map_err(|e| {
                err(format!(
                    "cannot open or create {}",
                    services::control(server)
                ))(&e)
            })?;
        let running = || {
            let pid = cosim_client::Connection::connect(server)
                .and_then(|c| c.info())
                .ok()
                .map(|r| r.pid);
            ServiceError::AlreadyRunning {
                name: server.into(),
                pid,
            }
        };
        if control_service.dynamic_config().number_of_servers() > 0 {
            return Err(running());
        }
        // `max_servers(1)`: of two servers starting at once, one gets here.
        let control = match control_service.server_builder().create() {
            Ok(c) => c,
            Err(ServerCreateError::ExceedsMaxSupportedServers) => return Err(running()),
            Err(e) => return Err(err("cannot create the control server".into())(&e)),
        };

        // NOTE: overflow stays enabled on the state: a reader that stops
        // reading loses old frames instead of blocking the server.
        // The publisher's memory holds every subscriber's whole buffer of
        // frames of the scene's largest size, allocated once (the static
        // strategy): the buffer shrinks for big scenes (`state_buffer`).
        let state_stream = |service: String| -> Result<StatePublisher<S>, ServiceError> {
            node.service_builder(&name(&service)?)
                .publish_subscribe::<[u64]>()
                .user_header::<StateHeader>()
                .enable_safe_overflow(true)
                .history_size(1)
                .subscriber_max_buffer_size(services::state_buffer(frame_words))
                .subscriber_max_borrowed_samples(2)
                .max_subscribers(services::MAX_STATE_SUBSCRIBERS)
                .max_publishers(1)
                .max_nodes(services::MAX_STATE_SUBSCRIBERS + 2)
                .open_or_create()
                .map_err(|e| err(format!("cannot create {service}"))(&e))?
                .publisher_builder()
                .initial_max_slice_len(frame_words.max(1))
                .create()
                .map_err(|e| err(format!("cannot publish {service}"))(&e))
        };
        let state = state_stream(services::state(server))?;
        let input_service = node
            .service_builder(&name(&services::input(server))?)
            .publish_subscribe::<[u64]>()
            .user_header::<InputHeader>()
            .enable_safe_overflow(true)
            .subscriber_max_buffer_size(services::INPUT_BUFFER)
            .max_subscribers(2)
            .max_publishers(services::MAX_INPUT_PUBLISHERS)
            .max_nodes(services::MAX_INPUT_PUBLISHERS + 2)
            .open_or_create()
            .map_err(|e| err(format!("cannot create {}", services::input(server)))(&e))?;
        let input = input_service
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
                .open_or_create()
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
        let every = if decimated {
            let publisher = state_stream(services::state_every(server))?;
            let ready = event(services::state_every_ready(server))?
                .notifier_builder()
                .create()
                .map_err(|e| err("cannot create the decimated stream's notifier".into())(&e))?;
            Some((publisher, ready))
        } else {
            None
        };
        Ok(Services {
            every,
            node,
            state,
            input,
            control,
            state_ready,
            wake,
            input_service,
            control_service,
        })
    }

    /// Publishes a frame and wakes the blocked readers.
    pub fn publish(&mut self, frame: &StateFrame) -> Result<(), ServiceError> {
        send(&self.state, frame).map_err(|e| err("cannot publish the state".into())(&e))?;
        // NOTE: after the send: a reader that polled before the frame
        // landed finds the event pending.
        self.state_ready
            .notify()
            .map_err(|e| err("cannot notify the state readers".into())(&e))?;
        Ok(())
    }

    /// Publishes a frame on the decimated stream (when there is one) and
    /// wakes its readers.
    pub fn publish_every(&mut self, frame: &StateFrame) -> Result<(), ServiceError> {
        let Some((publisher, ready)) = self.every.as_mut() else {
            return Ok(());
        };
        send(publisher, frame).map_err(|e| err("cannot publish the decimated state".into())(&e))?;
        ready
            .notify()
            .map_err(|e| err("cannot notify the decimated stream's readers".into())(&e))?;
        Ok(())
    }

    /// Reads the next input in the buffer into `into`; returns the id of
    /// the publisher that sent it (iceoryx2 writes a sample's origin; a
    /// client cannot forge it) and whether its words matched its header's
    /// counts (when not, `into` has the header's fields and no entries).
    pub fn receive_input(&self, into: &mut InputFrame) -> Result<Option<Received>, ServiceError> {
        Ok(self
            .input
            .receive()
            .map_err(|e| err("cannot receive inputs".into())(&e))?
            .map(|s| {
                let read = into.read(s.user_header(), s.payload());
                (s.origin().value(), read)
            }))
    }

    /// The node of input publisher `publisher`, if it is connected.
    pub fn publisher_node(&self, publisher: u128) -> Option<u128> {
        let mut node = None;
        self.input_service.dynamic_config().list_publishers(|p| {
            if p.publisher_id.value() == publisher {
                node = Some(p.node_id.value());
                return CallbackProgression::Stop;
            }
            CallbackProgression::Continue
        });
        node
    }

    /// The process id of the node of input publisher `publisher`, from
    /// iceoryx2's node id (which holds its creator's pid), not from what
    /// any message claims.
    pub fn publisher_pid(&self, publisher: u128) -> Option<u64> {
        let mut pid = None;
        self.input_service.dynamic_config().list_publishers(|p| {
            if p.publisher_id.value() == publisher {
                pid = p.node_id.pid::<S>().ok().map(|x| x.value() as u64);
                return CallbackProgression::Stop;
            }
            CallbackProgression::Continue
        });
        pid
    }

    /// Whether input publisher `publisher` is still connected (a process
    /// that ends normally removes its ports as it exits).
    pub fn publisher_connected(&self, publisher: u128) -> bool {
        self.publisher_node(publisher).is_some()
    }

    /// The node that sent control request `req`, read from the control
    /// service's ports rather than from what the request claims.
    pub fn request_node(&self, req: &Request<S>) -> Option<u128> {
        self.request_origin(req).map(|(node, _)| node)
    }

    /// The node that sent control request `req` and its process id (from
    /// the node id); `None` when its client port is gone.
    pub fn request_origin(&self, req: &Request<S>) -> Option<(u128, Option<u64>)> {
        let client = req.origin();
        let mut found = None;
        self.control_service.dynamic_config().list_clients(|c| {
            if c.client_id == client {
                let pid = c.node_id.pid::<S>().ok().map(|x| x.value() as u64);
                found = Some((c.node_id.value(), pid));
                return CallbackProgression::Stop;
            }
            CallbackProgression::Continue
        });
        found
    }

    /// The nodes of every control client and input publisher, each once
    /// (`cosim-link`'s mirror tells a remote client gone by them).
    pub fn client_nodes(&self, out: &mut Vec<u128>) {
        out.clear();
        self.control_service.dynamic_config().list_clients(|c| {
            out.push(c.node_id.value());
            CallbackProgression::Continue
        });
        self.input_service.dynamic_config().list_publishers(|p| {
            out.push(p.node_id.value());
            CallbackProgression::Continue
        });
        out.sort_unstable();
        out.dedup();
    }

    /// The next control request.
    pub fn receive_request(&self) -> Result<Option<Request<S>>, ServiceError> {
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

/// The frame's header and words, written straight into the loaned sample.
fn send<S: Service>(
    publisher: &StatePublisher<S>,
    frame: &StateFrame,
) -> Result<usize, impl fmt::Debug> {
    send_words(publisher, frame.header(), frame.words(), |w| {
        frame.encode(w)
    })
}

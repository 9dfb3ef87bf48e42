//! `Connection`: the control service's client (join, leave, pause, resume,
//! step, reset, snapshot, restore, the scene), and the services it opens.

use crate::*;

/// A node and the control service of one server.
pub struct Connection {
    pub(crate) name: String,
    pub(crate) node: Node<ipc::Service>,
    pub(crate) control_service: iceoryx2::service::port_factory::request_response::PortFactory<
        ipc::Service,
        ControlRequest,
        (),
        ControlResponse,
        (),
    >,
    pub(crate) control: RrClient<ipc::Service, ControlRequest, (), ControlResponse, ()>,
    pub(crate) wake: Notifier<ipc::Service>,
}

/// Default time to wait for a control answer.
pub const CONTROL_TIMEOUT: Duration = Duration::from_secs(5);

impl Connection {
    /// Connects to the server `name`: fails with [`ClientError::NoServer`]
    /// when none runs.
    pub fn connect(name: &str) -> Result<Connection, ClientError> {
        let node = crate::domain::node()?
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
    /// [`ClientError::Refused`]. The version and node id are this
    /// connection's; `pid` 0 is this process's (another is sent as it is:
    /// the server trusts neither, see docs/protocol.md).
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
        if req.pid == 0 {
            req.pid = u64::from(std::process::id());
        }
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

    /// Sends `req` exactly as given and wakes the server; the caller reads
    /// the responses. A link (`cosim-link`) forwards another host's
    /// client's requests with it: the server binds what they do to this
    /// connection's node, one per remote client.
    pub fn forward(
        &self,
        req: ControlRequest,
    ) -> Result<
        iceoryx2::pending_response::PendingResponse<
            ipc::Service,
            ControlRequest,
            (),
            ControlResponse,
            (),
        >,
        ClientError,
    > {
        let pending = self
            .control
            .send_copy(req)
            .map_err(|e| ipc("cannot send a control request")(&e))?;
        self.wake_server();
        Ok(pending)
    }

    /// Wakes the server (it also polls): after an input or a request.
    pub fn wake_server(&self) {
        let _ = self.wake.notify();
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

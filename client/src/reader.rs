//! The state subscriber that controllers and monitors share: the newest
//! frame, read into reused buffers, and the waits (spin, block, hybrid)
//! that end in `ServerGone` when the server is.

use crate::*;

/// A state message in shared memory: its header and payload words.
type StateSample = iceoryx2::sample::Sample<ipc::Service, [u64], StateHeader>;

/// The state subscription with its wake-up event.
pub(crate) struct StateReader {
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
    /// The hybrid wait's rule, carried from wait to wait.
    spin: std::cell::Cell<crate::SpinRule>,
}

impl StateReader {
    pub(crate) fn open(
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
    pub(crate) fn open_stream(
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
            spin: Default::default(),
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
    pub(crate) fn latest(&self) -> Result<Option<StateFrame>, ClientError> {
        match self.receive(true)? {
            Some(s) => StateFrame::decode(s.user_header(), s.payload())
                .map(Some)
                .map_err(ClientError::BadFrame),
            None => Ok(None),
        }
    }

    /// The next sample in the buffer, or with `newest` the newest one (the
    /// older ones dropped unread), read in place in shared memory.
    pub(crate) fn receive(&self, newest: bool) -> Result<Option<StateSample>, ClientError> {
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
    pub(crate) fn wait(
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
    pub(crate) fn wait_with(
        &self,
        node: &Node<ipc::Service>,
        mode: WaitMode,
        timeout: Duration,
        newest: bool,
        mut accept: impl FnMut(&StateHeader) -> bool,
        into: &mut StateFrame,
    ) -> Result<(), ClientError> {
        let start = Instant::now();
        let mut rule = self.spin.get();
        let spin_for = match mode {
            WaitMode::Spin => timeout,
            WaitMode::Block => Duration::ZERO,
            WaitMode::Hybrid => rule.budget().min(timeout),
        };
        let mut spinning = !spin_for.is_zero();
        let mut last = start;
        let mut spins = 0u32;
        let mut check = GoneCheck::new();
        loop {
            if let Some(sample) = self.receive(newest)? {
                if accept(sample.user_header()) {
                    if mode == WaitMode::Hybrid {
                        rule.finished(start.elapsed(), spinning);
                        self.spin.set(rule);
                    }
                    return into
                        .read(sample.user_header(), sample.payload())
                        .map_err(ClientError::BadFrame);
                }
                continue;
            }
            let now = Instant::now();
            let elapsed = now - start;
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
            // A spin that ran out (or, hybrid, was off its core) ends:
            // the rest of the wait blocks (`SpinRule`).
            if spinning
                && !rule.keep_spinning(mode == WaitMode::Hybrid, last, now, start + spin_for)
            {
                spinning = false;
                self.spin.set(rule);
            }
            if spinning {
                last = now;
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

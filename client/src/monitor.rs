//! `Monitor`: a reader of the state stream that never holds the server up.

use crate::*;

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
        let node = crate::domain::node()?
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
        let node = crate::domain::node()?
            .create::<ipc::Service>()
            .map_err(|e| ipc("cannot create an iceoryx2 node")(&e))?;
        let exists = ipc::Service::does_exist(
            &service_name(&services::state(name))?,
            crate::domain::config()?,
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

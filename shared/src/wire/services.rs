//! Service names: one function per service, no string literals elsewhere.
//! Everything of server `NAME` lives under `cosim/NAME/`.

/// Prefix of every service of every server.
pub const ROOT: &str = "cosim/";

/// Publish-subscribe, server to all: one state frame per step
/// ([`super::StateHeader`] and its words).
pub fn state(name: &str) -> String {
    format!("{ROOT}{name}/state")
}
/// Publish-subscribe, controllers to server: input frames
/// ([`super::InputHeader`] and its words).
pub fn input(name: &str) -> String {
    format!("{ROOT}{name}/input")
}
/// Request-response: [`super::ControlRequest`] and
/// [`super::ControlResponse`].
pub fn control(name: &str) -> String {
    format!("{ROOT}{name}/control")
}
/// Event, server to all: "a state frame was published".
pub fn state_ready(name: &str) -> String {
    format!("{ROOT}{name}/state-ready")
}
/// Publish-subscribe, server to monitors, with `serve --publish-every
/// N`: the frames of every N-th step (and the last), for monitors that
/// want fewer frames than the lockstep's.
pub fn state_every(name: &str) -> String {
    format!("{ROOT}{name}/state-every")
}
/// Event, server to the decimated stream's readers: "a frame of it".
pub fn state_every_ready(name: &str) -> String {
    format!("{ROOT}{name}/state-every-ready")
}
/// Event, clients to server: "an input or a request was sent".
pub fn wake(name: &str) -> String {
    format!("{ROOT}{name}/wake")
}
/// The server name of a control service name, if it is one.
pub fn server_of(service: &str) -> Option<&str> {
    service.strip_prefix(ROOT)?.strip_suffix("/control")
}

/// Subscribers of the state service (controllers, monitors, recorders).
pub const MAX_STATE_SUBSCRIBERS: usize = 32;
/// Buffer a state subscriber may ask for (a recorder wants every
/// frame), in a scene whose frames are small; see [`state_buffer`].
pub const MAX_STATE_BUFFER: usize = 1024;
/// Shared memory the samples of one state stream may take: the
/// publisher holds room for every subscriber's whole buffer.
pub const STATE_STREAM_BYTES: usize = 256 << 20;
/// Publishers of the input service.
pub const MAX_INPUT_PUBLISHERS: usize = 2 * super::MAX_CONTROLLERS;
/// The server's input buffer: several inputs per controller and step.
pub const INPUT_BUFFER: usize = 8 * super::MAX_CONTROLLERS;
/// Clients of the control service.
pub const MAX_CONTROL_CLIENTS: usize = 32;
/// Listeners and notifiers of each event service.
pub const MAX_EVENT_PORTS: usize = 48;

/// The largest buffer a state subscriber may ask for when a frame has
/// `words` payload words: [`MAX_STATE_BUFFER`] for small scenes, fewer
/// where that many frames for every subscriber would pass
/// [`STATE_STREAM_BYTES`] (a 4,000-body frame is 1.5 MB), never fewer
/// than 2.
pub fn state_buffer(words: usize) -> usize {
    let frame = core::mem::size_of::<super::StateHeader>() + 8 * words.max(1);
    (STATE_STREAM_BYTES / (frame * MAX_STATE_SUBSCRIBERS)).clamp(2, MAX_STATE_BUFFER)
}

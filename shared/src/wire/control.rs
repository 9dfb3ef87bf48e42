//! The control service: requests (join, leave, pause, ...) and their answers.

use iceoryx2::prelude::ZeroCopySend;

use super::*;

/// The chunks of the scene TOML (`MESSAGE_LEN` bytes each) the server
/// sends for one `CMD_SCENE` request, from byte `count` on: fewer than the
/// control service's response buffer (256), so that none is lost. A client
/// asks again from where it got to until it has `value` bytes.
pub const SCENE_CHUNKS_PER_REQUEST: usize = 200;

/// `ControlRequest::command`.
pub const CMD_JOIN: u32 = 1;
pub const CMD_LEAVE: u32 = 2;
pub const CMD_PAUSE: u32 = 3;
pub const CMD_RESUME: u32 = 4;
/// Take `count` steps, then pause.
pub const CMD_STEP: u32 = 5;
/// Back to the initial state (step 0); joined controllers stay joined.
pub const CMD_RESET: u32 = 6;
/// Keep the current state; the response's `snapshot` names it.
pub const CMD_SNAPSHOT: u32 = 7;
/// Go back to snapshot `count`.
pub const CMD_RESTORE: u32 = 8;
pub const CMD_INFO: u32 = 9;
pub const CMD_SHUTDOWN: u32 = 10;
/// The scene as run, as TOML: a stream of responses, each carrying up to
/// [`MESSAGE_LEN`] bytes in `message`; `value` holds the total length.
pub const CMD_SCENE: u32 = 11;

/// `ControlRequest::role` of a join.
pub const ROLE_CONTROLLER: u32 = 1;
pub const ROLE_MONITOR: u32 = 2;

#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("cosim::ControlRequest.v4")]
pub struct ControlRequest {
    /// [`PROTOCOL_VERSION`].
    pub version: u32,
    /// `CMD_*`.
    pub command: u32,
    /// `ROLE_*` for a join.
    pub role: u32,
    /// The controller a leave is for.
    pub controller_id: u32,
    /// Steps of `CMD_STEP`, snapshot id of `CMD_RESTORE`.
    pub count: u64,
    /// The client's iceoryx2 node id (low and high 64 bits), so that the
    /// server can tell a dead controller from a slow one.
    pub node_id_lo: u64,
    pub node_id_hi: u64,
    /// The client's process id (informational).
    pub pid: u64,
}

/// `ControlResponse::status`.
pub const RESP_OK: u32 = 0;
pub const RESP_FULL: u32 = 1;
pub const RESP_UNKNOWN_COMMAND: u32 = 2;
pub const RESP_UNKNOWN_CONTROLLER: u32 = 3;
pub const RESP_UNKNOWN_SNAPSHOT: u32 = 4;
pub const RESP_BAD_REQUEST: u32 = 5;

/// Bytes of `ControlResponse::message`.
pub const MESSAGE_LEN: usize = 120;

#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("cosim::ControlResponse.v4")]
pub struct ControlResponse {
    pub version: u32,
    /// `RESP_*`.
    pub status: u32,
    /// Id of a joined controller.
    pub controller_id: u32,
    /// 1 when the simulation is paused after the command.
    pub paused: u32,
    /// The server's step after the command.
    pub step: u64,
    pub sim_time: f64,
    pub dt: f64,
    pub model_hash: u64,
    pub body_count: u32,
    pub joint_count: u32,
    pub controller_count: u32,
    pub monitor_count: u32,
    /// Snapshot id of `CMD_SNAPSHOT`; total bytes of `CMD_SCENE`.
    pub value: u64,
    /// The server's process id.
    pub pid: u64,
    /// UTF-8, NUL-padded: a human-readable answer (errors say why).
    pub message: [u8; MESSAGE_LEN],
}

impl Default for ControlResponse {
    fn default() -> ControlResponse {
        ControlResponse {
            version: PROTOCOL_VERSION,
            status: RESP_OK,
            controller_id: 0,
            paused: 0,
            step: 0,
            sim_time: 0.0,
            dt: 0.0,
            model_hash: 0,
            body_count: 0,
            joint_count: 0,
            controller_count: 0,
            monitor_count: 0,
            value: 0,
            pid: 0,
            message: [0; MESSAGE_LEN],
        }
    }
}

impl ControlResponse {
    /// Sets the message, cut at a character boundary to fit.
    pub fn set_message(&mut self, text: &str) {
        self.message = [0; MESSAGE_LEN];
        let mut end = text.len().min(MESSAGE_LEN);
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        self.message[..end].copy_from_slice(&text.as_bytes()[..end]);
    }
    /// The message's bytes up to the NUL padding.
    pub fn message_bytes(&self) -> &[u8] {
        let end = self
            .message
            .iter()
            .position(|&b| b == 0)
            .unwrap_or(MESSAGE_LEN);
        &self.message[..end]
    }
    pub fn message(&self) -> String {
        String::from_utf8_lossy(self.message_bytes()).into_owned()
    }
}

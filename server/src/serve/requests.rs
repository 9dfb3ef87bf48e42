//! The control service's side of the lockstep server: each request
//! answered (join, leave, pause, resume, step, reset, snapshot, restore,
//! scene pages, shutdown), checked against who sent it.

use super::controllers::Slot;
use super::services::Request;
use super::{Ending, Flow, ServeError, Server};
use cosim_shared::wire::*;

impl Server {
    /// A reset or restore put the engine in another state: the next
    /// step's energy rise counts from it.
    fn state_jumped(&mut self) {
        let e = crate::engine::measure::energy(self.engine.model(), self.engine.state());
        self.c.energy.jumped(e.total);
    }

    pub(super) fn respond(&self, req: &Request, mut r: ControlResponse) {
        let s = self.engine.state();
        r.step = s.step;
        r.sim_time = s.t;
        r.dt = self.engine.model().params.h;
        r.model_hash = self.model_hash;
        r.body_count = self.engine.model().bodies.len() as u32;
        r.joint_count = self.engine.model().joints.len() as u32;
        r.controller_count = self.slots.len() as u32;
        r.monitor_count = self.monitors.len() as u32;
        r.paused = u32::from(self.paused);
        r.pid = u64::from(std::process::id());
        if let Err(e) = req.send_copy(r) {
            tracing::warn!("cannot answer a control request: {e:?}");
        }
    }

    pub(super) fn refuse(&self, req: &Request, status: u32, message: &str) {
        let mut r = ControlResponse {
            status,
            ..Default::default()
        };
        r.set_message(message);
        self.respond(req, r);
    }

    /// Serves the waiting requests. Inside a step (`in_step`), requests
    /// that change the state are kept for the step boundary.
    pub(super) fn serve_requests(&mut self, in_step: bool) -> Result<Flow, ServeError> {
        while let Some(req) = self.svc.receive_request()? {
            let r = *req.payload();
            if r.version != PROTOCOL_VERSION {
                self.refuse(
                    &req,
                    RESP_BAD_REQUEST,
                    &format!(
                        "protocol version {} (this server speaks {PROTOCOL_VERSION})",
                        r.version
                    ),
                );
                continue;
            }
            match r.command {
                CMD_JOIN => self.join(&req, &r)?,
                CMD_LEAVE if self.monitors.contains(&r.controller_id) => {
                    self.monitors.retain(|&m| m != r.controller_id);
                    self.respond(&req, ControlResponse::default());
                }
                CMD_LEAVE
                    if self.slots.iter().any(|s| {
                        s.id == r.controller_id
                            && self.svc.request_node(&req).is_some_and(|n| n != s.node_id)
                    }) =>
                {
                    // Only the process that joined leaves its slot.
                    self.refuse(
                        &req,
                        RESP_UNKNOWN_CONTROLLER,
                        &format!(
                            "controller {} was joined by another process",
                            r.controller_id
                        ),
                    );
                }
                CMD_LEAVE => {
                    // NOTE: inputs sent before the leave are in the buffer
                    // now; an answer to the coming step still applies to
                    // it, and the slot goes after that step.
                    let k = self.engine.state().step;
                    while self.next_input(k)? {}
                    let before = self.slots.len();
                    for s in &mut self.slots {
                        if s.id == r.controller_id && s.answered == Some(k) {
                            s.leaving = true;
                        }
                    }
                    self.slots.retain(|s| s.id != r.controller_id || s.leaving);
                    let found = self.slots.len() < before
                        || self.slots.iter().any(|s| s.id == r.controller_id);
                    if !found {
                        self.refuse(
                            &req,
                            RESP_UNKNOWN_CONTROLLER,
                            &format!("controller {} is not joined", r.controller_id),
                        );
                    } else {
                        tracing::info!("controller {} left", r.controller_id);
                        self.respond(&req, ControlResponse::default());
                    }
                }
                CMD_PAUSE => {
                    self.paused = true;
                    self.budget = None;
                    self.respond(&req, ControlResponse::default());
                }
                CMD_RESUME => {
                    self.paused = false;
                    self.budget = None;
                    self.respond(&req, ControlResponse::default());
                }
                CMD_STEP => {
                    if r.count == 0 {
                        self.refuse(&req, RESP_BAD_REQUEST, "step needs a count of at least 1");
                    } else {
                        self.paused = false;
                        self.budget = Some(r.count);
                        self.respond(&req, ControlResponse::default());
                    }
                }
                CMD_INFO => self.respond(&req, ControlResponse::default()),
                CMD_SCENE => self.send_scene(&req),
                CMD_SNAPSHOT => {
                    self.snapshots.push(self.engine.state().clone());
                    let id = self.snapshots.len() as u64;
                    if let Some(f) = self.files.as_mut() {
                        f.logs
                            .event("snapshot", self.engine.state().step, Some(id))?;
                    }
                    self.respond(
                        &req,
                        ControlResponse {
                            value: id,
                            ..Default::default()
                        },
                    );
                }
                CMD_RESET | CMD_RESTORE | CMD_SHUTDOWN => {
                    if in_step {
                        self.deferred.push(req);
                    } else if self.change_state(&req)? {
                        self.publish()?;
                    }
                    if self.shutdown {
                        return Ok(Flow::Stop(Ending::Shutdown));
                    }
                }
                other => self.refuse(
                    &req,
                    RESP_UNKNOWN_COMMAND,
                    &format!("unknown command {other}"),
                ),
            }
        }
        Ok(Flow::Go)
    }

    pub(super) fn join(&mut self, req: &Request, r: &ControlRequest) -> Result<(), ServeError> {
        if r.role != ROLE_CONTROLLER && r.role != ROLE_MONITOR {
            self.refuse(
                req,
                RESP_BAD_REQUEST,
                &format!("role = {}: 1 joins a controller, 2 a monitor", r.role),
            );
            return Ok(());
        }
        if r.role == ROLE_MONITOR {
            // A monitor need not join (subscribing to the state is enough);
            // one that does is counted in monitor_count until it leaves
            // with the id it gets, from the controllers' sequence (issue
            // 15: it got id 0, could not leave, and was counted for ever).
            let id = self.next_id;
            self.next_id += 1;
            self.monitors.push(id);
            self.respond(
                req,
                ControlResponse {
                    controller_id: id,
                    ..Default::default()
                },
            );
            return Ok(());
        }
        if self.slots.len() >= MAX_CONTROLLERS {
            self.refuse(
                req,
                RESP_FULL,
                &format!("{MAX_CONTROLLERS} controllers are joined already"),
            );
            return Ok(());
        }
        // The node is the one whose client port sent the request, and the
        // pid the one in its node id: what the request claims is never
        // trusted (issue 46: a join whose port had vanished took the node
        // id it named, another live process's; the log printed any pid a
        // join claimed). A join whose port is gone has no process to bind.
        let Some((node, pid)) = self.svc.request_origin(req) else {
            tracing::warn!(
                "a join whose client port is gone was refused (its request named pid {})",
                r.pid
            );
            self.refuse(
                req,
                RESP_BAD_REQUEST,
                "the join's client port is gone: join from a live client",
            );
            return Ok(());
        };
        let id = self.next_id;
        self.next_id += 1;
        let joints = self.engine.model().joints.len();
        let pid = pid.unwrap_or(0);
        self.slots.push(Slot::new(id, node, pid, joints));
        self.c.controllers_joined += 1;
        if r.pid == pid {
            tracing::info!("controller {id} (pid {pid}) joined");
        } else {
            tracing::info!(
                "controller {id} (pid {pid}) joined; its request claimed pid {}",
                r.pid
            );
        }
        self.respond(
            req,
            ControlResponse {
                controller_id: id,
                ..Default::default()
            },
        );
        // NOTE: a new subscriber is connected when the publisher next
        // sends: publish the current state again so the joiner has it.
        self.publish()
    }

    /// Reset, restore, shutdown; true when the state changed.
    pub(super) fn change_state(&mut self, req: &Request) -> Result<bool, ServeError> {
        let r = *req.payload();
        let step = self.engine.state().step;
        if matches!(r.command, CMD_RESET | CMD_RESTORE) {
            // The steps start over: an answer to a step number answered
            // before the jump is an answer, not a duplicate.
            for s in &mut self.slots {
                s.answered = None;
            }
        }
        match r.command {
            CMD_RESET => {
                self.engine.set_state(self.initial.clone());
                self.state_jumped();
                if let Some(f) = self.files.as_mut() {
                    f.logs.event("reset", step, None)?;
                }
                self.last_report = None;
                if let Some(f) = self.files.as_mut() {
                    f.writers.state(&self.engine)?;
                }
                self.respond(req, ControlResponse::default());
                Ok(true)
            }
            CMD_RESTORE => match self.snapshots.get((r.count as usize).wrapping_sub(1)) {
                Some(s) => {
                    self.engine.set_state(s.clone());
                    self.state_jumped();
                    if let Some(f) = self.files.as_mut() {
                        f.logs.event("restore", step, Some(r.count))?;
                    }
                    self.last_report = None;
                    if let Some(f) = self.files.as_mut() {
                        f.writers.state(&self.engine)?;
                    }
                    self.respond(req, ControlResponse::default());
                    Ok(true)
                }
                None => {
                    self.refuse(
                        req,
                        RESP_UNKNOWN_SNAPSHOT,
                        &format!(
                            "no snapshot {} (there are {})",
                            r.count,
                            self.snapshots.len()
                        ),
                    );
                    Ok(false)
                }
            },
            _ => {
                self.shutdown = true;
                self.respond(req, ControlResponse::default());
                Ok(false)
            }
        }
    }

    /// Up to `SCENE_CHUNKS_PER_REQUEST` chunks of the scene from byte
    /// `count` on (issue 15: one request streamed all of it, and a scene
    /// over 256 chunks, 30,720 bytes, lost its tail in the client's
    /// response buffer).
    pub(super) fn send_scene(&self, req: &Request) {
        let bytes = self.toml.as_bytes();
        let from = usize::try_from(req.payload().count)
            .unwrap_or(usize::MAX)
            .min(bytes.len());
        let chunks = bytes[from..]
            .chunks(MESSAGE_LEN)
            .take(SCENE_CHUNKS_PER_REQUEST);
        if from == bytes.len() {
            // Nothing left: one empty chunk still tells the length.
            self.respond(
                req,
                ControlResponse {
                    value: bytes.len() as u64,
                    ..Default::default()
                },
            );
        }
        for chunk in chunks {
            let mut r = ControlResponse {
                value: bytes.len() as u64,
                ..Default::default()
            };
            r.message[..chunk.len()].copy_from_slice(chunk);
            self.respond(req, r);
        }
    }
}

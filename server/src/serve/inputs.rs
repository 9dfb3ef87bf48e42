//! Steps 3 and 4 of the lockstep: gathering the controllers' inputs for a
//! step until all answered or the deadline, and what a miss does.

use super::*;

impl Server {
    /// Step k's inputs: until every controller answered or the deadline
    /// (from `published`). Also returns when it ended: the round trip's
    /// end, timed from `frame_out`, when the frame went out.
    pub(super) fn gather(
        &mut self,
        k: u64,
        published: Instant,
    ) -> Result<(Flow, Instant), ServeError> {
        self.status &= !(STATUS_INPUT_REJECTED | STATUS_DEADLINE_MISSED | STATUS_SOLVER_FAILED);
        for s in &mut self.slots {
            s.rejected = 0;
            s.missed_now = false;
            s.gone_checks = 0;
        }
        if self.slots.is_empty() {
            return Ok((Flow::Go, Instant::now()));
        }
        let deadline = published + self.opts.deadline;
        let spin_for = match self.opts.wait {
            WaitMode::Spin => self.opts.deadline,
            WaitMode::Block => Duration::ZERO,
            WaitMode::Hybrid => self.spin.budget(),
        };
        let spin_until = published + spin_for;
        let mut spinning = !spin_for.is_zero();
        let mut last = Instant::now();
        // A controller that is late is checked for having gone, first after
        // DEPARTURE_CHECK and then every DEPARTURE_CHECK: an answer in time
        // costs no check.
        let mut next_check = published + DEPARTURE_CHECK;
        let mut polls = 0u32;
        let all_answered =
            |slots: &[controllers::Slot]| slots.iter().all(|s| s.answered == Some(k));
        loop {
            // Stops at the input that completes the step: one receive per
            // controller, not one more that finds the queue empty (a
            // receive reads the connection's cache lines, which the
            // controller's core owns: about 0.2 us here).
            let mut done = all_answered(&self.slots);
            while !done && self.next_input(k)? {
                done = all_answered(&self.slots);
            }
            if done {
                let now = Instant::now();
                if self.opts.wait == WaitMode::Hybrid {
                    self.spin.finished(now - published, spinning);
                }
                self.c.round_trips.add(us(self.frame_out, now));
                return Ok((Flow::Go, now));
            }
            // Requests in the same loop: a controller that leaves is not
            // waited for.
            polls = polls.wrapping_add(1);
            if polls.is_multiple_of(64) || self.opts.wait != WaitMode::Spin {
                if let Flow::Stop(e) = self.serve_requests(true)? {
                    return Ok((Flow::Stop(e), Instant::now()));
                }
                if terminated() {
                    return Ok((Flow::Stop(Ending::Signal), Instant::now()));
                }
            }
            let now = Instant::now();
            if now >= deadline {
                break;
            }
            if now >= next_check {
                next_check = now + DEPARTURE_CHECK;
                if self.drop_departed(k) {
                    continue;
                }
            }
            // A spin that ran out (or, hybrid, was off its core) ends:
            // the rest of the wait blocks (`cosim_client::SpinRule`).
            let adaptive = self.opts.wait == WaitMode::Hybrid;
            if spinning && !self.spin.keep_spinning(adaptive, last, now, spin_until) {
                spinning = false;
            }
            if spinning {
                last = now;
                std::hint::spin_loop();
            } else {
                self.svc.block(deadline.min(next_check) - now)?;
            }
        }
        Ok((self.misses(k)?, Instant::now()))
    }

    /// Drops the controllers that owe step k and are gone: their input
    /// publisher left the service (a process that ends normally removes its
    /// ports) or their node is dead (a process killed or ended without
    /// cleanup). Issue 15, defect 5: such a controller stalled the run for
    /// the whole deadline and was counted as a miss. True if any went.
    fn drop_departed(&mut self, k: u64) -> bool {
        let svc = &self.svc;
        let before = self.slots.len();
        self.slots.retain_mut(|s| {
            if s.answered == Some(k) {
                return true;
            }
            // Two verdicts in a row: a node list read while other processes
            // create and remove nodes can miss a live one once.
            let now = s.publisher.is_some_and(|p| !svc.publisher_connected(p))
                || cosim_client::node_alive(s.node_id) == Some(false);
            s.gone_checks = if now { s.gone_checks + 1 } else { 0 };
            let gone = s.gone_checks >= 2;
            if gone {
                tracing::warn!(
                    "controller {} (pid {}) exited without leaving at step {k}; dropped",
                    s.id,
                    s.pid
                );
            }
            !gone
        });
        let gone = before - self.slots.len();
        if gone > 0 {
            self.svc.node.try_cleanup_dead_nodes();
            self.c.controllers_dropped += gone as u64;
            self.c.controllers_departed += gone as u64;
        }
        gone > 0
    }

    /// The policy for the controllers that did not answer step k.
    fn misses(&mut self, k: u64) -> Result<Flow, ServeError> {
        let mut dropped = Vec::new();
        for s in &mut self.slots {
            if s.answered == Some(k) {
                continue;
            }
            s.misses += 1;
            s.missed_now = true;
            self.c.deadline_misses += 1;
            self.status |= STATUS_DEADLINE_MISSED;
            s.apply_miss(self.opts.on_miss);
            let alive = cosim_client::node_alive(s.node_id);
            if alive == Some(false) {
                tracing::warn!(
                    "controller {} (pid {}) died at step {k}; dropped",
                    s.id,
                    s.pid
                );
                dropped.push(s.id);
            } else if s.misses >= self.opts.drop_after {
                tracing::warn!(
                    "controller {} (pid {}) missed {} deadlines in a row; dropped",
                    s.id,
                    s.pid,
                    s.misses
                );
                dropped.push(s.id);
            } else {
                tracing::warn!(
                    "controller {} missed the deadline of step {k} ({} ms): {}",
                    s.id,
                    self.opts.deadline.as_millis(),
                    self.opts.on_miss.as_str()
                );
            }
        }
        if !dropped.is_empty() {
            // Reclaim what the dead left in shared memory.
            self.svc.node.try_cleanup_dead_nodes();
            self.slots.retain(|s| !dropped.contains(&s.id));
            self.c.controllers_dropped += dropped.len() as u64;
        }
        match self.opts.on_miss {
            MissPolicy::Abort => {
                tracing::error!(
                    "a controller missed the deadline of step {k}; aborting (--on-miss abort)"
                );
                Ok(Flow::Stop(Ending::Aborted))
            }
            MissPolicy::Pause => {
                self.paused = true;
                Ok(Flow::Go)
            }
            MissPolicy::Hold | MissPolicy::Zero => Ok(Flow::Go),
        }
    }

    /// Logs every input still queued as `after_end` (the run took no
    /// further step) and counts it under that reason.
    pub(super) fn drain_inputs(&mut self) {
        while let Ok(Some(_)) = self.svc.receive_input(&mut self.input) {
            *self.c.inputs_rejected.entry("after_end").or_default() += 1;
            if let Some(f) = self.files.as_mut() {
                let _ = f.logs.input(&self.input, "after_end");
            }
        }
    }

    /// Takes the next input of the buffer for step `k`, if there is one.
    pub(super) fn next_input(&mut self, k: u64) -> Result<bool, ServeError> {
        let mut input = std::mem::take(&mut self.input);
        let got = self.svc.receive_input(&mut input);
        let taken = match got {
            Ok(Some((origin, read))) => self
                .take_input(&input, origin, read.is_ok(), k)
                .map(|()| true),
            Ok(None) => Ok(false),
            Err(e) => Err(e.into()),
        };
        self.input = input;
        taken
    }

    /// Takes `input` from publisher `origin`; `well_formed` says whether
    /// its words matched its header's counts.
    fn take_input(
        &mut self,
        input: &InputFrame,
        origin: u128,
        well_formed: bool,
        k: u64,
    ) -> Result<(), ServeError> {
        let lim = controllers::Limits {
            joints: self.engine.model().joints.len(),
            bodies: self.engine.model().bodies.len(),
            motored: &self.motored,
        };
        let idx = self.slots.iter().position(|s| s.id == input.controller_id);
        if let Some(i) = idx {
            let svc = &self.svc;
            if input.version == PROTOCOL_VERSION
                && !controllers::owns(&mut self.slots[i], origin, |p| svc.publisher_node(p))
            {
                // Counted and logged, but nothing of it reaches the slot:
                // its owner's step is still open.
                let name = controllers::reason_name(REJECT_FOREIGN_SENDER);
                *self.c.inputs_rejected.entry(name).or_default() += 1;
                if let Some(f) = self.files.as_mut() {
                    f.logs.input(input, name)?;
                }
                let s = &mut self.slots[i];
                if s.logged & REJECT_FOREIGN_SENDER == 0 {
                    s.logged |= REJECT_FOREIGN_SENDER;
                    tracing::warn!(
                        "rejected an input sent as controller {} by a process that did not join as it ({name}); further ones are counted, not logged",
                        input.controller_id
                    );
                }
                return Ok(());
            }
        }
        match controllers::check(input, well_formed, idx.map(|i| &self.slots[i]), k, lim) {
            Ok(()) => {
                if let Some(i) = idx {
                    controllers::accept(input, &mut self.slots[i], k);
                }
                self.c.inputs_applied += 1;
                if let Some(f) = self.files.as_mut() {
                    f.logs.input(input, "applied")?;
                }
            }
            Err(r) => {
                let name = controllers::reason_name(r.reason);
                *self.c.inputs_rejected.entry(name).or_default() += 1;
                self.status |= STATUS_INPUT_REJECTED;
                if let Some(f) = self.files.as_mut() {
                    f.logs.input(input, name)?;
                }
                if let Some(i) = idx {
                    let s = &mut self.slots[i];
                    s.rejected |= r.reason;
                    if r.answered {
                        // The step goes on with the policy's input.
                        s.answered = Some(k);
                        s.apply_miss(self.opts.on_miss.for_rejected());
                    }
                    if s.logged & r.reason == 0 {
                        s.logged |= r.reason;
                        tracing::warn!(
                            "rejected an input of controller {} for step {} ({name}); further ones of this reason are counted, not logged",
                            s.id,
                            input.step
                        );
                    }
                } else if !self.unjoined_logged.contains(&(origin, r.reason)) {
                    // A process that is no joined controller: logged once
                    // per sender and reason (issue 46: not logged at all),
                    // with the pid of the sender's node.
                    if self.unjoined_logged.len() < 64 {
                        self.unjoined_logged.push((origin, r.reason));
                    }
                    let pid = self
                        .svc
                        .publisher_pid(origin)
                        .map_or("unknown".to_string(), |p| p.to_string());
                    tracing::warn!(
                        "rejected an input from a process that is not a joined controller (pid {pid}, controller id {}, step {}: {name}); further ones of this sender and reason are counted, not logged",
                        input.controller_id,
                        input.step
                    );
                }
            }
        }
        Ok(())
    }
}

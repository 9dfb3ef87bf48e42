//! Step 5 of the lockstep: the net inputs into the engine, the step, its
//! outputs; and the summary a run leaves.

use super::*;

impl Server {
    /// The net inputs into the engine, the step, the outputs.
    /// Returns the engine's compute time (us).
    pub(super) fn take_step(&mut self, k: u64) -> Result<f64, ServeError> {
        for j in 0..self.engine.model().joints.len() {
            let t = controllers::net_torque(&self.slots, j, self.scene_torque[j]);
            if t != self.applied[j] {
                self.applied[j] = t;
                if let Some(f) = self.files.as_mut() {
                    f.logs.torque(k, j, t)?;
                }
            }
            // Cannot fail: index in range, values checked finite.
            let _ = self.engine.set_joint_torque(j, Vector3::from(t));
            if self.motored[j] {
                let v = controllers::net_motor(&self.slots, j, self.scene_motor[j]);
                if v.to_bits() != self.applied_motor[j].to_bits() {
                    self.applied_motor[j] = v;
                    if let Some(f) = self.files.as_mut() {
                        f.logs.motor(k, j, v)?;
                    }
                }
                // Cannot fail: a joint with a motor, a finite target.
                let _ = self.engine.set_motor_speed(j, v);
            }
        }
        for s in &self.slots {
            for b in &s.impulses {
                if let Some(f) = self.files.as_mut() {
                    f.logs.impulse(k, b.body as usize, b.linear, b.angular)?;
                }
                let _ = self.engine.add_body_impulse(
                    b.body as usize,
                    Vector3::from(b.linear),
                    Vector3::from(b.angular),
                );
            }
        }
        for s in &mut self.slots {
            s.impulses.clear();
        }
        self.slots.retain(|s| !s.leaving);
        let t0 = Instant::now();
        let report = self.engine.finish();
        let compute = t0.elapsed().as_secs_f64() * 1e6;
        self.c.step_compute.add(compute);
        if let Some(f) = self.files.as_mut() {
            f.logs.step(k, frame::state_hash(&self.engine))?;
        }
        self.c.max_penetration = self.c.max_penetration.max(report.max_penetration);
        self.c.max_joint_error = self.c.max_joint_error.max(report.max_joint_error);
        self.c.max_joint_angle_error = self
            .c
            .max_joint_angle_error
            .max(report.max_joint_angle_error);
        self.c.energy.add(&report);
        self.c.projected_contacts += report.projected as u64;
        if report.clamped_efforts > 0 && self.c.clamped_efforts == 0 {
            tracing::warn!(
                "step {}: a joint's torque exceeds its effort bound and is clamped to it; further clamps are counted (summary: clamped_efforts)",
                k + 1
            );
        }
        self.c.clamped_efforts += report.clamped_efforts as u64;
        self.c.early_matrix_steps += u64::from(report.early_matrix);
        self.c.ladder.add(&report);
        if let Some(e) = report.error {
            // NOTE: the policy stops the loop from taking this step again
            // with the same inputs (a re-run gives the same failure): it
            // pauses or stops, and the failure is counted and logged once.
            self.c.failures += 1;
            let policy = self.opts.on_failure;
            tracing::error!(
                "step {}: the solver failed ({e}); the state did not advance; --on-failure {}: {}",
                k + 1,
                policy.as_str(),
                match policy {
                    controllers::FailurePolicy::Abort => "stopping",
                    _ => "paused until resume, step, reset or restore",
                }
            );
            match policy {
                controllers::FailurePolicy::Abort => self.failed_stop = true,
                _ => self.paused = true,
            }
            // The inputs may be what failed (a torque of 1e308 N m is
            // finite): the retry waits for a new answer from each
            // controller, which the failed frame asks for (no
            // SLOT_ANSWERED). Held torques stay until replaced.
            for s in &mut self.slots {
                s.answered = None;
            }
        } else {
            self.c.steps += 1;
            if let Some(fb) = report.fallback {
                // Rate-limited: the first, then every 1000th.
                let n = self.c.ladder.fell_back();
                if n == 1 || n.is_multiple_of(1000) {
                    tracing::warn!(
                        "step {}: the rigid LCP has no solution the solver finds; the step went on {} ({n} such steps so far)",
                        k + 1,
                        fb.as_str()
                    );
                }
            }
        }
        // `--record-every N`: every N-th step, the last, and every step
        // that failed or fell back (nothing unusual is decimated away).
        let step = self.engine.state().step;
        let record = step.is_multiple_of(self.opts.record_every)
            || self.opts.steps == Some(self.c.steps)
            || report.error.is_some()
            || report.fallback.is_some();
        if record {
            self.write_step(&report)?;
        }
        self.last_report = Some(report);
        if self.c.steps.is_multiple_of(1000) {
            if let Some(f) = self.files.as_mut() {
                f.writers.flush()?;
            }
            if let Some(f) = self.files.as_mut() {
                f.logs.flush()?;
            }
        }
        Ok(compute)
    }

    /// The state after the last step and its report, in the per-step
    /// files (once per step).
    pub(super) fn write_step(&mut self, report: &StepReport) -> Result<(), ServeError> {
        let step = self.engine.state().step;
        let Some(f) = self.files.as_mut() else {
            return Ok(());
        };
        if report.ok() && self.last_written != Some(step) {
            f.writers.state(&self.engine)?;
            f.writers.impulses(&self.engine)?;
            self.last_written = Some(step);
        }
        f.writers.step(report, None)?;
        Ok(())
    }

    pub(super) fn write_summary(&self, ending: Ending, wall: f64) -> std::io::Result<()> {
        let c = &self.c;
        let rt = |p| c.round_trips.quantile(p);
        let summary = serde_json::json!({
            "scene": self.engine.model().name,
            "name": self.opts.name,
            "ending": format!("{ending:?}").to_lowercase(),
            "steps": c.steps,
            "t_end": self.engine.state().t,
            "dt": self.engine.model().params.h,
            "solver": self.engine.model().params.solver.as_str(),
            "model_hash": format!("{:016x}", self.model_hash),
            "failures": c.failures,
            "ended_on_failure": c.unrecovered,
            "on_failure": self.opts.on_failure.as_str(),
            "ladder": crate::output::ladder_json(&c.ladder),
            "fallback_steps": c.ladder.fell_back(),
            "controllers_joined": c.controllers_joined,
            "controllers_dropped": c.controllers_dropped,
            "controllers_departed": c.controllers_departed,
            "inputs_applied": c.inputs_applied,
            "inputs_rejected": c.inputs_rejected,
            "deadline_misses": c.deadline_misses,
            "round_trip_us": { "median": rt(0.5), "p99": rt(0.99) },
            "step_compute_us": { "median": c.step_compute.quantile(0.5), "p99": c.step_compute.quantile(0.99) },
            "wait": self.opts.wait.as_str(),
            "on_miss": self.opts.on_miss.as_str(),
            "deadline_ms": self.opts.deadline.as_secs_f64() * 1e3,
            "max_penetration": c.max_penetration,
            "max_joint_error": c.max_joint_error,
            "max_joint_angle_error": c.max_joint_angle_error,
            "energy_initial": c.energy.initial,
            "energy_final": c.energy.last,
            "max_energy_rise": c.energy.max_rise,
            "max_energy_rise_step": c.energy.max_rise_step,
            "projected_contacts": c.projected_contacts,
            "clamped_efforts": c.clamped_efforts,
            "early_matrix_steps": c.early_matrix_steps,
            "wall_seconds": wall,
            "stepping_seconds": c.stepping_seconds,
        });
        match &self.opts.out {
            Some(out) => std::fs::write(
                out.join("summary.json"),
                serde_json::to_string_pretty(&summary).unwrap_or_default() + "\n",
            ),
            None => Ok(()),
        }
    }
}

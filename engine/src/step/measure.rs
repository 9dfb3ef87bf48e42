//! The step's report: opened before the solve with the collision stage's
//! figures, closed with the measurements of the new state (energy,
//! penetration, joint error) and the stage times.

use super::{Clock, Engine};
use crate::constraint::applied;
use crate::measure;
use crate::measure::report::{Lap, StepError, StepReport, Timings};
use crate::solver::Rung;

impl Engine {
    /// The report of the step about to be solved, and its clock (started
    /// at the end of the collision stage).
    pub(super) fn open_report(&mut self) -> (StepReport, Clock) {
        let lap = Lap::start();
        let timings = Timings {
            collision: self.collision_time,
            assemble: self.early_assembly,
            // The wall time of prepare, then (in `measure`) of finish.
            total: self.collision_time + std::mem::take(&mut self.early_assembly),
            ..Timings::default()
        };
        let p = &self.model.params;
        let report = StepReport {
            step: self.state.step + 1,
            t: (self.state.step + 1) as f64 * p.h,
            solver: p.solver.as_str(),
            error: None,
            pivots: 0,
            residual: 0.0,
            lcp_size: 0,
            contacts_in_lcp: 0,
            active_contacts: 0,
            resolves: 0,
            left_out: 0,
            not_converged: false,
            regularized: 0,
            refined: 0,
            rung: Rung::Other,
            fallback: None,
            energy_refused: false,
            energy_allowance: 0.0,
            projected: std::mem::take(&mut self.projected),
            early_matrix: false,
            max_penetration: 0.0,
            max_joint_error: 0.0,
            max_joint_angle_error: 0.0,
            clamped_efforts: applied::clamped(&self.model, &self.state, &self.inputs),
            islands: 0,
            largest_island: 0,
            lemke_islands: 0,
            smooth_islands: 0,
            smooth_left: 0,
            pgs_islands: 0,
            sleeping: 0,
            energy: Default::default(),
            timings,
        };
        (report, Clock { lap, timings })
    }

    /// A failed step: the state is left as it was, and the report says why.
    pub(super) fn failed(
        &mut self,
        mut report: StepReport,
        clock: Clock,
        e: StepError,
    ) -> StepReport {
        report.error = Some(e);
        self.ws.impulses.clear();
        self.prepared = true; // the state did not change
        report.step = self.state.step;
        report.t = self.state.t;
        self.measure(report, clock)
    }

    pub(super) fn measure(&mut self, mut report: StepReport, clock: Clock) -> StepReport {
        let Clock {
            mut lap,
            mut timings,
        } = clock;
        let _span = tracing::trace_span!("measure").entered();
        report.energy = measure::energy(&self.model, &self.state);
        let (model, state, ws) = (&self.model, &self.state, &mut self.ws);
        let listing = ws.awake.refresh(state);
        let asleep = (ws.asleep).deepest(
            model,
            state,
            Some(listing),
            &mut ws.collision,
            &mut ws.measure,
        );
        report.max_penetration = ws.look_ahead(model, state).max(asleep);
        report.max_joint_error = measure::max_joint_error(&self.model, &self.state);
        report.max_joint_angle_error = measure::max_joint_angle_error(&self.model, &self.state);
        timings.measure = lap.lap();
        timings.total += lap.total();
        report.timings = timings;
        report
    }
}

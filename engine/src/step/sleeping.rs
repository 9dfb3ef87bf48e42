//! Sleeping's part of the step: the idle step of a world asleep whole,
//! the islands a body impulse wakes, and the sleep update after the step.

use super::Engine;
use crate::measure::report::{Lap, StepReport, Timings};
use crate::model::state;
use crate::sleep;
use nalgebra::Vector3;

/// What a step began with: a body impulse pending (`add_body_impulse`),
/// and whether it may be idle (every body asleep, no input).
#[derive(Debug, Clone, Copy)]
pub(super) struct Began {
    pub(super) impulses: bool,
    idle: bool,
}

impl Engine {
    /// Whether the next step is idle (see [`Engine::idle_step`]).
    pub(super) fn idles(&self) -> bool {
        self.model.params.skips.idle && !self.impulse_pending && self.idle.is_some()
    }

    /// A step of a world asleep whole, with no input: what it changes is
    /// the clock. A sleeping body keeps its pose and zero velocity to the
    /// bit, nothing is listed (every contact has no awake body, and no
    /// body is on a joint: such bodies never sleep), so no impulse, warm
    /// start or measurement changes; the first such step runs every stage
    /// and its report is kept (`idle`) as the report of those that follow,
    /// with their step, time and timings. `None` where the step must run:
    /// an input (a body impulse wakes its island; torques, motor targets
    /// and solver parameters drop the kept report), a restored state, or
    /// `Skips::idle` off.
    ///
    /// Why: a sleeping 1,000-sphere pile's step cost about 50 us, in ten
    /// passes over the bodies that each found every body asleep (reach,
    /// inverse masses, free velocity, the pose copy, the sleep update, the
    /// energy, the sleeping poses' comparison); Box2D and Rapier step a
    /// world asleep in constant time.
    pub(super) fn idle_step(&mut self) -> Option<StepReport> {
        if !self.idles() {
            return None;
        }
        let kept = self.idle.as_ref()?;
        let lap = Lap::start();
        self.state.step += 1;
        self.state.t = self.state.step as f64 * self.model.params.h;
        let report = StepReport {
            step: self.state.step,
            t: self.state.t,
            early_matrix: std::mem::take(&mut self.idle_prepared),
            timings: Timings {
                total: lap.total(),
                ..Timings::default()
            },
            ..*kept
        };
        Some(report)
    }

    /// Takes the step's inputs: the kept idle report is dropped (this step
    /// runs every stage), and a pending body impulse wakes its island, whose
    /// contacts must then be listed again.
    pub(super) fn take_inputs(&mut self) -> Began {
        // The step may be idle (see `idle_step`): it began with every body
        // asleep and has no input.
        let impulses = std::mem::take(&mut self.impulse_pending);
        let began = Began {
            impulses,
            idle: self.all_asleep && !impulses,
        };
        self.idle = None;
        self.idle_prepared = false;
        if impulses && self.wake_on_inputs() {
            self.prepared = false;
            self.ws.ahead_listed = false;
        }
        began
    }

    /// Wakes the sleeping islands that this step's body impulses push;
    /// true when one woke (its contacts must then be listed). Only called
    /// with an impulse pending (`impulse_pending`): the pass over every
    /// body's impulse, and the one that clears them, are for such steps.
    fn wake_on_inputs(&mut self) -> bool {
        if !state::any_asleep(&self.state) {
            return false;
        }
        let mut woke = false;
        for (i, (l, a)) in self.inputs.body_impulse.iter().enumerate() {
            if *l != Vector3::zeros() || *a != Vector3::zeros() {
                woke |= sleep::wake_body(&mut self.state, i);
            }
        }
        woke
    }

    /// Puts to sleep the islands at rest long enough (`[sim.sleep]`), and
    /// counts the sleeping bodies.
    pub(super) fn sleep(&mut self, report: &mut StepReport) {
        if let Some(params) = self.model.params.sleep {
            let _span = tracing::trace_span!("sleep").entered();
            sleep::update(
                &self.model,
                &params,
                &self.pgs_params,
                &mut self.state,
                &self.ws.contacts,
                &mut self.ws.awake,
                &mut self.ws.islands,
            );
        }
        report.sleeping = state::asleep_count(&self.state);
    }

    /// Keeps the report of a step that began and ended with every body
    /// asleep and had no input: the report of every idle step after it.
    pub(super) fn keep_if_idle(&mut self, began: Began, report: StepReport) -> StepReport {
        self.all_asleep = report.sleeping > 0 && report.sleeping == self.model.bodies.len();
        if began.idle && self.all_asleep {
            self.idle = Some(report);
        }
        report
    }
}

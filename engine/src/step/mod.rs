//! The step: the stages in order over the engine's model, state and
//! scratch space, each stage a file of this folder that calls into its
//! layer (`collision`, `constraint`, `solver`, `integrate`, `sleep`,
//! `measure`). Split around the control input as MuJoCo's
//! `mj_step1`/`mj_step2`:
//!
//! - [`Engine::prepare`]: the collision stage (contact set, waking, the
//!   projection out of deep penetration, `collide.rs`) and the matrix part
//!   of the mLCP for the inputs held so far: everything that does not
//!   depend on the controllers' inputs;
//! - [`Engine::finish`]: the inputs taken (a body impulse wakes its island,
//!   `sleeping.rs`), the solve (`solve.rs`), the position update
//!   (`integrate.rs`), the impulses recorded and kept as warm starts
//!   (`record.rs`), sleeping, and the measurements (`measure.rs`).
//!
//! [`Engine::step`] is both. A world asleep whole with no input steps idle
//! (`sleeping.rs`).

mod collide;
mod integrate;
mod measure;
mod record;
mod sleeping;
mod solve;
mod workspace;

use crate::constraint::applied::{InputError, Inputs};
use crate::constraint::contact::Contact;
use crate::measure::report::{ImpulseRecord, Lap, StepReport, Timings};
use crate::model::{Model, PgsParams, State};
use crate::solver::{matrix_free, Lemke, Pgs};
use nalgebra::Vector3;
use workspace::Workspace;

/// The engine: a compiled model, its state, the held inputs and the
/// scratch space of the stages. See the module doc for the step.
pub struct Engine {
    model: Model,
    state: State,
    inputs: Inputs,
    ws: Workspace,
    lemke: Lemke,
    pgs: Pgs,
    pgs_params: PgsParams,
    prepared: bool,
    collision_time: f64,
    /// Time `prepare` spent on the matrix part, counted as assembly.
    early_assembly: f64,
    /// Contacts projected out of deep penetration by this step's prepare.
    projected: usize,
    /// A body impulse waits for the next step (`add_body_impulse`).
    impulse_pending: bool,
    /// Every body was asleep when the last step ended.
    all_asleep: bool,
    /// The report of the last step that began and ended with every body
    /// asleep and had no input, while nothing has changed since: the
    /// report of every such step until then (see [`Engine::idle_step`]).
    idle: Option<StepReport>,
    /// `prepare` ran before this idle step.
    idle_prepared: bool,
}

/// The step's clock: the lap since the last stage boundary and the stage
/// times so far (observational: nothing in the physics reads them).
struct Clock {
    lap: Lap,
    timings: Timings,
}

impl Engine {
    pub fn new(model: Model) -> Engine {
        let max_pivots = model.params.lemke_max_pivots;
        let state = State::initial(&model);
        let inputs = Inputs::new(&model);
        Engine {
            pgs: Pgs::default(),
            pgs_params: model.params.pgs,
            model,
            state,
            inputs,
            ws: Workspace::default(),
            lemke: Lemke::with_max_pivots(max_pivots),
            prepared: false,
            collision_time: 0.0,
            early_assembly: 0.0,
            projected: 0,
            impulse_pending: false,
            all_asleep: false,
            idle: None,
            idle_prepared: false,
        }
    }

    pub fn model(&self) -> &Model {
        &self.model
    }

    pub fn state(&self) -> &State {
        &self.state
    }

    /// Restores a state (a snapshot taken with `state().clone()`).
    pub fn set_state(&mut self, mut state: State) {
        // The guess buffers change length from step to step: keep the ones
        // that grew during warm-up, so that a restore does not make the
        // next steps allocate.
        let mine = &mut self.state;
        mine.warm_active.clear();
        mine.warm_active.extend_from_slice(&state.warm_active);
        mine.warm_lcp.clear();
        mine.warm_lcp.extend_from_slice(&state.warm_lcp);
        mine.warm_contacts.clear();
        mine.warm_contacts.extend_from_slice(&state.warm_contacts);
        std::mem::swap(&mut mine.warm_active, &mut state.warm_active);
        std::mem::swap(&mut mine.warm_lcp, &mut state.warm_lcp);
        std::mem::swap(&mut mine.warm_contacts, &mut state.warm_contacts);
        self.state = state;
        self.prepared = false;
        self.ws.ahead_listed = false;
        self.all_asleep = false;
        self.idle = None;
        // Its sleeping bodies need not be at rest where the kept entries
        // (`Workspace::awake`) were written, nor its warm starts be those
        // the sleeping part was picked from (`sleeping_warm`).
        self.ws.awake.forget();
    }

    /// Tolerance, iteration cap and relaxation of the iterative solver.
    pub fn set_pgs_params(&mut self, params: PgsParams) {
        self.pgs_params = params;
        self.idle = None;
    }

    pub fn inputs(&self) -> &Inputs {
        &self.inputs
    }

    /// Sets the held effort of joint `joint` until changed: a torque
    /// (N m), `+torque` on body_b and `-torque` on body_a; for a slider a
    /// force (N) on body_b at its anchor and its opposite on body_a there
    /// (its part along the axis drives the slide). ROS's `effort`,
    /// MuJoCo's generalised force.
    pub fn set_joint_torque(
        &mut self,
        joint: usize,
        torque: Vector3<f64>,
    ) -> Result<(), InputError> {
        let joints = self.model.joints.len();
        if joint >= joints {
            return Err(InputError::UnknownJoint {
                index: joint,
                joints,
            });
        }
        if !torque.iter().all(|x| x.is_finite()) {
            return Err(InputError::NonFinite {
                what: "torque of joint",
                index: joint,
            });
        }
        self.inputs.joint_torque[joint] = torque;
        self.idle = None;
        Ok(())
    }

    /// Sets the target rate of joint `joint`'s motor until changed (rad/s
    /// for a hinge, m/s for a slider; `motor.rs`): Rapier's
    /// `set_motor_velocity`, ODE's `dParamVel`.
    pub fn set_motor_speed(&mut self, joint: usize, speed: f64) -> Result<(), InputError> {
        let joints = self.model.joints.len();
        if joint >= joints {
            return Err(InputError::UnknownJoint {
                index: joint,
                joints,
            });
        }
        if self.model.joints[joint].motor.is_none() {
            return Err(InputError::NoMotor { index: joint });
        }
        if !speed.is_finite() {
            return Err(InputError::NonFinite {
                what: "motor speed of joint",
                index: joint,
            });
        }
        self.inputs.motor_speed[joint] = speed;
        self.idle = None;
        Ok(())
    }

    /// Adds a world-frame impulse (N s) and angular impulse (N m s) to body
    /// `body` for the next step only.
    pub fn add_body_impulse(
        &mut self,
        body: usize,
        linear: Vector3<f64>,
        angular: Vector3<f64>,
    ) -> Result<(), InputError> {
        let bodies = self.model.bodies.len();
        if body >= bodies {
            return Err(InputError::UnknownBody {
                index: body,
                bodies,
            });
        }
        if !(linear.iter().chain(angular.iter()).all(|x| x.is_finite())) {
            return Err(InputError::NonFinite {
                what: "impulse on body",
                index: body,
            });
        }
        let imp = &mut self.inputs.body_impulse[body];
        imp.0 += linear;
        imp.1 += angular;
        self.impulse_pending = true;
        Ok(())
    }

    /// The impulses of the last step (normal, friction, joint).
    pub fn impulses(&self) -> &[ImpulseRecord] {
        &self.ws.impulses
    }

    /// The velocities `[v_i, w_i]` per body that the last step's solve gave
    /// and the position update used: the state's, except that an island
    /// the step put to sleep has zero in the state (`sleep::update`).
    pub fn solved_velocities(&self) -> &[f64] {
        &self.ws.nu
    }

    /// The contact set of the last step, every potential contact included.
    pub fn contacts(&self) -> &[Contact] {
        &self.ws.contacts
    }

    /// The last step's pure LCP `(n, M row-major, q)`, for tests and tools.
    pub fn last_lcp(&self) -> (usize, &[f64], &[f64]) {
        let m = &self.ws.mlcp;
        (m.lcp_size(), &m.lcp_m, &m.lcp_q)
    }

    /// One whole step.
    pub fn step(&mut self) -> StepReport {
        if let Some(report) = self.idle_step() {
            return report;
        }
        self.prepare_contacts();
        self.finish()
    }

    /// The part of the step that needs no input, for a caller that has
    /// time before the inputs arrive (the lockstep server, while the
    /// controllers compute): collision, contact set, inverse masses, and the
    /// matrix part of the mLCP for the contacts that the inputs held so far
    /// would select (see `Mlcp::matrix_for`). `finish` keeps that matrix
    /// when the actual inputs select the same contacts, cuts it down when
    /// they select fewer, and builds afresh otherwise: the step's bits are
    /// the same as `step`'s either way. Idempotent until the state changes.
    pub fn prepare(&mut self) {
        if self.idles() {
            // An idle step prepares nothing (`idle_step`), but says, as
            // the full one would, that its (empty) matrix was made early.
            self.idle_prepared = true;
            return;
        }
        let Some(mut lap) = self.prepare_contacts() else {
            return;
        };
        let _span = tracing::trace_span!("assemble_early").entered();
        let (model, ws) = (&self.model, &mut self.ws);
        ws.select(model, &self.state, &self.inputs);
        // A failure here is the step's to report: finish builds again.
        let _ = ws.mlcp.matrix_for(
            model,
            &self.state,
            &ws.contacts,
            &ws.minv,
            matrix_free(&model.params, &ws.contacts),
        );
        self.early_assembly = lap.lap();
    }

    /// The rest of the step, with the inputs as they are now. On failure the
    /// state is left unchanged and the report says why.
    pub fn finish(&mut self) -> StepReport {
        if let Some(report) = self.idle_step() {
            return report;
        }
        let began = self.take_inputs();
        self.prepare_contacts();
        let (mut report, mut clock) = self.open_report();
        let solved = self
            .solve(&mut report, &mut clock)
            .and_then(|()| self.integrate(&mut report));
        if began.impulses {
            self.inputs.clear_impulses();
        }
        if let Err(e) = solved {
            return self.failed(report, clock, e);
        }
        self.advance(&mut report);
        self.state.drifted.clone_from(&self.ws.drifted);
        self.sleep(&mut report);
        clock.timings.integrate = clock.lap.lap();
        let report = self.measure(report, clock);
        self.keep_if_idle(began, report)
    }
}

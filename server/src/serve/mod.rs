//! `cosim-server serve`: the engine behind iceoryx2 services, stepping in
//! lockstep with its controllers.
//!
//! Per step k (the state after k steps):
//! 1. publish state k and wake the readers;
//! 2. `Engine::prepare` (collision, contact set) while the controllers
//!    think;
//! 3. gather the inputs answering step k until every joined controller
//!    has answered or the deadline passes; control requests are served in
//!    the same loop;
//! 4. misses: the policy's input, dead-node check, drop;
//! 5. the net inputs into the engine, `Engine::finish`, the outputs.
//!
//! The engine stays a pure library: every file and every IPC call is here.

mod advance;
pub mod bench;
pub mod controllers;
pub mod frame;
mod inputs;
pub mod log;
mod pace;
pub mod replay;
mod requests;
pub mod services;
pub mod stats;
pub mod summarize;

use crate::engine::{Engine, Model, State, StepReport};
use crate::output::Writers;
use controllers::{MissPolicy, Slot};
use cosim_client::WaitMode;
use cosim_shared::wire::*;
use cosim_shared::Scene;
use nalgebra::Vector3;
use pace::Pace;
use services::{Request, ServiceError, Services};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// How a serve run is set up.
#[derive(Debug, Clone)]
pub struct ServeOptions {
    pub name: String,
    /// Wait for this many controllers before the first step.
    pub controllers: usize,
    pub deadline: Duration,
    pub on_miss: MissPolicy,
    pub on_failure: controllers::FailurePolicy,
    pub wait: WaitMode,
    /// Consecutive misses after which a live but silent controller is
    /// dropped.
    pub drop_after: u32,
    /// Stop after this many steps (None: until shutdown).
    pub steps: Option<u64>,
    /// Pace at this multiple of real time (None: as fast as possible).
    pub realtime: Option<f64>,
    /// Output folder; None writes nothing (a long-running server, or a
    /// benchmark that measures the loop alone).
    pub out: Option<PathBuf>,
    pub quiet: bool,
    /// Keep each step's start (seconds since the Unix epoch, a clock other
    /// processes share) and wall time in `Counters::timeline`, up to
    /// `steps` of them (allocated before the first step): for a benchmark
    /// that compares windows of one run.
    pub timeline: bool,
    /// Also publish every N-th step's frame (and the last) on the
    /// decimated stream `cosim/NAME/state-every` (`--publish-every N`).
    pub publish_every: Option<u64>,
    /// Write the per-step files (states, joints, impulses, step reports)
    /// for every N-th step, the last, and every failed or fallen-back
    /// step; `replay.csv` and `inputs.csv` keep every step.
    pub record_every: u64,
    /// Write into an `out` that holds an earlier run (else refused).
    pub overwrite: bool,
}

/// How often a late controller is checked for having exited (its
/// publisher gone or its node dead): short beside any deadline a user
/// sets, long beside an answer in time (microseconds), so that the check
/// (a read of the node list, tens of microseconds) costs nothing then.
const DEPARTURE_CHECK: Duration = Duration::from_millis(10);

/// Microseconds from `a` to `b`.
fn us(a: Instant, b: Instant) -> f64 {
    (b - a).as_secs_f64() * 1e6
}

/// Seconds since the Unix epoch: a clock other processes read too (the
/// timeline of `ServeOptions::timeline` and the bench's peers).
pub(crate) fn epoch_seconds() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// How a serve run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ending {
    /// `--steps` reached.
    Steps,
    /// A shutdown request.
    Shutdown,
    /// SIGINT or SIGTERM.
    Signal,
    /// A deadline miss under `--on-miss abort`.
    Aborted,
    /// A failed step under `--on-failure abort`.
    Failed,
}

/// Errors that stop a serve run before or during it.
#[derive(Debug)]
pub enum ServeError {
    Services(ServiceError),
    /// The scene's state frame is larger than a served scene's may be.
    TooLarge {
        bytes: usize,
        max: usize,
    },
    Io(std::io::Error),
    /// The output folder holds an earlier run (and `--overwrite` was not
    /// given).
    Occupied(PathBuf),
}

impl std::fmt::Display for ServeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ServeError::Services(e) => write!(f, "{e}"),
            ServeError::Occupied(p) => write!(
                f,
                "{} holds an earlier run; choose another --out, or add --overwrite",
                p.display()
            ),
            ServeError::TooLarge { bytes, max } => write!(
                f,
                "the scene's state frame takes {bytes} bytes; a served scene's may take at most {max} (its bodies, joints and contacts, see docs/protocol.md)"
            ),
            ServeError::Io(e) => write!(f, "{e}"),
        }
    }
}

impl From<ServiceError> for ServeError {
    fn from(e: ServiceError) -> Self {
        ServeError::Services(e)
    }
}
impl From<std::io::Error> for ServeError {
    fn from(e: std::io::Error) -> Self {
        ServeError::Io(e)
    }
}

/// The files of a run with an output folder.
struct Files {
    writers: Writers,
    logs: log::Logs,
}

/// What a run counted; it becomes `summary.json`.
#[derive(Debug, Default, Clone)]
pub struct Counters {
    /// Steps taken (a failed step is not one: the state did not advance).
    pub steps: u64,
    /// Failed steps, each counted once (the policy pauses or stops the
    /// run, so a step is tried again only after a command).
    pub failures: u64,
    /// The last step tried failed and no step, reset or restore came
    /// after it (the last report is that step's; reset and restore clear
    /// it): the run ended on a failure (exit status 1). A run that failed
    /// and went on is a recovered one (exit 0, `failures` counts).
    pub unrecovered: bool,
    /// The solve ladder's counts, fallbacks included (`engine::solver::fallback`).
    pub ladder: crate::engine::LadderCounts,
    pub controllers_joined: u64,
    /// Dropped for any reason: dead, gone, or silent for `--drop-after`
    /// deadlines.
    pub controllers_dropped: u64,
    /// Of those, the ones that exited without `leave` and were noticed
    /// before their deadline (`Server::drop_departed`).
    pub controllers_departed: u64,
    pub inputs_applied: u64,
    pub inputs_rejected: BTreeMap<&'static str, u64>,
    pub deadline_misses: u64,
    /// Publish of state k to the last input of step k (us), per step with
    /// controllers.
    pub round_trips: stats::Histogram,
    /// Engine compute per step (us).
    pub step_compute: stats::Histogram,
    /// `Engine::prepare` per step (us), overlapped with the controllers.
    pub prepare: stats::Histogram,
    /// Where a step's wall time goes (us per step): control requests at
    /// the boundary, waiting for the inputs after `prepare`, the inputs
    /// into the engine and the outputs around `finish`, and publishing.
    pub phases: Phases,
    /// Wall time from the first step's start to the end of the loop (s):
    /// `wall_seconds` less the wait for the controllers to join.
    pub stepping_seconds: f64,
    pub max_penetration: f64,
    pub max_joint_error: f64,
    pub max_joint_angle_error: f64,
    pub energy: crate::output::EnergyTally,
    /// Contacts projected out of deep penetration (as `run` counts them).
    pub projected_contacts: u64,
    /// Joint-steps whose held effort (the controllers' net torque) its
    /// bound clamped (`JointDesc::max_effort`).
    pub clamped_efforts: u64,
    /// Steps whose first solve used the matrix `Engine::prepare` made
    /// while the controllers computed (`StepReport::early_matrix`).
    pub early_matrix_steps: u64,
    /// With `ServeOptions::timeline`: (start since the epoch in s, wall
    /// time in us) of each step.
    pub timeline: Vec<(f64, f32)>,
}

/// The serve loop's phases besides the engine's compute (see
/// [`Counters::phases`]).
#[derive(Debug, Default, Clone)]
pub struct Phases {
    pub boundary: stats::Histogram,
    pub wait: stats::Histogram,
    pub around_step: stats::Histogram,
    pub publish: stats::Histogram,
    /// Wall time of each loop iteration (a step with everything around it):
    /// its median is robust to the preemptions that move a run's mean.
    pub step_wall: stats::Histogram,
}

/// What the control loop decided.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Flow {
    Go,
    Stop(Ending),
}

struct Server {
    opts: ServeOptions,
    svc: Services,
    engine: Engine,
    initial: State,
    snapshots: Vec<State>,
    toml: String,
    model_hash: u64,
    slots: Vec<Slot>,
    next_id: u32,
    /// The step last sent on the decimated stream.
    every_step: Option<u64>,
    /// Ids of the monitors that joined (see `join`).
    monitors: Vec<u32>,
    paused: bool,
    /// Steps left of a `step N` command.
    budget: Option<u64>,
    /// Requests that change the state wait for the step boundary.
    deferred: Vec<Request>,
    shutdown: bool,
    /// The frame published last; its buffers are reused.
    frame: StateFrame,
    /// Contacts a frame carries at most (`wire::contact_capacity`).
    contact_capacity: usize,
    /// The input read last; its buffers are reused.
    input: InputFrame,
    /// When the step loop started (after the controllers joined).
    stepping: Option<Instant>,
    sequence: u64,
    status: u32,
    last_report: Option<StepReport>,
    files: Option<Files>,
    /// The torque last given to the engine, per joint (replay logs changes).
    applied: Vec<[f64; 3]>,
    scene_torque: Vec<[f64; 3]>,
    /// Per joint: whether it has a motor, the scene's target, and the
    /// target last given to the engine (replay logs changes).
    motored: Vec<bool>,
    scene_motor: Vec<f64>,
    applied_motor: Vec<f64>,
    c: Counters,
    /// A failed step under `--on-failure abort`: the loop stops.
    failed_stop: bool,
    /// The last frame (with `STATUS_SHUTDOWN`) went out with the final
    /// state already.
    final_published: bool,
    /// When the last frame of the current state went out.
    frame_out: Instant,
    /// The step whose state the files hold last (`--record-every`).
    last_written: Option<u64>,
    /// Senders (input publisher, reason) of rejected inputs that are no
    /// joined controller, logged once each (at most 64 kept).
    unjoined_logged: Vec<(u128, u32)>,
    /// The hybrid wait's rule for the inputs (`cosim_client::SpinRule`).
    spin: cosim_client::SpinRule,
}

/// Runs a server on `scene` until `--steps`, a shutdown request or a
/// signal.
pub fn serve(scene: &Scene, opts: ServeOptions) -> Result<(Counters, Ending, f64), ServeError> {
    let mut model = Model::from_scene(scene);
    model.params.fallback = opts.on_failure == controllers::FailurePolicy::Continue;
    let frame_words = frame::max_words(&model);
    let bytes = std::mem::size_of::<StateHeader>() + 8 * frame_words;
    if bytes > MAX_FRAME_BYTES {
        return Err(ServeError::TooLarge {
            bytes,
            max: MAX_FRAME_BYTES,
        });
    }
    let contact_capacity = frame::contact_capacity(&model);
    let toml = scene.to_toml();
    // NOTE: the name first: a server refused because another of its name
    // runs must not touch that one's folder (issue 15: a refused server
    // rewrote scene.toml and the first run's replay failed at step 1).
    let svc = Services::create(&opts.name, opts.publish_every.is_some(), frame_words)?;
    if let Some(out) = &opts.out {
        if !opts.overwrite && crate::output::holds_run(out) {
            return Err(ServeError::Occupied(out.clone()));
        }
        std::fs::create_dir_all(out)?;
        std::fs::write(out.join("scene.toml"), &toml)?;
    }
    let files = match &opts.out {
        Some(out) => Some(Files {
            writers: Writers::create(out)?,
            logs: log::Logs::create(out)?,
        }),
        None => None,
    };
    let engine = Engine::new(model);
    let scene_torque: Vec<[f64; 3]> = engine
        .model()
        .joints
        .iter()
        .map(|j| j.effort.into())
        .collect();
    let motored = engine.model().motored();
    let scene_motor = engine.inputs().motor_speed.clone();
    let mut s = Server {
        initial: engine.state().clone(),
        snapshots: Vec::new(),
        model_hash: fnv1a(toml.as_bytes()),
        toml,
        slots: Vec::with_capacity(MAX_CONTROLLERS),
        next_id: 1,
        every_step: None,
        monitors: Vec::new(),
        paused: false,
        budget: None,
        deferred: Vec::new(),
        shutdown: false,
        frame: StateFrame::default(),
        contact_capacity,
        input: InputFrame::default(),
        stepping: None,
        sequence: 0,
        status: 0,
        last_report: None,
        files,
        applied: scene_torque.clone(),
        scene_torque,
        motored,
        applied_motor: scene_motor.clone(),
        scene_motor,
        c: Counters {
            energy: crate::output::EnergyTally::start(
                crate::engine::measure::energy(engine.model(), engine.state()).total,
            ),
            ..Counters::default()
        },
        failed_stop: false,
        final_published: false,
        frame_out: Instant::now(),
        last_written: None,
        unjoined_logged: Vec::with_capacity(64),
        spin: Default::default(),
        engine,
        svc,
        opts,
    };
    let started = Instant::now();
    let ending = s.run();
    let wall = started.elapsed().as_secs_f64();
    s.c.stepping_seconds = s.stepping.map_or(0.0, |t| t.elapsed().as_secs_f64());
    // The last frame tells every reader the server is gone.
    if !s.final_published {
        s.status |= STATUS_SHUTDOWN;
        let _ = s.publish();
    }
    // Answers that arrived after the last step (to a frame published
    // before a shutdown request or a signal) are logged and counted, not
    // dropped silently.
    s.drain_inputs();
    // The final state, where `--record-every` skipped it (a run stopped by
    // a signal or a shutdown request).
    if let Some(r) = s.last_report {
        if s.last_written != Some(s.engine.state().step) && r.ok() {
            s.write_step(&r)?;
        }
    }
    if let Some(f) = s.files.as_mut() {
        f.writers.flush()?;
        f.logs.flush()?;
    }
    let ending = ending?;
    s.c.unrecovered = s.last_report.is_some_and(|r| r.error.is_some());
    s.write_summary(ending, wall)?;
    Ok((s.c.clone(), ending, wall))
}

pub(crate) fn terminated() -> bool {
    iceoryx2_bb_posix::signal::SignalHandler::termination_requested()
}

impl Server {
    fn run(&mut self) -> Result<Ending, ServeError> {
        if let Some(f) = self.files.as_mut() {
            f.writers.state(&self.engine)?;
            self.last_written = Some(self.engine.state().step);
        }
        if self.opts.controllers > 0 {
            self.status |= STATUS_WAITING;
        }
        self.publish()?;
        if !self.opts.quiet {
            let h = self.engine.model().params.h;
            eprintln!(
                "serving '{}' on cosim/{}/ ({} bodies, {} joints, h = {} s)",
                self.engine.model().name,
                self.opts.name,
                self.engine.model().bodies.len(),
                self.engine.model().joints.len(),
                h,
            );
            eprintln!(
                "{}",
                match self.opts.steps {
                    Some(n) => format!(
                        "ends after {n} steps ({} s simulated; --steps, --duration or --forever to change)",
                        cosim_shared::num(n as f64 * h)
                    ),
                    None => "no end (--forever): serves until `cosim shutdown`, Ctrl-C or SIGTERM".into(),
                }
            );
            match &self.opts.out {
                Some(out) => eprintln!(
                    "recording to {}: {}, and every step's inputs and state hash for replay",
                    out.display(),
                    match self.opts.record_every {
                        1 => "states, joints, impulses and step reports of every step".to_string(),
                        n => format!("states, joints, impulses and step reports of every {n}th step (--record-every 1 for all)"),
                    }
                ),
                None => eprintln!("recording nothing (--no-record)"),
            }
            if self.opts.controllers > 0 {
                eprintln!(
                    "waiting for {} controller{} to join",
                    self.opts.controllers,
                    if self.opts.controllers == 1 { "" } else { "s" }
                );
            }
        }
        // Before the first step: wait for the controllers asked for.
        while self.slots.len() < self.opts.controllers {
            if let Flow::Stop(e) = self.serve_requests(false)? {
                return Ok(e);
            }
            if terminated() {
                return Ok(Ending::Signal);
            }
            self.svc.block(Duration::from_millis(50))?;
        }
        if self.status & STATUS_WAITING != 0 {
            self.status &= !STATUS_WAITING;
            self.publish()?;
        }
        let mut pace = Pace::new(self.opts.realtime, self.engine.state().t);
        // One clock read per phase boundary (a read is about 30 ns here):
        // the end of one phase is the start of the next, and the end of a
        // step's publish is the next step's top.
        let mut top = Instant::now();
        let start = top;
        // When the frame the controllers answer went out: the round trip's
        // start (issue 15: timed from the loop's boundary instead, a round
        // trip read 2.9-4.5 us against 87-194 us of wall time per step with
        // server and controller on one core, where the controller runs
        // between the publish and the boundary).
        self.frame_out = top;
        self.stepping = Some(start);
        let epoch0 = epoch_seconds();
        if self.opts.timeline {
            self.c.timeline = Vec::with_capacity(self.opts.steps.unwrap_or(0) as usize);
        }
        let mut last_top: Option<Instant> = None;
        let mut progress = crate::progress::Progress::new(self.opts.quiet, self.opts.steps);
        loop {
            if terminated() {
                return Ok(Ending::Signal);
            }
            if let Some(last) = last_top.replace(top) {
                self.c.phases.step_wall.add(us(last, top));
                // Within the capacity reserved above: no allocation.
                let t = &mut self.c.timeline;
                if t.len() < t.capacity() {
                    t.push((epoch0 + (last - start).as_secs_f64(), us(last, top) as f32));
                }
            }
            if let Flow::Stop(e) = self.boundary()? {
                return Ok(e);
            }
            let published = Instant::now();
            self.c.phases.boundary.add(us(top, published));
            if self.opts.steps.is_some_and(|n| self.c.steps >= n) {
                return Ok(Ending::Steps);
            }
            if self.paused {
                self.svc.block(Duration::from_millis(50))?;
                pace = Pace::new(self.opts.realtime, self.engine.state().t);
                top = Instant::now();
                continue;
            }
            let k = self.engine.state().step;
            self.engine.prepare();
            let t_wait = Instant::now();
            self.c.prepare.add(us(published, t_wait));
            let t_step = match self.gather(k, published)? {
                (Flow::Go, t) => t,
                (Flow::Stop(e), _) => return Ok(e),
            };
            self.c.phases.wait.add(us(t_wait, t_step));
            if self.paused {
                // --on-miss pause: this step waits for `resume`.
                self.frame_out = Instant::now();
                self.publish()?;
                top = Instant::now();
                continue;
            }
            let compute = self.take_step(k)?;
            let (joined, misses) = (self.slots.len(), self.c.deadline_misses);
            progress.tick(self.c.steps, || {
                format!(", {joined} controllers, {misses} deadline misses")
            });
            if self.failed_stop {
                self.publish()?;
                return Ok(Ending::Failed);
            }
            if self.opts.steps.is_some_and(|n| self.c.steps >= n) {
                // The final state goes out once, with the last-frame bit:
                // published without it, a controller would answer a step
                // that is never taken (issue 15, defect 7).
                self.status |= STATUS_SHUTDOWN;
                // --realtime: the run lasts its simulated time, as before.
                pace.wait(self.engine.state().t);
                self.publish()?;
                self.final_published = true;
                return Ok(Ending::Steps);
            }
            let t_publish = Instant::now();
            self.c
                .phases
                .around_step
                .add(us(t_step, t_publish) - compute);
            if let Some(b) = self.budget.as_mut() {
                *b = b.saturating_sub(1);
                if *b == 0 {
                    self.budget = None;
                    self.paused = true;
                }
            }
            // --realtime: state k goes out when it is due, so that the
            // round trip (from the publish) holds no pacing wait (issue
            // 46: paced after the publish, it held the whole wait).
            let t_publish = match pace.wait(self.engine.state().t) {
                true => Instant::now(),
                false => t_publish,
            };
            // The round trip starts before the send: the frame is visible
            // once the send is under way, and a server preempted between
            // the send and a clock read after it read a few us for a
            // controller's 0.3 ms (seen with every core busy).
            self.frame_out = Instant::now();
            self.publish()?;
            top = Instant::now();
            self.c.phases.publish.add(us(t_publish, top));
        }
    }

    /// Serves control requests, the deferred ones included; between steps.
    fn boundary(&mut self) -> Result<Flow, ServeError> {
        let flow = self.serve_requests(false)?;
        let deferred = std::mem::take(&mut self.deferred);
        let mut changed = false;
        for req in deferred {
            changed |= self.change_state(&req)?;
        }
        if changed {
            self.frame_out = Instant::now();
            self.publish()?;
        }
        if self.shutdown {
            return Ok(Flow::Stop(Ending::Shutdown));
        }
        Ok(flow)
    }

    /// Publishes the current state with the current status.
    fn publish(&mut self) -> Result<(), ServeError> {
        self.sequence += 1;
        let f = &mut self.frame;
        f.status = self.status;
        if self.opts.wait == WaitMode::Spin {
            f.status |= STATUS_SERVER_SPINS;
        }
        if self.paused {
            f.status |= STATUS_PAUSED;
        }
        frame::fill(
            f,
            &self.engine,
            self.last_report.as_ref(),
            self.contact_capacity,
        );
        f.sequence = self.sequence;
        f.model_hash = self.model_hash;
        f.controller_count = self.slots.len() as u32;
        f.controllers = [ControllerSlot::default(); MAX_CONTROLLERS];
        for (out, s) in f.controllers.iter_mut().zip(&self.slots) {
            *out = ControllerSlot {
                id: s.id,
                flags: SLOT_JOINED
                    | if s.missed_now { SLOT_MISSED } else { 0 }
                    | if s.answered == Some(f.step) {
                        SLOT_ANSWERED
                    } else {
                        0
                    },
                rejected: s.rejected,
                misses: s.misses,
                last_step: s.answered.unwrap_or(0),
            };
        }
        self.svc.publish(f)?;
        // The decimated stream: each N-th step once (a frame published
        // again for the same step, after a join or a pause, is not sent
        // twice), and the last frame whatever its step.
        if let Some(n) = self.opts.publish_every {
            let last = f.status & STATUS_SHUTDOWN != 0;
            if (f.step.is_multiple_of(n.max(1)) && self.every_step != Some(f.step)) || last {
                self.every_step = Some(f.step);
                self.svc.publish_every(f)?;
            }
        }
        Ok(())
    }
}

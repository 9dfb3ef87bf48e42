//! Lockstep runs of `bench ipc`: the server with its controller peers, and
//! a monitor's cost measured in windows of one run.

use super::*;

/// One lockstep measurement.
pub(super) struct Lockstep {
    /// The server name of the run.
    pub(super) name: String,
    pub(super) steps_per_s: f64,
    pub(super) round_trip_us: f64,
    pub(super) compute_us: f64,
    pub(super) compute_mean_us: f64,
    /// Wall time per step minus the mean compute (prepare + finish): what
    /// lockstep adds to a step.
    pub(super) overhead_us: f64,
    /// Means per step (us): boundary, prepare, wait, finish, around the
    /// step, publish.
    pub(super) phases: [f64; 6],
    /// Median wall time of a loop iteration (us).
    pub(super) median_step_us: f64,
    /// Each step's start (s since the epoch) and wall time (us), with a
    /// toggling monitor (see [`monitor_windows`]).
    pub(super) timeline: Vec<(f64, f32)>,
}

pub(super) fn lockstep(
    controllers: usize,
    mode: WaitMode,
    steps: u64,
    sidecar: Option<&str>,
) -> Result<Lockstep, BoxError> {
    lockstep_of(Client::Rust, controllers, mode, steps, sidecar)
}

pub(super) fn lockstep_of(
    client: Client,
    controllers: usize,
    mode: WaitMode,
    steps: u64,
    sidecar: Option<&str>,
) -> Result<Lockstep, BoxError> {
    lockstep_on(client, controllers, mode, steps, sidecar, None)
}

/// [`lockstep_of`] with the controllers on `cores` (a taskset list)
/// instead of core 1 for one and every core for several.
pub(super) fn lockstep_on(
    client: Client,
    controllers: usize,
    mode: WaitMode,
    steps: u64,
    sidecar: Option<&str>,
    cores: Option<&str>,
) -> Result<Lockstep, BoxError> {
    let mut name = run_name(controllers, mode, sidecar);
    if client == Client::Python {
        name.push_str("-py");
    }
    // A run of a million steps is Lemke's alone: the solve ladder takes
    // the reference scene through 10^6 steps (every_step_succeeds.rs).
    let scene = cosim_shared::scenes::reference()?;
    let opts = ServeOptions {
        name: name.clone(),
        controllers,
        deadline: Duration::from_secs(5),
        on_miss: crate::serve::controllers::MissPolicy::Hold,
        on_failure: crate::serve::controllers::FailurePolicy::Continue,
        wait: mode,
        drop_after: 3,
        steps: Some(steps),
        realtime: None,
        // The loop alone: the files are a cost of their own.
        out: None,
        quiet: true,
        timeline: sidecar.is_some_and(|r| r.ends_with("-toggle")),
        publish_every: None,
        record_every: 1,
        overwrite: true,
    };
    let server = std::thread::spawn(move || serve(&scene, opts).map_err(|e| e.to_string()));
    // Peers retry until the server's services exist.
    let mut peers = Vec::new();
    for _ in 0..controllers {
        // One controller gets core 1; several share every core.
        let cores = match cores {
            Some(c) => c.to_string(),
            None if controllers == 1 => "1".to_string(),
            None => all_cores(),
        };
        peers.push(match client {
            Client::Rust => peer_on(
                &cores,
                &["controller", "--name", &name, "--wait", mode.as_str()],
            )?,
            Client::Python => python_peer_on(&cores, &name, mode)?,
        });
    }
    if let Some(role) = sidecar {
        peers.push(peer_on(
            &all_cores(),
            &[role, "--name", &name, "--wait", "block"],
        )?);
    }
    let (mut c, _, _) = server.join().map_err(|_| "the server thread panicked")??;
    // From the first step: the controllers' start-up is not lockstep.
    let wall = c.stepping_seconds;
    drop(peers);
    let nan = f64::NAN;
    let compute_mean_us = c.step_compute.mean().unwrap_or(nan);
    let prepare_mean = c.prepare.mean().unwrap_or(nan);
    let m = |h: &crate::serve::stats::Histogram| h.mean().unwrap_or(nan);
    Ok(Lockstep {
        name,
        median_step_us: c.phases.step_wall.quantile(0.5).unwrap_or(nan),
        phases: [
            m(&c.phases.boundary),
            prepare_mean,
            m(&c.phases.wait),
            compute_mean_us,
            m(&c.phases.around_step),
            m(&c.phases.publish),
        ],
        overhead_us: wall / c.steps.max(1) as f64 * 1e6 - compute_mean_us - prepare_mean,
        compute_mean_us,
        steps_per_s: c.steps as f64 / wall,
        round_trip_us: c.round_trips.quantile(0.5).unwrap_or(nan),
        compute_us: c.step_compute.quantile(0.5).unwrap_or(nan),
        timeline: std::mem::take(&mut c.timeline),
    })
}

impl Lockstep {
    /// This measurement's row of the table, labelled `lockstep, WHAT`.
    pub(super) fn row(&self, what: &str) -> String {
        format!(
            "| lockstep, {what} | {:.0} | {:.2} | {:.2} / {:.2} | {:.2} |\n",
            self.steps_per_s,
            self.round_trip_us,
            self.compute_us,
            self.compute_mean_us,
            self.overhead_us
        )
    }
}

/// The server name of a lockstep run: unique per bench process and run
/// (a run repeated under one name could meet the last one's services
/// still being torn down: iceoryx2's `IsMarkedForDestruction`).
pub(super) fn run_name(controllers: usize, mode: WaitMode, sidecar: Option<&str>) -> String {
    static RUNS: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let run = RUNS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    format!(
        "bench-{}-{run}-{controllers}-{}-{}",
        std::process::id(),
        mode.as_str(),
        sidecar.unwrap_or("none")
    )
}

/// Where the toggling peer writes its windows (one line `start end
/// idle_end` per attach, seconds since the epoch: attached from start to
/// end, then detached and idle until idle_end).
pub(super) fn intervals_file(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("cosim-bench-{name}.intervals"))
}

/// Attached and detached windows, in `WINDOW` seconds each, with this
/// margin cut off both ends (attaching makes the server map the new
/// subscriber's connection once).
pub(super) const WINDOW: f64 = 0.1;

pub(super) const MARGIN: f64 = 0.02;

/// A monitor's cost measured inside one run: the monitor process attaches
/// (`Monitor::polling`, newest frame at 10 Hz) and detaches every
/// [`WINDOW`], and each attached window is compared with the detached one
/// right after it, by the steps per second and the median step in each.
/// Why: between separate runs this machine's noise (other tenants' load,
/// moving over seconds) spans +-10 %, more than the 5 % to be shown; two
/// adjacent windows of 0.1 s share most of it (0.3 s windows gave a third
/// of the pairs and wider quartiles). Returns the ratios, attached over
/// detached, of each pair: steps per second, and median step.
/// `role` is the toggling peer: `monitor-toggle` (`cosim monitor`) or
/// `view-toggle` (`cosim view` with a Foxglove client subscribed).
pub(super) fn monitor_windows(
    mode: WaitMode,
    steps: u64,
    role: &str,
) -> Result<(Vec<f64>, Vec<f64>), BoxError> {
    let l = lockstep(1, mode, steps, Some(role))?;
    let file = intervals_file(&l.name);
    let text = std::fs::read_to_string(&file).unwrap_or_default();
    let _ = std::fs::remove_file(&file);
    // Per line: attached from a to b, then detached from b to c (the peer
    // idle; its next attach, which asks the server for the scene or maps
    // a new port, comes after c).
    let windows: Vec<(f64, f64, f64)> = text
        .lines()
        .filter_map(|l| {
            let mut it = l.split_whitespace().map(|x| x.parse::<f64>());
            match (it.next(), it.next(), it.next()) {
                (Some(Ok(a)), Some(Ok(b)), Some(Ok(c))) => Some((a, b, c)),
                _ => None,
            }
        })
        .collect();
    // Steps whose start lies in [a + MARGIN, b - MARGIN]: rate and median.
    let window = |a: f64, b: f64| -> Option<(f64, f64)> {
        let (a, b) = (a + MARGIN, b - MARGIN);
        let lo = l.timeline.partition_point(|s| s.0 < a);
        let hi = l.timeline.partition_point(|s| s.0 < b);
        if hi <= lo + 100 {
            return None;
        }
        let mut walls: Vec<f64> = l.timeline[lo..hi].iter().map(|s| f64::from(s.1)).collect();
        Some(((hi - lo) as f64 / (b - a), median(&mut walls)))
    };
    let (mut rate, mut step) = (Vec::new(), Vec::new());
    for &(a, b, c) in &windows {
        if let (Some(on), Some(off)) = (window(a, b), window(b, c)) {
            rate.push(on.0 / off.0);
            step.push(on.1 / off.1);
        }
    }
    Ok((rate, step))
}

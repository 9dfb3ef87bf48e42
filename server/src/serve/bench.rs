//! `cosim-server bench ipc`: what lockstep costs, measured in one run.
//!
//! - the limit: a raw iceoryx2 ping-pong of a state frame and an input
//!   frame between two processes (spinning, and blocking on events);
//! - lockstep steps per second on the reference scene with 1, 2 and 4
//!   controller processes in spin, block and hybrid waiting;
//! - a monitor's cost, from windows of one run with it attached and
//!   detached ([`monitor_windows`]), the same for the live view (`cosim
//!   view` serving a Foxglove client), and a recorder process reading
//!   every frame;
//! - the baseline: the same lockstep over a TCP loopback socket, what a
//!   socket-based (gRPC-style) co-simulation pays at the least.
//!
//! Controllers and peers are this program started again with the hidden
//! `bench-peer` subcommand, so every figure crosses a process boundary.

use super::{epoch_seconds, serve, ServeOptions};
use crate::engine::{Engine, Model};
use cosim_client::{Controller, InputFrame, Monitor, WaitMode};
use cosim_shared::wire::{send_words, InputHeader, StateFrame, StateHeader, WordSink};
use iceoryx2::prelude::*;
use std::io::{Read, Write};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A child killed when dropped.
struct Peer(Child);
impl Drop for Peer {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Whether this process pinned itself to core 0 (see [`pin_self`]); then
/// peers are started on the cores [`peer_on`] is given.
static PINNED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Pins this process's main thread (and so the server thread it starts
/// later) to core 0 with `taskset`, when there are two cores or more and
/// the tool exists. Why: spinning lockstep assumes a core per process, and
/// unpinned, the scheduler's migrations between runs were larger than the
/// effects measured (a monitor's few percent).
fn pin_self(cores: usize) -> bool {
    let ok = cores >= 2
        && Command::new("taskset")
            .args(["-p", "-c", "0", &std::process::id().to_string()])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
    PINNED.store(ok, std::sync::atomic::Ordering::Relaxed);
    ok
}

/// Every core, as a taskset list.
fn all_cores() -> String {
    let n = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("0-{}", n.saturating_sub(1))
}

/// A peer on core 1 (the one other process of a two-process measurement).
fn peer(args: &[&str]) -> std::io::Result<Peer> {
    peer_on("1", args)
}

/// A peer on `cores` (a taskset list) when this process is pinned, else
/// wherever the scheduler puts it.
fn peer_on(cores: &str, args: &[&str]) -> std::io::Result<Peer> {
    let exe = std::env::current_exe()?;
    let mut cmd = if PINNED.load(std::sync::atomic::Ordering::Relaxed) {
        let mut c = Command::new("taskset");
        c.arg("-c").arg(cores).arg(exe);
        c
    } else {
        Command::new(exe)
    };
    cmd.arg("bench-peer")
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .map(Peer)
}

/// Who answers the lockstep: this program's Rust controller, or the
/// Python package's (`python3 -m cosim.peer`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Client {
    Rust,
    Python,
}

/// A Python controller of the `cosim` package on `cores`, as `peer_on`
/// places this program's peers.
fn python_peer_on(cores: &str, name: &str, mode: WaitMode) -> std::io::Result<Peer> {
    let mut cmd = if PINNED.load(std::sync::atomic::Ordering::Relaxed) {
        let mut c = Command::new("taskset");
        c.args(["-c", cores, "python3"]);
        c
    } else {
        Command::new("python3")
    };
    cmd.args(["-m", "cosim.peer", name, mode.as_str()])
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .map(Peer)
}

/// Whether `python3` imports the `cosim` package (`pip install ./python`).
fn python_package() -> bool {
    Command::new("python3")
        .args(["-c", "import cosim"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

type BoxError = Box<dyn std::error::Error>;

fn svc(name: &str) -> Result<ServiceName, BoxError> {
    Ok(name.try_into().map_err(|e| format!("{e:?}"))?)
}

fn e<E: std::fmt::Debug>(e: E) -> BoxError {
    format!("{e:?}").into()
}

/// The four services of the raw ping-pong, opened (or created) alike by
/// both sides: states go out on `ping`, inputs come back on `pong`, so both
/// payload types cross, as in lockstep.
struct PingPong {
    /// Owns the services; it lives as long as its ports.
    _node: Node<ipc::Service>,
    ping: iceoryx2::service::port_factory::publish_subscribe::PortFactory<
        ipc::Service,
        [u64],
        StateHeader,
    >,
    pong: iceoryx2::service::port_factory::publish_subscribe::PortFactory<
        ipc::Service,
        [u64],
        InputHeader,
    >,
    ping_ev: iceoryx2::service::port_factory::event::PortFactory<ipc::Service>,
    pong_ev: iceoryx2::service::port_factory::event::PortFactory<ipc::Service>,
}

impl PingPong {
    fn open(base: &str) -> Result<PingPong, BoxError> {
        let node = NodeBuilder::new().create::<ipc::Service>().map_err(e)?;
        let event = |s: &str| {
            node.service_builder(&svc(&format!("{base}/{s}"))?)
                .event()
                .open_or_create()
                .map_err(e)
        };
        Ok(PingPong {
            ping: node
                .service_builder(&svc(&format!("{base}/ping"))?)
                .publish_subscribe::<[u64]>()
                .user_header::<StateHeader>()
                .open_or_create()
                .map_err(e)?,
            pong: node
                .service_builder(&svc(&format!("{base}/pong"))?)
                .publish_subscribe::<[u64]>()
                .user_header::<InputHeader>()
                .open_or_create()
                .map_err(e)?,
            ping_ev: event("ping-ev")?,
            pong_ev: event("pong-ev")?,
            _node: node,
        })
    }
}

/// Waits for the next message the way `mode` says (spinning is the
/// caller's loop).
fn idle(mode: WaitMode, listen: &iceoryx2::port::listener::Listener<ipc::Service>) {
    if mode == WaitMode::Block {
        let _ = listen.timed_wait(|_| {}, Duration::from_millis(100));
    } else {
        std::hint::spin_loop();
    }
}

/// The echo side of the raw ping-pong.
fn ponger(base: &str, mode: WaitMode) -> Result<(), BoxError> {
    let p = PingPong::open(base)?;
    let sub = p.ping.subscriber_builder().create().map_err(e)?;
    let publ = p
        .pong
        .publisher_builder()
        .initial_max_slice_len(1)
        .create()
        .map_err(e)?;
    let listen = p.ping_ev.listener_builder().create().map_err(e)?;
    let notify = p.pong_ev.notifier_builder().create().map_err(e)?;
    let mut reply = InputFrame::default();
    let mut got = StateFrame::default();
    loop {
        if let Some(s) = sub.receive().map_err(e)? {
            // Read as a controller reads a frame.
            got.read(s.user_header(), s.payload()).map_err(e)?;
            if got.step == u64::MAX {
                return Ok(());
            }
            reply.step = got.step;
            send_words(&publ, reply.header(), reply.words(), |w| reply.encode(w)).map_err(e)?;
            notify.notify().map_err(e)?;
            continue;
        }
        idle(mode, &listen);
    }
}

/// Median round trip (us) of `n` raw ping-pongs.
fn raw_pingpong(mode: WaitMode, n: usize) -> Result<f64, BoxError> {
    let base = format!("cosim-bench-{}-{}", std::process::id(), mode.as_str());
    let p = PingPong::open(&base)?;
    // The reference scene's frame as the server publishes it.
    let engine = Engine::new(Model::from_scene(&cosim_shared::scenes::reference()?));
    let capacity = super::frame::contact_capacity(engine.model());
    let mut frame = StateFrame::default();
    super::frame::fill(&mut frame, &engine, None, capacity);
    let out = p
        .ping
        .publisher_builder()
        .initial_max_slice_len(super::frame::max_words(engine.model()))
        .create()
        .map_err(e)?;
    let inp = p.pong.subscriber_builder().create().map_err(e)?;
    let send = |frame: &StateFrame| {
        send_words(&out, frame.header(), frame.words(), |w| frame.encode(w)).map_err(e)
    };
    let notify = p.ping_ev.notifier_builder().create().map_err(e)?;
    let listen = p.pong_ev.listener_builder().create().map_err(e)?;
    let _peer = peer(&["pong", "--name", &base, "--wait", mode.as_str()])?;
    let mut times = Vec::with_capacity(n);
    // Until the ponger is subscribed, pings are lost: resend until a pong.
    let start = Instant::now();
    'warm: loop {
        frame.step = 0;
        send(&frame)?;
        notify.notify().map_err(e)?;
        let t = Instant::now();
        while t.elapsed() < Duration::from_millis(20) {
            if inp.receive().map_err(e)?.is_some() {
                break 'warm;
            }
        }
        if start.elapsed() > Duration::from_secs(20) {
            return Err("the ping-pong peer did not answer".into());
        }
    }
    for k in 1..=n as u64 {
        frame.step = k;
        let t0 = Instant::now();
        send(&frame)?;
        notify.notify().map_err(e)?;
        loop {
            if let Some(s) = inp.receive().map_err(e)? {
                if s.user_header().step == k {
                    break;
                }
                continue;
            }
            idle(mode, &listen);
        }
        times.push(t0.elapsed().as_secs_f64() * 1e6);
    }
    frame.step = u64::MAX;
    send(&frame)?;
    Ok(median(&mut times))
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// One lockstep measurement.
struct Lockstep {
    /// The server name of the run.
    name: String,
    steps_per_s: f64,
    round_trip_us: f64,
    compute_us: f64,
    compute_mean_us: f64,
    /// Wall time per step minus the mean compute (prepare + finish): what
    /// lockstep adds to a step.
    overhead_us: f64,
    /// Means per step (us): boundary, prepare, wait, finish, around the
    /// step, publish.
    phases: [f64; 6],
    /// Median wall time of a loop iteration (us).
    median_step_us: f64,
    /// Each step's start (s since the epoch) and wall time (us), with a
    /// toggling monitor (see [`monitor_windows`]).
    timeline: Vec<(f64, f32)>,
}

fn lockstep(
    controllers: usize,
    mode: WaitMode,
    steps: u64,
    sidecar: Option<&str>,
) -> Result<Lockstep, BoxError> {
    lockstep_of(Client::Rust, controllers, mode, steps, sidecar)
}

fn lockstep_of(
    client: Client,
    controllers: usize,
    mode: WaitMode,
    steps: u64,
    sidecar: Option<&str>,
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
        on_miss: super::controllers::MissPolicy::Hold,
        on_failure: super::controllers::FailurePolicy::Continue,
        wait: mode,
        drop_after: 3,
        steps: Some(steps),
        realtime: None,
        // The loop alone: the files are a cost of their own.
        out: None,
        quiet: true,
        timeline: sidecar.is_some_and(|r| r.ends_with("-toggle")),
        publish_every: None,
    };
    let server = std::thread::spawn(move || serve(&scene, opts).map_err(|e| e.to_string()));
    // Peers retry until the server's services exist.
    let mut peers = Vec::new();
    for _ in 0..controllers {
        // One controller gets core 1; several share every core.
        let cores = if controllers == 1 {
            "1".to_string()
        } else {
            all_cores()
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
    let m = |h: &super::stats::Histogram| h.mean().unwrap_or(nan);
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
    fn row(&self, what: &str) -> String {
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
fn run_name(controllers: usize, mode: WaitMode, sidecar: Option<&str>) -> String {
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
fn intervals_file(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("cosim-bench-{name}.intervals"))
}

/// Attached and detached windows, in `WINDOW` seconds each, with this
/// margin cut off both ends (attaching makes the server map the new
/// subscriber's connection once).
const WINDOW: f64 = 0.1;
const MARGIN: f64 = 0.02;

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
fn monitor_windows(
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

/// Lockstep over TCP loopback: the server sends the state frame's bytes,
/// the controller answers with an input frame's bytes, per step.
/// Returns steps per second, the median round trip, the overhead per step
/// and the median wall time of a step (us).
fn tcp_lockstep(steps: u64) -> Result<(f64, f64, f64, f64), BoxError> {
    let listener = std::net::TcpListener::bind("127.0.0.1:0")?;
    let port = listener.local_addr()?.port().to_string();
    let _peer = peer(&["tcp", "--name", &port, "--wait", "block"])?;
    let (mut sock, _) = listener.accept()?;
    sock.set_nodelay(true)?;
    let mut engine = Engine::new(Model::from_scene(&cosim_shared::scenes::reference()?));
    let capacity = super::frame::contact_capacity(engine.model());
    let mut frame = StateFrame::default();
    let mut bytes = Vec::new();
    let mut input = vec![0u8; input_bytes()];
    let mut times = Vec::with_capacity(steps as usize);
    let mut compute = 0.0;
    let mut step_walls = Vec::with_capacity(steps as usize);
    let start = Instant::now();
    for _ in 0..steps {
        let top = Instant::now();
        super::frame::fill(&mut frame, &engine, None, capacity);
        let t0 = Instant::now();
        sock.write_all(state_bytes(&frame, &mut bytes))?;
        sock.read_exact(&mut input)?;
        times.push(t0.elapsed().as_secs_f64() * 1e6);
        let t1 = Instant::now();
        engine.step();
        compute += t1.elapsed().as_secs_f64();
        step_walls.push(top.elapsed().as_secs_f64() * 1e6);
    }
    let wall = start.elapsed().as_secs_f64();
    let over = (wall - compute) / steps as f64 * 1e6;
    Ok((
        steps as f64 / wall,
        median(&mut times),
        over,
        median(&mut step_walls),
    ))
}

/// A state frame as a socket carries it: its length, a header's worth
/// of bytes (the step first) and the payload words, as many bytes as the
/// shared-memory message has.
fn state_bytes<'a>(f: &StateFrame, out: &'a mut Vec<u8>) -> &'a [u8] {
    struct Bytes<'b>(&'b mut Vec<u8>);
    impl WordSink for Bytes<'_> {
        fn put(&mut self, word: u64) {
            self.0.extend_from_slice(&word.to_le_bytes());
        }
    }
    out.clear();
    let len = std::mem::size_of::<StateHeader>() + 8 * f.words();
    out.extend_from_slice(&(len as u64).to_le_bytes());
    out.extend_from_slice(&f.step.to_le_bytes());
    out.resize(8 + std::mem::size_of::<StateHeader>(), 0);
    f.encode(&mut Bytes(out));
    out
}

/// An empty input as a socket carries it: a header's worth of bytes.
fn input_bytes() -> usize {
    std::mem::size_of::<InputHeader>()
}

/// `bench-peer`: the other process of each measurement.
pub fn run_peer(role: &str, name: &str, mode: WaitMode) -> Result<(), BoxError> {
    match role {
        "pong" => ponger(name, mode),
        "controller" => {
            let patience = Duration::from_secs(30);
            let mut c = cosim_client::when_up(patience, || Controller::join(name, mode))?;
            let mut input = InputFrame::default();
            while c.next_state_ref(Duration::from_secs(30)).is_ok() {
                c.send_ref(&mut input)?;
            }
            Ok(())
        }
        // The recorder takes every frame, woken for each.
        "recorder" => {
            let m = cosim_client::when_up(Duration::from_secs(30), || Monitor::open(name, 64))?;
            while let Ok(f) = m.next(Duration::from_secs(30)) {
                if f.status & cosim_shared::wire::STATUS_SHUTDOWN != 0 {
                    break;
                }
            }
            Ok(())
        }
        // As `cosim monitor` (the newest frame, ten times a second) for a
        // window, detached for the next, until the server is gone; the
        // attached intervals go to `intervals_file`.
        "monitor-toggle" => {
            let mut out = std::fs::File::create(intervals_file(name))?;
            loop {
                let Ok(m) =
                    cosim_client::when_up(Duration::from_secs(5), || Monitor::polling(name))
                else {
                    return Ok(());
                };
                let start = epoch_seconds();
                while epoch_seconds() < start + WINDOW {
                    if m.node().wait(Duration::from_millis(100)).is_err() {
                        return Ok(());
                    }
                    if let Some(f) = m.latest()? {
                        if f.status & cosim_shared::wire::STATUS_SHUTDOWN != 0 {
                            return Ok(());
                        }
                    }
                }
                drop(m);
                let end = epoch_seconds();
                std::thread::sleep(Duration::from_secs_f64(WINDOW));
                writeln!(out, "{start} {end} {}", epoch_seconds())?;
                out.flush()?;
            }
        }
        // As `cosim view --rate 30` with a Foxglove client subscribed to
        // every channel, for a window, detached for the next, as
        // `monitor-toggle`. The window starts once the view has its
        // monitor and listens (its scene request to the server is before).
        "view-toggle" => {
            let mut out = std::fs::File::create(intervals_file(name))?;
            loop {
                // The server may not be up yet; once it is gone, done.
                let up = cosim_client::when_up(Duration::from_secs(5), || {
                    cosim_client::Connection::connect(name)
                });
                if up.is_err() {
                    return Ok(());
                }
                let (tx, rx) = std::sync::mpsc::channel();
                let vname = name.to_string();
                let view = std::thread::spawn(move || {
                    let opts = cosim_client::view::ViewOptions {
                        listen: "127.0.0.1:0".into(),
                        rate: 30.0,
                        seconds: Some(WINDOW),
                    };
                    cosim_client::view::view(&vname, &opts, |a| {
                        let _ = tx.send(a);
                    })
                    .map_err(|e| e.to_string())
                });
                // No address: the server is gone (the view failed).
                let Ok(addr) = rx.recv_timeout(Duration::from_secs(5)) else {
                    return Ok(());
                };
                let start = epoch_seconds();
                let client = std::thread::spawn(move || foxglove_client(addr));
                let done = view.join().map_err(|_| "the view panicked")?;
                let end = epoch_seconds();
                let _ = client.join();
                if done.is_err() {
                    return Ok(());
                }
                std::thread::sleep(Duration::from_secs_f64(WINDOW));
                writeln!(out, "{start} {end} {}", epoch_seconds())?;
                out.flush()?;
            }
        }
        "tcp" => {
            let mut sock = std::net::TcpStream::connect(("127.0.0.1", name.parse::<u16>()?))?;
            sock.set_nodelay(true)?;
            let mut len = [0u8; 8];
            let mut state = Vec::new();
            let reply = vec![0u8; input_bytes()];
            while sock.read_exact(&mut len).is_ok() {
                let n = usize::try_from(u64::from_le_bytes(len))?;
                state.resize(n, 0);
                sock.read_exact(&mut state)?;
                sock.write_all(&reply)?;
            }
            Ok(())
        }
        other => Err(format!("unknown bench peer role {other:?}").into()),
    }
}

/// A Foxglove client of `cosim view` at `addr`: subscribes to every
/// channel advertised and reads until the view closes the connection.
fn foxglove_client(addr: std::net::SocketAddr) -> Result<(), String> {
    use tungstenite::client::IntoClientRequest;
    let mut req = format!("ws://{addr}")
        .into_client_request()
        .map_err(|e| e.to_string())?;
    req.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        tungstenite::http::HeaderValue::from_static(cosim_foxglove::live::SUBPROTOCOL),
    );
    let (mut ws, _) = tungstenite::connect(req).map_err(|e| e.to_string())?;
    while let Ok(m) = ws.read() {
        let tungstenite::Message::Text(t) = m else {
            continue;
        };
        let v: serde_json::Value = serde_json::from_str(t.as_str()).map_err(|e| e.to_string())?;
        if v["op"] == "advertise" {
            let subs: Vec<serde_json::Value> = v["channels"]
                .as_array()
                .into_iter()
                .flatten()
                .map(|c| serde_json::json!({ "id": c["id"], "channelId": c["id"] }))
                .collect();
            let msg = serde_json::json!({ "op": "subscribe", "subscriptions": subs });
            ws.send(tungstenite::Message::text(msg.to_string()))
                .map_err(|e| e.to_string())?;
        }
    }
    Ok(())
}

/// Runs every measurement and prints the table (Markdown).
pub fn run(steps: u64, quick: bool) -> Result<String, BoxError> {
    let mut out = String::new();
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    let pinned = pin_self(cores);
    out.push_str(&format!(
        "cosim-server bench ipc: reference scene, {steps} steps per lockstep row, {cores} cores{}\n\n",
        if pinned {
            "; server on core 0, a single controller or peer on core 1, several controllers and the monitor anywhere (taskset)"
        } else {
            "; not pinned"
        }
    ));
    out.push_str("| measurement | steps/s | round trip median (us) | step compute median / mean (us) | overhead per step (us) |\n|---|---|---|---|---|\n");
    let mut raw_spin = f64::NAN;
    for mode in [WaitMode::Spin, WaitMode::Block] {
        if quick && mode == WaitMode::Block {
            continue;
        }
        let rt = raw_pingpong(
            mode,
            if mode == WaitMode::Spin {
                20_000
            } else {
                5_000
            },
        )?;
        if mode == WaitMode::Spin {
            raw_spin = rt;
        }
        out.push_str(&format!(
            "| raw iceoryx2 ping-pong, {} | {:.0} | {rt:.2} | - | {rt:.2} |\n",
            mode.as_str(),
            1e6 / rt
        ));
    }
    let (tcp, tcp_rt, tcp_over, _) = tcp_lockstep(steps)?;
    out.push_str(&format!(
        "| lockstep over TCP loopback, 1 controller | {tcp:.0} | {tcp_rt:.2} | - | {tcp_over:.2} |\n"
    ));
    let mut rows = Vec::new();
    for n in [1usize, 2, 4] {
        for mode in [WaitMode::Spin, WaitMode::Block, WaitMode::Hybrid] {
            if quick && (n > 1 || mode == WaitMode::Block) {
                continue;
            }
            // Oversubscribed spinning is slow by design: fewer steps.
            let s = if mode == WaitMode::Spin && n + 1 > cores {
                steps / 10
            } else {
                steps
            };
            let r = lockstep(n, mode, s.max(100), None)?;
            out.push_str(&r.row(&format!(
                "{n} controller{}, {}",
                if n > 1 { "s" } else { "" },
                mode.as_str()
            )));
            rows.push((n, mode, r));
        }
    }
    // The Python package's controller (issue 16, point 9), where python3
    // has it: the same loop, answered from Python.
    if python_package() {
        for mode in [WaitMode::Spin, WaitMode::Block] {
            if quick && mode == WaitMode::Block {
                continue;
            }
            let r = lockstep_of(Client::Python, 1, mode, steps, None)?;
            out.push_str(&r.row(&format!(
                "1 Python controller (cosim package), {}",
                mode.as_str()
            )));
        }
    } else {
        out.push_str("| lockstep, 1 Python controller | skipped: python3 does not import the cosim package (pip install ./python) | - | - | - |\n");
    }
    let spin1 = rows
        .iter()
        .find(|(n, m, _)| *n == 1 && *m == WaitMode::Spin)
        .map(|r| r.2.steps_per_s)
        .unwrap_or(f64::NAN);
    let phases = rows
        .iter()
        .filter(|(n, _, _)| *n == 1)
        .map(|(_, mode, r)| {
            let p = r.phases;
            format!(
                "| {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |\n",
                mode.as_str(),
                p[0],
                p[1],
                p[2],
                p[3],
                p[4],
                p[5],
                1e6 / r.steps_per_s
            )
        })
        .collect::<String>();
    // The TCP baseline's blocking wake-ups vary with how idle the cores
    // are (2,700 to 8,800 steps/s across runs here): the ratio is taken
    // from medians of three alternating runs of each.
    let (mut spins, mut tcps) = (Vec::new(), Vec::new());
    let (mut spin_steps, mut tcp_steps) = (Vec::new(), Vec::new());
    for _ in 0..3 {
        let l = lockstep(1, WaitMode::Spin, steps, None)?;
        spins.push(l.steps_per_s);
        spin_steps.push(l.median_step_us);
        let t = tcp_lockstep(steps)?;
        tcps.push(t.0);
        tcp_steps.push(t.3);
    }
    let (spin_med, tcp_med) = (median(&mut spins), median(&mut tcps));
    // The median step of each run, robust to a run's preemptions.
    let (spin_step, tcp_step) = (median(&mut spin_steps), median(&mut tcp_steps));
    let overheads = rows
        .iter()
        .find(|(n, m, _)| *n == 1 && *m == WaitMode::Spin)
        .map(|(_, _, r)| {
            format!(
                "spin, 1 controller: round trip minus the step compute it overlaps (prepare) \
                 {:.2} us = {:.1}x the raw ping-pong ({raw_spin:.2} us); wall time per step minus \
                 prepare and finish {:.2} us = {:.1}x\n",
                r.round_trip_us - r.phases[1],
                (r.round_trip_us - r.phases[1]) / raw_spin,
                r.overhead_us,
                r.overhead_us / raw_spin
            )
        })
        .unwrap_or_default();
    let footer = format!(
        "\nspin, 1 controller, against TCP: {:.1}x the steps per second in the rows above; \
         medians of 3 alternating runs: {spin_med:.0} against {tcp_med:.0} steps/s, {:.1}x; \
         median step {spin_step:.2} us against {tcp_step:.2} us, {:.1}x\n\
         {overheads}\n\
         Where a step's wall time goes, 1 controller (means, us): control requests at the \
         step boundary, `Engine::prepare` (overlapped with the controller), waiting for the \
         input after it, `Engine::finish`, the inputs and outputs around it, publishing.\n\n\
         | wait | boundary | prepare | wait for input | finish | around finish | publish | wall per step |\n\
         |---|---|---|---|---|---|---|---|\n{phases}",
        spin1 / tcp,
        spin_med / tcp_med,
        tcp_step / spin_step
    );
    if quick {
        out.push_str(&footer);
        return Ok(out);
    }
    // The monitor's cost is a few percent at most, below this machine's
    // noise between two runs: measured inside one run of 50 times the
    // steps (see `monitor_windows`).
    // The live view (issue 16, point 8) in the spinning loop alone, the
    // one a monitor could slow most.
    let toggles = [
        (
            WaitMode::Spin,
            "monitor-toggle",
            "a monitor process (cosim monitor, newest frame at 10 Hz)",
        ),
        (
            WaitMode::Hybrid,
            "monitor-toggle",
            "a monitor process (cosim monitor, newest frame at 10 Hz)",
        ),
        (
            WaitMode::Spin,
            "view-toggle",
            "a view process (cosim view --rate 30, a Foxglove client subscribed to every channel)",
        ),
    ];
    for (mode, role, what) in toggles {
        let (mut rate, mut step) = monitor_windows(mode, 50 * steps, role)?;
        let pct = |v: &mut Vec<f64>| {
            if v.is_empty() {
                return "no windows".to_string();
            }
            v.sort_by(f64::total_cmp);
            let q = |p: f64| (v[((v.len() - 1) as f64 * p).round() as usize] - 1.0) * 100.0;
            format!(
                "{:+.1} % (quartiles {:+.1} / {:+.1} %)",
                q(0.5),
                q(0.25),
                q(0.75)
            )
        };
        out.push_str(&format!(
            "| lockstep, 1 controller, {}: {what} attached against detached, alternate {WINDOW} s windows of one run, median ratio over {} pairs of windows | steps/s {}; median step {} | - | - | - |\n",
            mode.as_str(),
            rate.len(),
            pct(&mut rate),
            pct(&mut step),
        ));
    }
    for mode in [WaitMode::Spin, WaitMode::Hybrid] {
        let r = lockstep(1, mode, steps, Some("recorder"))?;
        out.push_str(&r.row(&format!(
            "1 controller, {}, + recorder process (every frame, woken for each)",
            mode.as_str()
        )));
    }
    out.push_str(&footer);
    Ok(out)
}

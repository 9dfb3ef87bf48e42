//! The `cosim` command: control, monitor and record a running server.

use crate::pd::{self, Gains};
use crate::view;
use crate::{
    list_servers, ClientError, Connection, ControlResponse, Controller, InputFrame, Monitor,
    StateFrame, WaitMode, STATUS_PAUSED, STATUS_SHUTDOWN,
};
use clap::{Parser, Subcommand};
use cosim_foxglove::record::{RecordError, Recording};
use cosim_foxglove::{draw, schema, Drawing};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

#[derive(Parser, Debug)]
#[command(
    name = "cosim",
    version,
    about = "Control, watch and record a running cosim-server"
)]
pub struct Cli {
    /// Server name (`cosim-server serve --name NAME`).
    #[arg(long, global = true, default_value = "default")]
    pub name: String,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// The servers running on this machine.
    List,
    /// Step, time, counts and model hash of the server.
    Info,
    /// Stop stepping (controllers stay joined).
    Pause,
    /// Go on stepping.
    Resume,
    /// Take N steps, then pause.
    Step { n: u64 },
    /// Back to the initial state.
    Reset,
    /// Keep the current state; prints its snapshot id.
    Snapshot,
    /// Go back to a snapshot.
    Restore { id: u64 },
    /// Stop the server (it writes its outputs first).
    Shutdown,
    /// A live table: step, time, rate, body poses.
    Monitor {
        /// Stop after this many seconds of wall time.
        #[arg(long)]
        seconds: Option<f64>,
    },
    /// Serve the server's state to Foxglove, live (Foxglove: Open
    /// connection, Foxglove WebSocket, the printed address). A monitor:
    /// the server does not wait for it.
    View {
        /// Address to listen on (port 0: any free port).
        #[arg(long, default_value = "127.0.0.1:8765")]
        listen: String,
        /// Most frames per second sent to Foxglove.
        #[arg(long, default_value_t = 30.0, allow_negative_numbers = true)]
        rate: f64,
        /// Stop after this many seconds of wall time.
        #[arg(long)]
        seconds: Option<f64>,
    },
    /// Write the server's states as `run` does (scene.toml, states.csv,
    /// impulses.csv, steps.csv), so that `cosim-server plot DIR` draws them.
    Record {
        #[arg(long)]
        out: PathBuf,
        /// Stop after this many frames (default: until the server stops).
        #[arg(long)]
        frames: Option<u64>,
        /// Also write `recording.mcap` for Foxglove, as `cosim-server run
        /// --mcap` does.
        #[arg(long)]
        mcap: bool,
        /// Keep every frame: join the lockstep as a controller that sends
        /// no input, so that the server waits for the recorder each step
        /// (it counts among the server's controllers, with its deadline and
        /// miss policy). Without it the recorder reads as a monitor, never
        /// slows the server, and says how many frames it missed.
        #[arg(long)]
        lockstep: bool,
    },
    /// The PD controller of the reference scene (see `cosim_client::pd`).
    Pd {
        /// Target elevation of the upper arm (degrees above horizontal).
        #[arg(long, default_value_t = 10.0, allow_negative_numbers = true)]
        elevation: f64,
        /// Leave after this many steps (default: until the server stops).
        #[arg(long)]
        steps: Option<u64>,
        #[arg(long, value_enum, default_value_t = WaitMode::Hybrid)]
        wait: WaitMode,
        /// Give up when no state arrives for this long (s).
        #[arg(long, default_value_t = 30.0)]
        timeout: f64,
    },
    /// Run many experiments of one scene as parallel processes, each in
    /// its own iceoryx2 domain and folder, and write one table of their
    /// summaries (OUT/sweep.csv); an interrupted sweep resumes. See
    /// docs/sweeps.md.
    Sweep {
        /// The sweep file (TOML): scene, duration, solver, controller,
        /// `[grid]` and `[[run]]`.
        file: PathBuf,
        /// The sweep's folder: a folder per run and the table.
        #[arg(long)]
        out: PathBuf,
        /// Runs at once (default: the file's `parallel`, else the cores).
        #[arg(long)]
        parallel: Option<usize>,
        /// Only run number N (as `--list` numbers them): one task of a
        /// Slurm job array or a Ray job; `--table` joins them after.
        #[arg(long)]
        only: Option<usize>,
        /// Print the runs, a line each (number, parameters), and stop.
        #[arg(long)]
        list: bool,
        /// Only write the table from the runs' folders.
        #[arg(long)]
        table: bool,
        /// Run again runs whose summary is there already.
        #[arg(long)]
        redo: bool,
        /// The `cosim-server` program (default: the one beside `cosim`,
        /// else on PATH).
        #[arg(long)]
        server: Option<PathBuf>,
    },
    /// Open-loop torques from a CSV file with the header
    /// `step,joint,tx,ty,tz`: each row is sent at its step and held.
    Play {
        file: PathBuf,
        #[arg(long, value_enum, default_value_t = WaitMode::Hybrid)]
        wait: WaitMode,
        #[arg(long, default_value_t = 30.0)]
        timeout: f64,
    },
}

pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match execute(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

fn print_info(r: &ControlResponse) {
    println!(
        "step {} t = {} s (dt {} s), {} bodies, {} joints, {} controllers, {} monitors, {}, model {:016x}, pid {}",
        r.step,
        r.sim_time,
        r.dt,
        r.body_count,
        r.joint_count,
        r.controller_count,
        r.monitor_count,
        if r.paused != 0 { "paused" } else { "running" },
        r.model_hash,
        r.pid
    );
}

fn execute(cli: &Cli) -> Result<(), Box<dyn std::error::Error>> {
    let name = cli.name.as_str();
    match &cli.command {
        Command::Sweep {
            file,
            out,
            parallel,
            only,
            list,
            table,
            redo,
            server,
        } => {
            let o = crate::sweep::Options {
                file: file.clone(),
                out: out.clone(),
                parallel: *parallel,
                only: *only,
                list: *list,
                table: *table,
                redo: *redo,
                server: server.clone(),
            };
            crate::sweep::sweep(&o)?;
        }
        Command::List => {
            let servers = list_servers()?;
            if servers.is_empty() {
                println!("no cosim servers running");
            }
            for s in servers {
                match Connection::connect(&s).and_then(|c| c.info()) {
                    Ok(r) => {
                        print!("{s:<24} ");
                        print_info(&r);
                    }
                    Err(e) => println!("{s:<24} (not answering: {e})"),
                }
            }
        }
        Command::Info => print_info(&Connection::connect(name)?.info()?),
        Command::Pause => print_info(&Connection::connect(name)?.pause()?),
        Command::Resume => print_info(&Connection::connect(name)?.resume()?),
        Command::Step { n } => print_info(&Connection::connect(name)?.step(*n)?),
        Command::Reset => print_info(&Connection::connect(name)?.reset()?),
        Command::Snapshot => {
            let r = Connection::connect(name)?.snapshot()?;
            println!("snapshot {} at step {}", r.value, r.step);
        }
        Command::Restore { id } => print_info(&Connection::connect(name)?.restore(*id)?),
        Command::Shutdown => {
            Connection::connect(name)?.shutdown()?;
            println!("server '{name}' is shutting down");
        }
        Command::Monitor { seconds } => monitor(name, *seconds)?,
        Command::View {
            listen,
            rate,
            seconds,
        } => {
            if !(rate.is_finite() && *rate > 0.0) {
                return Err(format!(
                    "--rate must be a positive number of frames per second, not {rate}"
                )
                .into());
            }
            let opts = crate::view::ViewOptions {
                listen: listen.clone(),
                rate: *rate,
                seconds: *seconds,
            };
            let stats = crate::view::view(name, &opts, |addr| {
                println!(
                    "cosim view: server '{name}' at ws://{addr} (Foxglove: Open connection, Foxglove WebSocket)"
                );
                let _ = std::io::stdout().flush();
            })?;
            println!(
                "cosim view: {} frames drawn, {} messages sent, {} dropped for slow clients",
                stats.frames, stats.sent, stats.dropped
            );
        }
        Command::Record {
            out,
            frames,
            mcap,
            lockstep,
        } => {
            let r = record(name, out, *frames, *mcap, *lockstep)?;
            println!(
                "recorded {} frames into {} (steps {}..{}){}",
                r.frames,
                out.display(),
                r.first.unwrap_or(0),
                r.last.unwrap_or(0),
                match r.dropped {
                    0 => String::new(),
                    d => format!(
                        "; {d} frames were overwritten before they were read (--lockstep keeps every frame)"
                    ),
                }
            );
        }
        Command::Pd {
            elevation,
            steps,
            wait,
            timeout,
        } => {
            let gains = Gains {
                elevation_deg: *elevation,
                ..Gains::default()
            };
            let out = pd::run(
                name,
                &gains,
                *wait,
                *steps,
                Duration::from_secs_f64(*timeout),
            )?;
            println!(
                "pd: {} steps, final elevation {:.3} deg (target {elevation})",
                out.steps, out.final_elevation_deg
            );
        }
        Command::Play {
            file,
            wait,
            timeout,
        } => {
            let n = play(name, file, *wait, Duration::from_secs_f64(*timeout))?;
            println!("play: {n} steps answered");
        }
    }
    Ok(())
}

/// Redraw period of `cosim monitor`.
const MONITOR_PERIOD: Duration = Duration::from_millis(100);

/// The live table. It reads the newest frame ten times a second instead of
/// waking for every frame, so it costs the server nothing it could notice.
fn monitor(name: &str, seconds: Option<f64>) -> Result<(), ClientError> {
    let conn = Connection::connect(name)?;
    let names: Vec<String> = conn
        .scene_toml()
        .ok()
        .and_then(|t| cosim_shared::Scene::parse(&t, "<server scene>").ok())
        .map(|s| s.bodies.into_iter().map(|b| b.name).collect())
        .unwrap_or_default();
    let m = Monitor::polling(name)?;
    let start = Instant::now();
    let mut last: Option<(Instant, u64)> = None;
    loop {
        if seconds.is_some_and(|s| start.elapsed().as_secs_f64() > s) {
            return Ok(());
        }
        if m.node().wait(MONITOR_PERIOD).is_err() {
            return Ok(()); // SIGINT
        }
        let Some(f) = m.latest()? else {
            continue;
        };
        let now = Instant::now();
        let rate = last.map_or(0.0, |(t, step)| {
            f.step.saturating_sub(step) as f64 / now.duration_since(t).as_secs_f64()
        });
        last = Some((now, f.step));
        let mut out = String::new();
        out.push_str("\x1b[2J\x1b[H");
        out.push_str(&format!(
            "cosim '{name}'  step {}  t = {:.4} s  {:.0} steps/s  {} controllers  {}\n",
            f.step,
            f.sim_time,
            rate,
            f.controller_count,
            if f.status & STATUS_PAUSED != 0 {
                "paused"
            } else {
                "running"
            }
        ));
        out.push_str("body              x         y         z       |v|       |w|\n");
        for (i, b) in f.bodies().iter().enumerate() {
            let n = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            let label = names.get(i).cloned().unwrap_or_else(|| i.to_string());
            out.push_str(&format!(
                "{label:<12} {:>9.4} {:>9.4} {:>9.4} {:>9.4} {:>9.4}\n",
                b.position[0],
                b.position[1],
                b.position[2],
                n(b.linear_velocity),
                n(b.angular_velocity)
            ));
        }
        print!("{out}");
        let _ = std::io::stdout().flush();
        if f.status & STATUS_SHUTDOWN != 0 {
            return Ok(());
        }
    }
}

/// Writes the frames as `run` writes its files (and, with `mcap`,
/// `recording.mcap`); returns the frame count.
/// What a recording holds: its frames, the steps of the first and last,
/// and the frames the server overwrote before the recorder read them.
#[derive(Debug, Clone, Copy, Default)]
pub struct Recorded {
    pub frames: u64,
    pub first: Option<u64>,
    pub last: Option<u64>,
    pub dropped: u64,
}

impl Recorded {
    /// Writes frame `f` into `rec` and counts it.
    fn take(&mut self, rec: &mut Recorder, f: &StateFrame) -> std::io::Result<()> {
        rec.frame(f)?;
        self.first.get_or_insert(f.step);
        self.last = Some(f.step);
        self.frames += 1;
        if self.frames.is_multiple_of(1000) {
            rec.flush()?;
        }
        Ok(())
    }
}

pub fn record(
    name: &str,
    out: &Path,
    frames: Option<u64>,
    mcap: bool,
    lockstep: bool,
) -> Result<Recorded, Box<dyn std::error::Error>> {
    let conn = Connection::connect(name)?;
    let toml = conn.scene_toml()?;
    let scene = cosim_shared::Scene::parse(&toml, "<server scene>")?;
    std::fs::create_dir_all(out)?;
    std::fs::write(out.join("scene.toml"), &toml)?;
    let mut rec = Recorder::create(out, scene, mcap)?;
    let r = match lockstep {
        true => record_lockstep(name, &mut rec, frames)?,
        false => record_monitor(name, &mut rec, frames)?,
    };
    rec.finish()?;
    Ok(r)
}

/// What was recorded stays: the files end at the last frame.
fn server_gone(name: &str, r: &Recorded) {
    eprintln!(
        "warning: the server '{name}' is gone; the recording ends at frame {}",
        r.frames
    );
}

/// `record` as a monitor: never slows the server, counts what it missed.
fn record_monitor(
    name: &str,
    rec: &mut Recorder,
    frames: Option<u64>,
) -> Result<Recorded, Box<dyn std::error::Error>> {
    let m = Monitor::open(name, crate::services::MAX_STATE_BUFFER)?;
    let mut r = Recorded::default();
    let mut last_seq = None;
    while frames.is_none_or(|n| r.frames < n) {
        let f = match m.next(Duration::from_millis(500)) {
            Ok(f) => f,
            Err(ClientError::Timeout { .. }) => continue,
            Err(ClientError::Interrupted) => break,
            Err(ClientError::ServerGone { name }) => {
                server_gone(&name, &r);
                break;
            }
            Err(e) => return Err(e.into()),
        };
        if let Some(s) = last_seq {
            r.dropped += f.sequence.saturating_sub(s + 1);
        }
        last_seq = Some(f.sequence);
        r.take(rec, &f)?;
        if f.status & STATUS_SHUTDOWN != 0 {
            break;
        }
    }
    Ok(r)
}

/// `record --lockstep`: every frame, as a controller that answers each
/// with no input (the server waits for it as for any controller; it leaves
/// when dropped).
fn record_lockstep(
    name: &str,
    rec: &mut Recorder,
    frames: Option<u64>,
) -> Result<Recorded, Box<dyn std::error::Error>> {
    let mut c = Controller::join(name, WaitMode::Hybrid)?;
    let mut r = Recorded::default();
    let mut input = InputFrame::default();
    while frames.is_none_or(|n| r.frames < n) {
        match c.next_state_ref(Duration::from_millis(500)) {
            Ok(f) => r.take(rec, f)?,
            Err(ClientError::Timeout { .. }) => continue,
            // The last frame, with the final state.
            Err(ClientError::Shutdown) => {
                if let Some(f) = c.last_state() {
                    r.take(rec, f)?;
                }
                break;
            }
            Err(ClientError::Interrupted) => break,
            Err(ClientError::ServerGone { name }) => {
                server_gone(&name, &r);
                break;
            }
            Err(e) => return Err(e.into()),
        }
        c.send_ref(&mut input)?;
    }
    Ok(r)
}

/// The CSV files of a recording, in the formats of `cosim-server run`.
struct Recorder {
    scene: cosim_shared::Scene,
    /// `--mcap`: `recording.mcap` beside the CSV files, written as the
    /// frames come.
    mcap: Option<(Recording, Drawing, view::ContactPoints)>,
    /// The scene's contact ids per pair (`Scene::contact_features`).
    features: usize,
    states: std::io::BufWriter<std::fs::File>,
    joints: std::io::BufWriter<std::fs::File>,
    impulses: std::io::BufWriter<std::fs::File>,
    steps: std::io::BufWriter<std::fs::File>,
    last_step: Option<u64>,
}

impl Recorder {
    fn create(dir: &Path, scene: cosim_shared::Scene, mcap: bool) -> std::io::Result<Recorder> {
        let open = |n: &str, header: &str| -> std::io::Result<_> {
            let mut w = std::io::BufWriter::new(std::fs::File::create(dir.join(n))?);
            writeln!(w, "{header}")?;
            Ok(w)
        };
        Ok(Recorder {
            states: open("states.csv", cosim_shared::STATES_HEADER)?,
            joints: open("joints.csv", cosim_shared::JOINTS_HEADER)?,
            impulses: open("impulses.csv", cosim_shared::IMPULSES_HEADER)?,
            steps: open(
                "steps.csv",
                "step,t,status,residual,lcp_size,active_contacts",
            )?,
            mcap: match mcap {
                true => Some((
                    Recording::create(&dir.join("recording.mcap"))
                        .map_err(std::io::Error::other)?,
                    Drawing::new(&scene),
                    view::ContactPoints::new(&scene),
                )),
                false => None,
            },
            features: scene.contact_features(),
            scene,
            last_step: None,
        })
    }

    /// The frame's state on the recording's channels, as `run --mcap`
    /// writes them (forces go with the impulses, in `frame`).
    fn mcap_state(&mut self, f: &StateFrame) -> Result<(), RecordError> {
        let Some((rec, drawing, points)) = self.mcap.as_mut() else {
            return Ok(());
        };
        let t = f.sim_time;
        if rec.written().messages.is_empty() {
            let (once, not_drawn) = cosim_foxglove::visuals::sent_once(&self.scene, drawing);
            for what in &not_drawn {
                eprintln!("cosim record: warning: the recording does not draw {what}");
            }
            rec.not_drawn(not_drawn);
            for (topic, msg) in &once {
                rec.put(topic, schema::scene_update, t, msg)?;
            }
        }
        let poses = view::poses(f);
        let msg = view::scene_message(drawing, points, f, &poses);
        rec.put("/scene", schema::scene_update, t, &msg)?;
        rec.put(
            "/tf",
            schema::frame_transforms,
            t,
            &drawing.frame_transforms(t, &poses),
        )?;
        for (b, desc) in f.bodies().iter().zip(&self.scene.bodies) {
            let msg = draw::body_state(&view::body_row(b));
            rec.put(
                &format!("/bodies/{}", desc.name),
                schema::body_state,
                t,
                &msg,
            )?;
        }
        let report = || schema::step_report(&view::SOLVER_FIELDS);
        rec.put("/solver", report, t, &view::solver_message(f))
    }

    /// The frame's joint coordinates: joints.csv rows (no errors: the
    /// frames do not carry them) and `/joints/NAME` for the hinges and
    /// sliders, as `run` writes them.
    fn joint_rows(&mut self, f: &StateFrame) -> std::io::Result<()> {
        let t = f.sim_time;
        let (num, tn) = (cosim_shared::num, cosim_shared::num(t));
        for (desc, c) in self.scene.joints.iter().zip(&f.joint_coordinates) {
            let kind = desc.kind.as_str();
            if c[0].is_nan() {
                writeln!(self.joints, "{},{tn},{},{kind},,,,", f.step, desc.name)?;
                continue;
            }
            writeln!(
                self.joints,
                "{},{tn},{},{kind},{},{},,",
                f.step,
                desc.name,
                num(c[0]),
                num(c[1])
            )?;
            if let Some((rec, ..)) = self.mcap.as_mut() {
                let msg = draw::joint_coordinate(c[0], c[1]);
                rec.put(
                    &format!("/joints/{}", desc.name),
                    schema::joint_coordinate,
                    t,
                    &msg,
                )
                .map_err(std::io::Error::other)?;
            }
        }
        Ok(())
    }

    /// An impulse of the last step as a force on `/forces/KIND/NAME`.
    fn mcap_force(
        &mut self,
        kind: &str,
        name: &str,
        t: f64,
        h: f64,
        p: [f64; 3],
    ) -> Result<(), RecordError> {
        let Some((rec, ..)) = self.mcap.as_mut() else {
            return Ok(());
        };
        let f = nalgebra::Vector3::from(p) / h;
        let msg = draw::force_message(&f);
        rec.put(&format!("/forces/{kind}/{name}"), schema::force, t, &msg)
    }

    /// Closes the recording (its summary is written last).
    fn finish(mut self) -> std::io::Result<()> {
        self.flush()?;
        if let Some((rec, ..)) = self.mcap.take() {
            rec.finish().map_err(std::io::Error::other)?;
        }
        Ok(())
    }

    /// One frame; a frame repeating the last step (after a pause or a
    /// join) is skipped, one going back (reset, restore) starts over in
    /// the same files.
    fn frame(&mut self, f: &StateFrame) -> std::io::Result<()> {
        if self.last_step == Some(f.step) {
            return Ok(());
        }
        self.last_step = Some(f.step);
        let t = f.sim_time;
        // Numbers as the server writes them (`cosim_shared::num`), so that
        // a recording and the server's own files are the same text.
        let (num, tn) = (cosim_shared::num, cosim_shared::num(t));
        let h = if f.dt > 0.0 { f.dt } else { 1.0 };
        self.mcap_state(f).map_err(std::io::Error::other)?;
        for (b, desc) in f.bodies().iter().zip(&self.scene.bodies) {
            write!(self.states, "{},{tn},{}", f.step, desc.name)?;
            for v in b
                .position
                .iter()
                .chain(&b.orientation)
                .chain(&b.linear_velocity)
                .chain(&b.angular_velocity)
            {
                write!(self.states, ",{}", num(*v))?;
            }
            writeln!(self.states)?;
        }
        self.joint_rows(f)?;
        if f.step == 0 {
            return Ok(());
        }
        for (j, p) in f.joint_impulses.iter().enumerate() {
            let Some(joint) = self.scene.joints.get(j) else {
                continue;
            };
            if p.iter().any(|x| *x != 0.0) {
                writeln!(
                    self.impulses,
                    "{},{tn},joint,{},{},{},{},{},{}",
                    f.step,
                    joint.name,
                    joint.body_a,
                    joint.body_b,
                    num(p[0]),
                    num(p[1]),
                    num(p[2])
                )?;
                let name = joint.name.clone();
                self.mcap_force("joint", &name, t, h, *p)
                    .map_err(std::io::Error::other)?;
            }
        }
        let mut forces = Vec::new();
        for c in f.contacts() {
            let a = self
                .scene
                .bodies
                .get(c.body_a as usize)
                .map_or("?", |b| b.name.as_str());
            let b = if c.kind_b == crate::CONTACT_PLANE {
                self.scene.planes.get(c.index_b as usize).map(|p| &p.name)
            } else {
                self.scene.bodies.get(c.index_b as usize).map(|b| &b.name)
            }
            .map_or("?", |s| s.as_str());
            let label = cosim_shared::contact_label(a, b, c.id as usize % self.features);
            for (kind, p) in [("normal", c.normal), ("friction", c.friction)] {
                if p.iter().any(|x| *x != 0.0) {
                    writeln!(
                        self.impulses,
                        "{},{tn},{kind},{label},{a},{b},{},{},{}",
                        f.step,
                        num(p[0]),
                        num(p[1]),
                        num(p[2])
                    )?;
                    forces.push((kind, label.clone(), p));
                }
            }
        }
        for (kind, name, p) in forces {
            self.mcap_force(kind, &name, t, h, p)
                .map_err(std::io::Error::other)?;
        }
        writeln!(
            self.steps,
            "{},{tn},{},{},{},{}",
            f.step,
            if f.solver_status == 0 { "ok" } else { "failed" },
            num(f.residual),
            f.lcp_size,
            f.contact_count
        )
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.states.flush()?;
        self.joints.flush()?;
        self.impulses.flush()?;
        self.steps.flush()
    }
}

/// The open-loop player: rows `step,joint,tx,ty,tz` sent at their step;
/// returns the steps answered.
pub fn play(
    name: &str,
    file: &Path,
    wait: WaitMode,
    timeout: Duration,
) -> Result<u64, Box<dyn std::error::Error>> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let mut rows: Vec<(u64, u32, [f64; 3])> = Vec::new();
    for (k, line) in text.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        let cols: Vec<&str> = line.split(',').map(str::trim).collect();
        let bad = |what: &str| format!("{}:{}: {what}", file.display(), k + 1);
        if cols.len() != 5 {
            return Err(bad("expected 5 columns: step,joint,tx,ty,tz").into());
        }
        let step = cols[0]
            .parse()
            .map_err(|_| bad(&format!("step = {:?} is not a step number", cols[0])))?;
        let joint = cols[1]
            .parse()
            .map_err(|_| bad(&format!("joint = {:?} is not a joint index", cols[1])))?;
        let mut tau = [0.0; 3];
        for (i, t) in tau.iter_mut().enumerate() {
            *t = cols[2 + i]
                .parse()
                .map_err(|_| bad(&format!("torque = {:?} is not a number", cols[2 + i])))?;
        }
        rows.push((step, joint, tau));
    }
    rows.sort_by_key(|r| r.0);
    let last = rows.last().map_or(0, |r| r.0);
    let mut c = Controller::join(name, wait)?;
    let mut next = 0;
    let mut answered = 0;
    loop {
        let f = match c.next_state(timeout) {
            Ok(f) => f,
            Err(ClientError::Shutdown) => break,
            Err(e) => return Err(e.into()),
        };
        let mut input = InputFrame::default();
        while next < rows.len() && rows[next].0 <= f.step {
            input.push_torque(rows[next].1, rows[next].2);
            next += 1;
        }
        c.send(input)?;
        answered += 1;
        if f.step >= last && next == rows.len() {
            break;
        }
    }
    c.leave()?;
    Ok(answered)
}

//! `cosim-server serve`, `demo`, `replay` and the demo's controller.

use super::{RunArgs, EXIT_BAD_INPUT, EXIT_FAILED};
use crate::serve::controllers::{FailurePolicy, MissPolicy};
use crate::serve::replay::{replay as run_replay, ReplayOutcome};
use crate::serve::{serve as run_serve, Ending, ServeError, ServeOptions};
use cosim_client::WaitMode;
use cosim_figures::{self as plot, PlotOptions};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

#[derive(clap::Args, Debug, Clone)]
pub struct ServeArgs {
    /// Scene file (TOML) or robot (URDF, or MJCF .xml); the built-in reference scene
    /// when omitted.
    pub scene: Option<PathBuf>,
    #[command(flatten)]
    pub robot: super::RobotArgs,
    /// Server name: the services live under cosim/NAME/.
    #[arg(long, default_value = "default")]
    pub name: String,
    /// Wait for N controllers to join before the first step.
    #[arg(long, default_value_t = 0)]
    pub controllers: usize,
    /// How long to wait for the controllers' inputs of a step (ms).
    #[arg(long, default_value_t = 1000.0)]
    pub deadline_ms: f64,
    /// What a missed deadline does to that controller's input.
    #[arg(long, value_enum, default_value_t = MissPolicy::Hold)]
    pub on_miss: MissPolicy,
    /// What a step whose rigid LCP has no solution does: continue (the
    /// engine's relaxed or compliant fallback, reported; a step nothing
    /// solves pauses), pause or abort (rigid answers only).
    #[arg(long, value_enum, default_value_t = FailurePolicy::Continue)]
    pub on_failure: FailurePolicy,
    /// How the server waits for inputs.
    #[arg(long, value_enum, default_value_t = WaitMode::Hybrid)]
    pub wait: WaitMode,
    /// Drop a live controller after this many deadline misses in a row.
    #[arg(long, default_value_t = 3)]
    pub drop_after: u32,
    /// Stop after N steps (default: the scene's `duration` or `steps`).
    #[arg(long, conflicts_with_all = ["duration", "forever"])]
    pub steps: Option<u64>,
    /// Stop after this many simulated seconds.
    #[arg(long, allow_negative_numbers = true, conflicts_with = "forever")]
    pub duration: Option<f64>,
    /// No end: serve until `cosim shutdown`, Ctrl-C or SIGTERM.
    #[arg(long)]
    pub forever: bool,
    /// Write states, joints, impulses and step reports for every N-th step
    /// (and the last); the replay log keeps every step. Default: every step
    /// for a run with an end, about every 10 ms of simulated time with
    /// `--forever`.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub record_every: Option<u64>,
    /// Pace the simulation at FACTOR times real time (default: as fast as
    /// possible).
    #[arg(long, allow_negative_numbers = true)]
    pub realtime: Option<f64>,
    /// Step h in seconds.
    #[arg(long, allow_negative_numbers = true)]
    pub dt: Option<f64>,
    /// LCP solver.
    #[arg(long)]
    pub solver: Option<cosim_shared::SolverChoice>,
    /// Output folder (default out/serve-NAME): the files of `run`, plus
    /// inputs.csv and replay.csv.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write no files (a server that runs for days; benchmarks).
    #[arg(long, conflicts_with = "out")]
    pub no_record: bool,
    /// Write into an --out folder that holds an earlier run.
    #[arg(long)]
    pub overwrite: bool,
    /// Print nothing but errors.
    #[arg(long)]
    pub quiet: bool,
    /// Also publish every N-th step's state (and the last) on
    /// `cosim/NAME/state-every`, for monitors that want fewer frames
    /// (`cosim_client::Monitor::open_every`).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub publish_every: Option<u64>,
}

#[derive(clap::Args, Debug, Clone)]
pub struct DemoArgs {
    /// Simulated seconds.
    #[arg(long, default_value_t = 5.0)]
    pub duration: f64,
    /// Target elevation of the upper arm (degrees above horizontal).
    #[arg(long, default_value_t = 10.0, allow_negative_numbers = true)]
    pub elevation: f64,
    /// Output folder (default out/demo, or the first free out/demo-2, -3,
    /// ... when it holds an earlier run).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write into an --out folder that holds an earlier run.
    #[arg(long)]
    pub overwrite: bool,
    /// How server and controller wait.
    #[arg(long, value_enum, default_value_t = WaitMode::Hybrid)]
    pub wait: WaitMode,
    /// The strike's target elevation (degrees): from a fifth of the run to
    /// 45 % of it the controller swings the arm down to it, the lower
    /// sphere strikes the floor and presses on it, sliding; then it lifts
    /// the arm back.
    #[arg(long, default_value_t = -40.0, allow_negative_numbers = true)]
    pub strike: f64,
    /// Hold the arm all along, no strike.
    #[arg(long)]
    pub no_strike: bool,
}

#[derive(clap::Args, Debug, Clone)]
pub struct ReplayArgs {
    /// Output folder of a serve run (scene.toml, replay.csv).
    pub dir: PathBuf,
}

#[derive(clap::Args, Debug, Clone)]
pub struct SummarizeArgs {
    /// Output folder of a serve run that has no summary.json (killed).
    pub dir: PathBuf,
}

/// `summarize DIR`: summary.json rebuilt from the files of a run that did
/// not write one.
pub fn summarize(args: &SummarizeArgs) -> ExitCode {
    match crate::serve::summarize::summarize(&args.dir) {
        Ok(path) => {
            println!("summarize: wrote {}", path.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(EXIT_BAD_INPUT)
        }
    }
}

#[derive(clap::Args, Debug, Clone)]
pub struct PdArgs {
    #[arg(long, default_value = "default")]
    pub name: String,
    #[arg(long, default_value_t = 10.0, allow_negative_numbers = true)]
    pub elevation: f64,
    #[arg(long, value_enum, default_value_t = WaitMode::Hybrid)]
    pub wait: WaitMode,
    #[arg(long)]
    pub steps: Option<u64>,
    /// A strike: `FROM,TO,DEG`, steps FROM to TO at elevation DEG.
    #[arg(long, value_parser = strike)]
    pub strike: Option<cosim_client::pd::Strike>,
}

fn strike(s: &str) -> Result<cosim_client::pd::Strike, String> {
    let bad = || format!("{s:?}: write FROM,TO,DEG (steps, steps, degrees)");
    let [a, b, c] = s.split(',').collect::<Vec<_>>()[..] else {
        return Err(bad());
    };
    Ok(cosim_client::pd::Strike {
        from: a.trim().parse().map_err(|_| bad())?,
        to: b.trim().parse().map_err(|_| bad())?,
        elevation_deg: c.trim().parse().map_err(|_| bad())?,
    })
}

fn positive(name: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(format!("{name} must be a positive number, got {v}"))
    }
}

/// Checks the options and the scene; errors name the option or field.
fn options(args: &ServeArgs) -> Result<(cosim_shared::Scene, ServeOptions), String> {
    positive("--deadline-ms", args.deadline_ms)?;
    if let Some(r) = args.realtime {
        positive("--realtime", r)?;
    }
    if let Some(d) = args.duration {
        positive("--duration", d)?;
    }
    if args.drop_after == 0 {
        return Err("--drop-after must be at least 1".into());
    }
    if args.controllers > cosim_shared::wire::MAX_CONTROLLERS {
        return Err(format!(
            "--controllers {} exceeds the {} controllers a server takes",
            args.controllers,
            cosim_shared::wire::MAX_CONTROLLERS
        ));
    }
    if args.name.is_empty()
        || !args
            .name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.')
    {
        return Err(format!(
            "--name {:?}: use letters, digits, '-', '_' and '.'",
            args.name
        ));
    }
    let run = RunArgs {
        scene: args.scene.clone(),
        robot: args.robot,
        dt: args.dt,
        duration: None,
        steps: None,
        solver: args.solver,
        friction_directions: None,
        full: false,
        out: None,
        quiet: true,
        shadow: false,
        plot: false,
        animate: false,
        mcap: false,
        fps: None,
        gif_size: None,
        overwrite: false,
    };
    let mut scene = super::run::load(&run).map_err(|e| e.to_string())?;
    let steps = match args.forever {
        true => None,
        false => Some(args.steps.unwrap_or_else(|| {
            args.duration.map_or_else(
                || scene.step_count(),
                |d| (d / scene.sim.dt).round().max(1.0) as u64,
            )
        })),
    };
    // scene.toml is the scene as served: its length the one run.
    if let Some(n) = steps {
        scene.sim.steps = Some(n);
        scene.sim.duration = None;
    }
    let record_every = args.record_every.unwrap_or(match steps {
        Some(_) => 1,
        None => ((0.01 / scene.sim.dt).round() as u64).max(1),
    });
    let opts = ServeOptions {
        name: args.name.clone(),
        controllers: args.controllers,
        deadline: Duration::from_secs_f64(args.deadline_ms / 1e3),
        on_miss: args.on_miss,
        on_failure: args.on_failure,
        wait: args.wait,
        drop_after: args.drop_after,
        steps,
        realtime: args.realtime,
        out: match args.no_record {
            true => None,
            // A folder given is checked by `serve` once the name is known
            // to be free (a second server of a running name is refused as
            // such, its folder untouched).
            false => Some(match &args.out {
                Some(o) => o.clone(),
                None => crate::output::run_folder(
                    None,
                    PathBuf::from("out").join(format!("serve-{}", args.name)),
                    args.overwrite,
                    args.quiet,
                )?,
            }),
        },
        overwrite: args.overwrite,
        quiet: args.quiet,
        timeline: false,
        publish_every: args.publish_every,
        record_every,
    };
    Ok((scene, opts))
}

pub fn serve(args: &ServeArgs) -> ExitCode {
    let (scene, opts) = match options(args) {
        Ok(x) => x,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let quiet = opts.quiet;
    let out = opts.out.clone();
    report(run_serve(&scene, opts), out.as_deref(), quiet)
}

fn report(
    result: Result<(crate::serve::Counters, Ending, f64), ServeError>,
    out: Option<&std::path::Path>,
    quiet: bool,
) -> ExitCode {
    match result {
        Ok((c, ending, wall)) => {
            if !quiet {
                let rejected: u64 = c.inputs_rejected.values().sum();
                // Steps per second of the stepping alone: the wait for the
                // controllers to join is not the loop's (issue 15: 186
                // steps/s printed for 1.4 s of stepping in 10.7 s).
                let stepping = c.stepping_seconds;
                println!(
                    "served {} steps in {stepping:.3} s of stepping ({:.0} steps/s; {wall:.3} s with the wait for controllers), ended by {}; {} controllers joined, {} inputs applied, {rejected} rejected, {} deadline misses",
                    c.steps,
                    c.steps as f64 / stepping.max(1e-9),
                    format!("{ending:?}").to_lowercase(),
                    c.controllers_joined,
                    c.inputs_applied,
                    c.deadline_misses
                );
                if let Some(out) = out {
                    println!("output       {}", out.display());
                }
            }
            // Failures the run went on from (a resume with new inputs, a
            // reset, a restore) leave it a success; the count says them.
            if matches!(ending, Ending::Aborted | Ending::Failed) || c.unrecovered {
                ExitCode::from(EXIT_FAILED)
            } else {
                ExitCode::SUCCESS
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(match e {
                ServeError::TooLarge { .. } | ServeError::Occupied(_) => EXIT_BAD_INPUT,
                _ => EXIT_FAILED,
            })
        }
    }
}

/// Kills the child when dropped, so that no controller outlives the demo.
struct Child(std::process::Child);

impl Drop for Child {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

pub fn demo(args: &DemoArgs) -> ExitCode {
    if let Err(e) = positive("--duration", args.duration) {
        eprintln!("error: {e}");
        return ExitCode::from(EXIT_BAD_INPUT);
    }
    // A name of its own: two demos at once do not meet.
    let name = format!("demo-{}", std::process::id());
    let default = PathBuf::from("out/demo");
    let out = match crate::output::run_folder(args.out.as_deref(), default, args.overwrite, false) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let serve_args = ServeArgs {
        scene: None,
        robot: Default::default(),
        name: name.clone(),
        controllers: 1,
        deadline_ms: 2000.0,
        on_miss: MissPolicy::Hold,
        on_failure: FailurePolicy::Continue,
        wait: args.wait,
        drop_after: 3,
        steps: None,
        duration: Some(args.duration),
        forever: false,
        record_every: None,
        realtime: None,
        dt: None,
        solver: None,
        out: Some(out.clone()),
        no_record: false,
        // Chosen above.
        overwrite: true,
        quiet: false,
        publish_every: None,
    };
    let (scene, opts) = match options(&serve_args) {
        Ok(x) => x,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let exe = match std::env::current_exe() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: cannot find this program to start the controller: {e}");
            return ExitCode::from(EXIT_FAILED);
        }
    };
    // The strike, in steps of the scene's h.
    let steps = (args.duration / scene.sim.dt).round() as u64;
    let strike = format!("{},{},{}", steps / 5, steps * 9 / 20, args.strike);
    // The controller starts first and retries its join until the server is
    // up (see `pd_controller`).
    let child = std::process::Command::new(exe)
        .args([
            "pd-controller",
            "--name",
            &name,
            "--elevation",
            &args.elevation.to_string(),
            "--wait",
            args.wait.as_str(),
        ])
        .args(
            (!args.no_strike)
                .then_some(["--strike", strike.as_str()])
                .into_iter()
                .flatten(),
        )
        .spawn();
    let mut child = match child {
        Ok(c) => Child(c),
        Err(e) => {
            eprintln!("error: cannot start the PD controller: {e}");
            return ExitCode::from(EXIT_FAILED);
        }
    };
    println!(
        "demo: reference scene, PD controller (pid {}) holding the upper arm at {} deg{}, {} s in lockstep",
        child.0.id(),
        args.elevation,
        match args.no_strike {
            true => String::new(),
            false => format!(
                ", striking the floor at {} deg from {} s to {} s",
                args.strike,
                cosim_shared::num(args.duration / 5.0),
                cosim_shared::num(args.duration * 0.45)
            ),
        },
        args.duration
    );
    let code = report(run_serve(&scene, opts), Some(&out), false);
    // The controller ends on the server's last frame.
    let _ = child.0.wait();
    if let Err(e) = plot::render(
        &out,
        &PlotOptions {
            figures: true,
            animation: true,
            ..PlotOptions::default()
        },
    ) {
        eprintln!("error: {e}");
        return ExitCode::from(EXIT_FAILED);
    }
    println!(
        "figures      {}/plots/*.png, {}/animation.gif",
        out.display(),
        out.display()
    );
    code
}

/// The demo's controller process: joins (retrying while the server
/// starts), then runs the PD loop until the server shuts down.
pub fn pd_controller(args: &PdArgs) -> ExitCode {
    let gains = cosim_client::pd::Gains {
        elevation_deg: args.elevation,
        strike: args.strike,
        ..Default::default()
    };
    // The server may still be creating its services.
    let run = cosim_client::when_up(Duration::from_secs(30), || {
        cosim_client::pd::run(
            &args.name,
            &gains,
            args.wait,
            args.steps,
            Duration::from_secs(30),
        )
    });
    match run {
        Ok(out) => {
            println!(
                "pd: {} steps, final elevation {:.3} deg (target {})",
                out.steps, out.final_elevation_deg, args.elevation
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: pd controller: {e}");
            ExitCode::from(EXIT_FAILED)
        }
    }
}

pub fn replay(args: &ReplayArgs) -> ExitCode {
    match run_replay(&args.dir) {
        Ok(ReplayOutcome::Identical { steps, cut_at }) => {
            println!("replay: {steps} steps, every state identical to the bit");
            if let Some(line) = cut_at {
                println!(
                    "replay: replay.csv ends in a line cut off at line {line} (the server was stopped while writing it); the log ends after step {steps} of the session"
                );
            }
            if !args.dir.join("summary.json").exists() {
                println!(
                    "replay: no summary.json (the server did not end cleanly); `cosim-server summarize {}` rebuilds one from the files",
                    args.dir.display()
                );
            }
            ExitCode::SUCCESS
        }
        Ok(ReplayOutcome::Differs {
            n,
            step,
            recorded,
            replayed,
        }) => {
            eprintln!(
                "error: replay differs at step {} (the {n}-th step of the session): recorded state hash {recorded:016x}, replayed {replayed:016x}",
                step + 1
            );
            ExitCode::from(EXIT_FAILED)
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(EXIT_BAD_INPUT)
        }
    }
}

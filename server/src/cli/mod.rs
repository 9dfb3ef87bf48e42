//! The command line: `cosim-server run [SCENE] ...`.

mod lcp;
mod run;
pub mod serve;

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(
    name = "cosim-server",
    version,
    about = "Rigid multibody dynamics with exact frictional contact"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Run a scene (the built-in reference scene without SCENE) and write
    /// states.csv, impulses.csv, steps.csv and summary.json.
    Run(RunArgs),
    /// Draw the figures (DIR/plots/) and the animation (DIR/animation.gif)
    /// of an earlier run from its files.
    Plot(PlotArgs),
    /// Solve a Siconos LCP file (or mixed LCP, `*_mlcp.dat`) with Lemke and
    /// print the outcome.
    Lcp(LcpArgs),
    /// Solve a Siconos 3-D frictional-contact file with projected
    /// Gauss-Seidel on the circular cone.
    Fc3d(Fc3dArgs),
    /// Serve a scene over iceoryx2: controllers step in lockstep, monitors
    /// watch (see docs/protocol.md).
    Serve(serve::ServeArgs),
    /// The reference scene with a PD controller in a separate process, 5 s
    /// in lockstep; writes the outputs, figures and animation.
    Demo(serve::DemoArgs),
    /// Re-run a serve session from its folder and check every state bit for
    /// bit.
    Replay(serve::ReplayArgs),
    /// Rebuild summary.json from the files of a serve run that ended
    /// without writing one (a killed server): steps, failures, inputs by
    /// reason, where each log ends.
    Summarize(serve::SummarizeArgs),
    /// Benchmarks: `bench ipc` measures lockstep over iceoryx2 against a
    /// raw ping-pong and a TCP loopback baseline.
    Bench {
        #[command(subcommand)]
        what: BenchWhat,
    },
    /// The other process of a benchmark (started by `bench`).
    #[command(hide = true)]
    BenchPeer {
        role: String,
        #[arg(long)]
        name: String,
        #[arg(long, value_enum)]
        wait: cosim_client::WaitMode,
    },
    /// The demo's PD controller (started by `demo`).
    #[command(hide = true)]
    PdController(serve::PdArgs),
}

#[derive(Subcommand, Debug)]
pub enum BenchWhat {
    /// Lockstep steps per second over iceoryx2 (1, 2, 4 controllers; spin,
    /// block, hybrid; with a monitor), the raw ping-pong limit and TCP.
    Ipc {
        /// Steps per lockstep measurement.
        #[arg(long, default_value_t = 20_000)]
        steps: u64,
        /// Only the spinning rows with one controller, the limit and the
        /// TCP baseline (for working on the loop).
        #[arg(long)]
        quick: bool,
        /// Also write the table to this file.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Work-precision: error against wall time on cases with known
    /// answers (S1 rolling, S2 slide to roll, S3 bounce, S4 chain, S6
    /// corner, the reference scene), swept over h, solver, n_d and pruning.
    /// Writes accuracy.csv and accuracy-<case>.png.
    Accuracy(AccuracyArgs),
    /// What each skip of the step saves: per-stage median times with the
    /// skip on and off on the same scene, and the largest position
    /// difference between the two runs.
    Skips {
        /// Steps per run.
        #[arg(long, default_value_t = 3000)]
        steps: u64,
        /// Also write the table to this file.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Robustness: seeded random small scenes (corners, creases, touching
    /// and overlapping spheres, joints to the world, mu up to 1), each
    /// stepped and checked for failed steps, energy and speed bounds.
    Robust {
        /// Scenes to run.
        #[arg(long, default_value_t = 10_000)]
        scenes: u64,
        /// Steps per scene.
        #[arg(long, default_value_t = 20)]
        steps: u64,
        /// First seed (scenes use seed, seed + 1, ...).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        #[arg(long, default_value = "lemke")]
        solver: cosim_shared::SolverChoice,
        /// Print the scene of seed `--seed` as a scene file and stop (to
        /// run it with `cosim-server run FILE`).
        #[arg(long)]
        print_scene: bool,
        /// Also write the table to this file.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Fuzzing (seeded, stable Rust): mutated and generated scene files
    /// and random input frames; prints the counts and every defect found
    /// (a panic, an error that names nothing, a state made non-finite by a
    /// step that said it was fine). Exit status 1 when it finds any.
    Fuzz {
        /// Scene texts to try.
        #[arg(long, default_value_t = 100_000)]
        scenes: u64,
        /// Input frames to try.
        #[arg(long, default_value_t = 1_000_000)]
        inputs: u64,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Print the text of scene case N (as a defect names it) and stop.
        #[arg(long, value_name = "N")]
        print_scene: Option<u64>,
        /// Also write the counts to this file.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Piles of N spheres dropped into a box (issue 14): ms per step,
    /// solver work, worst overlap, escaped spheres, energy, memory.
    Pile {
        /// Pile sizes, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "100,1000,4000,10000")]
        n: Vec<usize>,
        #[arg(long, default_value_t = 500)]
        steps: u64,
        #[arg(long, default_value_t = 0.01)]
        dt: f64,
        #[arg(long, default_value = "auto")]
        solver: String,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Lay each pile out in this many layers, its square widening with
        /// N, instead of as a cube (10 x 10 x 10 at 1,000): piles as tall
        /// at every N.
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
        layers: Option<u64>,
        /// Print every K-th step's report to stderr.
        #[arg(long, default_value_t = 0)]
        trace: u64,
        /// PGS: the stopping rule's tolerance (m/s); the pile scene's own
        /// (`bench::pile::TOLERANCE`) by default.
        #[arg(long, default_value_t = cosim_bench::pile::TOLERANCE)]
        velocity_tolerance: f64,
        /// PGS: sweep cap.
        #[arg(long, default_value_t = crate::engine::solver::pgs::DEFAULT_MAX_ITERATIONS)]
        max_iterations: usize,
        /// PGS, residual rule: an island's tolerance is at least this
        /// fraction of its fastest approach (`[sim.pgs] relative`; 0: the
        /// tolerance alone).
        #[arg(long, default_value_t = cosim_shared::DEFAULT_PGS_RELATIVE)]
        relative: f64,
        /// PGS: what the velocity tolerance bounds, `distance` (to the
        /// answer) or `residual` (the constraint violation).
        #[arg(long, default_value = "residual")]
        stop: cosim_shared::PgsStop,
        /// PGS: plain sweeps, without the NNCG momentum step.
        #[arg(long)]
        no_momentum: bool,
        /// PGS: the relaxation factor omega on each update (1: plain
        /// Gauss-Seidel; between 1 and 2: over-relaxation). Measured with
        /// the momentum step (1,000 pile, 300 steps, 1e-2 m/s): 1.3 took
        /// twice the median sweeps of 1 (22 against 11), 1.6 left 69
        /// steps at the cap and 4.7 mm of overlap.
        #[arg(long, default_value_t = 1.0)]
        relaxation: f64,
        /// Every body steps every step (`[sim.sleep] enabled = false`);
        /// by default islands at rest sleep, as in every scene.
        #[arg(long, conflicts_with = "sleep_speeds")]
        no_sleep: bool,
        /// Sleeping at these thresholds instead of the defaults,
        /// `LINEAR,ANGULAR` (m/s, rad/s). Rapier's rule amounts to about
        /// `0.1,2` for these spheres: a body sleeps when no point of it
        /// moved faster than 0.1 m/s over a step.
        #[arg(long, value_parser = cosim_bench::pile::sleep_speeds)]
        sleep_speeds: Option<cosim_shared::scene::SleepDesc>,
        /// A pendulum swings above the pile: a body that never sleeps (it
        /// is on a joint) beside a pile that does, as a robot beside a
        /// heap; with sleeping, what the sleeping pile still costs.
        #[arg(long)]
        pendulum: bool,
        /// Also write the table to this file.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Stress suite: mass ratios, a pile at rest, 100 m/s impacts,
    /// degenerate and overlapping contacts, redundant joints, a long run,
    /// radii from 1 mm to 10 m. Prints a table (also to --out).
    Stress {
        /// Solvers to run every case with, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "lemke,pgs,auto")]
        solver: Vec<cosim_shared::SolverChoice>,
        /// Steps of the reference-scene long run.
        #[arg(long, default_value_t = 1_000_000)]
        long_steps: u64,
        /// Also write the table to this file.
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

#[derive(clap::Args, Debug, Clone)]
pub struct AccuracyArgs {
    /// Output folder.
    #[arg(long, default_value = "bench/results")]
    pub out: PathBuf,
    /// Two steps (1e-2, 1e-3) and two settings only.
    #[arg(long)]
    pub quick: bool,
    /// Only these cases (S1, S2, S3, S4, S6, S7, S8, REF), comma-separated.
    #[arg(long, value_delimiter = ',')]
    pub cases: Vec<String>,
}

#[derive(clap::Args, Debug, Clone)]
pub struct Fc3dArgs {
    /// The problem file (Siconos format, 3-D).
    pub file: PathBuf,
    /// Stop at this natural-map residual (divided by max(||q||, 1)).
    #[arg(long, default_value_t = 1e-6)]
    pub tolerance: f64,
    /// Iteration cap.
    #[arg(long, default_value_t = 20_000)]
    pub max_iterations: usize,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args, Debug, Clone)]
pub struct LcpArgs {
    /// The problem file (Siconos format, see ../shared/data/README.md).
    pub file: PathBuf,
    /// Print one JSON object: status (solved, ray_termination, pivot_limit,
    /// singular, not_converged), solver, pivots (Lemke) or iterations (PGS),
    /// residual, z.
    #[arg(long)]
    pub json: bool,
    /// lemke (complementary pivoting, with the engine's ladder of pivot
    /// tolerances, refinement and regularisation), lemke-plain (one run,
    /// what the corpus tests check) or pgs (projected Gauss-Seidel, which
    /// converges for symmetric positive semi-definite matrices).
    #[arg(long, default_value = "lemke")]
    pub solver: String,
    /// PGS: stop at this relative natural-map residual.
    #[arg(long, default_value_t = 1e-10)]
    pub tolerance: f64,
    /// PGS: sweep cap.
    #[arg(long, default_value_t = 100_000)]
    pub max_iterations: usize,
}

#[derive(clap::Args, Debug, Clone)]
pub struct PlotArgs {
    /// Output folder of a run (holding scene.toml and the CSV files).
    pub dir: PathBuf,
    /// A second run: both drawn in the same figures (DIR's series as usual,
    /// this one's thin over them), into DIR/compare/ unless --out says.
    pub other: Option<PathBuf>,
    /// Only these figures, comma-separated (positions, velocities,
    /// quaternions, joint_angles, joint_coordinates, energy, normal_forces, friction_forces,
    /// joint_forces, errors, timings, solver, lcp_size).
    #[arg(long)]
    pub only: Option<String>,
    /// Only these bodies (comma-separated names) and their contacts.
    #[arg(long)]
    pub bodies: Option<String>,
    /// A panel per contact and joint in the force figures, each with its
    /// own axis, so that one impact does not flatten the others.
    #[arg(long)]
    pub per_contact: bool,
    /// Draw from this time on (s).
    #[arg(long)]
    pub from: Option<f64>,
    /// Draw up to this time (s).
    #[arg(long)]
    pub to: Option<f64>,
    /// Image size WIDTHxHEIGHT in pixels (default 1100 wide, 260 a panel).
    #[arg(long)]
    pub size: Option<String>,
    /// Where the figures go: default DIR for a whole plot, DIR/focus for
    /// --from, --to, --only or --bodies, DIR/compare for a comparison.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Animation frames per simulated second (default 25; fewer make a
    /// smaller GIF, faster).
    #[arg(long)]
    pub fps: Option<f64>,
    /// Animation size WIDTHxHEIGHT in pixels (default 640x480).
    #[arg(long)]
    pub gif_size: Option<String>,
    /// Also write N evenly spread frames of the animation as PNG stills.
    #[arg(long, default_value_t = 0)]
    pub stills: usize,
    /// Write only DIR/recording.mcap (for Foxglove), no figures.
    #[arg(long)]
    pub mcap: bool,
}

/// What a robot file (URDF, MJCF) does not say: its base and a floor.
#[derive(clap::Args, Debug, Clone, Copy, Default)]
pub struct RobotArgs {
    /// The robot's floating root (a URDF root link with mass, an MJCF
    /// free joint) is welded to the world (a fixed-base arm); by default
    /// it floats, as in PyBullet, Drake and MuJoCo.
    #[arg(long)]
    pub fixed_base: bool,
    /// Add a floor plane: under a URDF robot's lowest point, at z = 0 for
    /// MJCF (none by default; MJCF models carry their own).
    #[arg(long)]
    pub floor: bool,
    /// The robot's bodies touch each other (a joint's two bodies never);
    /// by default they do not, as in PyBullet.
    #[arg(long)]
    pub self_collision: bool,
}

#[derive(clap::Args, Debug, Clone)]
pub struct RunArgs {
    /// Scene file (TOML) or robot (URDF, or MJCF .xml); the built-in reference scene
    /// when omitted.
    pub scene: Option<PathBuf>,
    #[command(flatten)]
    pub robot: RobotArgs,
    /// Step h in seconds (keeps the scene's simulated duration).
    #[arg(long, allow_negative_numbers = true)]
    pub dt: Option<f64>,
    /// Simulated seconds.
    #[arg(long, conflicts_with = "steps", allow_negative_numbers = true)]
    pub duration: Option<f64>,
    /// Number of steps.
    #[arg(long)]
    pub steps: Option<u64>,
    /// LCP solver.
    #[arg(long)]
    pub solver: Option<cosim_shared::SolverChoice>,
    /// Directions of the polyhedral friction cone (n_d).
    #[arg(long)]
    pub friction_directions: Option<usize>,
    /// Keep every potential contact in the LCP (no pruning), as in the notes.
    #[arg(long)]
    pub full: bool,
    /// Output folder; default out/<scene name> (or the first free
    /// out/<scene name>-2, -3, ... when it holds an earlier run).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write into an --out folder that holds an earlier run.
    #[arg(long)]
    pub overwrite: bool,
    /// Print nothing but errors.
    #[arg(long)]
    pub quiet: bool,
    /// Solve every step with the other solver too (lemke <-> pgs), from the
    /// same state, and record the velocity difference in steps.csv.
    #[arg(long)]
    pub shadow: bool,
    /// Draw the figures into DIR/plots/ (PNG and SVG).
    #[arg(long)]
    pub plot: bool,
    /// Write DIR/animation.gif.
    #[arg(long)]
    pub animate: bool,
    /// Animation frames per simulated second (default 25).
    #[arg(long)]
    pub fps: Option<f64>,
    /// Animation size WIDTHxHEIGHT in pixels (default 640x480).
    #[arg(long)]
    pub gif_size: Option<String>,
    /// Write DIR/recording.mcap: the run for Foxglove (3-D scene, frame
    /// transforms, numeric channels for its plot panel).
    #[arg(long)]
    pub mcap: bool,
}

/// Exit code for bad input (a scene or an option), as clap uses.
pub const EXIT_BAD_INPUT: u8 = 2;
/// Exit code for a run whose solver failed.
pub const EXIT_FAILED: u8 = 1;

pub fn main() -> ExitCode {
    let cli = Cli::parse();
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
                tracing_subscriber::EnvFilter::new("warn,iceoryx2_bb_loggers=error")
            }),
        )
        .with_writer(std::io::stderr)
        // Colour codes only for a terminal: a log file or a pipe gets plain
        // text (issue 15: ANSI codes in every captured stderr).
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    match cli.command {
        Command::Run(args) => run::run(&args),
        Command::Plot(args) => run::plot(&args),
        Command::Lcp(args) => lcp::lcp(&args),
        Command::Fc3d(args) => lcp::fc3d(&args),
        Command::Serve(args) => serve::serve(&args),
        Command::Demo(args) => serve::demo(&args),
        Command::Replay(args) => serve::replay(&args),
        Command::Summarize(args) => serve::summarize(&args),
        Command::PdController(args) => serve::pd_controller(&args),
        Command::Bench {
            what: BenchWhat::Ipc { steps, quick, out },
        } => print_table(
            "bench ipc",
            crate::serve::bench::run(steps, quick).map_err(|e| e.to_string()),
            out.as_deref(),
        ),
        Command::Bench {
            what: BenchWhat::Accuracy(args),
        } => bench_accuracy(&args),
        Command::Bench {
            what:
                BenchWhat::Stress {
                    solver,
                    long_steps,
                    out,
                },
        } => bench_stress(&solver, long_steps, out.as_deref()),
        Command::Bench {
            what:
                BenchWhat::Fuzz {
                    print_scene: Some(case),
                    ..
                },
        } => {
            print!("{}", crate::fuzz::scene_text(case));
            ExitCode::SUCCESS
        }
        Command::Bench {
            what:
                BenchWhat::Fuzz {
                    scenes,
                    inputs,
                    seed,
                    out,
                    ..
                },
        } => {
            use crate::fuzz;
            // The engine's warnings about the broken scenes would bury the
            // counts: the defects are what this prints.
            let quiet = tracing::subscriber::NoSubscriber::default();
            let (s, i) = tracing::subscriber::with_default(quiet, || {
                (fuzz::scenes(seed, scenes), fuzz::inputs(seed, inputs))
            });
            let mut text = format!(
                "bench fuzz (seed {seed})\n{}\n{}\n",
                s.line("scenes"),
                i.line("inputs")
            );
            for d in s.defects.iter().chain(&i.defects).take(50) {
                text += &format!("defect: {d}\n");
            }
            let code = print_table("bench fuzz", Ok(text), out.as_deref());
            if s.defects.is_empty() && i.defects.is_empty() {
                code
            } else {
                ExitCode::from(EXIT_FAILED)
            }
        }
        Command::Bench {
            what:
                BenchWhat::Robust {
                    seed,
                    print_scene: true,
                    ..
                },
        } => {
            print!("{}", cosim_bench::robust::scene(seed));
            ExitCode::SUCCESS
        }
        Command::Bench {
            what:
                BenchWhat::Robust {
                    scenes,
                    steps,
                    seed,
                    solver,
                    out,
                    ..
                },
        } => {
            use cosim_bench::robust;
            let table = robust::run(scenes, steps, seed, solver)
                .map(|s| robust::table(&s, steps, seed, solver));
            print_table("bench robust", table, out.as_deref())
        }
        Command::Bench {
            what:
                BenchWhat::Pile {
                    n,
                    steps,
                    dt,
                    solver,
                    seed,
                    layers,
                    trace,
                    velocity_tolerance,
                    max_iterations,
                    relative,
                    stop,
                    no_momentum,
                    relaxation,
                    no_sleep,
                    sleep_speeds,
                    pendulum,
                    out,
                },
        } => {
            use cosim_bench::pile;
            let settings = pile::Settings {
                dt,
                steps,
                solver,
                pgs: crate::engine::solver::PgsParams {
                    velocity_tolerance,
                    max_iterations,
                    momentum: !no_momentum,
                    relaxation,
                    stop,
                    relative,
                    ..Default::default()
                },
                seed,
                trace,
                sleep: match no_sleep {
                    true => cosim_shared::scene::SleepDesc::off(),
                    false => sleep_speeds.unwrap_or_default(),
                },
                shape: layers.map_or(pile::Shape::Cube, |l| pile::Shape::Layers(l as usize)),
                pendulum,
            };
            let rows: Vec<_> = n.iter().map(|&n| pile::run(n, &settings)).collect();
            let table = format!(
                "# Pile\n\nMachine: {}.\n\n{}",
                cosim_bench::accuracy::machine(),
                pile::table(&rows, &settings)
            );
            print_table("bench pile", Ok(table), out.as_deref())
        }
        Command::Bench {
            what: BenchWhat::Skips { steps, out },
        } => {
            let table = cosim_bench::skips::measure(steps).map(|ms| {
                format!(
                    "# Skips\n\nMachine: {}. Median microseconds per step, skip on / off, from the step reports.\n\n{}",
                    cosim_bench::accuracy::machine(),
                    cosim_bench::skips::table(&ms, steps)
                )
            });
            print_table("bench skips", table, out.as_deref())
        }
        Command::BenchPeer { role, name, wait } => {
            match crate::serve::bench::run_peer(&role, &name, wait) {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => {
                    eprintln!("error: bench peer {role}: {e}");
                    ExitCode::from(EXIT_FAILED)
                }
            }
        }
    }
}

fn bench_accuracy(args: &AccuracyArgs) -> ExitCode {
    use cosim_bench::{accuracy, cases::CaseId};
    let mut sweep = if args.quick {
        accuracy::Sweep::quick()
    } else {
        accuracy::Sweep::full()
    };
    if !args.cases.is_empty() {
        let mut cases = Vec::new();
        for c in &args.cases {
            match CaseId::parse(c) {
                Some(id) => cases.push(id),
                None => {
                    eprintln!(
                        "error: --cases: unknown case {c:?}, expected S1, S2, S3, S4, S6, S7, S8 or REF"
                    );
                    return ExitCode::from(EXIT_BAD_INPUT);
                }
            }
        }
        sweep.cases = cases;
    }
    let machine = accuracy::machine();
    println!("# bench accuracy on {machine}");
    let result = accuracy::sweep(&sweep, |p| println!("{}", p.line()));
    let (points, notes) = match result {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: bench accuracy: {e}");
            return ExitCode::from(EXIT_FAILED);
        }
    };
    for n in &notes {
        println!("{n}");
    }
    match accuracy::write(&points, &notes, &args.out, &machine) {
        Ok(files) => {
            for f in files {
                println!("wrote {}", f.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: bench accuracy: {e}");
            ExitCode::from(EXIT_FAILED)
        }
    }
}

fn bench_stress(
    solvers: &[cosim_shared::SolverChoice],
    long_steps: u64,
    out: Option<&std::path::Path>,
) -> ExitCode {
    use cosim_bench::stress;
    let mut all = Vec::new();
    for &s in solvers {
        for o in stress::all(s, long_steps) {
            println!(
                "{:5} {:40} {:5} {}  [{}] {}",
                s.as_str(),
                o.case,
                if o.pass { "pass" } else { "FAIL" },
                o.figure,
                o.solvers,
                o.note
            );
            all.push(o);
        }
    }
    let table = format!(
        "# Stress suite\n\nMachine: {}.\n\n{}",
        cosim_bench::accuracy::machine(),
        stress::table(&all)
    );
    if let Some(path) = out {
        if let Err(e) = std::fs::write(path, &table) {
            eprintln!("error: cannot write {}: {e}", path.display());
            return ExitCode::from(EXIT_FAILED);
        }
        println!("wrote {}", path.display());
    }
    ExitCode::SUCCESS
}

/// Prints a benchmark's table and writes it to `out` when given.
fn print_table(
    what: &str,
    table: Result<String, String>,
    out: Option<&std::path::Path>,
) -> ExitCode {
    let table = match table {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {what}: {e}");
            return ExitCode::from(EXIT_FAILED);
        }
    };
    print!("{table}");
    if let Some(path) = out {
        if let Err(e) = std::fs::write(path, &table) {
            eprintln!("error: cannot write {}: {e}", path.display());
            return ExitCode::from(EXIT_FAILED);
        }
    }
    ExitCode::SUCCESS
}

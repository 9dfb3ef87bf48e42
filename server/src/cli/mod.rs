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
        /// Also write the table to this file.
        #[arg(long)]
        out: Option<PathBuf>,
    },
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
    /// singular, not_converged), solver, pivots, residual, z.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args, Debug, Clone)]
pub struct PlotArgs {
    /// Output folder of a run (holding scene.toml and the CSV files).
    pub dir: PathBuf,
    /// Also write N evenly spread frames of the animation as PNG stills.
    #[arg(long, default_value_t = 0)]
    pub stills: usize,
}

#[derive(clap::Args, Debug, Clone)]
pub struct RunArgs {
    /// Scene file (TOML); the built-in reference scene when omitted.
    pub scene: Option<PathBuf>,
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
    /// Output folder; default out/<scene name>.
    #[arg(long)]
    pub out: Option<PathBuf>,
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
        .init();
    match cli.command {
        Command::Run(args) => run::run(&args),
        Command::Plot(args) => run::plot(&args),
        Command::Lcp(args) => lcp::lcp(&args),
        Command::Fc3d(args) => lcp::fc3d(&args),
        Command::Serve(args) => serve::serve(&args),
        Command::Demo(args) => serve::demo(&args),
        Command::Replay(args) => serve::replay(&args),
        Command::PdController(args) => serve::pd_controller(&args),
        Command::Bench {
            what: BenchWhat::Ipc { steps, out },
        } => match crate::serve::bench::run(steps) {
            Ok(table) => {
                print!("{table}");
                if let Some(path) = out {
                    if let Err(e) = std::fs::write(&path, &table) {
                        eprintln!("error: cannot write {}: {e}", path.display());
                        return ExitCode::from(EXIT_FAILED);
                    }
                }
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: bench ipc: {e}");
                ExitCode::from(EXIT_FAILED)
            }
        },
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

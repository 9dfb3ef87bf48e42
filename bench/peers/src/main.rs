//! `cosim-peers`: the work-precision cases with our engine, Rapier and
//! MuJoCo side by side, in one run, on one thread each.
//!
//! Every engine gets the same scene (our TOML, built from `cases.rs`), and
//! its trajectory is scored by the same `Scorer`. Timing covers the engine's
//! step calls only.

mod mujoco;
mod rapier;

use clap::Parser;
use cosim_server::bench::accuracy::{self, Point, Sweep};
use cosim_server::bench::cases::CaseId;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(about = "Work-precision of our engine, Rapier and MuJoCo on the same cases")]
struct Args {
    /// Output folder (CSV and diagrams).
    #[arg(long, default_value = "bench/results")]
    out: PathBuf,
    /// Two steps and two settings only.
    #[arg(long)]
    quick: bool,
    /// Only these cases (S1, S2, S3, S4, S6, REF), comma-separated.
    #[arg(long, value_delimiter = ',')]
    cases: Vec<String>,
    /// Python with the `mujoco` package (skipped when it does not import).
    #[arg(long, default_value = "python3")]
    python: String,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let mut sweep = if args.quick {
        Sweep::quick()
    } else {
        Sweep::full()
    };
    if !args.cases.is_empty() {
        sweep.cases = args.cases.iter().filter_map(|c| CaseId::parse(c)).collect();
    }
    let machine = accuracy::machine();
    println!("# peers on {machine}");
    let show = |p: &Point| println!("{}", p.line());
    let (mut points, mut notes) = match accuracy::sweep(&sweep, show) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: our sweep: {e}");
            return ExitCode::FAILURE;
        }
    };
    // The converged reference of the REF case, as our sweep used it.
    let reference = if sweep.cases.contains(&CaseId::Reference) {
        match accuracy::reference_trajectory(sweep.reference_h / 2.0, 8) {
            Ok(r) => Some(r),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        }
    } else {
        None
    };
    for &case in &sweep.cases {
        for &h in &sweep.steps {
            for p in rapier::run(case, h, reference.as_ref()) {
                show(&p);
                points.push(p);
            }
        }
    }
    match mujoco::available(&args.python) {
        Ok(version) => {
            notes.push(format!(
                "MuJoCo {version} (Python package; whole runs timed with mujoco.rollout, a C loop)"
            ));
            for &case in &sweep.cases {
                // Euler is MuJoCo's default; RK4 what a user picks for a
                // smooth system (it pays on the contact-free chain).
                for integrator in ["Euler", "RK4"] {
                    for &h in &sweep.steps {
                        match mujoco::run(&args.python, integrator, case, h, reference.as_ref()) {
                            Ok(p) => {
                                show(&p);
                                points.push(p);
                            }
                            Err(e) => eprintln!("mujoco {} h={h:e}: {e}", case.key()),
                        }
                    }
                }
            }
        }
        Err(e) => notes.push(format!("MuJoCo skipped: {e}")),
    }
    notes.push(format!(
        "Rapier {} (rapier3d-f64, default integration parameters: 4 solver iterations)",
        rapier::VERSION
    ));
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
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

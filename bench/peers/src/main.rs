//! `cosim-peers`: the work-precision cases with our engine, Rapier and
//! MuJoCo side by side, in one run, on one thread each.
//!
//! Every engine gets the same scene (our TOML, built from `cases.rs`), and
//! its trajectory is scored by the same `Scorer`. Timing covers the engine's
//! step calls only.

mod mujoco;
mod pile;
mod rapier;

use clap::Parser;
use cosim_bench::accuracy::{self, Point, Sweep};
use cosim_bench::cases::CaseId;
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
    /// Only these cases (S1, S2, S3, S4, S6, S7, S8, REF), comma-separated.
    #[arg(long, value_delimiter = ',')]
    cases: Vec<String>,
    /// Python with the `mujoco` package (skipped when it does not import).
    #[arg(long, default_value = "python3")]
    python: String,
    /// Instead of the cases: the pile of issue 14 at these sizes, ours
    /// and Rapier (1, 4, 8, 16 iterations; sleeping on and off).
    #[arg(long, value_delimiter = ',')]
    pile: Vec<usize>,
    /// Lay each pile out in this many layers (`bench pile --layers`)
    /// instead of as a cube.
    #[arg(long)]
    pile_layers: Option<usize>,
    /// Steps of each pile run.
    #[arg(long, default_value_t = 500)]
    pile_steps: u64,
    /// Our engine runs the piles up to this size only.
    #[arg(long, default_value_t = 4000)]
    ours_up_to: usize,
    /// Our PGS tolerances (m/s, the residual rule): the first is run with
    /// sleeping off and on, the others with sleeping off, as points of the
    /// work-precision figure.
    #[arg(long, value_delimiter = ',', default_value = "1e-2,3e-2,3e-3")]
    ours_tolerances: Vec<f64>,
    /// Our first tolerance without its run with sleeping on.
    #[arg(long)]
    no_ours_sleep: bool,
    /// Our first tolerance also with sleeping at these thresholds,
    /// `LINEAR,ANGULAR` (m/s, rad/s): `0.1,2` is about Rapier's rule for
    /// these spheres (no point faster than 0.1 m/s over a step).
    #[arg(long, value_parser = cosim_bench::pile::sleep_speeds)]
    ours_sleep_speeds: Option<cosim_shared::scene::SleepDesc>,
    /// Rapier's iteration counts (each with sleeping off and on).
    #[arg(long, value_delimiter = ',', default_value = "1,4,8,16")]
    rapier_iterations: Vec<usize>,
    /// Also write the pile table to this file.
    #[arg(long)]
    pile_out: Option<PathBuf>,
    /// Draw the pile figures again from a table written by --pile-out,
    /// without running the piles.
    #[arg(long)]
    pile_from: Option<PathBuf>,
}

fn piles(args: &Args) -> ExitCode {
    use cosim_bench::pile::{Settings, Shape};
    use cosim_shared::scene::SleepDesc;
    // The pile scene's own rule at each tolerance.
    let rule = cosim_bench::pile::pgs;
    let settings = Settings {
        dt: 0.01,
        steps: args.pile_steps,
        solver: "auto".into(),
        pgs: rule(args.ours_tolerances.first().copied().unwrap_or(1e-2)),
        seed: 1,
        trace: 0,
        sleep: SleepDesc::off(),
        shape: args
            .pile_layers
            .map_or(Shape::Cube, |l| Shape::Layers(l.max(1))),
        pendulum: false,
    };
    let mut rows = Vec::new();
    for &n in &args.pile {
        if n <= args.ours_up_to {
            for (k, &tolerance) in args.ours_tolerances.iter().enumerate() {
                let mut sleeps = vec![SleepDesc::off()];
                if k == 0 && !args.no_ours_sleep {
                    sleeps.push(SleepDesc::default());
                }
                if let Some(s) = args.ours_sleep_speeds.filter(|_| k == 0) {
                    sleeps.push(s);
                }
                for sleep in sleeps {
                    let r = pile::ours(
                        n,
                        &Settings {
                            sleep,
                            pgs: rule(tolerance),
                            ..settings.clone()
                        },
                    );
                    eprintln!("{r:?}");
                    rows.push(r);
                }
            }
        }
        for sleep in [false, true] {
            for &iterations in &args.rapier_iterations {
                let r = pile::rapier(n, &settings, iterations, sleep);
                eprintln!("{r:?}");
                rows.push(r);
            }
        }
    }
    let table = format!(
        "# Pile, ours and Rapier\n\nMachine: {}.\n\n{}\nFitted slope of the mean time per step against N (log-log):\n\n{}",
        accuracy::machine(),
        pile::table(&rows, &settings),
        pile::slopes(&rows)
    );
    println!("{table}");
    match pile::figures(&rows, &args.out, &accuracy::machine()) {
        Ok(files) => {
            for f in files {
                println!("wrote {}", f.display());
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    }
    if let Some(path) = &args.pile_out {
        if let Err(e) = std::fs::write(path, &table) {
            eprintln!("error: cannot write {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
    }
    ExitCode::SUCCESS
}

fn main() -> ExitCode {
    let args = Args::parse();
    if let Some(path) = &args.pile_from {
        let rows = std::fs::read_to_string(path)
            .map_err(|e| e.to_string())
            .and_then(|t| pile::parse_table(&t));
        let drawn = rows.and_then(|rows| pile::figures(&rows, &args.out, &accuracy::machine()));
        return match drawn {
            Ok(files) => {
                for f in files {
                    println!("wrote {}", f.display());
                }
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {}: {e}", path.display());
                ExitCode::FAILURE
            }
        };
    }
    if !args.pile.is_empty() {
        return piles(&args);
    }
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
    // Each case's converged reference, as our sweep used it.
    let mut references = Vec::new();
    for &case in &sweep.cases {
        match accuracy::case_reference(case, sweep.reference_h) {
            Ok(r) => references.push(r.map(|(r, _)| r)),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    for (&case, reference) in sweep.cases.iter().zip(&references) {
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
            for (&case, reference) in sweep.cases.iter().zip(&references) {
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

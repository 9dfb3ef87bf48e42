//! `cosim sweep`: many runs of one scene as parallel processes, each in
//! its own iceoryx2 domain (`crate::domain`) and its own folder, and one
//! table of their summaries. A run's folder holds its parameters
//! (`params.json`), the server's outputs and logs; a run whose folder has
//! its summary for the same parameters is not run again (an interrupted
//! sweep resumes). The engine is deterministic and a run shares nothing
//! with the others, so a run is reproduced to the bit by running its line
//! alone (`--only N`), whatever ran beside it.

mod plan;
mod runner;
mod table;

pub use plan::{Plan, Run};

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// What `cosim sweep` was asked.
#[derive(Debug, Clone)]
pub struct Options {
    pub file: PathBuf,
    pub out: PathBuf,
    /// Runs at once (default: the file's, else the machine's cores).
    pub parallel: Option<usize>,
    /// Only this run (a Slurm array task's, a Ray task's).
    pub only: Option<usize>,
    /// List the runs and stop.
    pub list: bool,
    /// Only rebuild the table from the runs' folders.
    pub table: bool,
    /// Run again the runs that have their summary already.
    pub redo: bool,
    /// The `cosim-server` program (default: beside this one, else PATH).
    pub server: Option<PathBuf>,
}

/// The folder of run `index` under `out`.
pub fn folder(out: &Path, index: usize) -> PathBuf {
    out.join(format!("run-{index:04}"))
}

/// Runs the sweep; the error says what went wrong, with the file's
/// problems all at once.
pub fn sweep(o: &Options) -> Result<(), String> {
    let plan = Plan::read(&o.file)?;
    if o.list {
        for r in &plan.runs {
            println!("{}\t{}", r.index, table::params_text(r));
        }
        return Ok(());
    }
    std::fs::create_dir_all(&o.out)
        .map_err(|e| format!("{}: cannot create: {e}", o.out.display()))?;
    if !o.table {
        let chosen: Vec<&Run> = match o.only {
            Some(i) => vec![plan.runs.get(i).ok_or_else(|| {
                format!(
                    "--only {i}: the sweep has runs 0 to {}",
                    plan.runs.len() - 1
                )
            })?],
            None => plan.runs.iter().collect(),
        };
        let runner = runner::Runner::new(&plan, o)?;
        let asked = chosen.len();
        let todo: Vec<&Run> = chosen
            .into_iter()
            .filter(|r| o.redo || !runner.done(r))
            .collect();
        let skipped = asked - todo.len();
        let parallel = o
            .parallel
            .or(plan.sweep.parallel)
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
            .max(1);
        eprintln!(
            "sweep: {} runs to do ({} done before), {} at once, into {}",
            todo.len(),
            skipped,
            parallel,
            o.out.display()
        );
        let next = AtomicUsize::new(0);
        let failed = Mutex::new(Vec::new());
        let start = std::time::Instant::now();
        std::thread::scope(|s| {
            for _ in 0..parallel.min(todo.len()) {
                s.spawn(|| loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    let Some(run) = todo.get(k) else { break };
                    let outcome = runner.run(run);
                    eprintln!(
                        "run {}: {} ({})",
                        run.index,
                        outcome,
                        table::params_text(run)
                    );
                    if outcome != "ok" {
                        failed
                            .lock()
                            .unwrap_or_else(|e| e.into_inner())
                            .push(run.index);
                    }
                });
            }
        });
        eprintln!(
            "sweep: {} runs in {:.2} s",
            todo.len(),
            start.elapsed().as_secs_f64()
        );
        let mut failed = failed.into_inner().unwrap_or_else(|e| e.into_inner());
        failed.sort_unstable();
        let path = table::write(&plan, &o.out)?;
        eprintln!("sweep: table {}", path.display());
        // A scheduler (a Slurm array, Ray) tells a failed task by its exit.
        if !failed.is_empty() {
            return Err(format!(
                "{} of {} runs did not end well: {failed:?} (their lines in the table and their folders' logs say why)",
                failed.len(),
                asked
            ));
        }
        return Ok(());
    }
    let path = table::write(&plan, &o.out)?;
    eprintln!("sweep: table {}", path.display());
    Ok(())
}

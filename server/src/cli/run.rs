//! `cosim-server run`.

use super::{PlotArgs, RunArgs, EXIT_BAD_INPUT, EXIT_FAILED};
use crate::engine::{Engine, Model, StepReport};
use crate::output::{num, Writers};
use cosim_figures::{self as plot, PlotOptions};
use cosim_shared::{Scene, SceneError};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Loads the scene and applies the command-line overrides, validating both.
pub fn load(args: &RunArgs) -> Result<Scene, SceneError> {
    let mut scene = match &args.scene {
        // A robot (`.urdf`, `.xml`: MJCF) is read as a scene of its own
        // (cosim_import), a scene's `[[robot]]`s placed
        // (cosim_import::scene); what they approximated or merged is said.
        Some(path) => {
            let imported = if cosim_import::is_robot(path) {
                let options = cosim_import::Options {
                    fixed_base: args.robot.fixed_base,
                    floor: args.robot.floor,
                    self_collision: args.robot.self_collision,
                    ..Default::default()
                };
                cosim_import::load(path, options)?
            } else {
                cosim_import::scene::load(path)?
            };
            if !args.quiet {
                for note in &imported.notes {
                    eprintln!("note: {}: {note}", path.display());
                }
            }
            imported.scene
        }
        None => cosim_shared::scenes::reference()?,
    };
    let file = args
        .scene
        .as_ref()
        .map_or("<built-in reference.toml>".to_string(), |p| {
            p.display().to_string()
        });
    let simulated = scene.step_count() as f64 * scene.sim.dt;
    if let Some(dt) = args.dt {
        scene.sim.dt = dt;
    }
    if let Some(t) = args.duration {
        scene.sim.duration = Some(t);
        scene.sim.steps = None;
    } else if let Some(n) = args.steps {
        scene.sim.steps = Some(n);
        scene.sim.duration = None;
    } else if args.dt.is_some() {
        scene.sim.duration = Some(simulated);
        scene.sim.steps = None;
    }
    if let Some(s) = args.solver {
        scene.sim.solver = s;
    }
    if let Some(nd) = args.friction_directions {
        scene.sim.friction_directions = nd;
    }
    // The overrides obey the same rules as the file; name the option.
    scene.validate(&file).map_err(|mut e| {
        let option = match e.field.as_str() {
            "sim.dt" if args.dt.is_some() => Some("--dt"),
            "sim.duration" if args.duration.is_some() => Some("--duration"),
            "sim.steps" if args.steps.is_some() => Some("--steps"),
            "sim.friction_directions" if args.friction_directions.is_some() => {
                Some("--friction-directions")
            }
            _ => None,
        };
        if let Some(o) = option {
            e.file = "command line".into();
            e.field = o.into();
        }
        e
    })?;
    Ok(scene)
}

/// What a run measured, for the summary.
#[derive(Default)]
struct Tally {
    failures: u64,
    first_failure: Option<String>,
    max_penetration: f64,
    max_joint_error: f64,
    max_joint_angle_error: f64,
    max_lcp_size: usize,
    pivots: u64,
    max_residual: f64,
    resolves: u64,
    regularized: u64,
    projected: u64,
    /// Joint-steps whose held effort its bound clamped.
    clamped_efforts: u64,
    ladder: crate::engine::LadderCounts,
    energy: crate::output::EnergyTally,
}

impl Tally {
    fn add(&mut self, r: &StepReport) {
        self.max_penetration = self.max_penetration.max(r.max_penetration);
        self.max_joint_error = self.max_joint_error.max(r.max_joint_error);
        self.max_joint_angle_error = self.max_joint_angle_error.max(r.max_joint_angle_error);
        self.max_lcp_size = self.max_lcp_size.max(r.lcp_size);
        self.pivots += r.pivots as u64;
        self.max_residual = self.max_residual.max(r.residual);
        self.resolves += r.resolves as u64;
        self.regularized += r.regularized as u64;
        self.projected += r.projected as u64;
        self.clamped_efforts += r.clamped_efforts as u64;
        self.ladder.add(r);
        self.energy.add(r);
        if let Some(e) = r.error {
            self.failures += 1;
            self.first_failure
                .get_or_insert_with(|| format!("step {}: {e}", r.step + 1));
        }
    }
}

pub fn run(args: &RunArgs) -> ExitCode {
    let scene = match load(args) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let mut model = Model::from_scene(&scene);
    model.params.full = args.full;
    let default = PathBuf::from("out").join(scene.name());
    let given = args.out.as_deref();
    let out = match crate::output::run_folder(given, default, args.overwrite, args.quiet) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    // The scene as run (overrides applied) goes with the outputs, so that
    // `plot` and later tools can read the run from its folder alone.
    let written = std::fs::create_dir_all(&out)
        .and_then(|_| std::fs::write(out.join("scene.toml"), scene.to_toml()));
    if let Err(e) = written {
        eprintln!(
            "error: cannot write {}: {e}",
            out.join("scene.toml").display()
        );
        return ExitCode::from(EXIT_FAILED);
    }
    let ok = match simulate(model, scene.step_count(), &out, args.quiet, args.shadow) {
        Ok(ok) => ok,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_FAILED);
        }
    };
    if args.plot || args.animate {
        let gif_size = match size_option("--gif-size", args.gif_size.as_deref()) {
            Ok(s) => s,
            Err(code) => return code,
        };
        let opts = PlotOptions {
            figures: args.plot,
            animation: args.animate,
            fps: args.fps,
            gif_size,
            ..PlotOptions::default()
        };
        if let Err(code) = draw(&out, &opts, args.quiet) {
            return code;
        }
    }
    if args.mcap {
        if let Err(code) = record(&out, args.quiet) {
            return code;
        }
    }
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FAILED)
    }
}

/// Writes `DIR/recording.mcap` from the run's files.
fn record(dir: &std::path::Path, quiet: bool) -> Result<(), ExitCode> {
    let path = dir.join("recording.mcap");
    match cosim_figures::mcap::write(dir, &path) {
        Ok(w) => {
            if !quiet {
                let n: u64 = w.messages.values().sum();
                println!(
                    "recording    {} ({n} messages on {} channels; open it in Foxglove)",
                    path.display(),
                    w.messages.len()
                );
            }
            for what in &w.not_drawn {
                eprintln!("warning: the recording does not draw {what}");
            }
            Ok(())
        }
        Err(e) => {
            eprintln!("error: {e}");
            Err(ExitCode::from(match e {
                cosim_figures::mcap::McapError::Read(_) => EXIT_BAD_INPUT,
                cosim_figures::mcap::McapError::Write(_) => EXIT_FAILED,
            }))
        }
    }
}

/// `cosim-server plot DIR`.
pub fn plot(args: &PlotArgs) -> ExitCode {
    if args.mcap {
        return match record(&args.dir, false) {
            Ok(()) => ExitCode::SUCCESS,
            Err(code) => code,
        };
    }
    let size = match size_option("--size", args.size.as_deref()) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let gif_size = match size_option("--gif-size", args.gif_size.as_deref()) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let figure = plot::figures::Options {
        only: args
            .only
            .as_ref()
            .map(|o| o.split(',').map(|s| s.trim().to_string()).collect()),
        size,
        per_contact: args.per_contact,
    };
    if let Some(only) = &figure.only {
        if let Some(bad) = only
            .iter()
            .find(|o| !plot::figures::STEMS.contains(&o.as_str()))
        {
            eprintln!(
                "error: --only {bad:?} is not a figure; the figures are {}",
                plot::figures::STEMS.join(", ")
            );
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    }
    // A window or a choice of figures or bodies is about the figures: no
    // animation.
    let focused =
        figure.only.is_some() || args.from.is_some() || args.to.is_some() || args.bodies.is_some();
    let opts = PlotOptions {
        figures: true,
        animation: !focused,
        stills: args.stills,
        figure,
        from: args.from,
        to: args.to,
        fps: args.fps,
        gif_size,
        bodies: args
            .bodies
            .as_ref()
            .map(|b| b.split(',').map(|s| s.trim().to_string()).collect()),
    };
    if let Some(other) = &args.other {
        let out = args.out.clone().unwrap_or_else(|| args.dir.join("compare"));
        return match plot::render_overlay(&args.dir, other, &out, &opts) {
            Ok(files) => {
                println!("figures      {} files in {}", files.len(), out.display());
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(match e {
                    plot::PlotError::Read(_) => EXIT_BAD_INPUT,
                    plot::PlotError::Draw(_) => EXIT_FAILED,
                })
            }
        };
    }
    // A window or a subset of figures or bodies goes beside the run's own
    // figures (`DIR/focus/`), never over them; `--out` puts any plot where
    // it says.
    let out = match (&args.out, focused) {
        (Some(o), _) => o.clone(),
        (None, true) => args.dir.join("focus"),
        (None, false) => args.dir.clone(),
    };
    match draw_into(&args.dir, &out, &opts, false) {
        Ok(()) => ExitCode::SUCCESS,
        Err(code) => code,
    }
}

/// An optional size option (`flag` WIDTHxHEIGHT): its value, or the exit
/// code of bad input after saying why.
fn size_option(flag: &str, value: Option<&str>) -> Result<Option<(u32, u32)>, ExitCode> {
    value.map(parse_size).transpose().map_err(|m| {
        eprintln!("error: {flag} {m}");
        ExitCode::from(EXIT_BAD_INPUT)
    })
}

/// `WIDTHxHEIGHT` in pixels, each 200 to 10,000.
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("{s:?}: write WIDTHxHEIGHT in pixels, e.g. 1600x900");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h): (u32, u32) = (
        w.trim().parse().map_err(|_| bad())?,
        h.trim().parse().map_err(|_| bad())?,
    );
    if !(200..=10_000).contains(&w) || !(200..=10_000).contains(&h) {
        return Err(format!("{s:?}: each side from 200 to 10000 pixels"));
    }
    Ok((w, h))
}

fn draw(dir: &std::path::Path, opts: &PlotOptions, quiet: bool) -> Result<(), ExitCode> {
    draw_into(dir, dir, opts, quiet)
}

fn draw_into(
    dir: &std::path::Path,
    out: &std::path::Path,
    opts: &PlotOptions,
    quiet: bool,
) -> Result<(), ExitCode> {
    if let Err(e) = std::fs::create_dir_all(out) {
        eprintln!("error: cannot create {}: {e}", out.display());
        return Err(ExitCode::from(EXIT_FAILED));
    }
    match plot::render_into(dir, out, opts) {
        Ok(files) => {
            if !quiet {
                println!("figures      {} files in {}", files.len(), out.display());
            }
            Ok(())
        }
        Err(e) => {
            eprintln!("error: {e}");
            Err(ExitCode::from(match e {
                plot::PlotError::Read(_) => EXIT_BAD_INPUT,
                plot::PlotError::Draw(_) => EXIT_FAILED,
            }))
        }
    }
}

/// Runs `steps` steps writing every file; `Ok(false)` when a step failed.
fn simulate(
    model: Model,
    steps: u64,
    out: &std::path::Path,
    quiet: bool,
    shadow: bool,
) -> std::io::Result<bool> {
    let started = Instant::now();
    let mut writers = Writers::create(out)?;
    // The shadow: the same model with the other solver, restarted from the
    // main run's state before every step.
    let mut shadow_engine = shadow.then(|| {
        let mut m = model.clone();
        m.params.solver = match m.params.solver {
            cosim_shared::SolverChoice::Lemke | cosim_shared::SolverChoice::Auto => {
                cosim_shared::SolverChoice::Pgs
            }
            cosim_shared::SolverChoice::Pgs => cosim_shared::SolverChoice::Lemke,
        };
        // A comparison: PGS close to its answer, as `solvers_agree` runs it.
        m.params.pgs = crate::engine::solver::PgsParams::precise();
        Engine::new(m)
    });
    let mut shadow_max = (0.0f64, 0.0f64);
    let mut engine = Engine::new(model);
    let energy_initial = crate::engine::measure::energy(engine.model(), engine.state());
    writers.state(&engine)?;
    let mut tally = Tally {
        energy: crate::output::EnergyTally::start(energy_initial.total),
        ..Tally::default()
    };
    let mut progress = crate::progress::Progress::new(quiet, Some(steps));
    let mut last_report = None;
    // Ctrl-C (SIGINT) or SIGTERM ends the run after the step under way:
    // the files are flushed and the summary written, marked interrupted.
    let mut interrupted = false;
    for k in 0..steps {
        if crate::serve::terminated() {
            interrupted = true;
            break;
        }
        if let Some(s) = shadow_engine.as_mut() {
            s.set_state(engine.state().clone());
        }
        let report = engine.step();
        tally.add(&report);
        if report.ok() {
            writers.state(&engine)?;
            writers.impulses(&engine)?;
        }
        let diff = shadow_engine.as_mut().and_then(|s| {
            if !(s.step().ok() && report.ok()) {
                return None;
            }
            let d = engine
                .state()
                .bodies
                .iter()
                .zip(&s.state().bodies)
                .fold((0.0f64, 0.0f64), |d, (a, b)| {
                    (d.0.max((a.v - b.v).norm()), d.1.max((a.w - b.w).norm()))
                });
            shadow_max = (shadow_max.0.max(d.0), shadow_max.1.max(d.1));
            Some(d)
        });
        writers.step(&report, diff)?;
        last_report = Some(report);
        if let Some(e) = report.error {
            // The problem Lemke failed on, for `cosim-server lcp FILE` (or
            // any Siconos solver): a failure one can reproduce without the
            // run. (A singular joint block fails before there is an LCP.)
            if matches!(e, crate::engine::StepError::Lemke(_)) {
                let (n, m, q) = engine.last_lcp();
                std::fs::write(
                    writers.dir().join("failed_lcp.dat"),
                    crate::corpus::write_lcp(n, m, q),
                )?;
            }
            break;
        }
        if k % 1000 == 999 {
            writers.flush()?;
        }
        progress.tick(k + 1, String::new);
    }
    progress.finish();
    writers.flush()?;
    let wall = started.elapsed().as_secs_f64();
    let state = engine.state();
    let model = engine.model();
    let energy_final = last_report.map(|r| r.energy).unwrap_or(energy_initial);
    let summary = serde_json::json!({
        "scene": model.name,
        "steps": state.step,
        "steps_requested": steps,
        "interrupted": interrupted,
        "t_end": state.t,
        "dt": model.params.h,
        "solver": model.params.solver.as_str(),
        "friction_directions": model.params.friction_directions,
        "pruning": !model.params.full,
        "failures": tally.failures,
        "first_failure": tally.first_failure,
        "max_penetration": tally.max_penetration,
        "max_joint_error": tally.max_joint_error,
        "max_joint_angle_error": tally.max_joint_angle_error,
        "max_lcp_size": tally.max_lcp_size,
        "pivots": tally.pivots,
        "max_residual": tally.max_residual,
        "resolves": tally.resolves,
        "regularized_solves": tally.regularized,
        "projected_contacts": tally.projected,
        "clamped_efforts": tally.clamped_efforts,
        "ladder": crate::output::ladder_json(&tally.ladder),
        "fallback_steps": tally.ladder.fell_back(),
        "shadow_max_dv": shadow.then_some(shadow_max.0),
        "shadow_max_dw": shadow.then_some(shadow_max.1),
        "energy_initial": energy_initial.total,
        "energy_final": energy_final.total,
        "energy_midpoint_initial": energy_initial.midpoint,
        "energy_midpoint_final": energy_final.midpoint,
        "max_energy_rise": tally.energy.max_rise,
        "max_energy_rise_step": tally.energy.max_rise_step,
        "wall_seconds": wall,
    });
    let path = out.join("summary.json");
    let mut f = std::fs::File::create(&path)?;
    writeln!(
        f,
        "{}",
        serde_json::to_string_pretty(&summary).unwrap_or_default()
    )?;

    if !quiet {
        println!(
            "scene        {} ({} bodies, {} planes, {} joints)",
            model.name,
            model.bodies.len(),
            model.planes.len(),
            model.joints.len()
        );
        println!(
            "steps        {} of h = {} s, t_end = {} s",
            state.step,
            num(model.params.h),
            num(state.t)
        );
        println!(
            "solver       {}, n_d = {}, {}",
            model.params.solver.as_str(),
            model.params.friction_directions,
            if model.params.full {
                "full LCP (no pruning)"
            } else {
                "pruned LCP"
            }
        );
        println!("LCP          largest {} unknowns, {} pivots in all, worst residual {:.1e}, {} re-solves, {} regularised solves", tally.max_lcp_size, tally.pivots, tally.max_residual, tally.resolves, tally.regularized);
        println!("ladder       {}", tally.ladder);
        if shadow {
            println!(
                "shadow       largest velocity difference to the other solver {:.2e} m/s, {:.2e} rad/s",
                shadow_max.0, shadow_max.1
            );
        }
        println!(
            "failures     {}{}",
            tally.failures,
            tally
                .first_failure
                .as_ref()
                .map_or(String::new(), |f| format!(" (first: {f})"))
        );
        println!("penetration  max {:.3e} m", tally.max_penetration);
        if tally.clamped_efforts > 0 {
            println!(
                "efforts      {} joint-steps clamped to their joint's max_effort",
                tally.clamped_efforts
            );
        }
        println!(
            "joint error  max {:.3e} m, {:.3e} rad",
            tally.max_joint_error, tally.max_joint_angle_error
        );
        println!(
            "energy       {:.6} J -> {:.6} J (midpoint {:.6} -> {:.6}){}",
            energy_initial.total,
            energy_final.total,
            energy_initial.midpoint,
            energy_final.midpoint,
            match tally.energy.max_rise > 0.0 {
                true => format!(
                    "; largest rise in a step {:.3e} J (step {})",
                    tally.energy.max_rise, tally.energy.max_rise_step
                ),
                false => String::new(),
            }
        );
        println!(
            "wall time    {:.3} s ({:.0} steps/s)",
            wall,
            state.step as f64 / wall.max(1e-9)
        );
        println!(
            "output       {}/{{states,joints,impulses,steps}}.csv, summary.json",
            writers.dir().display()
        );
    }
    if interrupted {
        eprintln!(
            "interrupted at step {} of {steps}: every file holds the steps taken, summary.json says so",
            state.step
        );
    }
    if let Some(f) = &tally.first_failure {
        eprintln!(
            "error: the solver failed at {f}; the files hold every step before it (and failed_lcp.dat the LCP Lemke failed on: cosim-server lcp FILE)"
        );
    }
    Ok(tally.failures == 0 && !interrupted)
}

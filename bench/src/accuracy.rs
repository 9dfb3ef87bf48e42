//! `cosim-server bench accuracy`: work-precision of our engine on the cases
//! of `cases.rs`, swept over h, solver, tolerance, `n_d` and pruning; a CSV
//! and one log-log diagram per case (error against wall time per simulated
//! second). The peers package adds Rapier's and MuJoCo's points to the same
//! table with [`Point`] and redraws with [`diagrams`].

use super::cases::{CaseId, Pose, Sample, Score, Scorer};
use cosim_engine::solver::PgsParams;
use cosim_engine::{Engine, ImpulseKind, Model};
use cosim_figures::{color, FONT};
use cosim_shared::num;
use cosim_shared::{FrictionCone, Integrator, PositionUpdate, Scene, SolverChoice};
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One solver configuration: a curve on the diagrams.
#[derive(Debug, Clone, PartialEq)]
pub struct Setting {
    pub name: String,
    pub solver: SolverChoice,
    /// PGS tolerance (relative natural-map residual).
    pub tolerance: f64,
    pub nd: usize,
    /// No pruning: every potential contact in the LCP.
    pub full: bool,
    pub cone: FrictionCone,
    pub position_update: PositionUpdate,
    /// The smooth islands' step (only the chains have one).
    pub integrator: Integrator,
}

impl Setting {
    /// Lemke, n_d = 8, with the trapezoid position update.
    pub fn trapezoid() -> Setting {
        Setting {
            name: "lemke nd=8 trapezoid".into(),
            position_update: PositionUpdate::Trapezoid,
            ..Setting::lemke(8, false)
        }
    }
    pub fn lemke(nd: usize, full: bool) -> Setting {
        Setting {
            name: format!("lemke nd={nd}{}", if full { " full" } else { "" }),
            solver: SolverChoice::Lemke,
            tolerance: 0.0,
            nd,
            full,
            cone: FrictionCone::Polyhedral,
            position_update: PositionUpdate::Euler,
            integrator: Integrator::Euler,
        }
    }
    /// Lemke, n_d = 8, with the smooth islands stepped by `integrator`.
    pub fn smooth(integrator: Integrator) -> Setting {
        let name = match integrator {
            Integrator::Rattle4 => "rattle4",
            Integrator::Rattle => "rattle",
            Integrator::Euler => "euler",
        };
        Setting {
            name: name.into(),
            integrator,
            ..Setting::lemke(8, false)
        }
    }
    pub fn pgs(tolerance: f64, cone: FrictionCone) -> Setting {
        let circ = if cone == FrictionCone::Circular {
            " circular"
        } else {
            ""
        };
        Setting {
            name: format!("pgs tol={tolerance:e}{circ}"),
            solver: SolverChoice::Pgs,
            tolerance,
            nd: 8,
            full: false,
            cone,
            position_update: PositionUpdate::Euler,
            integrator: Integrator::Euler,
        }
    }
}

/// One run: a point on a diagram.
#[derive(Debug, Clone)]
pub struct Point {
    pub engine: String,
    pub setting: String,
    pub case: CaseId,
    pub h: f64,
    pub steps: u64,
    /// Median wall time of the stepping (s) per simulated second.
    pub wall_per_sim_s: f64,
    pub score: Score,
    /// `None`, or why the run stopped early (it is then not drawn).
    pub failure: Option<String>,
}

pub const CSV_HEADER: &str =
    "engine,setting,case,h,steps,wall_s_per_sim_s,us_per_step,error,error_name,metrics,failure";

impl Point {
    /// One line of progress for the terminal.
    pub fn line(&self) -> String {
        format!(
            "{:6} {:4} {:28} h={:<7e} {:>10.3e} s/sim-s  error {:.3e}{}",
            self.engine,
            self.case.key(),
            self.setting,
            self.h,
            self.wall_per_sim_s,
            self.score.error,
            self.failure
                .as_deref()
                .map(|f| format!("  FAILED {f}"))
                .unwrap_or_default()
        )
    }

    pub fn csv(&self) -> String {
        let metrics: Vec<String> = self
            .score
            .metrics
            .iter()
            .map(|(k, v)| format!("{k}={}", num(*v)))
            .collect();
        let us = self.wall_per_sim_s * self.case.duration() / self.steps.max(1) as f64 * 1e6;
        format!(
            "{},{},{},{},{},{},{},{},\"{}\",{},{}",
            self.engine,
            field(&self.setting),
            self.case.key(),
            num(self.h),
            self.steps,
            num(self.wall_per_sim_s),
            num(us),
            num(self.score.error),
            self.case.error_name(),
            metrics.join(";"),
            field(self.failure.as_deref().unwrap_or(""))
        )
    }
}

/// Our engine's state and contact forces as a [`Sample`].
pub fn sample(engine: &Engine, out: &mut Sample) {
    let s = engine.state();
    out.t = s.t;
    out.bodies.clear();
    out.bodies.extend(s.bodies.iter().map(|b| Pose {
        x: b.x.into(),
        q: [b.q.w, b.q.i, b.q.j, b.q.k],
        v: b.v.into(),
        w: b.w.into(),
    }));
    out.forces.clear();
    let h = engine.model().params.h;
    for r in engine
        .impulses()
        .iter()
        .filter(|r| r.kind == ImpulseKind::Normal)
    {
        out.forces.push((
            engine.model().contact_name(r.index, r.a, r.b),
            r.impulse.norm() / h,
        ));
    }
}

/// The case's scene with the setting applied, and its model.
fn model(case: CaseId, setting: &Setting, h: f64) -> Result<(Scene, Model), String> {
    let mut scene = case.scene(h, setting.nd).map_err(|e| e.to_string())?;
    scene.sim.solver = setting.solver;
    scene.sim.friction_cone = setting.cone;
    scene.sim.position_update = setting.position_update;
    scene.sim.integrator = setting.integrator;
    let mut model = Model::from_scene(&scene);
    model.params.full = setting.full;
    Ok((scene, model))
}

fn engine(model: Model, setting: &Setting) -> Engine {
    let mut e = Engine::new(model);
    if setting.solver == SolverChoice::Pgs {
        e.set_pgs_params(PgsParams {
            tolerance: setting.tolerance,
            // The setting names the relative residual: that rule alone.
            ..PgsParams::distance(0.0)
        });
    }
    e
}

/// Repeats the timing until this much stepping time has been spent.
const TIMING_BUDGET_S: f64 = 0.3;
const MAX_REPEATS: usize = 9;

/// Runs `case` with `setting` at step `h` and scores it; `reference` is
/// the converged trajectory for `CaseId::Reference`.
pub fn run_ours(
    case: CaseId,
    setting: &Setting,
    h: f64,
    reference: Option<&Trajectory>,
) -> Result<Point, String> {
    let (scene, model) = model(case, setting, h)?;
    let steps = scene.step_count();
    let mut scorer = Scorer::new(case, &scene, reference.cloned());
    let mut e = engine(model.clone(), setting);
    let mut s = Sample::default();
    let mut failure = None;
    let mut elapsed = 0.0;
    for _ in 0..steps {
        let t0 = Instant::now();
        let r = e.step();
        elapsed += t0.elapsed().as_secs_f64();
        if let Some(err) = r.error {
            failure = Some(format!("step {}: {}", r.step + 1, err.code()));
            break;
        }
        sample(&e, &mut s);
        scorer.observe(&s);
    }
    let wall = if failure.is_some() {
        elapsed
    } else {
        median_run_time(elapsed, || {
            let mut e = engine(model.clone(), setting);
            let t0 = Instant::now();
            for _ in 0..steps {
                std::hint::black_box(e.step());
            }
            t0.elapsed().as_secs_f64()
        })
    };
    Ok(Point {
        engine: "ours".into(),
        setting: setting.name.clone(),
        case,
        h,
        steps,
        wall_per_sim_s: wall / case.duration(),
        score: scorer.finish(),
        failure,
    })
}

/// The median wall time (s) of a run: `first`, the scored run's stepping
/// time, and runs of `again` (without the scorer) until `TIMING_BUDGET_S`
/// is spent or there are `MAX_REPEATS` runs.
pub fn median_run_time(first: f64, mut again: impl FnMut() -> f64) -> f64 {
    let mut times = vec![first];
    let mut spent = first;
    while spent < TIMING_BUDGET_S && times.len() < MAX_REPEATS {
        let t = again();
        times.push(t);
        spent += t;
    }
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// A run that ended without its figure (S3 without an apex: no bounce
/// within the run) fails with that reason, so that it is not drawn.
pub fn no_figure(failure: Option<String>, score: &Score) -> Option<String> {
    failure.or_else(|| {
        (!score.error.is_finite()).then(|| "no figure (e.g. no apex within the run)".to_string())
    })
}

/// Body positions at sample times: the converged reference run.
pub type Trajectory = Vec<(f64, Vec<[f64; 3]>)>;

/// Sample spacing of the reference trajectory (s): every h of the sweep
/// divides it, so every run is compared at the same instants.
pub const REFERENCE_SPACING: f64 = 0.01;

/// The reference scene at step `h` (Lemke, n_d = 8), positions every
/// `REFERENCE_SPACING`.
pub fn reference_trajectory(h: f64, nd: usize) -> Result<Trajectory, String> {
    let every = (REFERENCE_SPACING / h).round() as u64;
    sampled(
        CaseId::Reference,
        h,
        nd,
        CaseId::Reference.duration(),
        every,
    )
}

/// Body positions of `case` at time `t` (Lemke, n_d = 8, step `h`).
fn positions_at(case: CaseId, h: f64, t: f64) -> Result<Vec<[f64; 3]>, String> {
    let steps = (t / h).round() as u64;
    let mut samples = sampled(case, h, 8, t, steps)?;
    Ok(samples.pop().map(|(_, x)| x).unwrap_or_default())
}

/// `case` run with Lemke (`nd` friction directions, step `h`) for `t`
/// seconds: the bodies' positions after every `every`-th step.
fn sampled(case: CaseId, h: f64, nd: usize, t: f64, every: u64) -> Result<Trajectory, String> {
    let setting = Setting::lemke(nd, false);
    let mut e = engine(model(case, &setting, h)?.1, &setting);
    let mut out = Vec::new();
    for _ in 0..(t / h).round() as u64 {
        let r = e.step();
        if let Some(err) = r.error {
            return Err(format!(
                "{} reference run at h = {h:e}: step {}: {err}",
                case.key(),
                r.step + 1
            ));
        }
        if e.state().step.is_multiple_of(every) {
            out.push((
                e.state().t,
                e.state().bodies.iter().map(|b| b.x.into()).collect(),
            ));
        }
    }
    Ok(out)
}

/// The converged reference of a case, where it is scored against one, and
/// a note on how converged it is: the reference scene's run at `h / 2`
/// (checked against `h`); for S4 and S7 (smooth, no contact, so our step
/// is first order in h) the positions at `CHAIN_REFERENCE_T` from runs at
/// `h`, `h / 2` and `h / 4`, Richardson-extrapolated from the finer pair
/// (`2 x(h/4) - x(h/2)`), with the coarser pair's extrapolation as its
/// check.
pub fn case_reference(case: CaseId, h: f64) -> Result<Option<(Trajectory, String)>, String> {
    match case {
        CaseId::Reference => {
            let a = reference_trajectory(h, 8)?;
            let b = reference_trajectory(h / 2.0, 8)?;
            let note = format!(
                "REF: converged run at h = {h:e}; it differs from the run at h/2 by {:.3e} m (largest position difference at the 0.01 s samples)",
                trajectory_distance(&a, &b)
            );
            Ok(Some((b, note)))
        }
        CaseId::Chain | CaseId::HingeChain => {
            let t = super::cases::CHAIN_REFERENCE_T;
            let x: Vec<Vec<[f64; 3]>> = [h, h / 2.0, h / 4.0]
                .iter()
                .map(|&h| positions_at(case, h, t))
                .collect::<Result<_, _>>()?;
            let extrapolate = |coarse: &[[f64; 3]], fine: &[[f64; 3]]| -> Vec<[f64; 3]> {
                coarse
                    .iter()
                    .zip(fine)
                    .map(|(c, f)| std::array::from_fn(|k| 2.0 * f[k] - c[k]))
                    .collect()
            };
            let (r1, r2) = (extrapolate(&x[0], &x[1]), extrapolate(&x[1], &x[2]));
            let note = format!(
                "{}: reference positions at t = {t} s from our runs at h = {h:e}, {:e}, {:e} (Lemke), Richardson-extrapolated (first order); the finest run is {:.3e} m from it, the coarser pair's extrapolation {:.3e} m",
                case.key(),
                h / 2.0,
                h / 4.0,
                super::farthest(&x[2], &r2),
                super::farthest(&r1, &r2),
            );
            Ok(Some((vec![(t, r2)], note)))
        }
        _ => Ok(None),
    }
}

/// Largest position difference between two trajectories at common times.
pub fn trajectory_distance(a: &Trajectory, b: &Trajectory) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0, |d, ((_, xa), (_, xb))| d.max(super::farthest(xa, xb)))
}

/// What to sweep.
pub struct Sweep {
    pub cases: Vec<CaseId>,
    pub steps: Vec<f64>,
    pub settings: Vec<Setting>,
    /// Step of the converged reference run (checked against half of it).
    pub reference_h: f64,
}

impl Sweep {
    pub fn full() -> Sweep {
        Sweep {
            cases: super::cases::ALL.to_vec(),
            steps: vec![1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4],
            settings: vec![
                Setting::lemke(8, false),
                Setting::trapezoid(),
                Setting::lemke(4, false),
                Setting::lemke(16, false),
                Setting::lemke(8, true),
                Setting::pgs(1e-4, FrictionCone::Polyhedral),
                Setting::pgs(1e-6, FrictionCone::Polyhedral),
                Setting::pgs(1e-10, FrictionCone::Polyhedral),
                Setting::pgs(1e-6, FrictionCone::Circular),
                Setting::smooth(Integrator::Rattle),
                Setting::smooth(Integrator::Rattle4),
            ],
            reference_h: 2e-5,
        }
    }

    /// Two steps, three settings: what the test runs.
    pub fn quick() -> Sweep {
        Sweep {
            cases: super::cases::ALL.to_vec(),
            steps: vec![1e-2, 1e-3],
            settings: vec![
                Setting::lemke(8, false),
                Setting::pgs(1e-6, FrictionCone::Polyhedral),
                Setting::trapezoid(),
                Setting::smooth(Integrator::Rattle4),
            ],
            reference_h: 1e-4,
        }
    }
}

/// Whether a setting changes anything in a case: n_d only matters with
/// friction, pruning only with contacts.
fn relevant(case: CaseId, s: &Setting) -> bool {
    let friction = matches!(
        case,
        CaseId::Rolling | CaseId::SlideToRoll | CaseId::BoxIncline | CaseId::Reference
    );
    let contacts = !matches!(case, CaseId::Chain | CaseId::HingeChain);
    (s.integrator == Integrator::Euler || !contacts)
        && (s.nd == 8 || friction)
        && (!s.full || contacts)
        && (s.cone == FrictionCone::Polyhedral || friction)
}

/// Runs the sweep; `progress` gets each point as it is measured.
pub fn sweep(
    sw: &Sweep,
    mut progress: impl FnMut(&Point),
) -> Result<(Vec<Point>, Vec<String>), String> {
    let mut points = Vec::new();
    let mut notes = Vec::new();
    for &case in &sw.cases {
        let reference = case_reference(case, sw.reference_h)?.map(|(r, note)| {
            notes.push(note);
            r
        });
        for setting in sw.settings.iter().filter(|s| relevant(case, s)) {
            for &h in &sw.steps {
                let p = run_ours(case, setting, h, reference.as_ref())?;
                progress(&p);
                points.push(p);
            }
        }
    }
    Ok((points, notes))
}

/// A CSV field as RFC 4180 has it: quoted (its quotes doubled) where it
/// holds a comma, a quote or a line break (MuJoCo's settings read
/// "Euler, Newton, pyramidal").
fn field(s: &str) -> std::borrow::Cow<'_, str> {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\"")).into()
    } else {
        s.into()
    }
}

pub fn csv(points: &[Point]) -> String {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for p in points {
        let _ = writeln!(s, "{}", p.csv());
    }
    s
}

/// Smallest error drawn: exact answers (0) sit on the floor of the axis.
const ERROR_FLOOR: f64 = 1e-14;

/// One log-log diagram per case: `<dir>/accuracy-<case>.png`, a curve per
/// engine and setting through its h values.
pub fn diagrams(points: &[Point], dir: &Path, machine: &str) -> Result<Vec<PathBuf>, String> {
    cosim_figures::ensure_font().map_err(|e| e.to_string())?;
    let mut files = Vec::new();
    let mut cases: Vec<CaseId> = Vec::new();
    for p in points {
        if !cases.contains(&p.case) {
            cases.push(p.case);
        }
    }
    for case in cases {
        let pts: Vec<&Point> = points
            .iter()
            .filter(|p| p.case == case && p.failure.is_none() && p.score.error.is_finite())
            .collect();
        if pts.is_empty() {
            continue;
        }
        let path = dir.join(format!("accuracy-{}.png", case.key()));
        let figure = Figure {
            title: case.title(),
            y_name: case.error_name(),
            y: &|p: &Point| p.score.error,
        };
        draw(&pts, &figure, &path, machine).map_err(|e| format!("{}: {e}", path.display()))?;
        files.push(path);
        // The chains' second score: the position at 1 s against the
        // converged reference.
        if matches!(case, CaseId::Chain | CaseId::HingeChain) {
            let position = |p: &Point| p.score.metric(POSITION_1S).unwrap_or(f64::NAN);
            let pts: Vec<&Point> = pts
                .into_iter()
                .filter(|p| position(p).is_finite())
                .collect();
            if pts.is_empty() {
                continue;
            }
            let title = format!("{}, position at 1 s", case.key());
            let figure = Figure {
                title: &title,
                y_name: "largest position error at t = 1 s (m)",
                y: &position,
            };
            let path = dir.join(format!("accuracy-{}-position.png", case.key()));
            draw(&pts, &figure, &path, machine).map_err(|e| format!("{}: {e}", path.display()))?;
            files.push(path);
        }
    }
    Ok(files)
}

/// The chains' metric of the position error at `CHAIN_REFERENCE_T`.
pub const POSITION_1S: &str = "position_error_1s_m";

/// What a work-precision diagram draws: its title, its y axis and each
/// point's value on it.
struct Figure<'a> {
    title: &'a str,
    y_name: &'a str,
    y: &'a dyn Fn(&Point) -> f64,
}

fn draw(
    pts: &[&Point],
    figure: &Figure,
    path: &Path,
    machine: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    let y = |p: &Point| (figure.y)(p).max(ERROR_FLOOR);
    let root = BitMapBackend::new(path, (1000, 720)).into_drawing_area();
    let mut chart = cosim_figures::log_log(
        &root,
        &format!("{} ({})", figure.title, machine),
        bounds(pts.iter().map(|p| p.wall_per_sim_s)),
        bounds(pts.iter().map(|p| y(p))),
        (
            "wall time per simulated second (s), one thread",
            figure.y_name,
        ),
        (|x| format!("{x:.0e}"), |y| format!("{y:.0e}")),
    )?;
    let mut curves: Vec<(String, String)> = Vec::new();
    for p in pts {
        let k = (p.engine.clone(), p.setting.clone());
        if !curves.contains(&k) {
            curves.push(k);
        }
    }
    // Our settings take the palette; the peers' curves dark tones of their
    // own, so that no colour names two curves (the palette has ten).
    const PEERS: [RGBColor; 4] = [
        RGBColor(0, 0, 0),
        RGBColor(125, 125, 125),
        RGBColor(150, 0, 0),
        RGBColor(0, 100, 0),
    ];
    let (mut ours, mut peers) = (0, 0);
    for (engine, setting) in &curves {
        let mut line: Vec<(f64, f64)> = pts
            .iter()
            .filter(|p| &p.engine == engine && &p.setting == setting)
            .map(|p| (p.wall_per_sim_s, y(p)))
            .collect();
        line.sort_by(|a, b| a.0.total_cmp(&b.0));
        let c = if engine == "ours" {
            ours += 1;
            color(ours - 1)
        } else {
            peers += 1;
            PEERS[(peers - 1) % PEERS.len()]
        };
        // One-pixel paths side by side, in the image's pixels: plotters
        // draws wider strokes wrongly in bitmaps (plotters issue 549).
        let pixels: Vec<(i32, i32)> = line.iter().map(|p| chart.backend_coord(p)).collect();
        cosim_figures::thick_path(&root, &pixels, c, if engine == "ours" { 2 } else { 3 })
            .map_err(|e| e.to_string())?;
        chart
            .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())?
            .label(format!("{engine}: {setting}"))
            .legend(move |(x, y)| Rectangle::new([(x, y - 1), (x + 20, y + 1)], c.filled()));
        if engine == "ours" {
            chart.draw_series(line.iter().map(|&p| Circle::new(p, 4, c.filled())))?;
        } else {
            chart.draw_series(line.iter().map(|&p| TriangleMarker::new(p, 7, c.filled())))?;
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font((FONT, 13))
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    root.present()?;
    Ok(())
}

/// Log-axis bounds with a margin of a factor 2 either side.
pub fn bounds(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = v.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    });
    if !(lo.is_finite() && hi > 0.0) {
        return (1e-3, 1.0);
    }
    (lo / 2.0, hi * 2.0)
}

/// "model name, cores" from /proc/cpuinfo, for the diagrams' captions.
pub fn machine() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = info
        .lines()
        .find_map(|l| l.strip_prefix("model name"))
        .map(|l| l.trim_start_matches([' ', '\t', ':']).trim().to_string())
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{model}, {cores} cores")
}

/// A Markdown table per case: error and wall time per simulated second of
/// every curve at h = 1e-2 and 1e-3, and beside each peer's point the error
/// of our Lemke curves (Euler and trapezoid position update) at the same
/// run time, interpolated log-log between their points.
pub fn summary(points: &[Point], machine: &str, notes: &[String]) -> String {
    let mut s = format!("# Work-precision\n\nMachine: {machine}, one thread per engine, all points from one run.\n\n");
    for n in notes {
        let _ = writeln!(s, "- {n}");
    }
    let mut cases: Vec<CaseId> = Vec::new();
    for p in points {
        if !cases.contains(&p.case) {
            cases.push(p.case);
        }
    }
    for case in cases {
        let _ = writeln!(
            s,
            "\n## {}\n\nError: {}. Diagram: `accuracy-{}.png`.\n",
            case.title(),
            case.error_name(),
            case.key()
        );
        s.push_str("| engine | setting | h | error | s per simulated s | ours at equal time: lemke nd=8 | lemke nd=8 trapezoid |\n|---|---|---|---|---|---|---|\n");
        let curve = |setting: &str| {
            let mut v: Vec<(f64, f64)> = points
                .iter()
                .filter(|p| {
                    p.case == case
                        && p.engine == "ours"
                        && p.setting == setting
                        && p.failure.is_none()
                })
                .map(|p| (p.wall_per_sim_s, p.score.error))
                .collect();
            v.sort_by(|a, b| a.0.total_cmp(&b.0));
            v
        };
        let (euler, trapezoid) = (curve("lemke nd=8"), curve("lemke nd=8 trapezoid"));
        for p in points.iter().filter(|p| p.case == case) {
            if !(p.h == 1e-2 || p.h == 1e-3) {
                continue;
            }
            let equal = |c: &[(f64, f64)]| {
                if p.engine == "ours" {
                    String::new()
                } else {
                    at_time(c, p.wall_per_sim_s)
                        .map_or("outside our range".into(), |e| format!("{e:.3e}"))
                }
            };
            let err = match &p.failure {
                Some(f) => format!("failed: {f}"),
                None => format!("{:.3e}", p.score.error),
            };
            let _ = writeln!(
                s,
                "| {} | {} | {:e} | {err} | {:.3e} | {} | {} |",
                p.engine,
                p.setting,
                p.h,
                p.wall_per_sim_s,
                equal(&euler),
                equal(&trapezoid)
            );
        }
    }
    s
}

/// Log-log interpolation of a curve `(time, error)` at `t`.
fn at_time(curve: &[(f64, f64)], t: f64) -> Option<f64> {
    let i = curve.windows(2).position(|w| w[0].0 <= t && t <= w[1].0)?;
    let ((t0, e0), (t1, e1)) = (curve[i], curve[i + 1]);
    let floor = |e: f64| e.max(ERROR_FLOOR).ln();
    let f = (t.ln() - t0.ln()) / (t1.ln() - t0.ln());
    Some((floor(e0) + f * (floor(e1) - floor(e0))).exp())
}

/// Writes `accuracy.csv`, `accuracy.md` and the diagrams into `dir`;
/// returns the files written.
pub fn write(
    points: &[Point],
    notes: &[String],
    dir: &Path,
    machine: &str,
) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let mut files = vec![dir.join("accuracy.csv"), dir.join("accuracy.md")];
    for (path, text) in files
        .iter()
        .zip([csv(points), summary(points, machine, notes)])
    {
        std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    files.extend(diagrams(points, dir, machine)?);
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::field;

    #[test]
    fn a_field_with_a_comma_or_a_quote_is_quoted() {
        assert_eq!(field("lemke nd=8"), "lemke nd=8");
        assert_eq!(
            field("Euler, Newton, pyramidal"),
            "\"Euler, Newton, pyramidal\""
        );
        assert_eq!(field("say \"hi\""), "\"say \"\"hi\"\"\"");
    }
}

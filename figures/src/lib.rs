//! `cosim-figures`: what a run looks like, drawn from its output files
//! alone: the figures (PNG and SVG), the animation (GIF), and the MCAP
//! recording for Foxglove. No IPC, no engine state beyond what the files
//! hold (the engine is used for its contact geometry).

pub mod animation;
pub mod camera;
pub mod chart;
pub mod data;
pub mod figures;
pub mod gif;
pub mod mcap;
mod panels;
pub mod text;

use cosim_engine::model::Counterpart;
use cosim_engine::{Model, State};
use cosim_shared::Scene;
use data::RunData;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
/// The colour type of [`color`], for readers of the figures.
pub use plotters::prelude::RGBColor;
use std::path::{Path, PathBuf};
use std::sync::Once;

/// The font family the figures use: DejaVu Sans, embedded in the binary
/// (`assets/`), so that text renders on a machine without any font.
pub const FONT: &str = "sans-serif";
static FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// Registers the embedded font (once); every drawing calls it first.
pub fn ensure_font() -> Result<(), PlotError> {
    static ONCE: Once = Once::new();
    let mut ok = true;
    ONCE.call_once(|| {
        ok = plotters::style::register_font(FONT, plotters::style::FontStyle::Normal, FONT_BYTES)
            .is_ok();
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Draw("the embedded font does not load".into()))
    }
}

/// A path `width` pixels wide, drawn as one-pixel paths side by side
/// (`width` x `width` offsets): plotters' bitmap backend draws strokes
/// wider than a pixel wrongly (plotters issue 549: spikes drawn as a piece
/// and a dot, steep segments dotted, lines out of their panel), and a
/// one-pixel path right. `path` is in the area's pixels.
pub fn thick_path<DB: plotters::prelude::DrawingBackend>(
    area: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    path: &[(i32, i32)],
    color: RGBColor,
    width: i32,
) -> Result<(), plotters::drawing::DrawingAreaErrorKind<DB::ErrorType>> {
    use plotters::prelude::*;
    for dx in 0..width.max(1) {
        for dy in 0..width.max(1) {
            let p: Vec<(i32, i32)> = path.iter().map(|&(x, y)| (x + dx, y + dy)).collect();
            area.draw(&PathElement::new(p, color.stroke_width(1)))?;
        }
    }
    Ok(())
}

/// `state` posed as recorded state `i` (what the collision stage needs to
/// place a contact; velocities and warm starts are left as they were).
pub fn pose_state(run: &RunData, i: usize, state: &mut State) {
    for (b, track) in state.bodies.iter_mut().zip(&run.bodies) {
        let r = &track.rows[i];
        b.x = Vector3::new(r[0], r[1], r[2]);
        b.q = UnitQuaternion::from_quaternion(Quaternion::new(r[3], r[4], r[5], r[6]));
    }
}

/// Where contact `name` (`a/b` or `a/b#k`, impulses.csv's
/// `contact_label`) touches body a in `state` ([`pose_state`]): the
/// engine's collision stage recomputed for that pair and feature. The
/// animation's arrows and the MCAP recording's start there.
pub fn contact_point(model: &Model, state: &State, name: &str) -> Option<Vector3<f64>> {
    let (pair, feature) = match name.split_once('#') {
        Some((pair, k)) => (pair, k.parse().ok()?),
        None => (name, 0),
    };
    let (a, b) = pair.split_once('/')?;
    let index = |n: &str| model.bodies.iter().position(|x| x.name == n);
    let ia = index(a)?;
    let other = match index(b) {
        Some(ib) => Counterpart::Body(ib),
        None => Counterpart::Plane(model.planes.iter().position(|p| p.name == b)?),
    };
    if feature >= model.features || matches!(other, Counterpart::Body(ib) if ib <= ia) {
        return None;
    }
    let id = model.contact_id(ia, other, feature);
    cosim_engine::collision::contact_point(model, state, id)
}

/// A log-log chart as the benchmarks draw them.
pub type LogLog<'a, 'b> = plotters::chart::ChartContext<
    'a,
    plotters::prelude::BitMapBackend<'b>,
    plotters::prelude::Cartesian2d<
        plotters::prelude::LogCoord<f64>,
        plotters::prelude::LogCoord<f64>,
    >,
>;

/// How an axis writes a tick's value.
pub type TickLabel = fn(f64) -> String;

/// A log-log chart on `root`, cleared: the caption, the axes over `x` and
/// `y` described by `desc` (x, y), the mesh, tick labels by `label` (x, y).
/// `bench accuracy` and the peers' pile figures draw on it.
pub fn log_log<'a, 'b>(
    root: &'a plotters::prelude::DrawingArea<
        plotters::prelude::BitMapBackend<'b>,
        plotters::coord::Shift,
    >,
    caption: &str,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    desc: (&str, &str),
    label: (TickLabel, TickLabel),
) -> Result<LogLog<'a, 'b>, Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(root)
        .caption(caption, (FONT, 20))
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc(desc.0)
        .y_desc(desc.1)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .x_label_formatter(&|x| label.0(*x))
        .y_label_formatter(&|y| label.1(*y))
        .draw()?;
    Ok(chart)
}

/// Colour `i` of the palette (Tableau 10): bodies, contacts and joints,
/// the same as in the recordings and the live view.
pub fn color(i: usize) -> RGBColor {
    let [r, g, b] = cosim_foxglove::palette::color(i);
    RGBColor(r, g, b)
}

#[derive(Debug, Clone, PartialEq)]
pub enum PlotError {
    /// A run file is missing or malformed.
    Read(String),
    /// Drawing or writing a figure failed.
    Draw(String),
}

impl std::fmt::Display for PlotError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PlotError::Read(m) => write!(f, "cannot read the run: {m}"),
            PlotError::Draw(m) => write!(f, "cannot draw: {m}"),
        }
    }
}

impl std::error::Error for PlotError {}

/// What to draw.
#[derive(Debug, Clone, Default)]
pub struct PlotOptions {
    pub figures: bool,
    pub animation: bool,
    /// PNG stills of the animation (0: none).
    pub stills: usize,
    /// Which figures, and their size.
    pub figure: figures::Options,
    /// The time window drawn (either end open).
    pub from: Option<f64>,
    pub to: Option<f64>,
    /// Frames per simulated second of the animation (default
    /// `animation::FPS`).
    pub fps: Option<f64>,
    /// The animation's size in pixels (default `animation::WIDTH` x
    /// `animation::HEIGHT`).
    pub gif_size: Option<(u32, u32)>,
    /// Only these bodies (and their contacts) in the figures.
    pub bodies: Option<Vec<String>>,
}

impl PlotOptions {
    /// The part of `run` the figures show: the time window, the bodies.
    fn focus(&self, run: data::RunData) -> Result<data::RunData, PlotError> {
        let run = run.window(self.from, self.to);
        match &self.bodies {
            Some(names) => run.only_bodies(names),
            None => Ok(run),
        }
    }
}

/// The frame of a run folder's figures: its scene named when its
/// `scene.toml` reads (an old recording without one is still drawn).
fn frame_of(dir: &Path) -> chart::Frame {
    chart::Frame {
        subtitle: Scene::load(&dir.join("scene.toml"))
            .map(|s| subtitle(&s))
            .unwrap_or_default(),
        ..chart::Frame::default()
    }
}

/// `plot A B`: the figures of two runs together (settings, solvers, time
/// steps), into `out`; returns the files written.
pub fn render_overlay(
    a: &Path,
    b: &Path,
    out: &Path,
    opts: &PlotOptions,
) -> Result<Vec<PathBuf>, PlotError> {
    ensure_font()?;
    let load = |d: &Path| opts.focus(data::RunData::load(d)?);
    let (ra, rb) = (load(a)?, load(b)?);
    let label = |d: &Path| {
        d.file_name().map_or_else(
            || d.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        )
    };
    let (la, mut lb) = (label(a), label(b));
    if lb == la {
        lb = format!("{lb}, 2nd");
    }
    std::fs::create_dir_all(out).map_err(|e| PlotError::Draw(format!("{}: {e}", out.display())))?;
    let mut frame = frame_of(a);
    let other = frame_of(b).subtitle;
    if other != frame.subtitle {
        frame.subtitle = format!("{la}: {}; {lb}: {other}", frame.subtitle);
    }
    figures::overlay((&ra, &la), (&rb, &lb), out, &frame, &opts.figure)
}

/// What a figure says of its run: the scene, the step, the solver.
pub fn subtitle(scene: &Scene) -> String {
    let sim = &scene.sim;
    format!(
        "scene {}, h = {} s, solver {}, n_d = {}",
        sim.name.as_deref().unwrap_or("(unnamed)"),
        chart::tick(sim.dt),
        sim.solver.as_str(),
        sim.friction_directions
    )
}

/// Draws the figures (into `DIR/plots/`) and the animation
/// (`DIR/animation.gif`) of the run in `dir`; returns the files written.
pub fn render(dir: &Path, opts: &PlotOptions) -> Result<Vec<PathBuf>, PlotError> {
    render_into(dir, dir, opts)
}

/// [`render`] into `out` (its `plots/`, `animation.gif` and stills)
/// instead of the run's folder.
pub fn render_into(dir: &Path, out: &Path, opts: &PlotOptions) -> Result<Vec<PathBuf>, PlotError> {
    ensure_font()?;
    let full = data::RunData::load(dir)?;
    let mut files = Vec::new();
    if opts.figures {
        let plots = out.join("plots");
        std::fs::create_dir_all(&plots)
            .map_err(|e| PlotError::Draw(format!("{}: {e}", plots.display())))?;
        let run = opts.focus(full.clone())?;
        files.extend(figures::all(&run, &plots, &frame_of(dir), &opts.figure)?);
    }
    let run = full;
    if opts.animation || opts.stills > 0 {
        let gif_size = opts
            .gif_size
            .unwrap_or((animation::WIDTH, animation::HEIGHT));
        let scene =
            Scene::load(&dir.join("scene.toml")).map_err(|e| PlotError::Read(e.to_string()))?;
        let model = Model::from_scene(&scene);
        if model.bodies.len() != run.bodies.len() {
            return Err(PlotError::Read(format!(
                "scene.toml has {} bodies, states.csv {}",
                model.bodies.len(),
                run.bodies.len()
            )));
        }
        if opts.animation {
            let path = out.join("animation.gif");
            let fps = opts.fps.unwrap_or(animation::FPS);
            animation::gif_at(&model, scene.camera.as_ref(), &run, &path, fps, gif_size)?;
            files.push(path);
        }
        if opts.stills > 0 {
            files.extend(animation::stills(
                &model,
                scene.camera.as_ref(),
                &run,
                out,
                "frame",
                opts.stills,
                gif_size,
            )?);
        }
    }
    Ok(files)
}

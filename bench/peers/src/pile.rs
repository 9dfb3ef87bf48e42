//! The pile of issue 14 (`cosim-server bench pile`) with Rapier beside our
//! engine, in one run: Rapier at 1, 4 (its default), 8 and 16 solver
//! iterations, with its sleeping on and off; ours with ours on and off.
//! Every run is scored by the same code: the worst overlap is our
//! `measure::max_penetration` on each step's poses, whichever engine made
//! them; the kinetic energy and the spheres out of the box from the poses
//! and twists too. Timing covers the step calls only.

use crate::rapier;
use cosim_bench::accuracy::bounds;
use cosim_bench::pile::{self, Settings};
use cosim_engine::{measure, BodyState, Model, State};
use cosim_figures::{color, ensure_font, log_log, LogLog, FONT};
use cosim_shared::scene::SleepDesc;
use cosim_shared::Scene;
use plotters::prelude::*;
use rapier3d_f64::prelude::*;
use std::time::Instant;

/// One engine's run of one pile.
#[derive(Debug, Clone)]
pub struct Row {
    pub engine: String,
    pub setting: String,
    pub n: usize,
    pub steps: u64,
    pub median_ms: f64,
    pub total_s: f64,
    pub worst_overlap: f64,
    pub escaped: usize,
    pub kinetic: f64,
    pub asleep: usize,
}

/// Ours, as `bench pile` runs it.
pub fn ours(n: usize, settings: &Settings) -> Row {
    let o = pile::run(n, settings);
    Row {
        engine: "ours".into(),
        setting: format!(
            "{} {:e} m/s, {}",
            settings.solver,
            settings.pgs.velocity_tolerance,
            match settings.sleep {
                s if !s.enabled => "no sleep".to_string(),
                s if s == SleepDesc::default() => "sleep".to_string(),
                s => format!("sleep at {} m/s, {} rad/s", s.linear_speed, s.angular_speed),
            }
        ),
        n,
        steps: o.steps,
        median_ms: o.median_step * 1e3,
        total_s: o.total,
        worst_overlap: o.worst_overlap,
        escaped: o.escaped,
        kinetic: o.kinetic,
        asleep: o.asleep,
    }
}

/// Rapier on the same pile with `iterations` solver iterations.
pub fn rapier(n: usize, settings: &Settings, iterations: usize, sleep: bool) -> Row {
    let text = pile::text_shaped(
        n,
        settings.shape,
        settings.dt,
        4,
        "pgs",
        settings.steps,
        settings.seed,
        SleepDesc::off(),
    );
    let scene = Scene::parse(&text, "<pile>").unwrap_or_else(|e| panic!("pile scene: {e}"));
    let model = Model::from_scene(&scene);
    let mut w = rapier::build(&scene, sleep);
    w.world.integration_parameters.num_solver_iterations = iterations.max(1);
    let mut state = State::initial(&model);
    let (mut scratch, mut geoms, mut asleep) = Default::default();
    let mut times = Vec::with_capacity(settings.steps as usize);
    let mut worst = 0.0f64;
    for _ in 0..settings.steps {
        let t0 = Instant::now();
        w.world.step();
        times.push(t0.elapsed().as_secs_f64());
        copy_state(&w, &mut state);
        worst = worst.max(measure::max_penetration(
            &model,
            &state,
            &mut scratch,
            &mut geoms,
            &mut asleep,
        ));
    }
    let total: f64 = times.iter().sum();
    times.sort_by(f64::total_cmp);
    let half = settings.shape.half_width(n);
    let kinetic = model
        .bodies
        .iter()
        .zip(&state.bodies)
        .map(|(b, s)| 0.5 * b.mass * s.v.norm_squared() + 0.5 * s.w.dot(&(b.inertia * s.w)))
        .sum();
    let asleep = w
        .bodies
        .iter()
        .filter(|(h, _)| w.world.bodies[*h].is_sleeping())
        .count();
    Row {
        engine: format!("rapier {}", rapier::VERSION),
        setting: format!(
            "{iterations} iterations{}, {}",
            if iterations == 4 { " (default)" } else { "" },
            if sleep { "sleep" } else { "no sleep" }
        ),
        n,
        steps: settings.steps,
        median_ms: times.get(times.len() / 2).copied().unwrap_or(0.0) * 1e3,
        total_s: total,
        worst_overlap: worst,
        escaped: state
            .bodies
            .iter()
            .filter(|b| b.x.x.abs() > half || b.x.y.abs() > half || b.x.z < 0.0)
            .count(),
        kinetic,
        asleep,
    }
}

/// Rapier's poses and twists into our state, for our measurements.
fn copy_state(w: &rapier::World, state: &mut State) {
    use nalgebra::{Quaternion, UnitQuaternion, Vector3};
    for ((h, _), s) in w.bodies.iter().zip(state.bodies.iter_mut()) {
        let b = &w.world.bodies[*h];
        let (x, q, v, om) = (b.translation(), b.rotation(), b.linvel(), b.angvel());
        *s = BodyState {
            x: Vector3::new(x.x, x.y, x.z),
            q: UnitQuaternion::new_normalize(Quaternion::new(q.w, q.x, q.y, q.z)),
            v: Vector3::new(v.x, v.y, v.z),
            w: Vector3::new(om.x, om.y, om.z),
        };
    }
}

/// The rows as a markdown table.
pub fn table(rows: &[Row], settings: &Settings) -> String {
    let mut t = format!(
        "Pile of spheres (r = {} m, mu = 0.5; {}), h = {}, n_d = 4 (ours), one thread each. \
         Ours: solver auto (PGS above 600 unknowns) stopped by the constraint violation \
         (the residual rule) at the tolerance shown.\n\n\
         | engine | setting | N | steps | ms/step (median) | s total | worst overlap (mm) | escaped | KE end (J) | asleep |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
        pile::RADIUS,
        settings.shape,
        settings.dt
    );
    for r in rows {
        t += &format!(
            "| {} | {} | {} | {} | {:.3} | {:.3e} | {:.2e} | {} | {:.2e} | {} |\n",
            r.engine,
            r.setting,
            r.n,
            r.steps,
            r.median_ms,
            r.total_s,
            r.worst_overlap * 1e3,
            r.escaped,
            r.kinetic,
            r.asleep
        );
    }
    t
}

/// Mean milliseconds per step of a row: the total over the steps, which
/// the fit of cost against N needs (a median hides the settling steps).
fn mean_ms(r: &Row) -> f64 {
    1e3 * r.total_s / r.steps.max(1) as f64
}

/// The least-squares slope of `ln y` against `ln x`, if two sizes or more.
pub fn slope(points: &[(f64, f64)]) -> Option<f64> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let (lx, ly): (Vec<f64>, Vec<f64>) = points.iter().map(|&(x, y)| (x.ln(), y.ln())).unzip();
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let sxy: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = lx.iter().map(|x| (x - mx).powi(2)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The curves of the rows: one per engine and setting, points by N.
/// Each engine and setting's fitted slope of mean time per step against
/// N (log-log), as lines of text (issue 47, point 4).
pub fn slopes(rows: &[Row]) -> String {
    curves(rows)
        .iter()
        .map(|(key, pts)| {
            let line: Vec<(f64, f64)> = pts.iter().map(|r| (r.n as f64, mean_ms(r))).collect();
            let sizes = pts
                .iter()
                .map(|r| r.n.to_string())
                .collect::<Vec<_>>()
                .join(", ");
            match slope(&line) {
                Some(s) => format!("- {key}: slope {s:.2} (N = {sizes})\n"),
                None => format!("- {key}: one size\n"),
            }
        })
        .collect()
}

fn curves(rows: &[Row]) -> Vec<(String, Vec<&Row>)> {
    let mut out: Vec<(String, Vec<&Row>)> = Vec::new();
    for r in rows {
        let key = format!("{}: {}", r.engine, r.setting);
        match out.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => v.push(r),
            None => out.push((key, vec![r])),
        }
    }
    for (_, v) in &mut out {
        v.sort_by_key(|r| r.n);
    }
    out
}

/// Each curve's colour and whether its markers are filled: ours in warm
/// colours by tolerance, Rapier in cool ones by iteration count, a
/// sleeping run hollow (with 10 colours for 12 curves the palette repeated
/// and ours could not be told from Rapier's 8 iterations).
fn styles(curves: &[(String, Vec<&Row>)]) -> Vec<(RGBColor, bool)> {
    const OURS: [usize; 4] = [3, 1, 6, 5];
    const RAPIER: [usize; 4] = [0, 2, 4, 9];
    let mut ours_settings: Vec<String> = Vec::new();
    curves
        .iter()
        .map(|(_, pts)| {
            let r = pts[0];
            let sleep = !r.setting.contains("no sleep");
            let base = r
                .setting
                .trim_end_matches(", sleep")
                .trim_end_matches(", no sleep");
            let c = if r.engine == "ours" {
                let k = ours_settings
                    .iter()
                    .position(|s| s == base)
                    .unwrap_or_else(|| {
                        ours_settings.push(base.to_string());
                        ours_settings.len() - 1
                    });
                color(OURS[k % OURS.len()])
            } else {
                let iterations: usize = base
                    .split_whitespace()
                    .next()
                    .and_then(|w| w.parse().ok())
                    .unwrap_or(0);
                let k = [1, 4, 8, 16]
                    .iter()
                    .position(|&i| i == iterations)
                    .unwrap_or(3);
                color(RAPIER[k])
            };
            (c, !sleep)
        })
        .collect()
}

/// A log axis' tick label only at 1, 2 and 5 times a power of ten: at
/// every tick the labels run into each other ("9001000").
fn sparse(x: f64, label: impl Fn(f64) -> String) -> String {
    let mantissa = x / 10f64.powf(x.log10().floor());
    if [1.0, 2.0, 5.0].iter().any(|m| (mantissa - m).abs() < 1e-6) {
        label(x)
    } else {
        String::new()
    }
}

/// The figures' size in pixels.
const SIZE: (u32, u32) = (1100, 720);

/// The legend of `chart`, at `position`.
fn legend<'a, 'b: 'a>(
    chart: &mut LogLog<'a, 'b>,
    position: SeriesLabelPosition,
) -> Result<(), Box<dyn std::error::Error>> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK.mix(0.4))
        .label_font((FONT, 12))
        .position(position)
        .draw()?;
    Ok(())
}

/// Overlaps below this (mm) sit on the axis floor.
const OVERLAP_FLOOR: f64 = 1e-5;

/// `pile-time.png` (mean time per step against N, log-log, the fitted
/// slope in each legend entry) and `pile-work-precision.png` (worst overlap
/// against mean time per step, each point labelled with its N) in `dir`.
/// Lines are one pixel wide: wider ones leave the plotting area in
/// plotters 0.3 (its issue 549). The legends sit where the data leave
/// the plot empty (cost grows with N; between our overlaps and Rapier's),
/// so that no point hides behind them.
pub fn figures(
    rows: &[Row],
    dir: &std::path::Path,
    machine: &str,
) -> Result<Vec<std::path::PathBuf>, String> {
    use plotters::prelude::*;
    ensure_font().map_err(|e| e.to_string())?;
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let curves = curves(rows);
    let styles = styles(&curves);
    let time = dir.join("pile-time.png");
    let precision = dir.join("pile-work-precision.png");
    let draw_time = || -> Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::new(&time, SIZE).into_drawing_area();
        let mut chart = log_log(
            &root,
            &format!("Pile: time per step against N ({machine})"),
            bounds(rows.iter().map(|r| r.n as f64)),
            bounds(rows.iter().map(mean_ms)),
            ("spheres N", "mean wall time per step (ms), one thread"),
            (
                |x| sparse(x, |x| format!("{x:.0}")),
                |y| sparse(y, |y| format!("{y:.0e}")),
            ),
        )?;
        for ((key, pts), &(c, filled)) in curves.iter().zip(&styles) {
            let marker = if filled {
                c.filled()
            } else {
                c.stroke_width(1)
            };
            let line: Vec<(f64, f64)> = pts.iter().map(|r| (r.n as f64, mean_ms(r))).collect();
            let fit = slope(&line).map_or("one size".to_string(), |s| format!("slope {s:.2}"));
            chart
                .draw_series(LineSeries::new(line.clone(), c.stroke_width(1)))?
                .label(format!("{key} ({fit})"))
                .legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(0, 0), (20, 0)], c.stroke_width(1))
                        + Circle::new((10, 0), 4, marker)
                });
            chart.draw_series(line.iter().map(|&p| Circle::new(p, 4, marker)))?;
        }
        legend(&mut chart, SeriesLabelPosition::LowerRight)?;
        root.present()?;
        Ok(())
    };
    draw_time().map_err(|e| format!("{}: {e}", time.display()))?;
    let overlap = |r: &Row| (r.worst_overlap * 1e3).max(OVERLAP_FLOOR);
    let draw_precision = || -> Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::new(&precision, SIZE).into_drawing_area();
        let mut chart = log_log(
            &root,
            &format!("Pile: worst overlap against time per step ({machine})"),
            bounds(rows.iter().map(mean_ms)),
            // Room above every point for the legend (below).
            {
                let (lo, hi) = bounds(rows.iter().map(overlap));
                (lo, hi * 30.0)
            },
            (
                "mean wall time per step (ms), one thread",
                "worst overlap over the run (mm)",
            ),
            (
                |x| sparse(x, |x| format!("{x:.0e}")),
                |y| sparse(y, |y| format!("{y:.0e}")),
            ),
        )?;
        // Each point's label where it overlaps no label placed before:
        // right of the point above or below it, else left of it, else none
        // (a cluster of runs at one N keeps one label; one engine's runs
        // with and without sleeping lie at nearly the same place, and
        // their labels printed over each other).
        let mut placed: Vec<[i32; 4]> = Vec::new();
        for ((key, pts), &(c, filled)) in curves.iter().zip(&styles) {
            let marker = if filled {
                c.filled()
            } else {
                c.stroke_width(1)
            };
            let at: Vec<Option<(i32, i32)>> = pts
                .iter()
                .map(|r| {
                    let (px, py) = chart.backend_coord(&(mean_ms(r), overlap(r)));
                    let text = format!("N={}", r.n);
                    let w = 7 * text.len() as i32;
                    [(7, -7), (7, 5), (-7 - w, -7), (-7 - w, 5)]
                        .into_iter()
                        .find(|&(dx, dy)| {
                            let b = [px + dx, py + dy - 1, px + dx + w, py + dy + 12];
                            let clear = placed
                                .iter()
                                .all(|p| b[2] < p[0] || p[2] < b[0] || b[3] < p[1] || p[3] < b[1]);
                            if clear {
                                placed.push(b);
                            }
                            clear
                        })
                })
                .collect();
            chart
                .draw_series(pts.iter().zip(at).map(|(r, at)| {
                    let label = match at {
                        Some(at) => Text::new(format!("N={}", r.n), at, (FONT, 11)),
                        None => Text::new(String::new(), (0, 0), (FONT, 11)),
                    };
                    EmptyElement::at((mean_ms(r), overlap(r)))
                        + Circle::new((0, 0), 5, marker)
                        + label
                }))?
                .label(key.clone())
                .legend(move |(x, y)| Circle::new((x + 10, y), 5, marker));
        }
        // Above every point, in the room the y range leaves there: between
        // our overlaps (below 1 mm) and Rapier's (above 5 mm) there is not
        // room enough for twelve entries (at the middle right the legend
        // hid our 3e-2 m/s point at 4,000).
        legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        root.present()?;
        Ok(())
    };
    draw_precision().map_err(|e| format!("{}: {e}", precision.display()))?;
    Ok(vec![time, precision])
}

/// The rows of a table that [`table`] wrote (`--pile-from`), to draw the
/// figures again without running the piles.
pub fn parse_table(text: &str) -> Result<Vec<Row>, String> {
    let mut rows = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let cells: Vec<&str> = line
            .trim()
            .trim_matches('|')
            .split('|')
            .map(str::trim)
            .collect();
        if cells.len() != 10 || cells[0] == "engine" || cells[0].starts_with("---") {
            continue;
        }
        let num = |i: usize| -> Result<f64, String> {
            cells[i]
                .parse::<f64>()
                .map_err(|e| format!("line {}: column {}: {:?}: {e}", k + 1, i + 1, cells[i]))
        };
        rows.push(Row {
            engine: cells[0].to_string(),
            setting: cells[1].to_string(),
            n: num(2)? as usize,
            steps: num(3)? as u64,
            median_ms: num(4)?,
            total_s: num(5)?,
            worst_overlap: num(6)? * 1e-3,
            escaped: num(7)? as usize,
            kinetic: num(8)?,
            asleep: num(9)? as usize,
        });
    }
    if rows.is_empty() {
        return Err("no pile rows in the table".into());
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_slope_of_a_power_law_is_its_exponent() {
        let pts: Vec<(f64, f64)> = [100.0, 1000.0, 4000.0]
            .iter()
            .map(|&n: &f64| (n, 3.0 * n.powf(1.1)))
            .collect();
        assert!((super::slope(&pts).unwrap() - 1.1).abs() < 1e-12);
        assert_eq!(super::slope(&pts[..1]), None);
    }

    #[test]
    fn each_setting_gets_its_own_slope_line() {
        let row = |engine: &str, n: usize, ms: f64| super::Row {
            engine: engine.into(),
            setting: "default".into(),
            n,
            steps: 100,
            median_ms: ms,
            total_s: ms * 0.1,
            worst_overlap: 0.0,
            escaped: 0,
            kinetic: 0.0,
            asleep: 0,
        };
        let rows = [
            row("a", 100, 1.0),
            row("b", 100, 1.0),
            row("a", 1000, 10f64.powf(1.2)),
            row("b", 1000, 100.0),
        ];
        let text = super::slopes(&rows);
        assert_eq!(
            text,
            "- a: default: slope 1.20 (N = 100, 1000)\n- b: default: slope 2.00 (N = 100, 1000)\n"
        );
    }
}

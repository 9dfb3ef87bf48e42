//! The figures: one per group of quantities, each as PNG and SVG, time on
//! x, one colour per body, contact or joint, with a legend.

use super::data::RunData;
use super::{color, PlotError, FONT};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// One series of a panel.
pub struct Series {
    pub name: String,
    pub color: RGBColor,
    pub points: Vec<(f64, f64)>,
}

/// One panel (a plot with its own y axis) of a figure.
pub struct Panel {
    pub ylabel: String,
    pub series: Vec<Series>,
}

/// Most points drawn per series: longer series are decimated to the
/// minimum and maximum of each bucket, so impacts stay visible as spikes.
const MAX_POINTS: usize = 4000;

fn decimate(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    if points.len() <= MAX_POINTS {
        return points.to_vec();
    }
    let bucket = points.len().div_ceil(MAX_POINTS / 2);
    let mut out = Vec::with_capacity(MAX_POINTS + 2);
    for chunk in points.chunks(bucket) {
        let (mut lo, mut hi) = (chunk[0], chunk[0]);
        for &p in chunk {
            if p.1 < lo.1 {
                lo = p;
            }
            if p.1 > hi.1 {
                hi = p;
            }
        }
        if lo.0 <= hi.0 {
            out.extend([lo, hi]);
        } else {
            out.extend([hi, lo]);
        }
    }
    out
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    // A flat series gets a visible band around its value.
    let pad = if hi > lo {
        0.06 * (hi - lo)
    } else {
        lo.abs().max(1e-3) * 0.1
    };
    (lo - pad, hi + pad)
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    panels: &[Panel],
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    // The whole image, in the backend's pixels: where the lines go.
    let canvas = root.clone();
    let root = root.titled(title, (FONT, 24)).map_err(e)?;
    let areas = root.split_evenly((panels.len(), 1));
    for (area, panel) in areas.iter().zip(panels) {
        let (x0, x1) = range(
            panel
                .series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.0)),
        );
        let (y0, y1) = range(
            panel
                .series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.1)),
        );
        let mut chart = ChartBuilder::on(area)
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc("t (s)")
            .y_desc(panel.ylabel.as_str())
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 16))
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(e)?;
        for s in &panel.series {
            let c = s.color;
            // NOTE: a line wider than a pixel goes wrong in plotters' bitmap
            // backend (plotters issue 549: a one-sample spike drawn as a
            // piece and a dot, steep segments dotted, lines out of their
            // panel; `a_known_series_is_drawn_where_it_must_be_and_nowhere_else`).
            // A one-pixel path is drawn right, so the 2-pixel line is that
            // path four times, a pixel apart, in the image's pixels.
            let mut path: Vec<(i32, i32)> = Vec::new();
            for p in decimate(&s.points) {
                let q = chart.backend_coord(&p);
                if path.last() != Some(&q) {
                    path.push(q);
                }
            }
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let shifted: Vec<(i32, i32)> =
                    path.iter().map(|&(x, y)| (x + dx, y + dy)).collect();
                canvas
                    .draw(&PathElement::new(shifted, c.stroke_width(1)))
                    .map_err(e)?;
            }
            chart
                .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())
                .map_err(e)?
                .label(s.name.as_str())
                .legend(move |(x, y)| Rectangle::new([(x, y - 1), (x + 20, y + 1)], c.filled()));
        }
        if !panel.series.is_empty() {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK.mix(0.4))
                .label_font((FONT, 14))
                .position(SeriesLabelPosition::UpperRight)
                .draw()
                .map_err(e)?;
        }
    }
    root.present().map_err(e)
}

/// Draws a figure as `<stem>.png` and `<stem>.svg`; returns both paths.
pub fn figure(
    dir: &Path,
    stem: &str,
    title: &str,
    panels: &[Panel],
) -> Result<Vec<PathBuf>, PlotError> {
    super::ensure_font()?;
    let height = 200 + 260 * panels.len() as u32;
    let png = dir.join(format!("{stem}.png"));
    let svg = dir.join(format!("{stem}.svg"));
    let fail = |p: &Path| {
        let p = p.display().to_string();
        move |m: String| PlotError::Draw(format!("{p}: {m}"))
    };
    draw(
        BitMapBackend::new(&png, (1100, height)).into_drawing_area(),
        title,
        panels,
    )
    .map_err(fail(&png))?;
    draw(
        SVGBackend::new(&svg, (1100, height)).into_drawing_area(),
        title,
        panels,
    )
    .map_err(fail(&svg))?;
    Ok(vec![png, svg])
}

/// Per-body series of `f` of the state row (see `BodyTrack::rows`).
fn body_series(run: &RunData, f: impl Fn(&[f64; 13]) -> f64 + Copy) -> Vec<Series> {
    run.bodies
        .iter()
        .enumerate()
        .map(|(i, b)| Series {
            name: b.name.clone(),
            color: color(i),
            points: run.t.iter().copied().zip(b.rows.iter().map(f)).collect(),
        })
        .collect()
}

fn component_panels(run: &RunData, labels: &[&str], first: usize) -> Vec<Panel> {
    labels
        .iter()
        .enumerate()
        .map(|(j, label)| Panel {
            ylabel: label.to_string(),
            series: body_series(run, move |r| r[first + j]),
        })
        .collect()
}

/// Series of impulse magnitudes of one kind, one per contact or joint.
fn impulse_series(run: &RunData, kind: &str, project: impl Fn(&[f64; 3]) -> f64) -> Vec<Series> {
    run.impulses
        .iter()
        .filter(|((k, _), _)| k == kind)
        .enumerate()
        .map(|(i, ((_, name), v))| Series {
            name: name.clone(),
            color: color(i),
            points: run
                .step_t
                .iter()
                .copied()
                .zip(v.iter().map(&project))
                .collect(),
        })
        .collect()
}

fn norm(p: &[f64; 3]) -> f64 {
    (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
}

/// Every figure of a run into `dir`; returns the files written.
pub fn all(run: &RunData, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let mut files = Vec::new();
    files.extend(figure(
        dir,
        "positions",
        "Positions of the centres of mass",
        &component_panels(run, &["x (m)", "y (m)", "z (m)"], 0),
    )?);
    files.extend(figure(
        dir,
        "velocities",
        "Linear and angular velocities (world frame)",
        &component_panels(
            run,
            &[
                "vx (m/s)",
                "vy (m/s)",
                "vz (m/s)",
                "wx (rad/s)",
                "wy (rad/s)",
                "wz (rad/s)",
            ],
            7,
        ),
    )?);
    files.extend(figure(
        dir,
        "quaternions",
        "Orientation quaternions (scalar first)",
        &component_panels(run, &["qw", "qx", "qy", "qz"], 3),
    )?);
    let energy = ["kinetic", "potential", "energy", "energy_midpoint"];
    files.extend(figure(
        dir,
        "energy",
        "Energy: kinetic, potential, total (end of step) and total with midpoint potential",
        &[Panel {
            ylabel: "energy (J)".into(),
            series: energy
                .iter()
                .enumerate()
                .map(|(i, name)| Series {
                    name: match *name {
                        "energy" => "total".into(),
                        "energy_midpoint" => "total (midpoint)".into(),
                        other => other.into(),
                    },
                    color: color(i),
                    points: run.step_series(name),
                })
                .collect(),
        }],
    )?);
    // Normal impulses point along the normal: their magnitude is the impulse.
    files.extend(figure(
        dir,
        "normal_impulses",
        "Normal impulse per contact",
        &[Panel {
            ylabel: "p_n (N s)".into(),
            series: impulse_series(run, "normal", norm),
        }],
    )?);
    files.extend(figure(
        dir,
        "friction_impulses",
        "Friction impulse magnitude per contact",
        &[Panel {
            ylabel: "|p_f| (N s)".into(),
            series: impulse_series(run, "friction", norm),
        }],
    )?);
    files.extend(figure(
        dir,
        "joint_impulses",
        "Joint impulse magnitude per joint",
        &[Panel {
            ylabel: "|p_b| (N s)".into(),
            series: impulse_series(run, "joint", norm),
        }],
    )?);
    let log_residual: Vec<(f64, f64)> = run
        .step_series("residual")
        .into_iter()
        .map(|(t, r)| (t, if r > 0.0 { r.log10() } else { -17.0 }))
        .collect();
    files.extend(figure(
        dir,
        "solver",
        "Solver work per step and residual",
        &[
            Panel {
                ylabel: "pivots".into(),
                series: vec![Series {
                    name: "Lemke pivots".into(),
                    color: color(0),
                    points: run.step_series("pivots"),
                }],
            },
            Panel {
                ylabel: "log10 residual".into(),
                series: vec![Series {
                    name: "relative natural-map residual (0 drawn as 1e-17)".into(),
                    color: color(1),
                    points: log_residual,
                }],
            },
        ],
    )?);
    files.extend(figure(
        dir,
        "lcp_size",
        "LCP size and contacts",
        &[
            Panel {
                ylabel: "unknowns".into(),
                series: vec![Series {
                    name: "LCP size".into(),
                    color: color(0),
                    points: run.step_series("lcp_size"),
                }],
            },
            Panel {
                ylabel: "contacts".into(),
                series: vec![
                    Series {
                        name: "in the LCP".into(),
                        color: color(1),
                        points: run.step_series("contacts_in_lcp"),
                    },
                    Series {
                        name: "active (p_n > 0)".into(),
                        color: color(2),
                        points: run.step_series("active_contacts"),
                    },
                ],
            },
        ],
    )?);
    Ok(files)
}

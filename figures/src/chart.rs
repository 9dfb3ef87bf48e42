//! The chart frame every figure is drawn in: panels of series over time,
//! stacked, with a legend beside them; decimated to what a pixel shows,
//! gaps where a series is not finite, ticks that read as numbers.

use super::{PlotError, FONT};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// One series of a panel; a non-finite `y` is a gap (a contact that was
/// not active at that step).
pub struct Series {
    pub name: String,
    pub color: RGBColor,
    pub points: Vec<(f64, f64)>,
    /// Drawn one pixel wide, over the others: a series that follows
    /// another closely stays visible on it.
    pub thin: bool,
}

/// How a panel's y axis maps values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scale {
    Linear,
    /// Linear within `±c`, logarithmic beyond (matplotlib's symlog), so
    /// that an impact does not flatten the forces of resting contact.
    Symlog {
        c: f64,
    },
}

impl Scale {
    fn to_axis(self, y: f64) -> f64 {
        match self {
            Scale::Linear => y,
            Scale::Symlog { c } if y.abs() <= c => y / c,
            Scale::Symlog { c } => y.signum() * (1.0 + (y.abs() / c).log10()),
        }
    }
    fn value_at(self, a: f64) -> f64 {
        match self {
            Scale::Linear => a,
            Scale::Symlog { c } if a.abs() <= 1.0 => a * c,
            Scale::Symlog { c } => a.signum() * c * 10f64.powf(a.abs() - 1.0),
        }
    }
}

/// One panel (a plot with its own y axis) of a figure.
pub struct Panel {
    pub ylabel: String,
    pub series: Vec<Series>,
    /// Whole numbers only (counts): fractional ticks are not labelled.
    pub counts: bool,
    pub scale: Scale,
    /// A force panel (or another whose spikes would flatten the rest, the
    /// timings): its scale is chosen from its series when drawn
    /// (`settle`), also after two runs' series were put together.
    pub auto_symlog: bool,
    /// A force panel's unit: N, or N m for torques.
    pub unit: &'static str,
}

impl Panel {
    pub fn new(ylabel: impl Into<String>, series: Vec<Series>) -> Panel {
        Panel {
            ylabel: ylabel.into(),
            series,
            counts: false,
            scale: Scale::Linear,
            auto_symlog: false,
            unit: "N",
        }
    }
    pub(crate) fn counts(mut self) -> Panel {
        self.counts = true;
        self
    }
    /// Whether any series has a point to draw.
    pub(crate) fn has_data(&self) -> bool {
        self.series
            .iter()
            .any(|s| s.points.iter().any(|p| p.1.is_finite()))
    }
}

/// What frames every panel of a run's figures: the subtitle (scene, step,
/// solver), the time axis, and the first failed step.
#[derive(Debug, Clone, Default)]
pub struct Frame {
    pub subtitle: String,
    /// The time axis, exactly (no padding below the start).
    pub t: Option<(f64, f64)>,
    /// Time, step and status of the first failed step.
    pub failure: Option<(f64, u64, String)>,
}

/// Most points drawn per run of a series: longer runs are decimated to
/// the minimum and maximum of each bucket, so impacts stay visible.
const MAX_POINTS: usize = 4000;

/// Width of the legend column right of each plot (pixels).
const LEGEND_WIDTH: u32 = 190;

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

/// The runs of consecutive finite points: a gap ends a run.
fn runs(points: &[(f64, f64)]) -> impl Iterator<Item = &[(f64, f64)]> {
    points
        .split(|p| !p.1.is_finite() || !p.0.is_finite())
        .filter(|r| !r.is_empty())
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

/// A tick's value as people write it: at most four significant digits,
/// no trailing zeros, no `-0`, exponents for the very large and small.
pub fn tick(v: f64) -> String {
    if v == 0.0 || v.abs() < 1e-12 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.2e}");
        // 1.50e3 -> 1.5e3
        return match s.split_once('e') {
            Some((m, e)) => {
                let m = m.trim_end_matches('0').trim_end_matches('.');
                format!("{m}e{e}")
            }
            None => s,
        };
    }
    let decimals = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
    let s = format!("{v:.decimals$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" {
        "0".into()
    } else {
        s
    }
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    frame: &Frame,
    panels: &[Panel],
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    // The whole image, in the backend's pixels: where lines and legends go.
    let canvas = root.clone();
    let mut root = root.titled(title, (FONT, 22)).map_err(e)?;
    if !frame.subtitle.is_empty() {
        root = root
            .titled(
                &frame.subtitle,
                (FONT, 15).into_font().color(&BLACK.mix(0.7)),
            )
            .map_err(e)?;
    }
    let areas = root.split_evenly((panels.len(), 1));
    for (k, (area, panel)) in areas.iter().zip(panels).enumerate() {
        let (x0, x1) = frame.t.unwrap_or_else(|| {
            range(
                panel
                    .series
                    .iter()
                    .flat_map(|s| s.points.iter().map(|p| p.0)),
            )
        });
        let scale = panel.scale;
        let (mut y0, mut y1) = range(
            panel
                .series
                .iter()
                .flat_map(|s| s.points.iter().map(move |p| scale.to_axis(p.1))),
        );
        if panel.counts {
            // Counts: from zero (a little below, so that a zero line shows)
            // to at least one.
            let span = (y1.max(1.0) - y0.min(0.0)).max(1.0);
            y0 = -0.04 * span;
            y1 = y1.max(1.0);
        }
        let mut chart = ChartBuilder::on(area)
            .margin(10)
            .margin_right(10 + LEGEND_WIDTH)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(e)?;
        let counts = panel.counts;
        let ylabel = |a: &f64| {
            let v = scale.value_at(*a);
            if counts && (v - v.round()).abs() > 1e-9 {
                String::new()
            } else {
                tick(v)
            }
        };
        chart
            .configure_mesh()
            .x_desc("t (s)")
            .y_desc(panel.ylabel.as_str())
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 16))
            .light_line_style(WHITE.mix(0.0))
            .x_label_formatter(&|x| tick(*x))
            .y_label_formatter(&ylabel)
            .y_labels(8)
            .draw()
            .map_err(e)?;
        let (px, py) = chart.plotting_area().get_pixel_range();
        for s in &panel.series {
            let c = s.color;
            for run in runs(&s.points) {
                // NOTE: a line wider than a pixel goes wrong in plotters'
                // bitmap backend (plotters issue 549: a one-sample spike
                // drawn as a piece and a dot, steep segments dotted, lines
                // out of their panel;
                // `a_known_series_is_drawn_where_it_must_be_and_nowhere_else`).
                // So the 2-pixel line is a one-pixel path four times, a
                // pixel apart, in the image's pixels (`thick_path`).
                let mut path: Vec<(i32, i32)> = Vec::new();
                for (t, y) in decimate(run) {
                    let q = chart.backend_coord(&(t, scale.to_axis(y)));
                    if path.last() != Some(&q) {
                        path.push(q);
                    }
                }
                // A value of one step alone (a contact active for a
                // single step: an impact) is a stem from the axis with a
                // dot, as an impulse is drawn; a 2-pixel dot alone is lost.
                if let [(x, y)] = path[..] {
                    path = vec![(x, py.end - 1), (x, y)];
                    canvas
                        .draw(&Rectangle::new(
                            [(x - 2, y - 2), (x + 3, y + 3)],
                            c.filled(),
                        ))
                        .map_err(e)?;
                }
                super::thick_path(&canvas, &path, c, if s.thin { 1 } else { 2 }).map_err(e)?;
            }
        }
        if let Some((t, step, status)) = &frame.failure {
            let x = chart.backend_coord(&(*t, y0)).0;
            let red = RGBColor(200, 0, 0);
            canvas
                .draw(&Rectangle::new(
                    [(x, py.start), (x + 1, py.end)],
                    red.filled(),
                ))
                .map_err(e)?;
            if k == 0 {
                canvas
                    .draw(&Text::new(
                        format!("step {step} failed: {status}"),
                        (x + 4, py.start + 2),
                        (FONT, 13).into_font().color(&red),
                    ))
                    .map_err(e)?;
            }
        }
        // The legend, in its own column right of the plot: never over
        // the data.
        let rows = ((py.end - py.start - 8) / 18).max(1) as usize;
        let x = px.end + 14;
        for (i, s) in panel.series.iter().enumerate() {
            let y = py.start + 6 + 18 * i as i32;
            if i + 1 == rows && panel.series.len() > rows {
                let more = format!("+{} more", panel.series.len() - i);
                canvas
                    .draw(&Text::new(more, (x, y), (FONT, 13).into_font()))
                    .map_err(e)?;
                break;
            }
            let bottom = if s.thin { y + 7 } else { y + 8 };
            canvas
                .draw(&Rectangle::new(
                    [(x, y + 6), (x + 20, bottom)],
                    s.color.filled(),
                ))
                .map_err(e)?;
            canvas
                .draw(&Text::new(
                    s.name.clone(),
                    (x + 26, y),
                    (FONT, 13).into_font(),
                ))
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
    frame: &Frame,
    panels: &[Panel],
) -> Result<Vec<PathBuf>, PlotError> {
    figure_sized(dir, stem, title, frame, panels, None)
}

/// [`figure`] of `size` pixels (width, height), or the default size.
pub(crate) fn figure_sized(
    dir: &Path,
    stem: &str,
    title: &str,
    frame: &Frame,
    panels: &[Panel],
    size: Option<(u32, u32)>,
) -> Result<Vec<PathBuf>, PlotError> {
    super::ensure_font()?;
    let (width, height) = size.unwrap_or((1100, 200 + 260 * panels.len() as u32));
    let png = dir.join(format!("{stem}.png"));
    let svg = dir.join(format!("{stem}.svg"));
    let fail = |p: &Path| {
        let p = p.display().to_string();
        move |m: String| PlotError::Draw(format!("{p}: {m}"))
    };
    draw(
        super::text::Kerned::new(BitMapBackend::new(&png, (width, height))).into_drawing_area(),
        title,
        frame,
        panels,
    )
    .map_err(fail(&png))?;
    draw(
        SVGBackend::new(&svg, (width, height)).into_drawing_area(),
        title,
        frame,
        panels,
    )
    .map_err(fail(&svg))?;
    Ok(vec![png, svg])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_read_as_people_write_them() {
        assert_eq!(tick(10.0), "10");
        assert_eq!(tick(-0.0), "0");
        assert_eq!(tick(-1e-15), "0");
        assert_eq!(tick(0.25), "0.25");
        assert_eq!(tick(1.5), "1.5");
        assert_eq!(tick(-2.0), "-2");
        assert_eq!(tick(12345.0), "12345");
        assert_eq!(tick(1.5e6), "1.5e6");
        assert_eq!(tick(2e-5), "2e-5");
    }

    #[test]
    fn symlog_is_linear_inside_and_a_decade_a_unit_outside() {
        let s = Scale::Symlog { c: 2.0 };
        assert_eq!(s.to_axis(1.0), 0.5);
        assert_eq!(s.to_axis(-2.0), -1.0);
        assert!((s.to_axis(200.0) - 3.0).abs() < 1e-12);
        for y in [-5000.0, -3.0, -0.5, 0.0, 0.7, 2.0, 19.0, 1e6] {
            assert!((s.value_at(s.to_axis(y)) - y).abs() <= 1e-9 * y.abs().max(1.0));
        }
    }

    #[test]
    fn gaps_split_a_series_into_runs() {
        let p = [
            (0.0, 1.0),
            (1.0, f64::NAN),
            (2.0, 2.0),
            (3.0, 3.0),
            (4.0, f64::NAN),
        ];
        let r: Vec<usize> = runs(&p).map(<[_]>::len).collect();
        assert_eq!(r, [1, 2]);
    }
}

//! The figures: one per group of quantities, each as PNG and SVG, time on
//! x, one colour per body, contact or joint, the legend beside the plot.
//! A figure says what it shows: its title names the scene, the step and
//! the solver; a group with nothing to show is not drawn; a failed run is
//! marked where it failed.

use super::chart::{figure_sized, Frame, Panel, Series};

use super::data::RunData;
use super::panels::{
    component_panels, force_panel, force_series, joint_angle_panels, joint_coordinate_panels,
    joint_force_panels,
};
use super::{color, PlotError};
use std::path::{Path, PathBuf};

/// Every figure's file stem, in drawing order.
pub const STEMS: [&str; 13] = [
    "positions",
    "velocities",
    "quaternions",
    "joint_angles",
    "joint_coordinates",
    "energy",
    "normal_forces",
    "friction_forces",
    "joint_forces",
    "errors",
    "timings",
    "solver",
    "lcp_size",
];

/// One figure: its file stem, title and panels.
pub struct Spec {
    pub stem: &'static str,
    pub title: &'static str,
    pub panels: Vec<Panel>,
}

/// What to draw and how big.
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// Only these figures (by stem); all when `None`.
    pub only: Option<Vec<String>>,
    /// Image size in pixels (width, height); 1100 wide and 260 a panel
    /// when `None`.
    pub size: Option<(u32, u32)>,
    /// A panel per contact or joint in the force figures, each with its
    /// own axis (up to [`MAX_SPLIT`] of them).
    pub per_contact: bool,
}

/// Most panels a force figure is split into with `per_contact`; a figure
/// with more series keeps them in one panel.
pub const MAX_SPLIT: usize = 24;

impl Panel {
    /// One panel per series, each named after it (forces keep their
    /// per-panel axis choice).
    fn split(self) -> Vec<Panel> {
        let Panel {
            ylabel,
            series,
            counts,
            scale,
            auto_symlog,
            unit,
        } = self;
        series
            .into_iter()
            .map(|s| Panel {
                ylabel: format!("{} {ylabel}", s.name),
                series: vec![s],
                counts,
                scale,
                auto_symlog,
                unit,
            })
            .collect()
    }
}

/// The time axis of a run: from its first state to its last.
fn time_axis(run: &RunData) -> Option<(f64, f64)> {
    match (run.t.first(), run.t.last()) {
        (Some(&a), Some(&b)) if b > a => Some((a, b)),
        // A run that failed its first step has one state.
        (Some(&a), _) => Some((a, a + run.h().unwrap_or(1.0))),
        _ => None,
    }
}

/// Draws `specs` into `dir`: empty panels left out, a figure with none
/// not drawn; returns the files written.
fn draw_specs(
    specs: Vec<Spec>,
    dir: &Path,
    frame: &Frame,
    opts: &Options,
) -> Result<Vec<PathBuf>, PlotError> {
    let mut files = Vec::new();
    for spec in specs {
        if let Some(only) = &opts.only {
            if !only.iter().any(|o| o == spec.stem) {
                continue;
            }
        }
        let split = opts.per_contact
            && spec.stem.ends_with("_forces")
            && spec.panels.iter().map(|p| p.series.len()).sum::<usize>() <= MAX_SPLIT;
        let panels: Vec<Panel> = spec
            .panels
            .into_iter()
            .flat_map(|p| if split { p.split() } else { vec![p] })
            .filter(Panel::has_data)
            .map(Panel::settle)
            .collect();
        if !panels.is_empty() {
            files.extend(figure_sized(
                dir, spec.stem, spec.title, frame, &panels, opts.size,
            )?);
        }
    }
    Ok(files)
}

/// Every figure of a run into `dir`, framed by `frame` (its time axis is
/// filled in from the run); returns the files written. Figures with no
/// data (no joints, no friction) are not drawn.
pub fn all(
    run: &RunData,
    dir: &Path,
    frame: &Frame,
    opts: &Options,
) -> Result<Vec<PathBuf>, PlotError> {
    let mut frame = frame.clone();
    frame.t = time_axis(run);
    frame.failure = frame.failure.or_else(|| run.first_failure.clone());
    draw_specs(specs(run), dir, &frame, opts)
}

/// Two runs in the same figures (`plot A B`): run `a`'s series drawn as
/// usual and named `NAME (LABEL_A)`, run `b`'s one pixel wide over them,
/// in the same colours, named `NAME (LABEL_B)`; the time axis covers both.
pub fn overlay(
    (a, label_a): (&RunData, &str),
    (b, label_b): (&RunData, &str),
    dir: &Path,
    frame: &Frame,
    opts: &Options,
) -> Result<Vec<PathBuf>, PlotError> {
    let mut frame = frame.clone();
    frame.t = match (time_axis(a), time_axis(b)) {
        (Some(x), Some(y)) => Some((x.0.min(y.0), x.1.max(y.1))),
        (x, y) => x.or(y),
    };
    frame.failure = frame
        .failure
        .or_else(|| a.first_failure.clone())
        .or_else(|| b.first_failure.clone());
    let mut merged = Vec::new();
    let mut from_b: Vec<Spec> = specs(b);
    for mut spec in specs(a) {
        let other = from_b
            .iter()
            .position(|s| s.stem == spec.stem)
            .map(|i| from_b.remove(i));
        let mut others = other.map(|o| o.panels).unwrap_or_default().into_iter();
        for panel in &mut spec.panels {
            for s in &mut panel.series {
                s.name = format!("{} ({label_a})", s.name);
            }
            if let Some(o) = others.next() {
                panel.series.extend(o.series.into_iter().map(|s| Series {
                    name: format!("{} ({label_b})", s.name),
                    thin: true,
                    ..s
                }));
            }
        }
        merged.push(spec);
    }
    draw_specs(merged, dir, &frame, opts)
}

/// The figures of a run.
pub fn specs(run: &RunData) -> Vec<Spec> {
    let mut specs = Vec::new();
    let mut put = |stem: &'static str, title: &'static str, panels: Vec<Panel>| {
        specs.push(Spec {
            stem,
            title,
            panels,
        });
    };
    put(
        "positions",
        "Positions of the centres of mass",
        component_panels(run, &["x (m)", "y (m)", "z (m)"], 0),
    );
    put(
        "velocities",
        "Linear and angular velocities (world frame)",
        component_panels(
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
    );
    put(
        "quaternions",
        "Orientation quaternions (scalar first)",
        component_panels(run, &["qw", "qx", "qy", "qz"], 3),
    );
    put(
        "joint_angles",
        "Joint rotations since the start: body_b relative to body_a, a rotation vector in body_a's frame",
        joint_angle_panels(run),
    );
    put(
        "joint_coordinates",
        "Hinge angles and slider offsets (body_b relative to body_a, joints.csv)",
        joint_coordinate_panels(run),
    );
    // The midpoint total last and thin: it follows the end-of-step total
    // closely, and both stay visible.
    let energy = [
        ("kinetic", "kinetic", 0),
        ("potential", "potential", 1),
        ("energy", "total", 2),
        ("energy_midpoint", "total (midpoint potential)", 3),
    ];
    put(
        "energy",
        "Energy: kinetic, potential, total (end of step) and total with midpoint potential",
        vec![Panel::new(
            "energy (J)",
            energy
                .iter()
                .map(|&(column, name, c)| Series {
                    name: name.into(),
                    color: color(c),
                    points: run.step_series(column),
                    thin: column == "energy_midpoint",
                })
                .collect(),
        )],
    );
    // Forces, not impulses: an impulse per step changes with h. The CSV
    // keeps the impulses.
    if let Some(h) = run.h() {
        put(
            "normal_forces",
            "Normal force per contact (impulse over the step / h; gaps: not in contact)",
            vec![force_panel("|f_n|", force_series(run, "normal", h))],
        );
        put(
            "friction_forces",
            "Friction force magnitude per contact (impulse / h)",
            vec![force_panel("|f_t|", force_series(run, "friction", h))],
        );
        let panels = joint_force_panels(run, h);
        // The title names the pushes' panels only where there are some.
        let title = if panels.len() > 1 {
            "Joint force magnitude per joint (impulse / h); below, limits' and motors' pushes"
        } else {
            "Joint force magnitude per joint (impulse / h)"
        };
        put("joint_forces", title, panels);
    }
    put(
        "errors",
        "Constraint errors: deepest penetration and largest joint error after each step",
        vec![
            Panel::new(
                "penetration (m)",
                vec![Series {
                    name: "max penetration".into(),
                    color: color(3),
                    points: run.step_series("max_penetration"),
                    thin: false,
                }],
            ),
            Panel::new(
                "joint error (m)",
                vec![Series {
                    name: "max joint error".into(),
                    color: color(4),
                    points: run.step_series("max_joint_error"),
                    thin: false,
                }],
            ),
            Panel::new(
                "joint rotation error (rad)",
                vec![Series {
                    name: "max joint rotation error".into(),
                    color: color(5),
                    points: run.step_series("max_joint_angle_error"),
                    thin: false,
                }],
            ),
        ],
    );
    let stages = [
        ("t_collision", "collision"),
        ("t_assemble", "assemble"),
        ("t_solve", "solve"),
        ("t_integrate", "integrate"),
        ("t_measure", "measure"),
        ("t_total", "total"),
    ];
    put(
        "timings",
        "Wall time per step by stage (this machine, this run)",
        // The first step's spike (the first factorisations, cold caches)
        // and the machine's hiccups would flatten the rest: the force
        // panels' symlog rule.
        vec![Panel {
            auto_symlog: true,
            unit: "us",
            ..Panel::new(
                "time",
                stages
                    .iter()
                    .enumerate()
                    .map(|(i, &(column, name))| Series {
                        name: name.into(),
                        color: color(i),
                        points: run
                            .step_series(column)
                            .into_iter()
                            .map(|(t, s)| (t, s * 1e6))
                            .collect(),
                        thin: false,
                    })
                    .collect(),
            )
        }],
    );
    let log_residual: Vec<(f64, f64)> = run
        .step_series("residual")
        .into_iter()
        .map(|(t, r)| (t, if r > 0.0 { r.log10() } else { -17.0 }))
        .collect();
    put(
        "solver",
        "Solver work per step and residual",
        vec![
            Panel::new(
                "pivots or sweeps",
                vec![Series {
                    name: "work".into(),
                    color: color(0),
                    points: run.step_series("pivots"),
                    thin: false,
                }],
            )
            .counts(),
            Panel::new(
                "log10 residual",
                vec![Series {
                    name: "natural map (0 as -17)".into(),
                    color: color(1),
                    points: log_residual,
                    thin: false,
                }],
            ),
        ],
    );
    put(
        "lcp_size",
        "LCP size and contacts",
        vec![
            Panel::new(
                "unknowns",
                vec![Series {
                    name: "LCP size".into(),
                    color: color(0),
                    points: run.step_series("lcp_size"),
                    thin: false,
                }],
            )
            .counts(),
            Panel::new(
                "contacts",
                vec![
                    Series {
                        name: "in the LCP".into(),
                        color: color(1),
                        points: run.step_series("contacts_in_lcp"),
                        thin: false,
                    },
                    Series {
                        name: "active (p_n > 0)".into(),
                        color: color(2),
                        points: run.step_series("active_contacts"),
                        thin: false,
                    },
                ],
            )
            .counts(),
        ],
    );
    specs
}

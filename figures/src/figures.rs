//! The figures: one per group of quantities, each as PNG and SVG, time on
//! x, one colour per body, contact or joint, the legend beside the plot.
//! A figure says what it shows: its title names the scene, the step and
//! the solver; a group with nothing to show is not drawn; a failed run is
//! marked where it failed.

use super::chart::{figure_sized, tick, Frame, Panel, Scale, Series};

use super::data::RunData;
use super::{color, PlotError};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use std::path::{Path, PathBuf};

/// Per-body series of `f` of the state row (see `BodyTrack::rows`).
fn body_series(run: &RunData, f: impl Fn(&[f64; 13]) -> f64 + Copy) -> Vec<Series> {
    run.bodies
        .iter()
        .enumerate()
        .map(|(i, b)| Series {
            name: b.name.clone(),
            color: color(i),
            points: run.t.iter().copied().zip(b.rows.iter().map(f)).collect(),
            thin: false,
        })
        .collect()
}

fn component_panels(run: &RunData, labels: &[&str], first: usize) -> Vec<Panel> {
    labels
        .iter()
        .enumerate()
        .map(|(j, label)| Panel::new(*label, body_series(run, move |r| r[first + j])))
        .collect()
}

/// The rotation vector equivalent to `v` (the same axis, the angle plus a
/// whole number of turns) nearest `last`: a joint that keeps turning is
/// drawn as one continuous curve, not one that jumps where its angle passes
/// 180 degrees.
fn unwrap(v: Vector3<f64>, last: &Vector3<f64>) -> Vector3<f64> {
    let angle = v.norm();
    if angle < 1e-12 {
        // No axis to turn about: the nearest multiple of a turn about
        // the last axis.
        let l = last.norm();
        if l < 1e-12 {
            return v;
        }
        let turns = (l / std::f64::consts::TAU).round();
        return last * (turns * std::f64::consts::TAU / l);
    }
    let axis = v / angle;
    // The whole turns that bring the angle nearest the last along this axis.
    let turns = ((axis.dot(last) - angle) / std::f64::consts::TAU).round();
    [turns - 1.0, turns, turns + 1.0]
        .into_iter()
        .map(|n| axis * (angle + n * std::f64::consts::TAU))
        .min_by(|x, y| (x - last).norm().total_cmp(&(y - last).norm()))
        .unwrap_or(v)
}

/// Each joint's rotation since the start: `r(t) = rel(t) rel(0)^-1`,
/// with `rel = q_a^-1 q_b` (body_b's orientation in body_a's frame; a
/// world end has the identity), as a rotation vector in body_a's frame
/// (axis times angle, in degrees, unwrapped to stay continuous: see
/// [`unwrap`]): its three components and its angle. A spherical joint has no single angle; this
/// is what MuJoCo's `mju_quat2Vel` gives for a ball joint's relative
/// rotation, and a hinge's angle is the component along its axis.
fn joint_angle_panels(run: &RunData) -> Vec<Panel> {
    let orientation = |name: &str| -> Option<Option<usize>> {
        if name == cosim_shared::scene::WORLD {
            return Some(None);
        }
        run.bodies.iter().position(|b| b.name == name).map(Some)
    };
    let at = |b: Option<usize>, i: usize| {
        b.map_or_else(UnitQuaternion::identity, |b| {
            let r = &run.bodies[b].rows[i];
            UnitQuaternion::from_quaternion(Quaternion::new(r[3], r[4], r[5], r[6]))
        })
    };
    let mut series: [Vec<Series>; 4] = Default::default();
    for (k, j) in run.joints.iter().enumerate() {
        let (Some(a), Some(b)) = (orientation(&j.body_a), orientation(&j.body_b)) else {
            continue;
        };
        if run.t.is_empty() {
            continue;
        }
        let rel = |i: usize| at(a, i).inverse() * at(b, i);
        let start = rel(0).inverse();
        let mut last = Vector3::zeros();
        let vectors: Vec<(f64, Vector3<f64>)> = (0..run.t.len())
            .map(|i| {
                last = unwrap((rel(i) * start).scaled_axis(), &last);
                // Below 1e-9 deg is the quaternion products' round-off
                // (1e-16 relative): drawn as zero, not as an axis
                // stretched over noise.
                let deg = last.map(|r| {
                    let d = r.to_degrees();
                    if d.abs() < 1e-9 {
                        0.0
                    } else {
                        d
                    }
                });
                (run.t[i], deg)
            })
            .collect();
        for (c, out) in series.iter_mut().enumerate() {
            out.push(Series {
                name: j.name.clone(),
                color: color(k),
                points: vectors
                    .iter()
                    .map(|(t, v)| (*t, if c < 3 { v[c] } else { v.norm() }))
                    .collect(),
                thin: false,
            });
        }
    }
    let labels = ["rx (deg)", "ry (deg)", "rz (deg)", "angle (deg)"];
    labels
        .iter()
        .zip(series)
        .map(|(label, s)| Panel::new(*label, s))
        .collect()
}

/// The hinges' angles and rates (deg, deg/s; the angle unwrapped across
/// the file's (-180, 180] so that a turning hinge draws a continuous
/// line) and the sliders' offsets and speeds (m, m/s), from joints.csv.
fn joint_coordinate_panels(run: &RunData) -> Vec<Panel> {
    let mut series: [Vec<Series>; 4] = Default::default();
    for (k, c) in run.coordinates.iter().enumerate() {
        let hinge = c.kind == "revolute";
        let mut turns = 0.0;
        let mut last: Option<f64> = None;
        type Points = Vec<(f64, f64)>;
        let (positions, rates): (Points, Points) = run
            .t
            .iter()
            .zip(&c.values)
            .map(|(&t, &(x, v))| {
                if !hinge {
                    return ((t, x), (t, v));
                }
                // A jump of more than pi between states is the wrap.
                if let Some(l) = last {
                    if x - l > std::f64::consts::PI {
                        turns -= std::f64::consts::TAU;
                    } else if l - x > std::f64::consts::PI {
                        turns += std::f64::consts::TAU;
                    }
                }
                last = Some(x);
                ((t, (x + turns).to_degrees()), (t, v.to_degrees()))
            })
            .unzip();
        let at = if hinge { 0 } else { 2 };
        for (slot, points) in [(at, positions), (at + 1, rates)] {
            series[slot].push(Series {
                name: c.name.clone(),
                color: color(k),
                points,
                thin: false,
            });
        }
    }
    let labels = [
        "hinge angle (deg)",
        "hinge rate (deg/s)",
        "slider offset (m)",
        "slider speed (m/s)",
    ];
    labels
        .iter()
        .zip(series)
        .map(|(label, s)| Panel::new(*label, s))
        .collect()
}

/// Force series (N: impulse over the step / h) of one kind, one per
/// contact or joint, with gaps where it was not active.
fn force_series(run: &RunData, kind: &str, h: f64) -> Vec<Series> {
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
                .zip(v.iter().map(|p| p.map_or(f64::NAN, |p| norm(&p) / h)))
                .collect(),
            thin: false,
        })
        .collect()
}

/// The joint forces figure's panels: the anchors' forces, then where a
/// limit or motor pushed, their pushes (impulse / h): a hinge's a torque
/// (N m), a slider's a force (N), each in its own panel (joints.csv
/// says which joint is which; without it the pushes are left out).
fn joint_force_panels(run: &RunData, h: f64) -> Vec<Panel> {
    let mut panels = vec![force_panel("|f_b|", force_series(run, "joint", h))];
    let kind_of = |name: &str| {
        run.coordinates
            .iter()
            .find(|c| c.name == name)
            .map(|c| c.kind.as_str())
    };
    for (kind, what, unit) in [
        ("revolute", "hinges |tau|", "N m"),
        ("prismatic", "sliders |f|", "N"),
    ] {
        let mut series: Vec<Series> = ["joint_limit", "joint_motor"]
            .iter()
            .flat_map(|k| {
                force_series(run, k, h).into_iter().map(move |mut s| {
                    s.name = format!("{} {}", s.name, &k["joint_".len()..]);
                    s
                })
            })
            .filter(|s| kind_of(s.name.split(' ').next().unwrap_or("")) == Some(kind))
            .collect();
        for (i, s) in series.iter_mut().enumerate() {
            s.color = color(i);
        }
        if !series.is_empty() {
            panels.push(Panel {
                unit,
                ..force_panel(what, series)
            });
        }
    }
    panels
}

/// A force panel of quantity `what` (its unit added when settled).
fn force_panel(what: &str, series: Vec<Series>) -> Panel {
    Panel {
        forces: true,
        ..Panel::new(what, series)
    }
}

impl Panel {
    /// A force panel's axis from its series: symlog when the largest force
    /// passes 100 times the typical one (the median of the nonzero
    /// values), so that one impact does not flatten resting contact; its
    /// linear range is that typical force, rounded down to a power of ten.
    fn settle(mut self) -> Panel {
        if !self.forces {
            return self;
        }
        self.forces = false;
        let mut values: Vec<f64> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.1.abs()))
            .filter(|v| v.is_finite() && *v > 0.0)
            .collect();
        values.sort_by(f64::total_cmp);
        let what = std::mem::take(&mut self.ylabel);
        match (values.get(values.len() / 2), values.last()) {
            (Some(&typical), Some(&largest)) if largest > 100.0 * typical => {
                let c = 10f64.powf(typical.log10().floor());
                self.ylabel = format!("{what} ({}, symlog, linear below {})", self.unit, tick(c));
                self.scale = Scale::Symlog { c };
            }
            _ => self.ylabel = format!("{what} ({})", self.unit),
        }
        self
    }
}

fn norm(p: &[f64; 3]) -> f64 {
    (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
}

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
            forces,
            unit,
        } = self;
        series
            .into_iter()
            .map(|s| Panel {
                ylabel: format!("{} {ylabel}", s.name),
                series: vec![s],
                counts,
                scale,
                forces,
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
        vec![Panel::new(
            "time (us)",
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
        )],
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{PI, TAU};

    #[test]
    fn a_joint_angle_is_body_b_turning_relative_to_body_a_since_the_start() {
        use super::super::data::{BodyTrack, JointEnds};
        use nalgebra::Unit;
        let turn = |axis: Vector3<f64>, deg: f64| {
            UnitQuaternion::from_axis_angle(&Unit::new_normalize(axis), deg.to_radians())
        };
        let row = |q: UnitQuaternion<f64>| {
            let mut r = [0.0; 13];
            r[3..7].copy_from_slice(&[q.w, q.i, q.j, q.k]);
            r
        };
        // Body a holds 40 deg about x; body b starts 10 deg about a's y
        // and turns 30 deg about a's z.
        let qa = turn(Vector3::x(), 40.0);
        let b0 = qa * turn(Vector3::y(), 10.0);
        let b1 = qa * turn(Vector3::z(), 30.0) * turn(Vector3::y(), 10.0);
        let joint = |name: &str, a: &str| JointEnds {
            name: name.into(),
            body_a: a.into(),
            body_b: "b".into(),
        };
        let run = RunData {
            t: vec![0.0, 1.0],
            bodies: vec![
                BodyTrack {
                    name: "a".into(),
                    rows: vec![row(qa), row(qa)],
                },
                BodyTrack {
                    name: "b".into(),
                    rows: vec![row(b0), row(b1)],
                },
            ],
            joints: vec![joint("ab", "a"), joint("wb", "world"), joint("gone", "c")],
            ..Default::default()
        };
        let panels = joint_angle_panels(&run);
        let value = |panel: usize, joint: usize| panels[panel].series[joint].points[1].1;
        // In a's frame: 30 deg about z.
        assert!(value(0, 0).abs() < 1e-9 && value(1, 0).abs() < 1e-9);
        assert!((value(2, 0) - 30.0).abs() < 1e-9);
        assert!((value(3, 0) - 30.0).abs() < 1e-9);
        // Against the world: 30 deg about a's z seen in the world frame.
        let axis = qa * Vector3::z();
        for c in 0..3 {
            assert!((value(c, 1) - 30.0 * axis[c]).abs() < 1e-9, "{c}");
        }
        // A joint naming no body of the run is left out; at t = 0 nothing turned.
        assert_eq!(panels[0].series.len(), 2);
        assert!(panels
            .iter()
            .all(|p| p.series.iter().all(|s| s.points[0].1.abs() < 1e-12)));
    }

    /// A limit's and a motor's pushes are drawn as forces (impulse / h)
    /// below the anchors' forces: a hinge's in N m, a slider's in N, each
    /// in its own panel, named by joint and kind; without joints.csv (no
    /// joint kinds) they are left out rather than drawn in a wrong unit.
    #[test]
    fn limits_and_motors_draw_their_pushes_by_unit() {
        use super::super::data::JointCoordinate;
        let h = 0.01;
        let step_t: Vec<f64> = (1..=3).map(|k| k as f64 * h).collect();
        let mut impulses = std::collections::BTreeMap::new();
        let series = |v: [f64; 3]| vec![Some(v), None, Some(v)];
        impulses.insert(("joint".into(), "elbow".into()), series([0.0, 0.0, 0.05]));
        impulses.insert(
            ("joint_limit".into(), "elbow".into()),
            series([0.0, 0.03, 0.04]),
        );
        impulses.insert(
            ("joint_motor".into(), "rail".into()),
            series([0.02, 0.0, 0.0]),
        );
        let coordinate = |name: &str, kind: &str| JointCoordinate {
            name: name.into(),
            kind: kind.into(),
            values: Vec::new(),
        };
        let mut run = RunData {
            step_t,
            impulses,
            coordinates: vec![
                coordinate("elbow", "revolute"),
                coordinate("rail", "prismatic"),
            ],
            ..Default::default()
        };
        let settled: Vec<Panel> = joint_force_panels(&run, h)
            .into_iter()
            .map(Panel::settle)
            .collect();
        let labels: Vec<&str> = settled.iter().map(|p| p.ylabel.as_str()).collect();
        assert_eq!(
            labels,
            ["|f_b| (N)", "hinges |tau| (N m)", "sliders |f| (N)"]
        );
        assert_eq!(settled[1].series[0].name, "elbow limit");
        assert_eq!(settled[2].series[0].name, "rail motor");
        let p = &settled[1].series[0].points;
        assert!((p[0].1 - 5.0).abs() < 1e-12 && p[1].1.is_nan(), "{p:?}");
        assert!((settled[2].series[0].points[2].1 - 2.0).abs() < 1e-12);
        run.coordinates.clear();
        assert_eq!(joint_force_panels(&run, h).len(), 1);
    }

    #[test]
    fn joint_coordinates_draw_a_turning_hinge_unwrapped_and_a_slider_in_metres() {
        use super::super::data::JointCoordinate;
        // A hinge turning at 2 rad/s for 4 s (8 rad: past 180 deg twice),
        // its angle as joints.csv wraps it; a slider at 0.1 m/s.
        let t: Vec<f64> = (0..=400).map(|k| k as f64 * 0.01).collect();
        let wrap = |a: f64| (a + PI).rem_euclid(TAU) - PI;
        let run = RunData {
            t: t.clone(),
            coordinates: vec![
                JointCoordinate {
                    name: "hinge".into(),
                    kind: "revolute".into(),
                    values: t.iter().map(|&t| (wrap(2.0 * t), 2.0)).collect(),
                },
                JointCoordinate {
                    name: "rail".into(),
                    kind: "prismatic".into(),
                    values: t.iter().map(|&t| (0.1 * t, 0.1)).collect(),
                },
            ],
            ..Default::default()
        };
        let panels = joint_coordinate_panels(&run);
        let labels: Vec<&str> = panels.iter().map(|p| p.ylabel.as_str()).collect();
        assert_eq!(
            labels,
            [
                "hinge angle (deg)",
                "hinge rate (deg/s)",
                "slider offset (m)",
                "slider speed (m/s)"
            ]
        );
        for (k, &t) in t.iter().enumerate() {
            let at = |panel: usize| panels[panel].series[0].points[k];
            assert!(
                (at(0).1 - (2.0 * t).to_degrees()).abs() < 1e-9,
                "t {t}: {:?}",
                at(0)
            );
            assert!((at(1).1 - 2f64.to_degrees()).abs() < 1e-9);
            assert!((at(2).1 - 0.1 * t).abs() < 1e-12 && (at(3).1 - 0.1).abs() < 1e-12);
            assert_eq!(at(0).0, t);
        }
        // Each joint in its own panels only.
        assert!(panels.iter().all(|p| p.series.len() == 1));
        assert_eq!(panels[0].series[0].name, "hinge");
        assert_eq!(panels[2].series[0].name, "rail");
    }

    #[test]
    fn a_joint_that_keeps_turning_is_one_continuous_curve() {
        // 170 then 190 deg about z: the rotation vector of the second is
        // 170 deg about -z; unwrapped, 190 about +z.
        let last = Vector3::new(0.0, 0.0, 170f64.to_radians());
        let v = Vector3::new(0.0, 0.0, -170f64.to_radians());
        let u = unwrap(v, &last);
        assert!((u.z.to_degrees() - 190.0).abs() < 1e-9, "{u}");
        // Two full turns on: 725 deg, from 5 deg about z.
        let last = Vector3::new(0.0, 0.0, 720f64.to_radians());
        let u = unwrap(Vector3::new(0.0, 0.0, 5f64.to_radians()), &last);
        assert!((u.z.to_degrees() - 725.0).abs() < 1e-9, "{u}");
        // Ten turns on, from -175 deg read as 175 about -z: 3,425 deg.
        let last = Vector3::new(0.0, 0.0, 3420f64.to_radians());
        let u = unwrap(Vector3::new(0.0, 0.0, -175f64.to_radians()), &last);
        assert!((u.z.to_degrees() - 3425.0).abs() < 1e-9, "{u}");
    }
}

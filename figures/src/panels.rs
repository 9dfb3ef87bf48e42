//! The panels the figures are made of: series of bodies, joints, contacts
//! and forces read out of a run.

use super::chart::{tick, Panel, Scale, Series};
use super::color;
use super::data::RunData;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// Per-body series of `f` of the state row (see `BodyTrack::rows`).
pub(crate) fn body_series(run: &RunData, f: impl Fn(&[f64; 13]) -> f64 + Copy) -> Vec<Series> {
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

pub(crate) fn component_panels(run: &RunData, labels: &[&str], first: usize) -> Vec<Panel> {
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
pub(crate) fn unwrap(v: Vector3<f64>, last: &Vector3<f64>) -> Vector3<f64> {
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
pub(crate) fn joint_angle_panels(run: &RunData) -> Vec<Panel> {
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
pub(crate) fn joint_coordinate_panels(run: &RunData) -> Vec<Panel> {
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
pub(crate) fn force_series(run: &RunData, kind: &str, h: f64) -> Vec<Series> {
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
pub(crate) fn joint_force_panels(run: &RunData, h: f64) -> Vec<Panel> {
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
pub(crate) fn force_panel(what: &str, series: Vec<Series>) -> Panel {
    Panel {
        auto_symlog: true,
        ..Panel::new(what, series)
    }
}

impl Panel {
    /// A force panel's axis from its series: symlog when the largest force
    /// passes 20 times the typical one (the median of the nonzero
    /// values), so that one impact does not flatten resting contact; its
    /// linear range is that typical force, rounded down to a power of ten.
    pub(crate) fn settle(mut self) -> Panel {
        if !self.auto_symlog {
            return self;
        }
        self.auto_symlog = false;
        let mut values: Vec<f64> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.1.abs()))
            .filter(|v| v.is_finite() && *v > 0.0)
            .collect();
        values.sort_by(f64::total_cmp);
        let what = std::mem::take(&mut self.ylabel);
        match (values.get(values.len() / 2), values.last()) {
            (Some(&typical), Some(&largest)) if largest > 20.0 * typical => {
                let c = 10f64.powf(typical.log10().floor());
                self.ylabel = format!("{what} ({}, symlog, linear below {})", self.unit, tick(c));
                self.scale = Scale::Symlog { c };
            }
            _ => self.ylabel = format!("{what} ({})", self.unit),
        }
        self
    }
}

pub(crate) fn norm(p: &[f64; 3]) -> f64 {
    (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
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

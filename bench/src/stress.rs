//! `cosim-server bench stress`: scenes that break engines (issue #6).
//!
//! Each case runs a scene, checks its pass criteria and reports the worst
//! figure it saw and which solver produced the steps. The tests in
//! `tests/tests/stress.rs` assert that every case passes; `bench stress`
//! prints the table (`bench/results/stress.md`).

use super::text::{joint, plane, sphere};
use cosim_engine::solver::PgsParams;
use cosim_engine::{Engine, Model, StepReport};
use cosim_shared::{Scene, SolverChoice};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The outcome of one case.
#[derive(Debug, Clone)]
pub struct Outcome {
    pub case: String,
    pub solver: SolverChoice,
    pub pass: bool,
    /// The worst figures seen, with units.
    pub figure: String,
    /// Solvers that produced the steps, with step counts ("lemke: 1999,
    /// pgs (auto: lemke failed): 1").
    pub solvers: String,
    /// Why it failed, or what it noticed.
    pub note: String,
}

const G: f64 = 9.81;

/// Per-run bookkeeping of a case.
#[derive(Default)]
struct Stats {
    solvers: BTreeMap<&'static str, u64>,
    regularized: usize,
    projected: usize,
    not_converged: usize,
    failure: Option<String>,
    max_penetration: f64,
    max_joint_error: f64,
}

impl Stats {
    fn solvers(&self) -> String {
        let v: Vec<String> = self
            .solvers
            .iter()
            .map(|(k, n)| format!("{k}: {n}"))
            .collect();
        v.join(", ")
    }
}

fn engine(toml: &str, solver: SolverChoice) -> Engine {
    // The cases' scenes are ours: a parse error is a bug here, not input.
    let mut scene = Scene::parse(toml, "<stress scene>").unwrap_or_else(|e| panic!("{e}"));
    scene.sim.solver = solver;
    let mut e = Engine::new(Model::from_scene(&scene));
    // The suite asks for exact answers: PGS at the tolerance that gives them.
    e.set_pgs_params(PgsParams::precise());
    e
}

/// Steps `n` times (stops at the first failed step), calling `each` after
/// every successful step.
fn run(e: &mut Engine, n: u64, mut each: impl FnMut(&Engine, &StepReport)) -> Stats {
    let mut st = Stats::default();
    for _ in 0..n {
        let r = e.step();
        *st.solvers.entry(r.solver).or_default() += 1;
        if let Some(err) = r.error {
            st.failure = Some(format!("step {} failed: {err}", r.step + 1));
            break;
        }
        if !e.state().bodies.iter().all(|b| {
            b.x.iter()
                .chain(b.v.iter())
                .chain(b.w.iter())
                .all(|x| x.is_finite())
        }) {
            st.failure = Some(format!("step {}: non-finite state", r.step));
            break;
        }
        st.regularized += r.regularized;
        st.projected += r.projected;
        st.not_converged += usize::from(r.not_converged);
        st.max_penetration = st.max_penetration.max(r.max_penetration);
        st.max_joint_error = st.max_joint_error.max(r.max_joint_error);
        each(e, &r);
    }
    st
}

fn outcome(
    case: String,
    solver: SolverChoice,
    st: &Stats,
    checks: &[(bool, String)],
    figure: String,
) -> Outcome {
    let mut notes: Vec<String> = st.failure.iter().cloned().collect();
    notes.extend(checks.iter().filter(|(ok, _)| !ok).map(|(_, m)| m.clone()));
    if st.regularized > 0 {
        notes.push(format!("{} regularised solves", st.regularized));
    }
    if st.projected > 0 {
        notes.push(format!(
            "{} contacts projected out of deep penetration",
            st.projected
        ));
    }
    if st.not_converged > 0 {
        notes.push(format!(
            "{} steps at the PGS iteration cap",
            st.not_converged
        ));
    }
    Outcome {
        case,
        solver,
        pass: st.failure.is_none() && checks.iter().all(|(ok, _)| *ok),
        figure,
        solvers: st.solvers(),
        note: notes.join("; "),
    }
}

fn sim(h: f64, extra: &str) -> String {
    format!("[sim]\ndt = {h:e}\nsteps = 1\n{extra}")
}
/// Total normal force (N) on the planes in the last step.
fn plane_force(e: &Engine) -> f64 {
    use cosim_engine::{ImpulseKind, Party};
    e.impulses()
        .iter()
        .filter(|r| r.kind == ImpulseKind::Normal && matches!(r.b, Party::Plane(_)))
        .map(|r| r.impulse.z)
        .sum::<f64>()
        / e.model().params.h
}

fn drift(e: &Engine, start: &[Vector3<f64>]) -> f64 {
    e.state()
        .bodies
        .iter()
        .zip(start)
        .map(|(b, s)| (b.x - s).norm())
        .fold(0.0, f64::max)
}

fn starts(e: &Engine) -> Vec<Vector3<f64>> {
    e.state().bodies.iter().map(|b| b.x).collect()
}

/// A scene where everything rests on the planes for 2 s: the planes carry
/// `weight` (N) every step to 1e-6, nothing drifts (1e-9 m) and, with
/// `exact_contact`, nothing penetrates (1e-9 m).
fn resting(
    case: String,
    toml: &str,
    solver: SolverChoice,
    weight: f64,
    exact_contact: bool,
) -> Outcome {
    let mut e = engine(toml, solver);
    let start = starts(&e);
    let mut force_err: f64 = 0.0;
    let st = run(&mut e, 2000, |e, _| {
        force_err = force_err.max((plane_force(e) - weight).abs() / weight);
    });
    let d = drift(&e, &start);
    let mut checks = vec![
        (
            force_err < 1e-6,
            format!("plane force off by {force_err:.1e} of the weight"),
        ),
        (d < 1e-9, format!("drift {d:.1e} m")),
    ];
    if exact_contact {
        checks.push((
            st.max_penetration < 1e-9,
            format!("penetration {:.1e} m", st.max_penetration),
        ));
    }
    outcome(
        case,
        solver,
        &st,
        &checks,
        format!(
            "force {force_err:.1e} rel, drift {d:.1e} m, penetration {:.1e} m",
            st.max_penetration
        ),
    )
}

/// A heavy sphere resting on a light one on a plane: the floor carries
/// both weights, nothing moves.
pub fn stack(ratio: f64, solver: SolverChoice) -> Outcome {
    let r = 0.1;
    let toml = sim(1e-3, "")
        + &sphere("light", r, 1.0, [0.0, 0.0, r], [0.0; 3], 0.5, 0.0)
        + &sphere("heavy", r, ratio, [0.0, 0.0, 3.0 * r], [0.0; 3], 0.5, 0.0)
        + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0);
    resting(
        format!("stack 1:{ratio:e}"),
        &toml,
        solver,
        (1.0 + ratio) * G,
        true,
    )
}

/// A chain of six spheres, alternately of mass 1 and `ratio`, from a fixed
/// point, released horizontal, no contact: joint error and energy.
pub fn heavy_light_chain(ratio: f64, solver: SolverChoice) -> Outcome {
    let (link, r) = (0.2, 0.05);
    let mut toml = sim(1e-3, "sphere_contacts = false\n");
    for i in 0..6 {
        let m = if i % 2 == 0 { 1.0 } else { ratio };
        toml += &sphere(
            &format!("s{i}"),
            r,
            m,
            [link * (i + 1) as f64, 0.0, 0.0],
            [0.0; 3],
            0.0,
            0.0,
        );
    }
    for i in 0..6 {
        let a = if i == 0 {
            "world".to_string()
        } else {
            format!("s{}", i - 1)
        };
        toml += &joint(
            &format!("j{i}"),
            &a,
            &format!("s{i}"),
            [link * i as f64, 0.0, 0.0],
        );
    }
    let mut e = engine(&toml, solver);
    let scale: f64 = e
        .model()
        .bodies
        .iter()
        .zip(&e.state().bodies)
        .map(|(b, s)| b.mass * G * s.x.norm())
        .sum();
    let mut e0 = None;
    let mut rise: f64 = 0.0;
    let st = run(&mut e, 2000, |_, rep| {
        let e0 = *e0.get_or_insert(rep.energy.midpoint);
        rise = rise.max((rep.energy.midpoint - e0) / scale);
    });
    // The psi/h stabilisation may lift a bob by up to the joint error: the
    // midpoint energy may rise by sum m g |psi| (see tests/joints.rs).
    let lift =
        e.model().bodies.iter().map(|b| b.mass * G).sum::<f64>() * st.max_joint_error / scale;
    outcome(
        format!("chain 1:{ratio:e}"),
        solver,
        &st,
        &[
            (
                st.max_joint_error < 1e-3,
                format!("joint error {:.1e} m", st.max_joint_error),
            ),
            (
                rise <= lift + 1e-12,
                format!("energy rose by {rise:.1e} of sum m g L"),
            ),
        ],
        format!(
            "joint error {:.1e} m, energy rise {rise:.1e}",
            st.max_joint_error
        ),
    )
}

/// Five spheres dropped into a box of five planes that fits four of them
/// side by side, the fifth on top, 60 s: after settling (the last 30 s)
/// every speed stays below 1e-6 m/s and nothing creeps. (A sphere free to
/// roll on a flat floor rolls for ever without rolling resistance, in any
/// rigid-body engine; so the box holds the base.)
pub fn pile(solver: SolverChoice) -> Outcome {
    let (r, h) = (0.05, 1e-2);
    let half = 2.0 * r;
    let mut toml = sim(h, "friction_directions = 4\n")
        + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0)
        + &plane("x-", [1.0, 0.0, 0.0], [-half, 0.0, 0.0], 0.5, 0.0)
        + &plane("x+", [-1.0, 0.0, 0.0], [half, 0.0, 0.0], 0.5, 0.0)
        + &plane("y-", [0.0, 1.0, 0.0], [0.0, -half, 0.0], 0.5, 0.0)
        + &plane("y+", [0.0, -1.0, 0.0], [0.0, half, 0.0], 0.5, 0.0);
    let mut k = 0;
    for i in 0..2 {
        for j in 0..2 {
            // Dropped from different heights: they land one by one.
            let z = r + 0.01 + 0.02 * k as f64;
            toml += &sphere(
                &format!("b{k}"),
                r,
                0.1,
                [r * (2 * i - 1) as f64, r * (2 * j - 1) as f64, z],
                [0.0; 3],
                0.5,
                0.0,
            );
            k += 1;
        }
    }
    // Off centre by 3 mm: it has to find the pocket of the four below.
    toml += &sphere("top", r, 0.1, [0.003, -0.002, 0.3], [0.0; 3], 0.5, 0.0);
    let mut e = engine(&toml, solver);
    let steps = (60.0 / h) as u64;
    let settle = steps / 2;
    let mut at_settle = Vec::new();
    let mut speed: f64 = 0.0;
    let st = run(&mut e, steps, |e, rep| {
        if rep.step == settle {
            at_settle = starts(e);
        }
        if rep.step > settle {
            for b in &e.state().bodies {
                speed = speed.max(b.v.norm());
            }
        }
    });
    let creep = if at_settle.is_empty() {
        f64::NAN
    } else {
        drift(&e, &at_settle)
    };
    outcome(
        "pile of 5 in a box, 60 s".into(),
        solver,
        &st,
        &[
            (
                speed < 1e-6,
                format!("speed {speed:.1e} m/s after settling"),
            ),
            (creep < 1e-6, format!("creep {creep:.1e} m over 30 s")),
        ],
        format!("speed {speed:.1e} m/s, creep {creep:.1e} m (last 30 s)"),
    )
}

/// A sphere at 100 m/s into a plane at h = 1e-2: it must not tunnel.
pub fn high_speed(solver: SolverChoice) -> Outcome {
    let r = 0.1;
    let toml = sim(1e-2, "")
        + &sphere(
            "bullet",
            r,
            1.0,
            [0.0, 0.0, 0.55],
            [0.0, 0.0, -100.0],
            0.5,
            0.0,
        )
        + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0);
    let mut e = engine(&toml, solver);
    let mut lowest = f64::INFINITY;
    let st = run(&mut e, 100, |e, _| {
        lowest = lowest.min(e.state().bodies[0].x.z - r)
    });
    outcome(
        "100 m/s into a plane, h = 1e-2".into(),
        solver,
        &st,
        &[(
            lowest > -1e-9,
            format!("lowest point {lowest:.1e} m below the plane"),
        )],
        format!("lowest height {lowest:.1e} m"),
    )
}

/// Near-degenerate contact: a sphere resting in a crease of two planes at
/// 179 degrees, on three coincident planes, or exactly touching.
pub fn degenerate(kind: &str, solver: SolverChoice) -> Outcome {
    let r = 0.1;
    let half = 0.5f64.to_radians();
    let toml = match kind {
        "crease" => {
            sim(1e-3, "")
                + &sphere(
                    "ball",
                    r,
                    1.0,
                    [0.0, 0.0, r / half.cos()],
                    [0.0; 3],
                    0.5,
                    0.0,
                )
                + &plane("left", [half.sin(), 0.0, half.cos()], [0.0; 3], 0.5, 0.0)
                + &plane("right", [-half.sin(), 0.0, half.cos()], [0.0; 3], 0.5, 0.0)
        }
        "coincident" => {
            sim(1e-3, "")
                + &sphere("ball", r, 1.0, [0.0, 0.0, r], [0.0; 3], 0.5, 0.0)
                + &plane("floor1", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0)
                + &plane("floor2", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0)
                + &plane("floor3", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0)
        }
        _ => {
            // Exactly touching at rest, against a floor and a wall that it
            // touches without being pushed into it.
            sim(1e-3, "")
                + &sphere("ball", r, 1.0, [r, 0.0, r], [0.0; 3], 0.5, 0.0)
                + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0)
                + &plane("wall", [1.0, 0.0, 0.0], [0.0; 3], 0.5, 0.0)
        }
    };
    let name = match kind {
        "crease" => "crease of two planes at 179 deg",
        "coincident" => "three coincident contacts",
        _ => "exactly touching at rest (floor and wall)",
    };
    resting(name.into(), &toml, solver, G, false)
}

/// A sphere starting 5 mm inside a corner of three planes, with friction:
/// the step must recover (the overlap goes, the sphere is not launched).
pub fn overlap(solver: SolverChoice) -> Outcome {
    let r = 0.1;
    let c = r - 0.005;
    let toml = sim(1e-3, "")
        + &sphere("ball", r, 1.0, [c, c, c], [0.0; 3], 0.5, 0.0)
        + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0)
        + &plane("wall_x", [1.0, 0.0, 0.0], [0.0; 3], 0.5, 0.0)
        + &plane("wall_y", [0.0, 1.0, 0.0], [0.0; 3], 0.5, 0.0);
    let mut e = engine(&toml, solver);
    let mut late_pen: f64 = 0.0;
    let mut speed: f64 = 0.0;
    let st = run(&mut e, 1000, |e, rep| {
        if rep.step > 100 {
            late_pen = late_pen.max(rep.max_penetration);
        }
        speed = speed.max(e.state().bodies[0].v.norm());
    });
    let end = e.state().bodies[0].x;
    let off = (end - Vector3::new(r, r, r)).norm();
    outcome(
        "5 mm overlap in a corner, mu = 0.5".into(),
        solver,
        &st,
        &[
            (late_pen < 1e-6, format!("penetration {late_pen:.1e} m after 0.1 s")),
            (off < 1e-3, format!("ended {off:.1e} m from the corner's resting place")),
        ],
        format!("max speed {speed:.2} m/s, end {off:.1e} m from rest place, penetration after 0.1 s {late_pen:.1e} m"),
    )
}

/// Redundant joints: two joints on the same pair (same anchor, or two
/// anchors: a hinge), and a closed loop world-A-B-world.
pub fn redundant(kind: &str, solver: SolverChoice) -> Outcome {
    let r = 0.05;
    let base = sim(1e-3, "sphere_contacts = false\n")
        + &sphere("A", r, 1.0, [0.3, 0.0, 0.0], [0.0; 3], 0.0, 0.0)
        + &sphere("B", r, 1.0, [0.6, 0.0, 0.0], [0.0, 0.5, 0.0], 0.0, 0.0)
        + &joint("shoulder", "world", "A", [0.0; 3]);
    let toml = match kind {
        "same anchor" => {
            base + &joint("elbow", "A", "B", [0.3, 0.0, 0.0])
                + &joint("elbow2", "A", "B", [0.3, 0.0, 0.0])
        }
        "hinge" => {
            base + &joint("elbow", "A", "B", [0.45, 0.0, 0.0])
                + &joint("elbow2", "A", "B", [0.45, 0.1, 0.0])
        }
        _ => {
            base + &joint("elbow", "A", "B", [0.45, 0.0, 0.0])
                + &joint("back", "B", "world", [0.9, 0.0, 0.0])
        }
    };
    let mut e = engine(&toml, solver);
    let st = run(&mut e, 2000, |_, _| {});
    let name = match kind {
        "same anchor" => "two joints, same pair and anchor",
        "hinge" => "two joints, same pair, two anchors",
        _ => "closed loop world-A-B-world",
    };
    outcome(
        name.into(),
        solver,
        &st,
        &[(
            st.max_joint_error < 1e-3,
            format!("joint error {:.1e} m", st.max_joint_error),
        )],
        format!(
            "joint error {:.1e} m, {} regularised solves",
            st.max_joint_error, st.regularized
        ),
    )
}

/// The reference scene for `steps` steps: no failure, joints and energy
/// bounded.
pub fn long_run(steps: u64, solver: SolverChoice) -> Outcome {
    let mut scene = match cosim_shared::scenes::reference() {
        Ok(s) => s,
        Err(e) => panic!("built-in scene: {e}"),
    };
    scene.sim.solver = solver;
    let mut e = Engine::new(Model::from_scene(&scene));
    e.set_pgs_params(PgsParams::precise());
    let mut e0 = None;
    let mut emax = f64::NEG_INFINITY;
    let st = run(&mut e, steps, |_, rep| {
        e0.get_or_insert(rep.energy.midpoint);
        emax = emax.max(rep.energy.midpoint);
    });
    let rise = emax - e0.unwrap_or(emax);
    outcome(
        format!("reference scene, {steps} steps"),
        solver,
        &st,
        &[
            (
                st.max_joint_error < 1e-3,
                format!("joint error {:.1e} m", st.max_joint_error),
            ),
            // The torque on the shoulder does work: energy may rise by what
            // it puts in; bound it by a joule (the scene's scale is ~2 J).
            (
                rise < 1.0,
                format!("energy rose {rise:.2e} J above its start"),
            ),
        ],
        format!(
            "joint error {:.1e} m, penetration {:.1e} m, energy max - start {rise:.2e} J",
            st.max_joint_error, st.max_penetration
        ),
    )
}

/// Radii from 1 mm to 10 m in one scene, everything resting.
pub fn radii(solver: SolverChoice) -> Outcome {
    let toml = sim(1e-3, "")
        + &sphere("big", 10.0, 1000.0, [0.0, 0.0, 10.0], [0.0; 3], 0.5, 0.0)
        + &sphere("grain", 1e-3, 1e-3, [20.0, 0.0, 1e-3], [0.0; 3], 0.5, 0.0)
        + &sphere(
            "grain_on_top",
            1e-3,
            1e-3,
            [0.0, 0.0, 20.0 + 1e-3],
            [0.0; 3],
            0.5,
            0.0,
        )
        + &sphere("ball", 0.1, 1.0, [-15.0, 0.0, 0.1], [0.0; 3], 0.5, 0.0)
        + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0);
    let weight = (1000.0 + 2e-3 + 1.0) * G;
    resting("radii 1 mm to 10 m".into(), &toml, solver, weight, true)
}

/// Every case with `solver`; the long run with `long_steps` steps.
pub fn all(solver: SolverChoice, long_steps: u64) -> Vec<Outcome> {
    let mut v = Vec::new();
    for ratio in [1.0, 1e1, 1e2, 1e3, 1e4] {
        v.push(stack(ratio, solver));
    }
    for ratio in [1.0, 1e2, 1e4] {
        v.push(heavy_light_chain(ratio, solver));
    }
    v.push(pile(solver));
    v.push(high_speed(solver));
    for kind in ["crease", "coincident", "touching"] {
        v.push(degenerate(kind, solver));
    }
    v.push(overlap(solver));
    for kind in ["same anchor", "hinge", "loop"] {
        v.push(redundant(kind, solver));
    }
    v.push(radii(solver));
    v.push(long_run(long_steps, solver));
    v
}

/// The table of outcomes as Markdown.
pub fn table(outcomes: &[Outcome]) -> String {
    let mut s = String::from("| case | solver | result | worst figures | steps by solver | notes |\n|---|---|---|---|---|---|\n");
    for o in outcomes {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} |",
            o.case,
            o.solver.as_str(),
            if o.pass { "pass" } else { "**FAIL**" },
            o.figure,
            o.solvers,
            o.note
        );
    }
    s
}

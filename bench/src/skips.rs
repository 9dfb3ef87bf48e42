//! `cosim-server bench skips`: what each skip of the step saves, from the
//! step report's per-stage timings, with the skip on and off on the same
//! scene in one run, and how far apart the two trajectories end up (the
//! skips must not change the answer).

use cosim_engine::model::Params;
use cosim_engine::solver::PgsParams;
use cosim_engine::{Engine, Model, Timings};
use cosim_shared::{Scene, SolverChoice};
use std::fmt::Write as _;

const FRICTIONLESS: &str = include_str!("../../examples/scenes/frictionless.toml");
/// Two boxes stacked on a floor, the upper sliding, and a capsule rolling
/// into them: supports on several vertices and ends, faces clipped
/// between boxes (a small scene: the full LCP of shapes.toml holds 930
/// unknowns).
const STACK: &str = "[sim]\nname = \"stack\"\ndt = 0.001\nduration = 2.0\nfriction_directions = 8\nsolver = \"lemke\"\n\
[[body]]\nname = \"base\"\nhalf_extents = [0.12, 0.12, 0.06]\nmass = 2.0\nposition = [0.0, 0.0, 0.0605]\nfriction = 0.6\n\
[[body]]\nname = \"top\"\nhalf_extents = [0.08, 0.05, 0.05]\nmass = 0.5\nposition = [0.02, 0.01, 0.175]\n\
orientation = [0.9659258262890683, 0.0, 0.0, 0.25881904510252074]\nvelocity = [0.3, 0.0, 0.0]\nfriction = 0.6\n\
[[body]]\nname = \"roller\"\nradius = 0.04\nhalf_length = 0.1\nmass = 0.6\nposition = [0.4, 0.0, 0.04]\n\
orientation = [0.7071067811865476, 0.7071067811865476, 0.0, 0.0]\nvelocity = [-0.8, 0.0, 0.0]\n\
angular_velocity = [0.0, -20.0, 0.0]\nfriction = 0.5\n\
[[plane]]\nname = \"floor\"\nnormal = [0.0, 0.0, 1.0]\npoint = [0.0, 0.0, 0.0]\nfriction = 0.5\n";

/// Medians of the stage timings (s) over a run, and the positions of every
/// step.
pub struct Run {
    pub stages: Timings,
    pub positions: Vec<Vec<[f64; 3]>>,
    pub failures: usize,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// Runs `model` for `steps` steps.
pub fn run(model: Model, steps: u64) -> Run {
    let mut e = Engine::new(model);
    // The skips are compared at a tolerance far below the differences the
    // test allows.
    e.set_pgs_params(PgsParams::precise());
    let mut t: [Vec<f64>; 6] = Default::default();
    let mut positions = Vec::new();
    let mut failures = 0;
    for _ in 0..steps {
        let r = e.step();
        if r.error.is_some() {
            failures += 1;
            break;
        }
        let s = r.timings;
        for (v, x) in t.iter_mut().zip([
            s.collision,
            s.assemble,
            s.solve,
            s.integrate,
            s.measure,
            s.total,
        ]) {
            v.push(x);
        }
        positions.push(e.state().bodies.iter().map(|b| b.x.into()).collect());
    }
    let [a, b, c, d, f, g] = &mut t;
    Run {
        stages: Timings {
            collision: median(a),
            assemble: median(b),
            solve: median(c),
            integrate: median(d),
            measure: median(f),
            total: median(g),
        },
        positions,
        failures,
    }
}

/// Largest position difference between two runs over their common steps.
pub fn distance(a: &Run, b: &Run) -> f64 {
    a.positions
        .iter()
        .zip(&b.positions)
        .fold(0.0, |d, (xa, xb)| d.max(super::farthest(xa, xb)))
}

/// Largest difference of the new velocities (m/s, rad/s) over a run with
/// the skip on, when each step is also taken from the same state with the
/// skip off: whether the skip changes a step's answer, free of the
/// trajectory's chaos (a PGS run started differently drifts apart at the
/// solver's tolerance, and the reference scene amplifies that to O(1)).
/// Steps where either side stopped at the PGS iteration cap are not
/// compared (their answer is wherever the sweeps stopped) but counted.
pub fn per_step_difference(on: Model, off: Model, steps: u64) -> PerStep {
    let mut a = Engine::new(on);
    let mut b = Engine::new(off);
    a.set_pgs_params(PgsParams::precise());
    b.set_pgs_params(PgsParams::precise());
    let mut out = PerStep::default();
    for _ in 0..steps {
        b.set_state(a.state().clone());
        let (ra, rb) = (a.step(), b.step());
        if ra.error.is_some() || rb.error.is_some() {
            out.difference = f64::INFINITY;
            return out;
        }
        out.capped_on += usize::from(ra.not_converged);
        out.capped_off += usize::from(rb.not_converged);
        if ra.not_converged || rb.not_converged {
            continue;
        }
        for (x, y) in a.state().bodies.iter().zip(&b.state().bodies) {
            out.difference = out
                .difference
                .max((x.v - y.v).norm())
                .max((x.w - y.w).norm());
        }
    }
    out
}

/// See [`per_step_difference`].
#[derive(Debug, Clone, Copy, Default)]
pub struct PerStep {
    /// Largest velocity difference over the compared steps.
    pub difference: f64,
    /// Steps at the iteration cap with the skip on, and off.
    pub capped_on: usize,
    pub capped_off: usize,
}

/// One skip measured: the scene, the runs with it and without.
pub struct Measured {
    pub skip: &'static str,
    pub scene: &'static str,
    pub on: Run,
    pub off: Run,
    pub per_step: PerStep,
}

impl Measured {
    /// Runs `on` and `off` for `steps` steps, and `off` from each state of
    /// `on`.
    fn of(skip: &'static str, scene: &'static str, on: Model, off: Model, steps: u64) -> Measured {
        Measured {
            skip,
            scene,
            per_step: per_step_difference(on.clone(), off.clone(), steps),
            on: run(on, steps),
            off: run(off, steps),
        }
    }
}

fn model(scene: &Scene, solver: SolverChoice) -> Model {
    let mut s = scene.clone();
    s.sim.solver = solver;
    Model::from_scene(&s)
}

/// Spheres flying about in a closed box without gravity (seeded, 64
/// spheres of 3 to 6 cm at up to 2 m/s, mu = 0.3, e = 0.5): a few touch at a
/// time, so that listing every pair (2,016) against those within reach is
/// what the broad phase saves.
pub fn gas() -> Result<Scene, String> {
    use crate::text::{plane, sphere};
    let mut rng = crate::robust::Rng::new(14);
    let mut t = String::from(
        "[sim]\nname = \"gas\"\ndt = 0.002\nsteps = 1000\ngravity = [0.0, 0.0, 0.0]\nfriction_directions = 4\nsolver = \"lemke\"\n\n",
    );
    for (i, n) in [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ]
    .into_iter()
    .enumerate()
    {
        let point = [-0.5 * n[0], -0.5 * n[1], -0.5 * n[2]];
        t += &plane(&format!("wall{i}"), n, point, 0.3, 0.5);
    }
    // A 4 x 4 x 4 lattice 0.2 m apart, so that nothing starts overlapping.
    for i in 0..64usize {
        let x = [
            -0.3 + 0.2 * (i % 4) as f64,
            -0.3 + 0.2 * (i / 4 % 4) as f64,
            -0.3 + 0.2 * (i / 16) as f64,
        ];
        let mut v = || rng.range(-2.0, 2.0);
        let vel = [v(), v(), v()];
        let r = rng.range(0.03, 0.06);
        t += &sphere(&format!("s{i}"), r, 1.0, x, vel, 0.3, 0.5);
    }
    Scene::parse(&t, "<gas>").map_err(|e| e.to_string())
}

/// The skips on their scenes: pruning, Lemke's support guess and PGS's
/// warm start on the reference scene, friction rows on the frictionless
/// scene, the broad phase on [`gas`].
pub fn measure(steps: u64) -> Result<Vec<Measured>, String> {
    let reference = cosim_shared::scenes::reference().map_err(|e| e.to_string())?;
    let frictionless =
        Scene::parse(FRICTIONLESS, "frictionless.toml").map_err(|e| e.to_string())?;
    let gas = gas()?;
    let shapes = Scene::parse(STACK, "stack").map_err(|e| e.to_string())?;
    // Each skip: its scene and solver, and how to switch it off.
    type Off = fn(&mut Params);
    let cases: [(&'static str, &'static str, &Scene, SolverChoice, Off); 8] = [
        (
            "broad phase (sphere pairs within reach)",
            "gas of 64 spheres, Lemke",
            &gas,
            SolverChoice::Lemke,
            |p| p.skips.broad_phase = false,
        ),
        (
            "broad phase (boxes and capsules: bounding spheres)",
            "stack of boxes, Lemke",
            &shapes,
            SolverChoice::Lemke,
            |p| p.skips.broad_phase = false,
        ),
        (
            "pruning (boxes and capsules)",
            "stack of boxes, Lemke",
            &shapes,
            SolverChoice::Lemke,
            |p| p.full = true,
        ),
        (
            "pruning (contacts that cannot close)",
            "reference, Lemke",
            &reference,
            SolverChoice::Lemke,
            |p| p.full = true,
        ),
        (
            "pruning with PGS (distance rule)",
            "reference, PGS",
            &reference,
            SolverChoice::Pgs,
            |p| p.full = true,
        ),
        (
            "no friction rows where mu = 0",
            "frictionless, Lemke",
            &frictionless,
            SolverChoice::Lemke,
            |p| p.skips.frictionless_rows = false,
        ),
        (
            "Lemke starts from the last support",
            "reference, Lemke",
            &reference,
            SolverChoice::Lemke,
            |p| p.skips.lemke_guess = false,
        ),
        (
            "PGS warm start",
            "reference, PGS",
            &reference,
            SolverChoice::Pgs,
            |p| p.skips.warm_start = false,
        ),
    ];
    let out = cases
        .into_iter()
        .map(|(skip, on_scene, scene, solver, switch_off)| {
            let on = model(scene, solver);
            let mut off = on.clone();
            switch_off(&mut off.params);
            Measured::of(skip, on_scene, on, off, steps)
        })
        .collect();
    Ok(out)
}

fn us(x: f64) -> String {
    format!("{:.2}", x * 1e6)
}

/// The table: median microseconds per stage with the skip on / off.
pub fn table(ms: &[Measured], steps: u64) -> String {
    let mut s = format!(
        "| skip | scene ({steps} steps) | collision | assemble | solve | total | saved | trajectories apart (m) | one step apart (m/s) | steps at the PGS cap, on / off |\n|---|---|---|---|---|---|---|---|---|---|\n"
    );
    for m in ms {
        let (a, b) = (&m.on.stages, &m.off.stages);
        let _ = writeln!(
            s,
            "| {} | {} | {} / {} | {} / {} | {} / {} | {} / {} | {:.0} % | {:.1e}{} | {:.1e} | {} / {} |",
            m.skip,
            m.scene,
            us(a.collision),
            us(b.collision),
            us(a.assemble),
            us(b.assemble),
            us(a.solve),
            us(b.solve),
            us(a.total),
            us(b.total),
            100.0 * (1.0 - a.total / b.total),
            distance(&m.on, &m.off),
            if m.on.failures + m.off.failures > 0 { " (a run failed)" } else { "" },
            m.per_step.difference,
            m.per_step.capped_on,
            m.per_step.capped_off
        );
    }
    s
}

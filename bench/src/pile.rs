//! The pile of issue 14: N spheres (r = 0.05 m, m = 1 kg, mu = 0.5) on a
//! grid 0.12 m apart with 1 cm of seeded jitter, dropped into a box of a
//! floor and four walls. For N = 100 it is the 5 x 5 x 4 grid in
//! walls 0.35 m from the centre; a larger N is a cube of spheres (10 x 10 x
//! 10 at 1,000, the issue's) or, with [`Shape::Layers`], a square of that
//! many layers that widens with N, and the walls 0.05 m outside it.

use crate::robust::Rng;
use crate::text::{joint, plane, sphere};
use cosim_engine::solver::PgsParams;
use cosim_shared::scene::SleepDesc;
use cosim_shared::{Scene, SolverChoice};

/// Sphere radius (m) of the pile.
pub const RADIUS: f64 = 0.05;

/// How a pile of more than 100 spheres is laid out.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Shape {
    /// Layers about as many as the side (10 x 10 x 10 for 1,000): the pile
    /// grows taller with N, and so does the path its load takes.
    #[default]
    Cube,
    /// This many layers (at least one), the square widening with N: a pile
    /// as tall at every N, which separates the cost of N from that of
    /// height (a tall pile needs more sweeps to the same tolerance).
    Layers(usize),
}

impl Shape {
    /// The grid of `n` spheres: side of the square layer and the layer count.
    fn grid(self, n: usize) -> (usize, usize) {
        if n <= 100 && self == Shape::Cube {
            return (5, n.div_ceil(25));
        }
        let side = match self {
            Shape::Cube => (n as f64).cbrt().ceil() as usize,
            Shape::Layers(l) => (n as f64 / l.max(1) as f64).sqrt().ceil() as usize,
        }
        .max(1);
        (side, n.div_ceil(side * side))
    }

    /// The pile's half width: the walls' distance from the centre (m).
    pub fn half_width(self, n: usize) -> f64 {
        let (side, _) = self.grid(n);
        if n <= 100 && self == Shape::Cube {
            0.35
        } else {
            0.5 * 0.12 * side as f64 + 0.05
        }
    }
}

impl std::fmt::Display for Shape {
    /// As the tables name it: `cubes`, `10 layers`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Shape::Cube => write!(f, "cubes"),
            Shape::Layers(l) => write!(f, "{l} layers"),
        }
    }
}

/// The cube pile's half width: the walls' distance from the centre (m).
pub fn half_width(n: usize) -> f64 {
    Shape::Cube.half_width(n)
}

/// The stopping rule's tolerance (m/s) the pile runs at: the scene
/// default (`cosim_shared::DEFAULT_PGS_TOLERANCE`, the residual rule),
/// which was chosen on this pile.
pub const TOLERANCE: f64 = cosim_shared::DEFAULT_PGS_TOLERANCE;

/// The pile's rule at `tolerance` as the engine takes it ([`TOLERANCE`]
/// in the pile scene; `bench pile --velocity-tolerance` and the peers
/// bench's other points).
pub fn pgs(tolerance: f64) -> PgsParams {
    PgsParams {
        stop: cosim_shared::PgsStop::Residual,
        velocity_tolerance: tolerance,
        ..PgsParams::default()
    }
}

/// The scene text of a pile of `n` spheres, with step `dt` and friction
/// directions `nd`, solver `solver` (`"pgs"`, `"lemke"`, `"auto"`).
pub fn text(n: usize, dt: f64, nd: usize, solver: &str, steps: u64, seed: u64) -> String {
    text_shaped(
        n,
        Shape::Cube,
        dt,
        nd,
        solver,
        steps,
        seed,
        SleepDesc::default(),
    )
}

/// [`text`] laid out as `shape` says, with sleeping as `sleep` says. What
/// is at its default is left out of the text, as a user writes a scene.
#[allow(clippy::too_many_arguments)]
pub fn text_shaped(
    n: usize,
    shape: Shape,
    dt: f64,
    nd: usize,
    solver: &str,
    steps: u64,
    seed: u64,
    sleep: SleepDesc,
) -> String {
    let (side, _) = shape.grid(n);
    let w = shape.half_width(n);
    let mut rng = Rng::new(seed);
    let mut t = format!(
        "[sim]\nname = \"pile-{n}\"\ndt = {dt:e}\nsteps = {steps}\nfriction_directions = {nd}\n"
    );
    if solver != SolverChoice::default().as_str() {
        t += &format!("solver = \"{solver}\"\n");
    }
    t += "\n";
    if !sleep.enabled {
        t += "[sim.sleep]\nenabled = false\n\n";
    } else if sleep != SleepDesc::default() {
        t += &format!(
            "[sim.sleep]\nafter = {:e}\nlinear_speed = {:e}\nangular_speed = {:e}\n\n",
            sleep.after, sleep.linear_speed, sleep.angular_speed
        );
    }
    t += &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0);
    for (i, (nx, ny)) in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)]
        .into_iter()
        .enumerate()
    {
        t += &plane(
            &format!("wall{i}"),
            [nx, ny, 0.0],
            [-w * nx, -w * ny, 0.0],
            0.5,
            0.0,
        );
    }
    let origin = -0.5 * 0.12 * (side as f64 - 1.0);
    for i in 0..n {
        let (ix, iy, iz) = (i % side, i / side % side, i / (side * side));
        let mut jitter = || rng.range(-0.01, 0.01);
        let x = [
            origin + 0.12 * ix as f64 + jitter(),
            origin + 0.12 * iy as f64 + jitter(),
            RADIUS + 0.02 + 0.12 * iz as f64 + jitter().abs(),
        ];
        t += &sphere(&format!("s{i}"), RADIUS, 1.0, x, [0.0; 3], 0.5, 0.0);
    }
    t
}

/// [`text`] parsed.
pub fn scene(n: usize, dt: f64, nd: usize, solver: &str, steps: u64, seed: u64) -> Scene {
    Scene::parse(&text(n, dt, nd, solver, steps, seed), "<pile>")
        .unwrap_or_else(|e| panic!("the pile scene is valid: {e}"))
}

/// Sleeping at `LINEAR,ANGULAR` (m/s, rad/s, both positive), `after` at
/// its default: the `--sleep-speeds` options of `bench pile` and of the
/// peers' pile.
pub fn sleep_speeds(s: &str) -> Result<SleepDesc, String> {
    let parse = |t: &str| match t.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("`{t}` is not a positive speed")),
    };
    match s.split(',').collect::<Vec<_>>()[..] {
        [l, a] => Ok(SleepDesc {
            linear_speed: parse(l)?,
            angular_speed: parse(a)?,
            ..Default::default()
        }),
        _ => Err(format!("`{s}` is not LINEAR,ANGULAR")),
    }
}

/// How a pile is run (`bench pile`'s options).
#[derive(Debug, Clone)]
pub struct Settings {
    pub dt: f64,
    pub steps: u64,
    pub solver: String,
    pub pgs: PgsParams,
    pub seed: u64,
    /// Print every `trace`-th step's report (0: none).
    pub trace: u64,
    /// Sleeping (`[sim.sleep]`): on at its defaults unless set.
    pub sleep: SleepDesc,
    pub shape: Shape,
    /// A pendulum swings above the pile ([`pendulum`]): a body that never
    /// sleeps beside a pile that does, as a robot's links beside a heap.
    pub pendulum: bool,
}

/// A sphere of the pile's size on a spherical joint 6 m above the floor's
/// centre, 0.5 m below it and swinging at 0.5 m/s: it never reaches the
/// pile (the cube of 10,000 is 22 layers, about 2.7 m tall) and, on a
/// joint, never sleeps.
pub fn pendulum() -> String {
    let bob = sphere(
        "bob",
        RADIUS,
        1.0,
        [0.0, 0.0, 5.5],
        [0.5, 0.0, 0.0],
        0.5,
        0.0,
    );
    bob + &joint("pivot", "world", "bob", [0.0, 0.0, 6.0])
}

/// One pile run's figures (`bench pile`).
#[derive(Debug, Clone, Default)]
pub struct Outcome {
    pub n: usize,
    pub steps: u64,
    /// Steps that failed (the run stops at the first).
    pub failed: u64,
    /// Steps whose solve stopped at the iteration cap.
    pub capped: u64,
    /// Median and total wall time of a step (s).
    pub median_step: f64,
    pub total: f64,
    /// Median and largest solver work per step (sweeps or pivots).
    pub median_work: usize,
    pub max_work: usize,
    /// Largest overlap of two spheres or a sphere and a wall over the run (m).
    pub worst_overlap: f64,
    /// Spheres outside the box at the end.
    pub escaped: usize,
    /// Kinetic energy at the end (J).
    pub kinetic: f64,
    /// The largest body speed at the end (m/s): what keeps a pile's one
    /// island awake when it is above the sleeping threshold.
    pub max_speed: f64,
    /// The state's heap bytes per body at the end.
    pub state_bytes_per_body: f64,
    /// Bodies asleep at the end.
    pub asleep: usize,
    /// Steps that projected contacts out of deep penetration
    /// (`engine::integrate::project`): none in a pile that runs as it should.
    pub projecting: u64,
}

/// Runs the pile of `n` spheres as `settings` say.
pub fn run(n: usize, settings: &Settings) -> Outcome {
    use cosim_engine::{Engine, Model};
    let Settings {
        dt,
        steps,
        ref solver,
        pgs,
        seed,
        trace,
        sleep,
        shape,
        pendulum,
    } = *settings;
    let mut text = text_shaped(n, shape, dt, 4, solver, steps, seed, sleep);
    if pendulum {
        text += &self::pendulum();
    }
    let scene =
        Scene::parse(&text, "<pile>").unwrap_or_else(|e| panic!("the pile scene is valid: {e}"));
    let mut e = Engine::new(Model::from_scene(&scene));
    e.set_pgs_params(pgs);
    let mut times = Vec::with_capacity(steps as usize);
    let mut work = Vec::with_capacity(steps as usize);
    let mut out = Outcome {
        n,
        steps,
        ..Outcome::default()
    };
    for k in 0..steps {
        let r = e.step();
        if trace > 0 && (k % trace == 0 || r.error.is_some()) {
            eprintln!(
                "pile {n} step {k}: {:.2} ms, {} {} work, residual {:.1e}, lcp {}, active {}, islands {} (lemke {}, pgs {}, largest {} bodies), pen {:.2e} m, projected {}, resolves {}, left out {}, fallback {:?}, refused {}, ke {:.3e}, asleep {}, {} (ms: collision {:.2}, assemble {:.2}, solve {:.2}, integrate {:.2}, measure {:.2})",
                r.timings.total * 1e3,
                r.solver,
                r.pivots,
                r.residual,
                r.lcp_size,
                r.active_contacts,
                r.islands,
                r.lemke_islands,
                r.pgs_islands,
                r.largest_island,
                r.max_penetration,
                r.projected,
                r.resolves,
                r.left_out,
                r.fallback,
                r.energy_refused,
                r.energy.kinetic,
                r.sleeping,
                r.status(),
                r.timings.collision * 1e3,
                r.timings.assemble * 1e3,
                r.timings.solve * 1e3,
                r.timings.integrate * 1e3,
                r.timings.measure * 1e3,
            );
        }
        if r.error.is_some() {
            out.failed += 1;
            break;
        }
        out.capped += u64::from(r.not_converged);
        out.projecting += u64::from(r.projected > 0);
        times.push(r.timings.total);
        work.push(r.pivots);
        out.worst_overlap = out.worst_overlap.max(r.max_penetration);
        out.kinetic = r.energy.kinetic;
        out.asleep = r.sleeping;
    }
    out.total = times.iter().sum();
    times.sort_by(f64::total_cmp);
    out.median_step = times.get(times.len() / 2).copied().unwrap_or(0.0);
    work.sort_unstable();
    out.median_work = work.get(work.len() / 2).copied().unwrap_or(0);
    out.max_work = work.last().copied().unwrap_or(0);
    let w = shape.half_width(n);
    out.escaped = e
        .state()
        .bodies
        .iter()
        .filter(|b| b.x.x.abs() > w || b.x.y.abs() > w || b.x.z < 0.0)
        .count();
    out.state_bytes_per_body = e.state().heap_bytes() as f64 / n as f64;
    out.max_speed = e
        .state()
        .bodies
        .iter()
        .map(|b| b.v.norm())
        .fold(0.0, f64::max);
    out
}

/// The table of [`run`]s.
pub fn table(rows: &[Outcome], settings: &Settings) -> String {
    let (dt, solver) = (settings.dt, &settings.solver);
    let (stop, tol) = (settings.pgs.stop, settings.pgs.velocity_tolerance);
    let s = settings.sleep;
    let sleep = match s.enabled {
        true => format!(
            "sleeping on ({} m/s, {} rad/s, {} s)",
            s.linear_speed, s.angular_speed, s.after
        ),
        false => "sleeping off".into(),
    };
    let shape = settings.shape;
    let pendulum = match settings.pendulum {
        true => ", a pendulum swinging above (not in N; its energy in KE end)",
        false => "",
    };
    let mut t = format!(
        "Pile of spheres (r = {RADIUS} m, mu = 0.5; {shape}), h = {dt}, n_d = 4, solver {solver} \
         (PGS: {stop:?} rule at {tol:e} m/s), {sleep}{pendulum}.\n\n\
         | N | steps | failed | at cap | ms/step (median) | s total | work (median / max) | worst overlap (mm) | escaped | KE end (J) | max speed end (m/s) | asleep | state B/body |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    );
    for o in rows {
        t += &format!(
            "| {} | {} | {} | {} | {:.3} | {:.2} | {} / {} | {:.3} | {} | {:.2e} | {:.1e} | {} | {:.0} |\n",
            o.n,
            o.steps,
            o.failed,
            o.capped,
            o.median_step * 1e3,
            o.total,
            o.median_work,
            o.max_work,
            o.worst_overlap * 1e3,
            o.escaped,
            o.kinetic,
            o.max_speed,
            o.asleep,
            o.state_bytes_per_body
        );
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_layered_pile_is_as_tall_at_every_size() {
        for n in [100usize, 1000, 4000, 10_000] {
            let (side, layers) = Shape::Layers(10).grid(n);
            assert!(side * side * layers >= n && side * side * (layers - 1) < n);
            assert!(layers <= 10, "{n}: {layers} layers");
        }
        assert_eq!(Shape::Layers(10).grid(1000), Shape::Cube.grid(1000));
        assert_eq!(Shape::Layers(10).grid(4000), (20, 10));
    }

    #[test]
    fn the_pile_starts_inside_its_box_without_overlaps() {
        for (n, shape) in [
            (100usize, Shape::Cube),
            (1000, Shape::Cube),
            (4000, Shape::Cube),
            (100, Shape::Layers(3)),
            (4000, Shape::Layers(10)),
        ] {
            let text = text_shaped(n, shape, 0.01, 4, "pgs", 10, 1, SleepDesc::off());
            let s = Scene::parse(&text, "<pile>").expect("valid");
            assert_eq!(s.bodies.len(), n);
            let w = shape.half_width(n);
            let x: Vec<[f64; 3]> = s.bodies.iter().map(|b| b.position).collect();
            for p in &x {
                assert!(
                    p[0].abs() + RADIUS < w && p[1].abs() + RADIUS < w,
                    "{n}: {p:?}"
                );
                assert!(p[2] > RADIUS, "{n}: {p:?}");
            }
            // Neighbours on the grid are 0.12 m apart, less 2 cm of jitter.
            for (i, a) in x.iter().enumerate() {
                for b in &x[i + 1..] {
                    let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2))
                        .sqrt();
                    assert!(d > 2.0 * RADIUS, "{n}: spheres {d} m apart");
                }
            }
        }
    }
}

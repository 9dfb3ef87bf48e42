//! Helpers shared by the end-to-end physics tests in `tests/tests/`.

use cosim_server::engine::{Engine, Model, StepReport};
use cosim_shared::Scene;

/// An engine on a scene given as TOML text; panics with the validation
/// message if the test's own scene is wrong.
pub fn engine(toml: &str) -> Engine {
    let scene = Scene::parse(toml, "<test scene>").unwrap_or_else(|e| panic!("{e}"));
    Engine::new(Model::from_scene(&scene))
}

/// Steps `n` times, handing each report to `check`; panics on a failed step.
pub fn run(engine: &mut Engine, n: u64, mut check: impl FnMut(&Engine, &StepReport)) {
    for _ in 0..n {
        let r = engine.step();
        if let Some(e) = r.error {
            panic!("step {} failed: {e}", r.step);
        }
        check(engine, &r);
    }
}

/// The solver the analytic tests run with: `lemke` unless the environment
/// variable `COSIM_TEST_SOLVER` names another (`.ci/run` runs them with
/// `pgs` too).
pub fn solver() -> String {
    std::env::var("COSIM_TEST_SOLVER").unwrap_or_else(|_| "lemke".into())
}

/// `[sim]` header with the given step and gravity.
/// With `pgs`, the distance rule at 1e-6 m/s (not the default residual
/// rule at 1e-2, a pile's): the analytic tolerances are Lemke's.
pub fn sim(dt: f64, steps: u64, gravity: [f64; 3]) -> String {
    let solver = solver();
    let pgs = if solver == "pgs" {
        "pgs = { stop = \"distance\", tolerance = 1e-6 }\n"
    } else {
        ""
    };
    format!(
        "[sim]\ndt = {dt:e}\nsteps = {steps}\ngravity = [{:e}, {:e}, {:e}]\nfriction_directions = 8\nsolver = \"{solver}\"\n{pgs}",
        gravity[0], gravity[1], gravity[2]
    )
}

/// Scene text: `[[body]]` spheres, `[[plane]]`s, spherical `[[joint]]`s
/// (the benchmarks' helpers).
pub use cosim_bench::text::{capsule, cuboid, joint, plane, sphere};

/// A `[[joint]]` of any type, with its axis where it has one.
pub fn joint_of(
    kind: &str,
    name: &str,
    a: &str,
    b: &str,
    anchor: [f64; 3],
    axis: Option<[f64; 3]>,
) -> String {
    let mut s = format!(
        "[[joint]]\nname = \"{name}\"\ntype = \"{kind}\"\nbody_a = \"{a}\"\nbody_b = \"{b}\"\nanchor = [{:e}, {:e}, {:e}]\n",
        anchor[0], anchor[1], anchor[2]
    );
    if let Some(u) = axis {
        s += &format!("axis = [{:e}, {:e}, {:e}]\n", u[0], u[1], u[2]);
    }
    s
}

pub const G: f64 = 9.81;

/// The text of a scene shipped in `examples/scenes/`.
pub fn shipped_scene(name: &str) -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples/scenes")
        .join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The momenta of a run of spheres in zero gravity, watched step by step
/// against what a joint's drift explains: a joint's anchor rows put `+p`
/// and `-p` on its two bodies at their own anchors, `psi` apart, a moment
/// `psi x p`, so over the run `|L - L_0| <= sum |psi| |p|` (the drift at
/// each step's start, the step's anchor impulse); every other impulse
/// of a joint, limit or motor is internal and moves neither momentum.
pub struct Momenta {
    p0: nalgebra::Vector3<f64>,
    l0: nalgebra::Vector3<f64>,
    psi: f64,
    /// `sum |psi| |p|` so far (N m s).
    pub moments: f64,
    /// The largest change of the linear momentum (N s), and of the
    /// angular one beyond `moments` (N m s).
    pub dp: f64,
    pub dl: f64,
}

impl Momenta {
    /// Linear and angular momentum (about the origin) of `e`'s bodies;
    /// spheres, whose inertia is the same in every frame.
    pub fn of(e: &Engine) -> (nalgebra::Vector3<f64>, nalgebra::Vector3<f64>) {
        let (mut p, mut l) = (nalgebra::Vector3::zeros(), nalgebra::Vector3::zeros());
        for (b, st) in e.model().bodies.iter().zip(&e.state().bodies) {
            p += st.v * b.mass;
            l += st.x.cross(&(st.v * b.mass)) + b.inertia * st.w;
        }
        (p, l)
    }

    /// Starts watching from `e`'s state (its drift: zero).
    pub fn start(e: &Engine) -> Momenta {
        let (p0, l0) = Momenta::of(e);
        Momenta {
            p0,
            l0,
            psi: 0.0,
            moments: 0.0,
            dp: 0.0,
            dl: 0.0,
        }
    }

    /// After a step with report `r` (the drift it ends with starts the
    /// next); the scene's first joint's anchor impulse.
    pub fn after_step(&mut self, e: &Engine, r: &StepReport) {
        let (p, l) = Momenta::of(e);
        let anchor = e
            .impulses()
            .iter()
            .find(|i| i.kind == cosim_server::engine::ImpulseKind::Joint)
            .map_or(0.0, |i| i.impulse.norm());
        self.moments += self.psi * anchor;
        self.psi = r.max_joint_error;
        self.dp = self.dp.max((p - self.p0).norm());
        self.dl = self.dl.max((l - self.l0).norm() - self.moments);
    }
}

/// A car: a 1 kg sphere (r = 0.05 m) at (0, 0, 1) on a level rail along
/// x from the world (prismatic joint `rail`), under gravity, with `extra`
/// lines added to the joint (a force, a range, a motor).
pub fn rail_car(h: f64, steps: u64, extra: &str) -> Engine {
    let mut s = sim(h, steps, [0.0, 0.0, -G]);
    s += &sphere("car", 0.05, 1.0, [0.0, 0.0, 1.0], [0.0; 3], 0.0, 0.0);
    s += &joint_of(
        "prismatic",
        "rail",
        "world",
        "car",
        [0.0, 0.0, 1.0],
        Some([1.0, 0.0, 0.0]),
    );
    s += extra;
    engine(&s)
}

/// Two free spheres in zero gravity on a hinge about z at A's centre (the
/// origin; `collide = false`): A of 2 kg, B of 1 kg 0.2 m along x,
/// turning about the hinge at `spin` rad/s (its centre moving at `0.2
/// spin` along y), with `extra` lines added to the joint.
pub fn elbow_pair(h: f64, steps: u64, spin: f64, extra: &str) -> Engine {
    let mut s = sim(h, steps, [0.0; 3]);
    s += &sphere("a", 0.05, 2.0, [0.0; 3], [0.0; 3], 0.0, 0.0);
    s += &sphere(
        "b",
        0.05,
        1.0,
        [0.2, 0.0, 0.0],
        [0.0, 0.2 * spin, 0.0],
        0.0,
        0.0,
    );
    s += &format!("angular_velocity = [0.0, 0.0, {spin:e}]\n");
    s += &joint_of(
        "revolute",
        "elbow",
        "a",
        "b",
        [0.0; 3],
        Some([0.0, 0.0, 1.0]),
    );
    s += "collide = false\n";
    s += extra;
    engine(&s)
}

/// The standard output of `python3 args` (with the `mujoco` package that
/// scripts/test.sh installs), run in a temporary folder: MuJoCo writes
/// its warnings to MUJOCO_LOG.TXT in the working folder. Panics with its
/// error output if it fails.
pub fn mujoco_python<I, S>(args: I) -> String
where
    I: IntoIterator<Item = S>,
    S: AsRef<std::ffi::OsStr>,
{
    let out = std::process::Command::new("python3")
        .current_dir(std::env::temp_dir())
        .args(args)
        .output()
        .expect("python3 with the mujoco package (scripts/test.sh installs it)");
    assert!(
        out.status.success(),
        "python3: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The coordinate and rate of the hinge or slider named `name`.
pub fn coordinate_of(e: &Engine, name: &str) -> (f64, f64) {
    let j = e
        .model()
        .joints
        .iter()
        .find(|j| j.name == name)
        .unwrap_or_else(|| panic!("no joint {name:?}"));
    cosim_server::engine::constraint::joint::coordinate(j, e.state()).expect("a hinge or slider")
}

/// The level pendulum's hinge (`level_pendulum`), its lines to follow.
pub fn pivot() -> String {
    joint_of(
        "revolute",
        "pivot",
        "world",
        "bob",
        [0.0, 0.0, 1.0],
        Some([0.0, 1.0, 0.0]),
    )
}

/// A pendulum hinged to the world about y at (0, 0, 1), its bob (1 kg, r
/// = 0.05 m) 0.5 m along x, level at the start (a positive angle swings
/// it down) and turning at `w0` rad/s, with `extra` lines added to the
/// joint (`pivot`).
pub fn level_pendulum(h: f64, steps: u64, gravity: [f64; 3], w0: f64, extra: &str) -> Engine {
    let l = 0.5;
    let mut s = sim(h, steps, gravity);
    s += &sphere(
        "bob",
        0.05,
        1.0,
        [l, 0.0, 1.0],
        [0.0, 0.0, -w0 * l],
        0.0,
        0.0,
    );
    s += &format!("angular_velocity = [0.0, {w0:e}, 0.0]\n");
    s += &pivot();
    s += extra;
    engine(&s)
}

/// What a run of a robot of a corpus found.
pub struct CorpusRun {
    pub steps: u64,
    /// The first failed step's error, if one failed (the run stops there).
    pub failed: Option<String>,
    pub penetration: f64,
    pub joint_error: f64,
    /// The most the total energy rose above the start's (J).
    pub gain: f64,
}

/// Runs `model` for `steps` steps, stopping at a failed one.
pub fn corpus_run(model: cosim_server::engine::Model, steps: u64) -> CorpusRun {
    let mut e = Engine::new(model);
    let e0 = cosim_server::engine::measure::energy(e.model(), e.state()).total;
    let mut r = CorpusRun {
        steps: 0,
        failed: None,
        penetration: 0.0,
        joint_error: 0.0,
        gain: 0.0,
    };
    for _ in 0..steps {
        let s = e.step();
        r.steps += 1;
        if let Some(err) = s.error {
            r.failed = Some(format!("{err:?}"));
            break;
        }
        r.penetration = r.penetration.max(s.max_penetration);
        r.joint_error = r.joint_error.max(s.max_joint_error);
        r.gain = r.gain.max(s.energy.total - e0);
    }
    r
}

/// Asserts `robust::check`'s bounds on a run: no failed step, no step's
/// kinetic energy over its free motion's plus its declared allowance, the
/// midpoint energy within the start's plus the inputs' work, no body
/// faster than that allows (`what` names the run in a failure).
pub fn assert_within_bounds(c: &cosim_bench::robust::Check, what: &str) {
    assert_eq!(c.failures, 0, "{what}: {:?}", c.first_failure);
    assert!(
        c.kinetic <= 0.0,
        "{what}: a step gained {} J over its bound",
        c.kinetic
    );
    assert!(
        c.energy <= 0.0,
        "{what}: midpoint energy {} J over its bound",
        c.energy
    );
    assert!(
        c.speed <= 0.0,
        "{what}: a body {} m/s faster than its bound",
        c.speed
    );
}

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
pub fn sim(dt: f64, steps: u64, gravity: [f64; 3]) -> String {
    format!(
        "[sim]\ndt = {dt:e}\nsteps = {steps}\ngravity = [{:e}, {:e}, {:e}]\nfriction_directions = 8\nsolver = \"{}\"\n",
        gravity[0], gravity[1], gravity[2], solver()
    )
}

/// Scene text: `[[body]]` spheres, `[[plane]]`s, spherical `[[joint]]`s
/// (the benchmarks' helpers).
pub use cosim_server::bench::text::{joint, plane, sphere};

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

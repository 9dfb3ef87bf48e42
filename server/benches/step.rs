//! Per-step time of the reference scene with each solver (h = 1e-3, n_d =
//! 8): `cargo bench -p cosim-server --bench step`. The engine steps on
//! through the 10 s trajectory (flight, impacts, resting contact), restarting
//! from the initial state every 10,000 steps, so that PGS keeps its warm
//! start as in a real run.

use cosim_server::engine::{Engine, Model};
use cosim_server::scenes;
use cosim_shared::SolverChoice;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

fn step(c: &mut Criterion) {
    let scene = scenes::reference().expect("built-in scene");
    let mut group = c.benchmark_group("reference_step");
    for solver in [SolverChoice::Lemke, SolverChoice::Pgs] {
        let mut model = Model::from_scene(&scene);
        model.params.solver = solver;
        let mut engine = Engine::new(model);
        let initial = engine.state().clone();
        group.bench_function(solver.as_str(), |b| {
            b.iter(|| {
                if engine.state().step >= 10_000 {
                    engine.set_state(initial.clone());
                }
                black_box(engine.step())
            })
        });
    }
    group.finish();
}

criterion_group!(benches, step);
criterion_main!(benches);

//! Per-step time of the reference scene with each solver (h = 1e-3, n_d =
//! 8): `cargo bench -p cosim-server --bench step`. The engine steps on
//! through the 10 s trajectory (flight, impacts, resting contact), restarting
//! from the initial state every 10,000 steps, so that PGS keeps its warm
//! start as in a real run.

use cosim_server::engine::{Engine, Model};
use cosim_shared::scenes;
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

/// One criterion benchmark per stage of the step as the lockstep server
/// runs it, on states of the reference run with contacts active (steps 300,
/// 700, 1500): `prepare` (detection, contact set, inverse masses, and the
/// mLCP's matrix for the contacts the held inputs select: the part that
/// overlaps the controllers), the LCP solve alone (Lemke on the step's
/// reduced LCP), and the rest of the step (`finish`: applied impulses,
/// pruning, the right-hand side on prepare's matrix, solve, recovery,
/// integration, measurements). `bench skips` shows what each skip saves
/// from the step reports.
fn stages(c: &mut Criterion) {
    let scene = scenes::reference().expect("built-in scene");
    let mut engine = Engine::new(Model::from_scene(&scene));
    let mut states = Vec::new();
    for _ in 0..1500 {
        engine.step();
        if matches!(engine.state().step, 300 | 700 | 1500) {
            states.push(engine.state().clone());
        }
    }
    let mut group = c.benchmark_group("stage");
    group.bench_function("prepare", |b| {
        b.iter_custom(|iters| {
            let mut total = std::time::Duration::ZERO;
            for i in 0..iters {
                engine.set_state(states[i as usize % states.len()].clone());
                let t0 = std::time::Instant::now();
                engine.prepare();
                total += t0.elapsed();
            }
            total
        })
    });
    group.bench_function("finish", |b| {
        b.iter_custom(|iters| {
            let mut total = std::time::Duration::ZERO;
            for i in 0..iters {
                engine.set_state(states[i as usize % states.len()].clone());
                engine.prepare();
                let t0 = std::time::Instant::now();
                black_box(engine.finish());
                total += t0.elapsed();
            }
            total
        })
    });
    // The reduced LCPs of those steps, solved alone.
    let lcps: Vec<(usize, Vec<f64>, Vec<f64>)> = states
        .iter()
        .map(|s| {
            engine.set_state(s.clone());
            engine.step();
            let (n, m, q) = engine.last_lcp();
            (n, m.to_vec(), q.to_vec())
        })
        .collect();
    // Lemke alone on those LCPs, round robin; and on the same matrices with
    // q >= 0 (every contact separating), which Lemke answers with z = 0
    // before it builds a tableau: what the trivial-LCP shortcut saves.
    let trivial: Vec<(usize, Vec<f64>, Vec<f64>)> = lcps
        .iter()
        .map(|(n, m, q)| (*n, m.clone(), q.iter().map(|x| x.abs()).collect()))
        .collect();
    let mut lemke = cosim_server::engine::solver::Lemke::new();
    let mut z = vec![0.0; lcps.iter().map(|l| l.0).max().unwrap_or(0)];
    for (name, set) in [("lemke_solve", &lcps), ("lemke_trivial", &trivial)] {
        group.bench_function(name, |b| {
            let mut i = 0;
            b.iter(|| {
                let (n, m, q) = &set[i % set.len()];
                i += 1;
                let lcp = cosim_server::engine::solver::Lcp { n: *n, m, q };
                black_box(lemke.solve(&lcp, &mut z[..*n]).is_ok())
            })
        });
    }
    group.finish();
}

criterion_group!(benches, step, stages);
criterion_main!(benches);

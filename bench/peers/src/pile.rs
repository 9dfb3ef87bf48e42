//! The pile of issue 14 (`cosim-server bench pile`) with Rapier beside our
//! engine, in one run: Rapier at 1, 4 (its default), 8 and 16 solver
//! iterations, with its sleeping on and off; ours with ours on and off.
//! Every run is scored by the same code: the worst overlap is our
//! `measure::max_penetration` on each step's poses, whichever engine made
//! them; the kinetic energy and the spheres out of the box from the poses
//! and twists too. Timing covers the step calls only.

use crate::rapier;
use cosim_server::bench::pile::{self, Settings};
use cosim_server::engine::{measure, BodyState, Model, State};
use cosim_shared::Scene;
use rapier3d_f64::prelude::*;
use std::time::Instant;

/// One engine's run of one pile.
#[derive(Debug, Clone)]
pub struct Row {
    pub engine: String,
    pub setting: String,
    pub n: usize,
    pub steps: u64,
    pub median_ms: f64,
    pub total_s: f64,
    pub worst_overlap: f64,
    pub escaped: usize,
    pub kinetic: f64,
    pub asleep: usize,
}

/// Ours, as `bench pile` runs it.
pub fn ours(n: usize, settings: &Settings) -> Row {
    let o = pile::run(n, settings);
    Row {
        engine: "ours".into(),
        setting: format!(
            "{} {}",
            settings.solver,
            if settings.sleep { "sleep" } else { "no sleep" }
        ),
        n,
        steps: o.steps,
        median_ms: o.median_step * 1e3,
        total_s: o.total,
        worst_overlap: o.worst_overlap,
        escaped: o.escaped,
        kinetic: o.kinetic,
        asleep: o.asleep,
    }
}

/// Rapier on the same pile with `iterations` solver iterations.
pub fn rapier(n: usize, settings: &Settings, iterations: usize, sleep: bool) -> Row {
    let text = pile::text(n, settings.dt, 4, "pgs", settings.steps, settings.seed);
    let scene = Scene::parse(&text, "<pile>").unwrap_or_else(|e| panic!("pile scene: {e}"));
    let model = Model::from_scene(&scene);
    let mut w = rapier::build(&scene, sleep);
    w.world.integration_parameters.num_solver_iterations = iterations.max(1);
    let mut state = State::initial(&model);
    let (mut scratch, mut geoms) = Default::default();
    let mut times = Vec::with_capacity(settings.steps as usize);
    let mut worst = 0.0f64;
    for _ in 0..settings.steps {
        let t0 = Instant::now();
        w.world.step();
        times.push(t0.elapsed().as_secs_f64());
        copy_state(&w, &mut state);
        worst = worst.max(measure::max_penetration(
            &model,
            &state,
            &mut scratch,
            &mut geoms,
        ));
    }
    let total: f64 = times.iter().sum();
    times.sort_by(f64::total_cmp);
    let half = pile::half_width(n);
    let kinetic = model
        .bodies
        .iter()
        .zip(&state.bodies)
        .map(|(b, s)| 0.5 * b.mass * s.v.norm_squared() + 0.5 * s.w.dot(&(b.inertia * s.w)))
        .sum();
    let asleep = w
        .bodies
        .iter()
        .filter(|(h, _)| w.world.bodies[*h].is_sleeping())
        .count();
    Row {
        engine: format!("rapier {}", rapier::VERSION),
        setting: format!(
            "{iterations} iterations{}, {}",
            if iterations == 4 { " (default)" } else { "" },
            if sleep { "sleep" } else { "no sleep" }
        ),
        n,
        steps: settings.steps,
        median_ms: times.get(times.len() / 2).copied().unwrap_or(0.0) * 1e3,
        total_s: total,
        worst_overlap: worst,
        escaped: state
            .bodies
            .iter()
            .filter(|b| b.x.x.abs() > half || b.x.y.abs() > half || b.x.z < 0.0)
            .count(),
        kinetic,
        asleep,
    }
}

/// Rapier's poses and twists into our state, for our measurements.
fn copy_state(w: &rapier::World, state: &mut State) {
    use nalgebra::{Quaternion, UnitQuaternion, Vector3};
    for ((h, _), s) in w.bodies.iter().zip(state.bodies.iter_mut()) {
        let b = &w.world.bodies[*h];
        let (x, q, v, om) = (b.translation(), b.rotation(), b.linvel(), b.angvel());
        *s = BodyState {
            x: Vector3::new(x.x, x.y, x.z),
            q: UnitQuaternion::new_normalize(Quaternion::new(q.w, q.x, q.y, q.z)),
            v: Vector3::new(v.x, v.y, v.z),
            w: Vector3::new(om.x, om.y, om.z),
        };
    }
}

/// The rows as a markdown table.
pub fn table(rows: &[Row], settings: &Settings) -> String {
    let mut t = format!(
        "Pile of spheres (r = {} m, mu = 0.5), h = {}, n_d = 4 (ours), one thread each.\n\n\
         | engine | setting | N | steps | ms/step (median) | s total | worst overlap (mm) | escaped | KE end (J) | asleep |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
        pile::RADIUS,
        settings.dt
    );
    for r in rows {
        t += &format!(
            "| {} | {} | {} | {} | {:.3} | {:.2} | {:.2e} | {} | {:.2e} | {} |\n",
            r.engine,
            r.setting,
            r.n,
            r.steps,
            r.median_ms,
            r.total_s,
            r.worst_overlap * 1e3,
            r.escaped,
            r.kinetic,
            r.asleep
        );
    }
    t
}

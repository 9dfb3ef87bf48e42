//! The skips of the step do not change the answer (issue #6): pruning
//! (with Lemke to the bit, but on boxes' indeterminate supports to
//! round-off; with PGS to its tolerance),
//! the broad phase (issue 14), no friction rows where mu = 0, Lemke's
//! support guess, PGS warm start,
//! each on and off on the same scene (`cosim-server bench skips` times them).

use cosim_bench::skips;

#[test]
fn skips_do_not_change_the_trajectory() {
    let ms = skips::measure(2000).expect("scenes");
    for m in &ms {
        assert_eq!(
            m.on.failures + m.off.failures,
            0,
            "{}: a run failed",
            m.skip
        );
        assert_eq!(m.on.positions.len(), 2000, "{}", m.skip);
        // Pruning: identical to the bit (the canonical re-solve, prune.rs).
        // Friction rows at mu = 0 carry zero impulse: round-off apart.
        // Warm start changes only where PGS starts: each step's answer
        // agrees to the solver's tolerance (relative residual 1e-10 of
        // velocities of order 1 m/s); whole PGS trajectories of the chaotic
        // reference scene drift apart from that, so only steps are compared,
        // and only those where neither side stopped at the iteration cap
        // (closed-loop steps: the warm start from the last step's large
        // indeterminate impulses is what keeps PGS from converging there;
        // `bench skips` counts them).
        // Lemke's support guess gives the solution a pivoted path gives, by
        // another arithmetic (a small factorisation): each step agrees to
        // round-off (verified residual 1e-8 relative at most; velocities of
        // order 1 m/s), the chaotic trajectory then drifts as above.
        // Pruning with PGS (the canonical re-solve too under the distance
        // rule; not under the residual rule, piles): each step agrees to
        // the solver's tolerance, as the warm start's (measured: 1e-10 m/s
        // apart at most, not to the bit).
        // Pruning on boxes and capsules: a box resting on four vertices
        // with friction is a statically indeterminate support, whose
        // frictional LCP has many solutions, not all with the same
        // velocities (measured: a contact with z = 7.7e-8 in one run has
        // z = 0 and w = 2.8e-7 m/s in the other), so Lemke's answer
        // depends on what else its first LCP held, and the canonical
        // re-solve (prune.rs) cannot name one set for both. The runs
        // agree to round-off (measured 1.9e-15 m over 2,000 steps).
        let (d, bound) = match m.skip {
            s if s.starts_with("pruning (boxes") => (skips::distance(&m.on, &m.off), 1e-12),
            s if s.starts_with("pruning with PGS") => (m.per_step.difference, 1e-6),
            s if s.starts_with("pruning") => (skips::distance(&m.on, &m.off), 0.0),
            // The broad phase leaves out only pairs that prune.rs leaves
            // out too, and keeps the canonical order: identical to the bit.
            s if s.starts_with("broad") => (skips::distance(&m.on, &m.off), 0.0),
            s if s.starts_with("no friction") => (skips::distance(&m.on, &m.off), 1e-12),
            s if s.starts_with("Lemke") => (m.per_step.difference, 1e-8),
            _ => (m.per_step.difference, 1e-6),
        };
        assert!(
            d <= bound,
            "{} on {}: differ by {d:e} (bound {bound:e})",
            m.skip,
            m.scene
        );
        assert!(
            m.per_step.difference <= 1e-6,
            "{}: one step apart by {:e}",
            m.skip,
            m.per_step.difference
        );
    }
}

/// The broad phase's reach grows within a step when a body moves farther
/// than its start speed said (issue 14): A is shot at B by a client impulse
/// (its free speed reaches past its start speed of zero), and B, which
/// rests, is thrown into C by that contact (its new speed reaches past its
/// free speed). Every pair is caught, and the run is the one that lists all
/// pairs, to the bit.
#[test]
fn the_broad_phase_widens_for_fast_free_and_new_speeds() {
    use cosim_bench::text::sphere;
    use cosim_server::engine::{Engine, Model};
    use nalgebra::Vector3;
    let text = format!(
        "[sim]\nname = \"chain\"\ndt = 0.001\nsteps = 100\ngravity = [0.0, 0.0, 0.0]\nsolver = \"lemke\"\n\n{}{}{}",
        sphere("a", 0.05, 1.0, [0.0, 0.0, 0.0], [0.0; 3], 0.2, 0.0),
        sphere("b", 0.05, 1.0, [0.1, 0.0, 0.0], [0.0; 3], 0.2, 0.0),
        sphere("c", 0.05, 1.0, [0.21, 0.0, 0.0], [0.0; 3], 0.2, 0.0),
    );
    let scene = cosim_shared::Scene::parse(&text, "<chain>").unwrap();
    let run = |broad: bool| {
        let mut model = Model::from_scene(&scene);
        model.params.skips.broad_phase = broad;
        let mut e = Engine::new(model);
        let mut states = Vec::new();
        for k in 0..100 {
            if k == 0 {
                e.add_body_impulse(0, Vector3::new(30.0, 0.0, 0.0), Vector3::zeros())
                    .unwrap();
            }
            let r = e.step();
            assert!(r.ok(), "{r:?}");
            states.push(e.state().clone());
        }
        states
    };
    let (on, off) = (run(true), run(false));
    assert!(on == off, "the broad phase changed the trajectory");
    // The impulse went down the chain: C moves off, faster than A.
    let last = &on[99].bodies;
    assert!(last[2].v.x > 1.0 && last[2].v.x > last[0].v.x, "{last:?}");
}

/// The step's measurement lists the next step's geometry, which the next
/// collision stage takes instead of detecting again
/// (`Workspace::look_ahead`): the penetration a step reports is the one
/// measured on its state alone, to the bit; and a restored snapshot or a
/// wake by an input (in `finish` called alone) drops the listing of the state before: the next steps
/// are those an engine new to that state takes. Random scenes (boxes,
/// capsules, joints, corners) with sleeping at thresholds it reaches
/// within their 20 steps.
#[test]
fn the_measurement_s_listing_serves_the_next_step_and_no_other() {
    use cosim_bench::robust;
    use cosim_server::engine::model::state;
    use cosim_server::engine::{measure, Engine, Model};
    use nalgebra::Vector3;
    let (mut restored, mut woken) = (0, 0);
    for seed in 1..=80 {
        let model = Model::from_scene(&robust::sleeping_scene(seed));
        let mut e = Engine::new(model.clone());
        let mut states = vec![e.state().clone()];
        for step in 1..=20 {
            let r = e.step();
            let (mut collision, mut scratch, mut asleep) = Default::default();
            let alone = measure::max_penetration(
                &model,
                e.state(),
                &mut collision,
                &mut scratch,
                &mut asleep,
            );
            assert_eq!(
                r.max_penetration.to_bits(),
                alone.to_bits(),
                "seed {seed} step {step}: reported {:e}, alone {alone:e}",
                r.max_penetration
            );
            states.push(e.state().clone());
        }
        // Back to step 5 after step 20: steps 6 to 10 again, to the bit.
        e.set_state(states[5].clone());
        for (k, want) in states.iter().enumerate().take(11).skip(6) {
            e.step();
            assert!(e.state() == want, "seed {seed}: step {k} after the restore");
        }
        restored += 1;
        // A push on a sleeping body after a step: the step an engine new
        // to that state takes with the same push.
        let Some(i) = (0..model.bodies.len()).find(|&i| state::asleep(e.state(), i)) else {
            continue;
        };
        let push = Vector3::new(0.0, 0.0, 1e-3 * model.bodies[i].mass);
        let mut fresh = Engine::new(model.clone());
        fresh.set_state(e.state().clone());
        for engine in [&mut e, &mut fresh] {
            engine
                .add_body_impulse(i, push, Vector3::zeros())
                .expect("a body of the scene");
        }
        // `finish` alone: the wake comes before any collision stage (as
        // `step` has it, whose own collision stage takes the listing first).
        e.finish();
        fresh.step();
        assert!(
            e.state() == fresh.state(),
            "seed {seed}: the step after waking body {i}"
        );
        woken += 1;
    }
    assert!(
        restored == 80 && woken >= 20,
        "{restored} restored, {woken} woken"
    );
}

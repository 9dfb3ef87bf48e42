//! Determinism: the same scene and inputs give the same bits, also after a
//! snapshot is restored (the state is complete).

use cosim_server::engine::{Engine, Model};
use cosim_shared::scenes;

#[test]
fn restoring_a_snapshot_replays_the_same_bits() {
    let scene = scenes::reference().expect("built-in scene");
    let mut e = Engine::new(Model::from_scene(&scene));
    for _ in 0..500 {
        assert!(e.step().ok());
    }
    let snapshot = e.state().clone();
    let mut first = Vec::new();
    for _ in 0..1000 {
        let r = e.step();
        assert!(r.ok());
        first.push(r);
    }
    let end = e.state().clone();
    e.set_state(snapshot);
    for (k, r) in first.iter().enumerate() {
        let again = e.step();
        assert_eq!(
            (again.pivots, again.lcp_size, again.energy),
            (r.pivots, r.lcp_size, r.energy),
            "step {k}"
        );
    }
    assert_eq!(e.state(), &end);
    // A second engine from scratch agrees too.
    let mut fresh = Engine::new(Model::from_scene(&scene));
    for _ in 0..1500 {
        fresh.step();
    }
    assert_eq!(fresh.state(), &end);
}

/// The iterative solver's warm start is part of the state, so a restored
/// PGS run repeats its bits too.
#[test]
fn restoring_a_snapshot_replays_pgs_too() {
    let scene = scenes::reference().expect("built-in scene");
    let mut model = Model::from_scene(&scene);
    model.params.solver = cosim_shared::SolverChoice::Pgs;
    let mut e = Engine::new(model);
    for _ in 0..300 {
        e.step();
    }
    let snapshot = e.state().clone();
    assert!(
        snapshot.warm_contacts.iter().any(|w| w.normal > 0.0)
            || snapshot.warm_joint.iter().any(|&p| p != 0.0)
    );
    for _ in 0..300 {
        e.step();
    }
    let end = e.state().clone();
    e.set_state(snapshot);
    for _ in 0..300 {
        e.step();
    }
    assert_eq!(e.state(), &end);
}

/// The lockstep server makes the mLCP's matrix in `Engine::prepare`, before
/// the inputs arrive, for the contacts the held inputs would select; the
/// step keeps it, cuts it down or builds afresh. None of that may change a
/// bit: `prepare` + `finish` against `step` on the same inputs, with
/// torques that change every step and kicks that throw the spheres into
/// contacts the prediction left out (both paths must occur), for each
/// solver.
#[test]
fn the_matrix_made_before_the_inputs_changes_no_bit() {
    use cosim_shared::SolverChoice;
    use nalgebra::Vector3;
    let scene = scenes::reference().expect("built-in scene");
    for solver in [SolverChoice::Lemke, SolverChoice::Pgs, SolverChoice::Auto] {
        let mut model = Model::from_scene(&scene);
        model.params.solver = solver;
        let (mut early, mut plain) = (Engine::new(model.clone()), Engine::new(model));
        let (mut kept, mut missed) = (0, 0);
        for k in 0..3000u64 {
            early.prepare();
            // A torque that changes every step, and every 97 steps a kick
            // of either sphere down into the floor.
            let phase = k as f64 * 0.37;
            let torque = Vector3::new(phase.sin(), (2.0 * phase).cos(), 0.3 * phase.sin());
            let kick =
                (k % 97 == 0).then(|| ((k / 97) as usize % 2, Vector3::new(20.0, -15.0, -40.0)));
            for e in [&mut early, &mut plain] {
                e.set_joint_torque(0, torque * 0.5).expect("joint 0");
                e.set_joint_torque(1, -torque * 0.2).expect("joint 1");
                if let Some((body, p)) = kick {
                    e.add_body_impulse(body, p, Vector3::zeros()).expect("body");
                }
            }
            let (a, b) = (early.finish(), plain.step());
            assert_eq!(a.error, b.error, "{solver:?} step {k}");
            assert_eq!(early.state(), plain.state(), "{solver:?} step {k}");
            assert_eq!(
                (a.pivots, a.lcp_size),
                (b.pivots, b.lcp_size),
                "{solver:?} step {k}"
            );
            assert!(!b.early_matrix, "step() makes no early matrix");
            if a.contacts_in_lcp > 0 {
                if a.early_matrix {
                    kept += 1;
                } else {
                    missed += 1;
                }
            }
        }
        assert!(kept > 1000, "{solver:?}: early matrix used {kept} times");
        assert!(missed > 0, "{solver:?}: the prediction never missed");
    }
}

/// A state grows with the scene, not with its square (issue 14, point 5):
/// the warm start held an entry per potential contact, N P + N (N - 1) / 2
/// of them, 16 MB for 1,000 spheres, copied by every snapshot and restore.
#[test]
fn a_state_holds_memory_in_proportion_to_its_bodies() {
    for n in [100usize, 1000] {
        let scene = cosim_bench::pile::scene(n, 0.01, 4, "pgs", 10, 1);
        let mut e = Engine::new(Model::from_scene(&scene));
        let first = e.state().heap_bytes();
        // A few steps: the spheres fall, the bottom layer lands later.
        for _ in 0..3 {
            e.step();
        }
        let per_body = e.state().heap_bytes().max(first) / n;
        eprintln!("{n} spheres: {per_body} bytes of state per body");
        assert!(per_body <= 200, "{n} spheres: {per_body} bytes per body");
    }
}

//! Determinism: the same scene and inputs give the same bits, also after a
//! snapshot is restored (the state is complete).

use cosim_server::engine::{Engine, Model};
use cosim_server::scenes;

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
        snapshot.warm_normal.iter().any(|&p| p > 0.0)
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

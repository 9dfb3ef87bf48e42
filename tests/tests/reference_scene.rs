//! The reference scene (acceptance 9): the full LCP has 7 (2 + n_d)
//! unknowns, pruned and full runs agree, Lemke solves every step of 10 s.

use cosim_server::engine::{Engine, Model};
use cosim_shared::scenes;

/// Runs the reference scene for 10 s; returns every state (flattened) and
/// the number of regularised solves.
fn run_reference(h: f64, nd: usize, full: bool) -> (Vec<Vec<f64>>, usize) {
    let mut scene = scenes::reference().expect("built-in scene is valid");
    scene.sim.dt = h;
    scene.sim.friction_directions = nd;
    let mut model = Model::from_scene(&scene);
    model.params.full = full;
    assert_eq!(model.potential_contacts(), 7);
    let mut e = Engine::new(model);
    let steps = (10.0 / h).round() as u64;
    let (mut states, mut reg_full) = (Vec::new(), 0);
    for _ in 0..steps {
        let r = e.step();
        assert!(
            r.ok(),
            "h = {h}, n_d = {nd}, full = {full}: step {} failed: {}",
            r.step,
            r.status()
        );
        if full {
            assert_eq!(r.lcp_size, 7 * (2 + nd), "full LCP size at step {}", r.step);
        }
        reg_full += r.regularized;
        let s: Vec<f64> = e
            .state()
            .bodies
            .iter()
            .flat_map(|b| {
                let q = b.q.quaternion();
                [
                    b.x.x, b.x.y, b.x.z, q.w, q.i, q.j, q.k, b.v.x, b.v.y, b.v.z, b.w.x, b.w.y,
                    b.w.z,
                ]
            })
            .collect();
        assert!(s.iter().all(|x| x.is_finite()));
        states.push(s);
    }
    (states, reg_full)
}

#[test]
fn pruned_and_full_agree_and_lemke_never_fails() {
    for h in [1e-3, 1e-2] {
        for nd in [4, 8, 16] {
            let (pruned, reg_pruned) = run_reference(h, nd, false);
            let (full, reg_full) = run_reference(h, nd, true);
            let worst = pruned
                .iter()
                .zip(&full)
                .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
                .fold(0.0, f64::max);
            eprintln!("h = {h}, n_d = {nd}: {} steps, largest pruned-full difference {worst:e}, {reg_pruned} / {reg_full} regularised solves (pruned / full)", pruned.len());
            assert!(
                worst <= 1e-9,
                "h = {h}, n_d = {nd}: pruned and full differ by {worst}"
            );
            // The regularised retry is the exception, not the rule.
            assert!(
                (reg_pruned + reg_full) * 1000 <= pruned.len(),
                "h = {h}, n_d = {nd}: too many regularised solves"
            );
        }
    }
}

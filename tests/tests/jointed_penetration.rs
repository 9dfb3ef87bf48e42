//! Issue 48, point 6: bodies on joints that start in penetration are
//! moved out as free bodies are, by a projection that holds their joints
//! (`integrate::project`), not launched by the velocity stabilisation at
//! `beta depth / h` (a 5-link chain lying 2 cm into the floor left at
//! 4 m/s at h = 1e-3; a URDF chain on the floor at 50 m/s and 12 kJ).

use cosim_server::engine::{Engine, Model};
use cosim_shared::{Scene, SolverChoice};

/// Five spheres of radius 5 cm in a row along x, each hinged to the next
/// about y at their touching point, lying `depth` into the floor.
fn sunk_chain(depth: f64, solver: SolverChoice) -> String {
    let r = 0.05;
    let z = r - depth;
    let mut text = format!(
        "[sim]\nname = \"sunk\"\ndt = 0.001\nsteps = 100\nsolver = \"{}\"\n\n\
         [[plane]]\nname = \"floor\"\nnormal = [0.0, 0.0, 1.0]\npoint = [0.0, 0.0, 0.0]\nfriction = 0.5\n\n",
        solver.as_str()
    );
    for i in 0..5 {
        text += &format!(
            "[[body]]\nname = \"s{i}\"\nradius = {r}\nmass = 1.0\nposition = [{}, 0.0, {z}]\nfriction = 0.5\n\n",
            2.0 * r * i as f64
        );
    }
    for i in 0..4 {
        text += &format!(
            "[[joint]]\nname = \"j{i}\"\ntype = \"revolute\"\nbody_a = \"s{i}\"\nbody_b = \"s{}\"\nanchor = [{}, 0.0, {z}]\naxis = [0.0, 1.0, 0.0]\n\n",
            i + 1,
            2.0 * r * i as f64 + r
        );
    }
    text
}

#[test]
fn a_chain_sunk_into_the_floor_is_lifted_out_not_launched() {
    for solver in [SolverChoice::Lemke, SolverChoice::Pgs, SolverChoice::Auto] {
        let text = sunk_chain(0.02, solver);
        let scene = Scene::parse(&text, "<sunk chain>").unwrap();
        let mut e = Engine::new(Model::from_scene(&scene));
        let first = e.step();
        assert!(first.ok(), "{first:?}");
        // Every contact deeper than the slop took part, the joints held.
        assert_eq!(first.projected, 5, "{first:?}");
        assert!(first.max_joint_error < 1e-9, "{first:?}");
        assert!(first.max_penetration < 1e-4, "{first:?}");
        // No faster than a step of free fall from rest (g h = 9.8 mm/s),
        // with a margin for the floor's answer: before, 4 m/s.
        let fastest = e
            .state()
            .bodies
            .iter()
            .map(|b| b.v.norm())
            .fold(0.0f64, f64::max);
        assert!(
            fastest < 2.0 * 9.81e-3,
            "{}: {fastest} m/s",
            solver.as_str()
        );
        // Then it lies still: no energy from the start's overlap.
        let k0 = first.energy.kinetic;
        for _ in 0..99 {
            let r = e.step();
            assert!(r.ok(), "{r:?}");
            assert!(
                r.energy.kinetic <= k0.max(1e-6),
                "{}: {r:?}",
                solver.as_str()
            );
        }
    }
}

//! Islands (issue 14, point 2): the step reports the bodies its
//! constraints tie together. A sphere alone on the floor, a stack of two,
//! a jointed pair in flight and a free sphere: three islands, the largest
//! of two bodies; a sphere in the groove of two ties the three.

use cosim_server::bench::text::{joint, plane, sphere};
use cosim_server::engine::{Engine, Model};

#[test]
fn the_step_reports_its_islands() {
    let r = 0.1;
    let text = format!(
        "[sim]\nname = \"islands\"\ndt = 0.001\nsteps = 10\nsolver = \"lemke\"\n\n{}{}{}{}{}{}{}{}",
        plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0),
        sphere("alone", r, 1.0, [0.0, 0.0, r], [0.0; 3], 0.5, 0.0),
        sphere("bottom", r, 1.0, [1.0, 0.0, r], [0.0; 3], 0.5, 0.0),
        sphere("top", r, 1.0, [1.0, 0.0, 3.0 * r], [0.0; 3], 0.5, 0.0),
        sphere("free", r, 1.0, [2.0, 0.0, 2.0], [0.0; 3], 0.5, 0.0),
        sphere("p", r, 1.0, [3.0, 0.0, 2.0], [0.0; 3], 0.5, 0.0),
        sphere("q", r, 1.0, [3.3, 0.0, 2.0], [0.0; 3], 0.5, 0.0),
        joint("pq", "p", "q", [3.15, 0.0, 2.0]),
    );
    let scene = cosim_shared::Scene::parse(&text, "<islands>").unwrap();
    let mut e = Engine::new(Model::from_scene(&scene));
    for _ in 0..10 {
        let rep = e.step();
        assert!(rep.ok(), "{rep:?}");
        assert_eq!((rep.islands, rep.largest_island), (3, 2), "{rep:?}");
    }
    // A sphere laid in the groove of two on the floor ties them: its
    // contacts carry its weight (side by side, the two would carry none
    // and stay two islands).
    let z = r + 3f64.sqrt() * r;
    let text = format!(
        "[sim]\nname = \"groove\"\ndt = 0.001\nsteps = 10\nsolver = \"lemke\"\n\n{}{}{}{}{}{}{}",
        plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0),
        sphere("left", r, 1.0, [-r, 0.0, r], [0.0; 3], 0.5, 0.0),
        sphere("right", r, 1.0, [r, 0.0, r], [0.0; 3], 0.5, 0.0),
        sphere("top", r, 1.0, [0.0, 0.0, z], [0.0; 3], 0.5, 0.0),
        sphere("p", r, 1.0, [3.0, 0.0, 2.0], [0.0; 3], 0.5, 0.0),
        sphere("q", r, 1.0, [3.3, 0.0, 2.0], [0.0; 3], 0.5, 0.0),
        joint("pq", "p", "q", [3.15, 0.0, 2.0]),
    );
    let scene = cosim_shared::Scene::parse(&text, "<groove>").unwrap();
    let mut e = Engine::new(Model::from_scene(&scene));
    let rep = e.step();
    assert!(rep.ok(), "{rep:?}");
    assert_eq!((rep.islands, rep.largest_island), (2, 3), "{rep:?}");
}

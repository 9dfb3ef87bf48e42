//! After warm-up, a step allocates nothing: every buffer is owned by the
//! engine and reused. A counting global allocator (this test binary only)
//! counts the allocations made while stepping, per thread: the tests run
//! in parallel, and one's warm-up must not count in another's step.

use cosim_server::engine::{Engine, ImpulseKind, Model};
use cosim_shared::scenes;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    // A const initialiser: reading it allocates nothing.
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn count() {
    // `try_with`: an allocation while the thread's locals are torn down is
    // not counted rather than a panic.
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

/// Allocations made by this thread so far.
fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

// SAFETY: every call is forwarded unchanged to the system allocator; the
// counter has no effect on the memory handed out.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: same contract as our caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as our caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: same contract as our caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Runs `model` for `steps` steps (the warm-up: one pass sees the largest
/// problems), then the same steps again from the initial state; the
/// allocations of the second pass, and the active contacts and joint
/// limits (impulse records) of the first.
fn second_pass_allocations(model: Model, steps: usize) -> (usize, usize) {
    let mut engine = Engine::new(model);
    let initial = engine.state().clone();
    let mut contacts = 0;
    for _ in 0..steps {
        let r = engine.step();
        assert!(r.ok());
        contacts += engine
            .impulses()
            .iter()
            .filter(|i| matches!(i.kind, ImpulseKind::Normal | ImpulseKind::JointLimit))
            .count();
    }
    engine.set_state(initial);
    let before = allocations();
    for _ in 0..steps {
        assert!(engine.step().ok());
    }
    (allocations() - before, contacts)
}

#[test]
fn stepping_allocates_nothing_after_warm_up() {
    for full in [true, false] {
        let scene = scenes::reference().expect("built-in scene");
        let mut model = Model::from_scene(&scene);
        model.params.full = full;
        let (made, _) = second_pass_allocations(model, 2000);
        assert_eq!(
            made, 0,
            "full = {full}: {made} allocations in 2000 steps after warm-up"
        );
    }
}

/// The same with a hinge and a fixed joint (their rotation rows) and a
/// contact between a jointed body and a free one: the shipped hinges,
/// slider and limits scenes (the last: limits hit and held), and the
/// boxes and capsules of shapes.toml.
#[test]
fn hinges_sliders_and_fixed_joints_allocate_nothing_after_warm_up() {
    // And sliders: slider.toml's rail and pendulum run into a ball.
    for (name, solver) in [
        ("hinges.toml", cosim_shared::SolverChoice::Lemke),
        ("hinges.toml", cosim_shared::SolverChoice::Pgs),
        ("slider.toml", cosim_shared::SolverChoice::Lemke),
        ("slider.toml", cosim_shared::SolverChoice::Pgs),
        ("limits.toml", cosim_shared::SolverChoice::Lemke),
        ("limits.toml", cosim_shared::SolverChoice::Pgs),
        // Boxes and capsules: each shape pair's contacts, clipped on the
        // stack (collision/box_box.rs).
        ("shapes.toml", cosim_shared::SolverChoice::Lemke),
        ("shapes.toml", cosim_shared::SolverChoice::Pgs),
        // Rotors (`armature`) on the hinges: their rows among the joints'.
        ("hinges.toml+armature", cosim_shared::SolverChoice::Lemke),
        ("hinges.toml+armature", cosim_shared::SolverChoice::Pgs),
    ] {
        let text = match name.strip_suffix("+armature") {
            Some(file) => cosim_tests::shipped_scene(file).replace(
                "type = \"revolute\"\n",
                "type = \"revolute\"\narmature = 0.01\n",
            ),
            None => cosim_tests::shipped_scene(name),
        };
        if name.ends_with("+armature") {
            assert!(text.contains("armature"), "no hinge in {name}");
        }
        let scene = cosim_shared::Scene::parse(&text, name).expect("shipped scene");
        let mut model = Model::from_scene(&scene);
        model.params.solver = solver;
        let (made, contacts) = second_pass_allocations(model, 3000);
        assert!(contacts > 0, "{name}: nothing touched, no limit held");
        assert_eq!(
            made,
            0,
            "{name}, {}: {made} allocations after warm-up",
            solver.as_str()
        );
    }
}

/// The same with the broad phase at work (issue 14, point 5): the gas of
/// 64 spheres in a box lists a few of its 2,016 pairs each step, and its
/// reach widens when a sphere is hit; a second pass over the same run
/// allocates nothing, with the broad phase and without it.
#[test]
fn the_broad_phase_allocates_nothing_after_warm_up() {
    let scene = cosim_bench::skips::gas().expect("the gas scene");
    for broad in [true, false] {
        let mut model = Model::from_scene(&scene);
        model.params.skips.broad_phase = broad;
        let (made, contacts) = second_pass_allocations(model, 1000);
        assert!(contacts > 100, "the spheres touch: {contacts} contacts");
        assert_eq!(
            made, 0,
            "broad phase {broad}: {made} allocations in 1000 steps after warm-up"
        );
    }
}

/// The same through sleeping (issue 14, point 4): a stack that falls
/// asleep, is woken by a sphere dropped on it, and sleeps again; the
/// second pass allocates nothing.
#[test]
fn sleeping_and_waking_allocate_nothing_after_warm_up() {
    use cosim_bench::text::{plane, sphere};
    let r = 0.1;
    let text = format!(
        "[sim]\nname = \"sleep\"\ndt = 0.001\nsteps = 10\nsolver = \"lemke\"\n\n[sim.sleep]\nafter = 0.1\n\n{}{}{}{}",
        plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0),
        sphere("bottom", r, 1.0, [0.0, 0.0, r], [0.0; 3], 0.5, 0.0),
        sphere("top", r, 1.0, [0.0, 0.0, 3.0 * r], [0.0; 3], 0.5, 0.0),
        sphere("faller", r, 1.0, [0.0, 0.0, 5.0 * r + 0.2], [0.0; 3], 0.5, 0.0),
    );
    let model = Model::from_scene(&cosim_shared::Scene::parse(&text, "<sleep>").unwrap());
    let mut e = Engine::new(model.clone());
    let (mut slept, mut woke) = (false, false);
    for _ in 0..1500 {
        let rep = e.step();
        woke |= slept && rep.sleeping == 0;
        slept |= rep.sleeping > 0;
    }
    assert!(slept && woke, "slept {slept}, woke {woke}");
    let (made, _) = second_pass_allocations(model, 1500);
    assert_eq!(made, 0, "{made} allocations in 1500 steps after warm-up");
}

/// The same on a pile (issue 14, points 2 and 5): 100 spheres dropped into
/// a box with `auto`, whose steps split by island between Lemke (small
/// islands, blocks built from their rows) and PGS (the pile); the second
/// pass over the same 300 steps allocates nothing.
#[test]
fn a_pile_split_between_lemke_and_pgs_allocates_nothing_after_warm_up() {
    use cosim_bench::pile;
    let scene = pile::scene(100, 0.01, 4, "auto", 300, 1);
    let mut model = Model::from_scene(&scene);
    model.params.pgs = pile::pgs(pile::TOLERANCE);
    let mut engine = Engine::new(model);
    let initial = engine.state().clone();
    let mut split = 0;
    for _ in 0..300 {
        let r = engine.step();
        assert!(r.ok(), "{r:?}");
        split += usize::from(r.lemke_islands > 0 && r.pgs_islands > 0);
    }
    // Measured: 18 steps (the falling phase and the pile's edge).
    assert!(split > 10, "{split} steps split between the solvers");
    engine.set_state(initial);
    let before = allocations();
    for _ in 0..300 {
        assert!(engine.step().ok());
    }
    let made = allocations() - before;
    assert_eq!(made, 0, "{made} allocations in 300 steps after warm-up");
}

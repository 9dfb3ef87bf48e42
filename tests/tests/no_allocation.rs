//! After warm-up, a step allocates nothing: every buffer is owned by the
//! engine and reused. A counting global allocator (this test binary only)
//! counts the allocations made while stepping.

use cosim_server::engine::{Engine, Model};
use cosim_server::scenes;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call is forwarded unchanged to the system allocator; the
// counter has no effect on the memory handed out.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: same contract as our caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as our caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: same contract as our caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn stepping_allocates_nothing_after_warm_up() {
    for full in [true, false] {
        let scene = scenes::reference().expect("built-in scene");
        let mut model = Model::from_scene(&scene);
        model.params.full = full;
        let mut engine = Engine::new(model);
        let initial = engine.state().clone();
        // Warm-up: one pass over the run sees the largest problems.
        for _ in 0..2000 {
            assert!(engine.step().ok());
        }
        engine.set_state(initial);
        let before = ALLOCATIONS.load(Ordering::Relaxed);
        for _ in 0..2000 {
            assert!(engine.step().ok());
        }
        let made = ALLOCATIONS.load(Ordering::Relaxed) - before;
        assert_eq!(
            made, 0,
            "full = {full}: {made} allocations in 2000 steps after warm-up"
        );
    }
}

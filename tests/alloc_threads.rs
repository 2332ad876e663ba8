//! A step split between threads allocates nothing in steady state either, on any thread
//! (counted by a global allocator over every thread; this file holds one test, so no
//! other test allocates on the same counter).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use sandbox2d::{SolverKind, SolverSettings, World, scene};

struct Counting;

static ALLOCS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static COUNTING: Counting = Counting;

#[test]
fn steady_steps_on_two_threads_allocate_nothing() {
    let text = "name = \"pile\"\n[world]\ngravity = [0.0, -10.0]\n\
                [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [200.0, 2.0] }\nposition = [0.0, -1.0]\n\
                [[pyramid]]\nbase = 30\n";
    for kind in SolverKind::ALL {
        let s = SolverSettings {
            sleep: false,
            ..SolverSettings::defaults(kind)
        };
        let sc = scene::load_str(text, "pile.toml").unwrap();
        let mut w = World::from_def(&sc.world, s).unwrap();
        w.set_threads(2);
        for _ in 0..60 {
            w.step().unwrap();
        }
        assert!(w.parallel_jobs() > 0, "{kind:?}: the workers ran");
        let before = ALLOCS.load(Ordering::Relaxed);
        for _ in 0..60 {
            w.step().unwrap();
        }
        let n = ALLOCS.load(Ordering::Relaxed) - before;
        assert_eq!(
            n, 0,
            "{kind:?}: {n} allocations in 60 steady steps on two threads"
        );
    }
}

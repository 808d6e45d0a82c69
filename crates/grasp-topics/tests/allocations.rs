//! A Gibbs sweep (finite and DP) allocates nothing: counted with a global allocator.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use grasp_topics::synthetic::{SyntheticSpec, sample_dataset, well_separated_prototypes};
use grasp_topics::{DpState, GibbsState, Hyperparameters};

struct Counting;
static ALLOCS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Whether this thread's allocations are counted: only the measured sweeps', not the test
    /// harness's other threads.
    static COUNTED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

fn count() {
    if COUNTED.try_with(|c| c.get()).unwrap_or(false) {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
    }
}

// Forwards to the system allocator and counts (a test-only allocator, hence the allowed unsafe).
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(p, l, n) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn sweeps_do_not_allocate() {
    let mut rng = bayes::rng::seeded(4);
    let spec = SyntheticSpec {
        objects: 10,
        grasps_per_object: 8,
        alpha: 0.5,
        appearance_dof: 20.0,
        prototypes: well_separated_prototypes(4, 3, 20.0),
    };
    let d = sample_dataset(&spec, &mut rng).unwrap().data;
    let h = Hyperparameters::from_data(&d);
    let mut g = GibbsState::new(&d, &h, 6).unwrap();
    g.initialise(&d, &mut rng);
    let mut dp = DpState::new(&d, &h, 1.0, 3).unwrap();
    dp.initialise(&d, &mut rng);
    let before = ALLOCS.load(Ordering::Relaxed);
    COUNTED.with(|c| c.set(true));
    for _ in 0..5 {
        g.sweep(&d, &mut rng);
        dp.sweep(&d, &mut rng);
    }
    let _ = g.log_joint();
    COUNTED.with(|c| c.set(false));
    assert_eq!(ALLOCS.load(Ordering::Relaxed) - before, 0);
}

//! The streaming forward filter allocates nothing per step (counting global allocator). This
//! file holds a single test so no other test thread allocates while it counts.

use bayes::hmm::{ForwardFilter, Hmm, ScaledFilter};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator unchanged; only counts calls.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn forward_filter_step_does_not_allocate() {
    let ninf = f64::NEG_INFINITY;
    // One dense and one sparse (left-to-right) model; emissions include impossible entries and
    // a fully impossible step at the end.
    let dense = Hmm::from_probabilities(&[0.5, 0.3, 0.2], &[0.6, 0.3, 0.1, 0.2, 0.5, 0.3, 0.1, 0.1, 0.8]).unwrap();
    let sparse = Hmm::new(
        vec![0.0, ninf, ninf],
        vec![
            (0.9f64).ln(),
            (0.1f64).ln(),
            ninf,
            ninf,
            (0.5f64).ln(),
            (0.5f64).ln(),
            ninf,
            ninf,
            0.0,
        ],
    )
    .unwrap();
    let rows: Vec<[f64; 3]> = (0..200)
        .map(|t| [-(t as f64 % 3.0), if t % 7 == 0 { ninf } else { -1.0 }, -0.5])
        .chain(std::iter::once([ninf; 3]))
        .collect();
    for hmm in [&dense, &sparse] {
        let mut f = ForwardFilter::new(hmm);
        let before = ALLOCATIONS.load(Ordering::SeqCst);
        for row in &rows {
            f.step(hmm, row).unwrap();
        }
        f.reset(hmm);
        for row in &rows {
            f.step(hmm, row).unwrap();
        }
        let after = ALLOCATIONS.load(Ordering::SeqCst);
        assert_eq!(after - before, 0, "allocations during {} steps", 2 * rows.len());
        assert!(f.is_impossible());
    }
    // The scaled filter, including steps where states fall below 1e-280 and are tracked in log
    // space (the first state of the left-to-right model decays at e^-1 per step, then e^-40), and
    // the step where they come back.
    let ltr = Hmm::new(
        vec![0.0, ninf, ninf],
        vec![
            (0.9f64).ln(),
            (0.1f64).ln(),
            ninf,
            ninf,
            (0.5f64).ln(),
            (0.5f64).ln(),
            ninf,
            ninf,
            0.0,
        ],
    )
    .unwrap();
    let lin: Vec<[f64; 3]> = (0..400)
        .map(|t| {
            if t < 300 {
                [(-40.0f64).exp(), 1.0, 1.0]
            } else {
                [1.0, 1e-3, 1e-3]
            }
        })
        .collect();
    for hmm in [&dense, &sparse, &ltr] {
        let mut f = ScaledFilter::new(hmm);
        let before = ALLOCATIONS.load(Ordering::SeqCst);
        for row in &lin {
            f.step(hmm, row).unwrap();
        }
        f.reset(hmm);
        for row in &lin {
            f.step(hmm, row).unwrap();
        }
        let after = ALLOCATIONS.load(Ordering::SeqCst);
        assert_eq!(
            after - before,
            0,
            "scaled filter allocations during {} steps",
            2 * lin.len()
        );
    }
}

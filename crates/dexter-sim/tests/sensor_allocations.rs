//! Reading the fingertip F/T sensors allocates nothing (they are read at the control rate).

use dexter_sim::physics::{DexterSim, SimSettings};
use dexter_sim::scene::Scene;
use dexter_sim::snapshot::FingertipWrench;

struct CountingAlloc;

thread_local! {
    static ALLOCATIONS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

// SAFETY: forwards to the system allocator; only counts.
#[allow(unsafe_code)]
unsafe impl std::alloc::GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { std::alloc::System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { std::alloc::System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: std::alloc::Layout, new_size: usize) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { std::alloc::System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

fn allocations() -> usize {
    ALLOCATIONS.with(|c| c.get())
}

#[test]
fn fingertip_wrenches_allocate_nothing() {
    let scene = Scene::builtin("pick-place").expect("builtin scene");
    let mut sim = DexterSim::new(&scene, SimSettings::default()).unwrap();
    for _ in 0..50 {
        sim.step();
    }
    let mut tips = [FingertipWrench {
        arm: dexter_sim::Arm::Left,
        finger: 1,
        force: [0.0; 3],
        torque: [0.0; 3],
        in_contact: false,
    }; 6];
    sim.fingertip_wrenches(&mut tips);
    let before = allocations();
    let mut sum = 0.0;
    for _ in 0..1000 {
        sim.fingertip_wrenches(&mut tips);
        sum += tips.iter().map(|t| t.force[2]).sum::<f64>();
    }
    assert_eq!(allocations() - before, 0, "reading the F/T sensors allocated");
    assert!(sum.is_finite());
    assert_eq!(tips[4].finger, 2);
}

//! The control tick allocates nothing: counted with a global allocator wrapper.
#![allow(unsafe_code)] // a counting GlobalAlloc needs it; the library itself denies unsafe code

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use control_basis::{
    Contact, ControlStack, Controller, FeedbackElement, ManipulabilityRows, MotorUnits, Operator, Potential, Reference,
    Sensor, StackSettings, forward_kinematics, math::Vec3,
};

struct Counting;
static ALLOCS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Whether this thread's allocations are counted: only the measured loop's, not the test
    /// harness's other threads (a loaded machine once saw 4 of theirs counted).
    static COUNTED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

fn count() {
    if COUNTED.try_with(|c| c.get()).unwrap_or(false) {
        ALLOCS.fetch_add(1, Ordering::SeqCst);
    }
}

// Forwards to the system allocator and counts; upholds GlobalAlloc's contract by delegation.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn control_tick_allocates_nothing() {
    let chain = common::wam_chain();
    let n = chain.dof();
    let tip = chain.links().len() - 1;
    let reach = Controller::reach_pose(&chain, tip, 5.0).unwrap();
    let manip = Controller::manipulability(&chain, ManipulabilityRows::Full, 10.0).unwrap();
    let limits = Controller::joint_limits(&chain, 1.0).unwrap();
    let grasp = Controller::new(
        "grasp",
        FeedbackElement {
            sensor: Sensor::ContactLoads,
            operator: Operator::LowPass {
                time_constant_secs: 0.05,
            },
        },
        Potential::ForceResidual { moment_weight: 10.0 },
        MotorUnits::all(n),
        1.0,
    )
    .unwrap();
    let mut stack = ControlStack::new(&chain, vec![reach, manip, limits, grasp], StackSettings::default()).unwrap();
    let mut s = chain.new_state();
    s.set_q(&chain, &[0.3, -0.4, 0.5, 1.2, -0.3, 0.4, 0.2]).unwrap();
    forward_kinematics(&chain, &mut s);
    let mut target = *s.tip_pose();
    target.translation.vector.x += 0.3;
    stack.set_reference(&chain, 0, Reference::Pose(target)).unwrap();
    let contacts = [
        Contact {
            link: tip,
            point: Vec3::new(0.5, 0.0, 0.8),
            force: Vec3::new(-1.0, 0.0, 0.0),
        },
        Contact {
            link: tip,
            point: Vec3::new(0.4, 0.02, 0.8),
            force: Vec3::new(1.0, 0.1, 0.0),
        },
    ];
    // Warm up (first evaluation may size buffers), then count.
    for _ in 0..3 {
        stack.tick(&chain, &mut s, &contacts, 0.002);
    }
    let before = ALLOCS.load(Ordering::SeqCst);
    COUNTED.with(|c| c.set(true));
    for _ in 0..1000 {
        stack.tick(&chain, &mut s, &contacts, 0.002);
        for i in 0..n {
            let d = stack.delta_u()[i];
            s.q_mut()[i] += d;
        }
    }
    COUNTED.with(|c| c.set(false));
    let after = ALLOCS.load(Ordering::SeqCst);
    assert_eq!(
        after - before,
        0,
        "the control tick allocated {} times in 1000 ticks",
        after - before
    );
}

//! Allocations per step, counted: a step of a running simulation writes what it repeats into
//! buffers it keeps (docs/performance.md, "Kept between calls, and the energy guard's cost"),
//! so on bodies out of reach, where an allocation and its release are a tenth of the step's
//! wall time, the count per step stays at what is still made afresh (the forward dynamics' own
//! vectors, the step's new state, damped RK4's stage states). Counted per thread by this
//! binary's allocator (its own test target, so no other test pays for it): the scene keeps every
//! pair out of reach, so no pair is evaluated on another thread. The counts are exact; the
//! bounds are those measured when they were set plus one a step, which a change of the standard
//! library's own allocations may take (before the buffers were kept: 31, 42, 48 and 153 a
//! step).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::Path;

/// The system allocator, counting this thread's allocations.
struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: every call is passed on to the system allocator unchanged; the count touches only a
// thread-local cell that needs no allocation.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// One allocation more on this thread (none counted where its storage is gone, at its exit).
fn count() {
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

#[global_allocator]
static COUNTING: Counting = Counting;

/// Three free bodies (box, sphere, capsule) 0.5 m apart and 0.5 m above a floor, weightless:
/// nothing ever in reach, every pair proven out of reach by a kept proof. `option` is the
/// integrator's MJCF.
fn floating3(option: &str) -> String {
    format!(
        r#"<mujoco model="floating3">
  <option gravity="0 0 0" timestep="0.002" {option}
  <worldbody>
    <geom name="floor" type="plane" size="3 3 0.1"/>
    <body name="b0" pos="0 0 0.5"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="1"/></body>
    <body name="b1" pos="0.5 0 0.5"><freejoint/><geom type="sphere" size="0.05" mass="1"/></body>
    <body name="b2" pos="0 0.5 0.5"><freejoint/><geom type="capsule" size="0.03 0.05" mass="1"/></body>
  </worldbody>
</mujoco>"#
    )
}

/// Allocations per step of 2 ms (one internal step) of `xml`, over 200 steps after 25.
fn per_step(xml: &str) -> f64 {
    let scene = scm::scene::load_str(xml, Path::new("floating3.xml")).unwrap();
    let mut sim = scm::sim::Simulation::new(scene, xml);
    sim.data.current.state.v[0] = 0.1; // moving, so the kept proofs are checked, not idle
    for _ in 0..25 {
        sim.advance(0.002).unwrap();
    }
    let before = ALLOCATIONS.with(Cell::get);
    for _ in 0..200 {
        sim.advance(0.002).unwrap();
    }
    (ALLOCATIONS.with(Cell::get) - before) as f64 / 200.0
}

#[test]
fn a_step_out_of_reach_allocates_no_more_than_when_counted() {
    let counted: Vec<(&str, f64, f64)> = [
        (
            "semi-implicit Euler",
            r#"integrator="Euler"><flag eulerdamp="disable"/></option>"#,
            11.0,
        ),
        ("damped Euler", r#"integrator="Euler"/>"#, 12.0),
        ("implicit Euler", r#"integrator="implicitfast"/>"#, 20.0),
        ("damped RK4", r#"integrator="RK4"/>"#, 75.0),
    ]
    .into_iter()
    .map(|(name, option, bound)| (name, per_step(&floating3(option)), bound))
    .collect();
    for (name, n, _) in &counted {
        println!("{name}: {n} allocations a step");
        // The allocator counts: a step makes its new state at least.
        assert!(*n >= 1.0, "{name}: no allocation counted");
    }
    for (name, n, bound) in counted {
        assert!(
            n <= bound + 1.0,
            "{name}: {n} allocations a step, more than {bound} + 1"
        );
    }
}

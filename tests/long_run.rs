//! Load: a long run with steady memory and no drift of the quaternion norms: 10⁶ steps of
//! `t_push` (2000 s simulated, the finger making and breaking contact every second; about
//! 7 minutes in release on the shared 2-core machine, 447 s in one run) and 10⁴ steps of `box_stack` (three free boxes
//! settling and resting). `cargo run --release --example long_run` runs the same code with
//! progress lines, 10⁶ steps of each; its numbers are in docs/fmu.md, Errors and limits.
//!
//! Memory: the live heap bytes of the stepping thread (a counting global allocator, so other
//! tests running in parallel do not count) after the first tenth of the run and at every step
//! after it may not exceed the warm-up level by more than 4 kB: a leak of even one byte per
//! step would show as 18 kB. Quaternions are normalized after every step, so their norms stay
//! 1 to a few ulps (1e-15); 1e-13 allows for the output's rounding.

#[path = "../examples/long_run.rs"]
#[allow(dead_code)]
mod example;

#[test]
fn t_push_long_run_keeps_memory_steady() {
    let p = example::t_push(1_000_000, |_, _| {});
    assert!(
        p.live_max - p.live_after_warmup <= 4096,
        "live heap grew: {p:?}"
    );
    // The finger makes and breaks contact every second: about 4000 changes in 2000 s.
    assert!(p.contact_changes >= 2000, "the finger did not push: {p:?}");
    assert!(
        p.max_abs_position.is_finite() && p.max_abs_position < 100.0,
        "{p:?}"
    );
}

#[test]
fn box_stack_long_run_keeps_memory_steady_and_quaternions_unit() {
    let p = example::box_stack(10_000, |_, _| {});
    assert!(
        p.live_max - p.live_after_warmup <= 4096,
        "live heap grew: {p:?}"
    );
    assert!(p.max_quat_norm_error < 1e-13, "{p:?}");
}

//! Load: a long run with steady memory and no drift of the quaternion norms: 10⁵ steps of
//! `t_push` (200 s simulated, the finger making and breaking contact every second; about a
//! minute in release) and 10⁴ steps of `box_stack` (three free boxes settling and resting).
//! `cargo run --release --example long_run` runs the same code with progress lines, 10⁶ steps
//! of each; its numbers are in docs/fmu.md, Errors and limits. The suite ran 10⁶ steps of
//! `t_push` until the CI machine spent 13 of its 65 minutes on this one test; 10⁵ steps still
//! make and break contact about 400 times.
//!
//! Memory: the live heap bytes of the stepping thread (a counting global allocator, so other
//! tests running in parallel do not count) after the first tenth of the run and at every step
//! after it may not exceed the warm-up level by more than 4 kB: a leak of even one byte per
//! step would show as 90 kB over `t_push`'s 9·10⁴ steps after warm-up, 9 kB over
//! `box_stack`'s 9000. Quaternions are normalized after every step, so their norms stay 1 to
//! a few ulps (1e-15); 1e-13 allows for the output's rounding.

#[path = "../examples/long_run.rs"]
#[allow(dead_code)]
mod example;

#[test]
fn t_push_long_run_keeps_memory_steady() {
    let p = example::t_push(100_000, |_, _| {});
    assert!(
        p.live_max - p.live_after_warmup <= 4096,
        "live heap grew: {p:?}"
    );
    // The finger makes and breaks contact every second: about 400 changes in 200 s.
    assert!(p.contact_changes >= 200, "the finger did not push: {p:?}");
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

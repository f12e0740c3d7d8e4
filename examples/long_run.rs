//! Long run through the C ABI (`fmi2*` exports of the crate), for the load part of the
//! hardening issue: `t_push` stepped for a million communication steps of 2 ms (2000 s
//! simulated) with its finger pushing the T in a closed loop (contact made and broken every
//! second), then `box_stack` (three free bodies: quaternions) stepped as long, and per phase:
//! the live heap bytes of the stepping thread (a counting allocator), the resident set size,
//! the quaternion norms' largest distance from 1, and the time per step.
//!
//! ```sh
//! cargo run --release --example long_run               # 1e6 steps each (t_push ~ 0.5 ms/step: minutes)
//! cargo run --release --example long_run -- 100000     # fewer
//! cargo run --release --example long_run -- 1000000 t_push   # one scene
//! ```
//!
//! `tests/long_run.rs` runs the same code for 2·10⁴ steps and asserts that the live heap does
//! not grow and the norms stay at 1 to rounding.

use scm::fmi::ffi::*;
#[path = "support/host.rs"]
mod host;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::Path;

/// The system allocator, counting the bytes live per thread (allocations minus frees on the
/// same thread): a thread that steps one instance sees exactly that instance's heap.
pub struct Counting;

thread_local! {
    static LIVE: Cell<isize> = const { Cell::new(0) };
}

fn add(bytes: isize) {
    // `try_with`: no panic during thread teardown.
    let _ = LIVE.try_with(|l| l.set(l.get() + bytes));
}

// SAFETY: forwards to the system allocator unchanged.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        add(layout.size() as isize);
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        add(layout.size() as isize);
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        add(-(layout.size() as isize));
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        add(new_size as isize - layout.size() as isize);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Live heap bytes allocated by this thread and not freed.
pub fn live_bytes() -> isize {
    LIVE.with(|l| l.get())
}

/// Resident set size of the process (bytes), from `/proc/self/statm` (0 where unavailable).
pub fn rss_bytes() -> usize {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| {
            s.split_whitespace()
                .nth(1)
                .and_then(|p| p.parse::<usize>().ok())
        })
        .map_or(0, |pages| pages * 4096)
}

/// An instance of a bundled scene through the C ABI, its resources unpacked into a temporary
/// folder as `scm pack` lays them out.
pub struct Run {
    fmu: host::Instance,
}

impl Run {
    /// Instantiates and initializes `scene` (Co-Simulation).
    pub fn new(scene: &str) -> Run {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("resources/scenes")
            .join(format!("{scene}.xml"));
        let tag = format!("long-run-{scene}-{:?}", std::thread::current().id());
        let dir = host::unpack_scene(&path, &tag).unwrap();
        let fmu = host::Instance::new(&dir, fmi2CoSimulation, host::quiet())
            .unwrap_or_else(|e| panic!("{scene}: {e}"));
        fmu.initialize().unwrap();
        Run { fmu }
    }

    /// Value reference of a variable.
    pub fn vr(&self, name: &str) -> u32 {
        self.fmu.vr(name).unwrap()
    }

    /// Every value reference whose name ends with `suffix`.
    pub fn vrs_ending(&self, suffix: &str) -> Vec<u32> {
        self.fmu
            .names()
            .iter()
            .enumerate()
            .filter(|(_, n)| n.ends_with(suffix))
            .map(|(i, _)| i as u32)
            .collect()
    }

    /// Reads a Real.
    pub fn get(&self, vr: u32) -> f64 {
        self.fmu.get_real(&[vr]).unwrap()[0]
    }

    /// Sets a Real.
    pub fn set(&self, vr: u32, v: f64) {
        self.fmu.set_real(&[vr], &[v]).unwrap();
    }

    /// One communication step from `t` by `h`; panics on anything but `fmi2OK`.
    pub fn step(&self, t: f64, h: f64) {
        assert_eq!(self.fmu.do_step(t, h), fmi2OK, "fmi2DoStep at t = {t}");
    }
}

/// What a phase of the long run measured.
#[derive(Debug)]
pub struct Phase {
    /// Steps taken.
    pub steps: usize,
    /// Live heap bytes of the stepping thread after the warm-up and at the end.
    pub live_after_warmup: isize,
    /// See `live_after_warmup`.
    pub live_at_end: isize,
    /// The largest live heap reading after the warm-up.
    pub live_max: isize,
    /// Largest |‖q‖ − 1| over every quaternion at every step.
    pub max_quat_norm_error: f64,
    /// Wall time per step (s).
    pub seconds_per_step: f64,
    /// Contact on/off transitions seen (a pair's smooth distance crossing 1 mm).
    pub contact_changes: usize,
    /// Largest |coordinate| of every position output at the end (finite means the run stayed finite).
    pub max_abs_position: f64,
}

/// Steps `scene` for `steps` communication steps of `h` (s); `drive(run, t)` sets the inputs
/// before each step. The warm-up is the first tenth of the run.
pub fn phase(
    scene: &str,
    steps: usize,
    h: f64,
    mut drive: impl FnMut(&Run, f64),
    mut progress: impl FnMut(usize, isize),
) -> Phase {
    let run = Run::new(scene);
    let w: Vec<u32> = run.vrs_ending(".quat.w");
    let distances = run.vrs_ending(".distance");
    let positions: Vec<u32> = run
        .fmu
        .names()
        .iter()
        .enumerate()
        .filter(|(_, n)| n.ends_with(".q") || n.contains(".pos."))
        .map(|(i, _)| i as u32)
        .collect();
    let warmup = (steps / 10).max(1);
    let (mut live_after_warmup, mut live_max, mut max_err, mut changes) =
        (0, isize::MIN, 0.0f64, 0);
    let mut touching: Vec<bool> = distances.iter().map(|&d| run.get(d) < 1e-3).collect();
    let started = std::time::Instant::now();
    for k in 0..steps {
        let t = k as f64 * h;
        drive(&run, t);
        run.step(t, h);
        for &wv in &w {
            let q: Vec<f64> = (0..4).map(|i| run.get(wv + i)).collect();
            max_err = max_err.max((q.iter().map(|x| x * x).sum::<f64>().sqrt() - 1.0).abs());
        }
        for (i, &d) in distances.iter().enumerate() {
            let now = run.get(d) < 1e-3;
            if now != touching[i] {
                changes += 1;
                touching[i] = now;
            }
        }
        if k + 1 == warmup {
            live_after_warmup = live_bytes();
        }
        if k + 1 >= warmup {
            live_max = live_max.max(live_bytes());
        }
        if (k + 1).is_multiple_of(10_000) {
            progress(k + 1, live_bytes());
        }
    }
    let seconds_per_step = started.elapsed().as_secs_f64() / steps as f64;
    let max_abs_position = positions
        .iter()
        .map(|&p| run.get(p).abs())
        .fold(0.0, f64::max);
    Phase {
        steps,
        live_after_warmup,
        live_at_end: live_bytes(),
        live_max,
        max_quat_norm_error: max_err,
        seconds_per_step,
        contact_changes: changes,
        max_abs_position,
    }
}

/// `t_push` with the finger following the T in a closed loop: its target is the contact point
/// under the T's stem (T centre + 9.75 cm in y, the stem's end plus the finger's radius, in the
/// finger's coordinates, which start 25 cm below the T) ± 1 cm at 1 Hz, so that it pushes for
/// half of every second and lets go for the other half; laterally it follows the T's centre.
pub fn t_push(steps: usize, progress: impl FnMut(usize, isize)) -> Phase {
    let mut vrs = None;
    phase(
        "t_push",
        steps,
        0.002,
        |run, t| {
            let (tx, ty, ax, ay) = *vrs.get_or_insert_with(|| {
                (
                    run.vr("t_x.q"),
                    run.vr("t_y.q"),
                    run.vr("act_x.ctrl"),
                    run.vr("act_y.ctrl"),
                )
            });
            run.set(ax, run.get(tx));
            run.set(
                ay,
                run.get(ty) + 0.0975 + 0.01 * (2.0 * std::f64::consts::PI * t).sin(),
            );
        },
        progress,
    )
}

/// `box_stack` (three free boxes settling on a plane and resting): the quaternion norms.
pub fn box_stack(steps: usize, progress: impl FnMut(usize, isize)) -> Phase {
    phase("box_stack", steps, 0.002, |_, _| {}, progress)
}

#[allow(dead_code)]
fn main() {
    let steps: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().expect("STEPS"))
        .unwrap_or(1_000_000);
    type Driver = fn(usize, &mut dyn FnMut(usize, isize)) -> Phase;
    let phases: [(&str, Driver); 2] = [
        ("t_push", |n, p| t_push(n, p)),
        ("box_stack", |n, p| box_stack(n, p)),
    ];
    let only: Vec<String> = std::env::args().skip(2).collect();
    for (name, f) in phases
        .into_iter()
        .filter(|(n, _)| only.is_empty() || only.iter().any(|o| o == n))
    {
        let mut report = |k: usize, live: isize| {
            if k.is_multiple_of(100_000) {
                println!(
                    "{name}: step {k}: live heap {live} B, RSS {:.1} MB",
                    rss_bytes() as f64 / 1e6
                );
            }
        };
        let rss0 = rss_bytes();
        let p = f(steps, &mut report);
        println!(
            "{name}: {} steps, {:.1} µs/step; live heap after warm-up {} B, at the end {} B, max {} B (growth {} B); RSS {:.1} -> {:.1} MB; max |‖q‖-1| = {:.2e}; contact changes {}; max |position| {:.3} m",
            p.steps,
            1e6 * p.seconds_per_step,
            p.live_after_warmup,
            p.live_at_end,
            p.live_max,
            p.live_at_end - p.live_after_warmup,
            rss0 as f64 / 1e6,
            rss_bytes() as f64 / 1e6,
            p.max_quat_norm_error,
            p.contact_changes,
            p.max_abs_position
        );
    }
}

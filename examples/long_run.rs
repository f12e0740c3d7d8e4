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
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::ffi::CString;
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
    c: fmi2Component,
    names: Vec<String>,
    _callbacks: Box<fmi2CallbackFunctions>,
}

impl Run {
    /// Instantiates and initializes `scene` (Co-Simulation).
    pub fn new(scene: &str) -> Run {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("resources/scenes")
            .join(format!("{scene}.xml"));
        let d = scm::pack::describe(&path).unwrap();
        let dir = std::env::temp_dir()
            .join(format!(
                "scm-long-run-{}-{scene}-{:?}",
                std::process::id(),
                std::thread::current().id()
            ))
            .join("resources");
        for (file, bytes) in &d.resources {
            let p = dir.join(file);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, bytes).unwrap();
        }
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(scm::sim::SCENE_FILE), &d.scene_text).unwrap();
        let uri = CString::new(format!("file://{}", dir.display())).unwrap();
        let guid = CString::new(scm::sim::guid(&d.scene_text)).unwrap();
        let names = scm::sim::Simulation::from_file(&path)
            .unwrap()
            .rows()
            .iter()
            .map(|(v, _)| v.name.clone())
            .collect();
        let callbacks = Box::new(fmi2CallbackFunctions {
            logger: None,
            allocateMemory: None,
            freeMemory: None,
            stepFinished: None,
            componentEnvironment: std::ptr::null_mut(),
        });
        unsafe {
            let c = scm::fmi2Instantiate(
                c"long".as_ptr(),
                fmi2CoSimulation,
                guid.as_ptr(),
                uri.as_ptr(),
                &*callbacks,
                0,
                0,
            );
            assert!(!c.is_null(), "{scene}: fmi2Instantiate failed");
            assert_eq!(scm::fmi2EnterInitializationMode(c), fmi2OK);
            assert_eq!(scm::fmi2ExitInitializationMode(c), fmi2OK);
            Run {
                c,
                names,
                _callbacks: callbacks,
            }
        }
    }

    /// Value reference of a variable.
    pub fn vr(&self, name: &str) -> u32 {
        self.names
            .iter()
            .position(|n| n == name)
            .unwrap_or_else(|| panic!("no variable {name}")) as u32
    }

    /// Every value reference whose name ends with `suffix`.
    pub fn vrs_ending(&self, suffix: &str) -> Vec<u32> {
        self.names
            .iter()
            .enumerate()
            .filter(|(_, n)| n.ends_with(suffix))
            .map(|(i, _)| i as u32)
            .collect()
    }

    /// Reads a Real.
    pub fn get(&self, vr: u32) -> f64 {
        let mut v = f64::NAN;
        assert_eq!(unsafe { scm::fmi2GetReal(self.c, &vr, 1, &mut v) }, fmi2OK);
        v
    }

    /// Sets a Real.
    pub fn set(&self, vr: u32, v: f64) {
        assert_eq!(unsafe { scm::fmi2SetReal(self.c, &vr, 1, &v) }, fmi2OK);
    }

    /// One communication step from `t` by `h`; panics on anything but `fmi2OK`.
    pub fn step(&self, t: f64, h: f64) {
        let s = unsafe { scm::fmi2DoStep(self.c, t, h, fmi2True) };
        assert_eq!(s, fmi2OK, "fmi2DoStep at t = {t}");
    }
}

impl Drop for Run {
    fn drop(&mut self) {
        unsafe { scm::fmi2FreeInstance(self.c) };
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
        .names
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

//! Pair-force evaluation, pruned against naive: sphere–box and box–box at 100, 1k, 10k and
//! 100k points per body, time (criterion) and peak heap memory of one evaluation (a counting
//! global allocator). At the end a Markdown table of the same cases is printed (median of
//! repeated runs, measured in this run) for the README, then the targets from the
//! same rows: the sharp-ε time from 1k to 100k points per body (≤ 3×) and the memory at 100k ×
//! 100k (< 64 MB).
//!
//! `cargo bench --bench pair_contact` (all), `cargo bench --bench pair_contact -- table` (the
//! table only), `-- table sharp` or `-- table scene` (the table's rows of one ε only).
//!
//! The naive path is O(I1·I2): it is run up to 1k points per body (10k would take minutes per
//! evaluation) and marked "skipped" above.

use criterion::{criterion_group, BenchmarkId, Criterion};
use nalgebra::{Matrix3, Rotation3, Vector3};
use scm::collision::{Collider, Frame};
use scm::contact::{pair_contact, pair_contact_naive, ContactParams, Dissipation};
use scm::geometry::Shape;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Counts live heap bytes and their peak since the last reset.
struct Counting;
static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(l) };
        if !p.is_null() {
            let now = LIVE.fetch_add(l.size(), Ordering::Relaxed) + l.size();
            PEAK.fetch_max(now, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) };
        LIVE.fetch_sub(l.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Spacing that gives about `n` points on a surface of `area` (m²).
fn spacing_for(area: f64, n: usize) -> f64 {
    (area / n as f64).sqrt()
}

struct Case {
    name: &'static str,
    a: Collider,
    b: Collider,
    fa: Frame<f64>,
    fb: Frame<f64>,
}

/// Sphere (r = 5 cm) resting 1 mm deep on a box (20 × 20 × 10 cm), and a box (10 cm cube)
/// tilted onto the same box, its lowest corner 1 mm deep: `n` points per body (about).
fn cases(n: usize) -> Vec<Case> {
    let big = Shape::Box {
        half: Vector3::new(0.1, 0.1, 0.05),
    };
    let big = Collider::Aopc(big.sample(spacing_for(2.0 * (0.04 + 0.02 + 0.02), n)));
    let sphere = Collider::Aopc(
        Shape::Sphere { radius: 0.05 }
            .sample(spacing_for(4.0 * std::f64::consts::PI * 0.05 * 0.05, n)),
    );
    let cube = Collider::Aopc(
        Shape::Box {
            half: Vector3::repeat(0.05),
        }
        .sample(spacing_for(6.0 * 0.01, n)),
    );
    let at = |z: f64, rot: Matrix3<f64>| Frame {
        rotation: rot,
        origin: Vector3::new(0.0, 0.0, z),
        linvel: Vector3::new(0.01, 0.0, -0.01),
        angvel: Vector3::new(0.0, 0.1, 0.0),
    };
    let tilt = Rotation3::from_euler_angles(0.3, 0.4, 0.1).into_inner();
    // Lowest corner of the tilted cube: the smallest z over its corners.
    let low = (0..8)
        .map(|i| {
            (tilt
                * Vector3::new(
                    if i & 1 == 0 { -0.05 } else { 0.05 },
                    if i & 2 == 0 { -0.05 } else { 0.05 },
                    if i & 4 == 0 { -0.05 } else { 0.05 },
                ))
            .z
        })
        .fold(f64::INFINITY, f64::min);
    vec![
        Case {
            name: "sphere-box",
            a: big.clone(),
            b: sphere,
            fa: Frame::identity(),
            fb: at(0.05 + 0.05 - 0.001, Matrix3::identity()),
        },
        Case {
            name: "box-box",
            a: big,
            b: cube,
            fa: Frame::identity(),
            fb: at(0.05 - low - 0.001, tilt),
        },
    ]
}

/// The two ε settings: sharp (ε1 = 1e-9 m², ε2 = 1e-7 m: the points that matter stay a few at
/// every resolution) and the bundled scenes' (ε1 = 1e-5 m², ε2 = 1e-3 m: a band of ~4 cm of
/// the field carries weight, so its point count grows with the resolution).
fn params(sharp: bool) -> ContactParams<f64> {
    let (eps1, eps2) = if sharp { (1e-9, 1e-7) } else { (1e-5, 1e-3) };
    ContactParams {
        eps1,
        eps1_scale: [1.0; 2],
        eps2,
        eps3: 1e-4,
        stiffness: 1e4,
        dissipation_velocity: 0.1,
        stiction_velocity: 0.01,
        friction: 0.5,
        dissipation_force: f64::INFINITY,
        hold_separation: false,
        margin: 0.0,
        adhesion: 0.0,
        gap: 0.0,
        pull: None,
        surface: None,
        dissipation: Dissipation::Paper,
    }
}

const SIZES: [usize; 4] = [100, 1_000, 10_000, 100_000];
const NAIVE_MAX: usize = 1_000;

fn bench(c: &mut Criterion) {
    for n in SIZES {
        for case in cases(n) {
            for sharp in [true, false] {
                let prm = params(sharp);
                let label = format!("{}/{}", case.name, if sharp { "sharp" } else { "scene" });
                pair_contact(&case.a, &case.fa, &case.b, &case.fb, &prm); // builds the BVHs
                let mut g = c.benchmark_group(label);
                g.sample_size(10);
                g.bench_with_input(BenchmarkId::new("pruned", n), &n, |bch, _| {
                    bch.iter(|| pair_contact(&case.a, &case.fa, &case.b, &case.fb, &prm))
                });
                if n <= NAIVE_MAX {
                    g.bench_with_input(BenchmarkId::new("naive", n), &n, |bch, _| {
                        bch.iter(|| pair_contact_naive(&case.a, &case.fa, &case.b, &case.fb, &prm))
                    });
                }
                g.finish();
            }
        }
    }
}

/// Median time of `f` over runs filling about 0.5 s (at least 3), and the peak heap bytes of
/// one run beyond what was live before it.
fn measure(mut f: impl FnMut()) -> (f64, usize) {
    let live = LIVE.load(Ordering::Relaxed);
    PEAK.store(live, Ordering::Relaxed);
    let t0 = Instant::now();
    f();
    let first = t0.elapsed().as_secs_f64();
    let peak = PEAK.load(Ordering::Relaxed) - live;
    let runs = ((0.5 / first.max(1e-9)) as usize).clamp(3, 20_000);
    let mut times: Vec<f64> = (0..runs)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], peak)
}

fn fmt_time(s: f64) -> String {
    if s < 1e-3 {
        format!("{:.1} µs", s * 1e6)
    } else if s < 1.0 {
        format!("{:.2} ms", s * 1e3)
    } else {
        format!("{:.2} s", s)
    }
}

/// `only`: `Some(true)` prints the sharp rows alone, `Some(false)` the scene rows alone.
fn table(only: Option<bool>) {
    println!("\n| pair | ε | points per body (a + b) | pruned time | pruned peak memory | naive time | naive peak memory | body memory (AOPCs + BVHs) |");
    println!("| --- | --- | --- | --- | --- | --- | --- | --- |");
    // (pair, n, sharp, pruned time, pruned peak bytes, body bytes), for the summary below.
    let mut rows: Vec<(&str, usize, bool, f64, usize, usize)> = Vec::new();
    for n in SIZES {
        let live0 = LIVE.load(Ordering::Relaxed);
        let cs = cases(n);
        for case in &cs {
            pair_contact(&case.a, &case.fa, &case.b, &case.fb, &params(true)); // builds the BVHs
        }
        let body_mem = (LIVE.load(Ordering::Relaxed) - live0) / cs.len();
        for case in &cs {
            for sharp in [true, false] {
                if only.is_some_and(|o| o != sharp) {
                    continue;
                }
                let prm = params(sharp);
                let (tp, mp) = measure(|| {
                    std::hint::black_box(pair_contact(&case.a, &case.fa, &case.b, &case.fb, &prm));
                });
                let naive = if n <= NAIVE_MAX {
                    let (tn, mn) = measure(|| {
                        std::hint::black_box(pair_contact_naive(
                            &case.a, &case.fa, &case.b, &case.fb, &prm,
                        ));
                    });
                    (fmt_time(tn), format!("{:.1} kB", mn as f64 / 1e3))
                } else {
                    ("skipped (O(I1·I2))".into(), "–".into())
                };
                rows.push((case.name, n, sharp, tp, mp, body_mem));
                println!(
                    "| {} | {} | {} + {} | {} | {:.1} kB | {} | {} | {:.1} MB |",
                    case.name,
                    if sharp { "sharp" } else { "scene" },
                    case.a.len(),
                    case.b.len(),
                    fmt_time(tp),
                    mp as f64 / 1e3,
                    naive.0,
                    naive.1,
                    body_mem as f64 / 1e6
                );
            }
        }
    }
    // The targets, from this run's rows: time growing at most 3× from 1k to 100k
    // points per body at fixed (sharp) ε, memory under 64 MB at 100k × 100k.
    let largest = SIZES[SIZES.len() - 1];
    let kilo = |n: usize| {
        if n.is_multiple_of(1000) {
            format!("{}k", n / 1000)
        } else {
            n.to_string()
        }
    };
    let at = |name: &str, n: usize, sharp: bool| {
        rows.iter()
            .find(|r| r.0 == name && r.1 == n && r.2 == sharp)
    };
    for name in ["sphere-box", "box-box"] {
        if let (Some(small), Some(big)) = (at(name, 1000, true), at(name, largest, true)) {
            println!("{name}, sharp ε: pruned time {} → {} from 1k to {} points per body, {:.1}× (target ≤ 3×)", fmt_time(small.3), fmt_time(big.3), kilo(largest), big.3 / small.3);
        }
        for sharp in [true, false] {
            if let Some(big) = at(name, largest, sharp) {
                let total = (big.4 + big.5) as f64 / 1e6;
                println!("{name}, {} ε, {} points per body: {:.1} MB of bodies + {:.2} MB per evaluation = {total:.1} MB (target < 64 MB)", if sharp { "sharp" } else { "scene" }, kilo(largest), big.5 as f64 / 1e6, big.4 as f64 / 1e6);
            }
        }
    }
}

criterion_group!(benches, bench);

fn main() {
    let table_only = std::env::args().any(|a| a == "table");
    if !table_only {
        benches();
        Criterion::default().configure_from_args().final_summary();
    }
    let only = if std::env::args().any(|a| a == "sharp") {
        Some(true)
    } else if std::env::args().any(|a| a == "scene") {
        Some(false)
    } else {
        None
    };
    table(only);
}

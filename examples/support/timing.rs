//! Timing shared by the measuring examples (`step_cost`, `pair_stats`), included with
//! `#[path]`: Cargo builds `examples/*.rs` as examples and leaves this folder alone.

use std::time::Instant;

/// Median time per call (s) of each function, over 9 rounds; each round runs one batch of every
/// function in turn (batches sized so that all rounds together take about `budget` seconds), so
/// a change of machine load hits every function alike and their ratios stay meaningful.
pub fn time_interleaved(budget: f64, fs: &mut [&mut dyn FnMut()]) -> Vec<f64> {
    let rounds = 9;
    let per_fn = budget / (rounds * fs.len()) as f64;
    let sizes: Vec<usize> = fs
        .iter_mut()
        .map(|f| {
            let t = Instant::now();
            f();
            ((per_fn / t.elapsed().as_secs_f64().max(1e-9)).floor() as usize).max(1)
        })
        .collect();
    let mut samples = vec![Vec::with_capacity(rounds); fs.len()];
    for _ in 0..rounds {
        for (k, f) in fs.iter_mut().enumerate() {
            let t = Instant::now();
            for _ in 0..sizes[k] {
                f();
            }
            samples[k].push(t.elapsed().as_secs_f64() / sizes[k] as f64);
        }
    }
    samples
        .into_iter()
        .map(|mut s| {
            s.sort_by(f64::total_cmp);
            s[rounds / 2]
        })
        .collect()
}

//! Time per step of every integrator on `t_push` at h = 2 ms, measured in one run:
//! `cargo run --release --example step_timing`.
//!
//! The finger pushes the T as in the paper's rollouts: it approaches for 1 s (no contact), then
//! pushes the T for 1.5 s. Every integrator runs the same 2.5 s in communication steps of 2 ms
//! (the internal step of the fixed-step methods; `dopri5` chooses its own inside, with
//! `solver.step` = 2 ms as its largest). Reported: wall time per 2 ms step, over the contact-free
//! approach and over the push, and the ratio to semi-implicit Euler.

use scm::integrate::Integrator;
use scm::sim::{Simulation, Value};
use std::path::PathBuf;
use std::time::Instant;

fn main() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("resources/scenes/t_push.xml");
    let h = 0.002;
    let mut rows = Vec::new();
    for integrator in Integrator::ALL {
        let mut sim = Simulation::from_file(&path).expect("t_push loads");
        sim.model.integrator = integrator;
        sim.model.timestep = h;
        let (mut free, mut contact) = (0.0, 0.0);
        let n = (2.5 / h).round() as usize;
        for k in 0..n {
            let t = k as f64 * h;
            sim.set("act_x.ctrl", Value::Real(0.01)).expect("input");
            sim.set("act_y.ctrl", Value::Real((0.1 * t).min(0.25)))
                .expect("input");
            let start = Instant::now();
            if let Err(e) = sim.advance(h) {
                println!("{}: refused at t = {t}: {e}", integrator.name());
                break;
            }
            let dt = start.elapsed().as_secs_f64();
            if t < 1.0 {
                free += dt;
            } else {
                contact += dt;
            }
        }
        let per = |total: f64, steps: f64| total / steps * 1e6;
        rows.push((
            integrator.name(),
            per(free, 1.0 / h),
            per(contact, 1.5 / h),
            sim.data.current.state.q[1],
        ));
    }
    let base = rows
        .iter()
        .find(|r| r.0 == "semi_implicit_euler")
        .map(|r| (r.1, r.2))
        .unwrap_or((1.0, 1.0));
    println!("t_push, h = 2 ms: wall time per step (µs) and ratio to semi_implicit_euler");
    println!(
        "{:<22} {:>12} {:>7} {:>12} {:>7} {:>14}",
        "integrator", "no contact", "ratio", "pushing", "ratio", "T moved (m)"
    );
    for (name, free, contact, moved) in rows {
        println!(
            "{name:<22} {free:>12.1} {:>7.2} {contact:>12.1} {:>7.2} {moved:>14.5}",
            free / base.0,
            contact / base.1
        );
    }
}

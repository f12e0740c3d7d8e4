//! Pair and step cost on one scene at a chosen state, measured in one run (a diagnostic for
//! the contact pipeline's speed):
//!
//! ```text
//! pair_stats SCENE.xml [--set NAME=VALUE]... [--warmup S] [--naive] [--profile pair|pair_kept|proof|step|jacobian N]
//! ```
//! The state is reached by simulating `--warmup` seconds with the `--set` values (e.g.
//! `--set act_y.ctrl=0.13 --warmup 0.5` presses the finger of `t_push.xml` against the T, as
//! the report's speed study does). Printed: per pair the band statistics (query points
//! evaluated and skipped, plane terms visited), whether it is out of reach
//! (`collision::out_of_reach`), the time of that proof and of one pruned pair evaluation, and
//! with `--naive` of one naive one; then the time of one `Model::step` (the scene's integrator, `f64`) and of
//! the full step Jacobian with respect to `(q, v, u)` (`derivatives::step_jacobian`), all timed
//! in interleaved rounds. With `--profile`, only that quantity runs N times (for callgrind).
use scm::collision::separation_band;
use scm::contact::{pair_contact, pair_contact_memo, pair_contact_naive};
use scm::integrate::State;
use scm::sim::{Simulation, Value};
use std::hint::black_box;
use std::time::Instant;

#[path = "support/timing.rs"]
mod timing;
use timing::time_interleaved;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).expect("usage: pair_stats SCENE.xml [--set NAME=VALUE]... [--warmup S] [--naive] [--profile pair|pair_kept|proof|step|jacobian N]");
    let mut sim = Simulation::from_file(std::path::Path::new(path)).expect("scene");
    let (mut warmup, mut profile): (f64, Option<(String, usize)>) = (0.0, None);
    let mut long = false;
    let mut i = 2;
    while i < args.len() {
        match args[i].as_str() {
            "--set" => {
                let (n, x) = args[i + 1].split_once('=').expect("NAME=VALUE");
                sim.set(n, Value::Real(x.parse().expect("number")))
                    .expect("set");
            }
            "--warmup" => warmup = args[i + 1].parse().expect("seconds"),
            "--naive" => {
                long = true;
                i -= 1;
            }
            "--profile" => {
                profile = Some((
                    args[i + 1].clone(),
                    args[i + 2].parse::<usize>().expect("N"),
                ));
                i += 1;
            }
            other => panic!("unknown option {other}"),
        }
        i += 2;
    }
    sim.initialize().expect("init");
    let n = (warmup / 0.002).round() as usize;
    for _ in 0..n {
        sim.advance(0.002).expect("warm-up step");
    }
    let m = sim.model.clone();
    let state = sim.data.current.state.clone();
    let u = sim.inputs();
    let prm = sim.data.current.params;
    let h = m.timestep;
    let kin = m
        .tree
        .kinematics_with(&state.q, &state.v, &u[m.actuators.len()..]);
    let point = scm::derivatives::Point {
        q: state.q.clone(),
        v: state.v.clone(),
        u: u.clone(),
        params: prm,
        act: Vec::new(),
    };
    let jac = || {
        scm::derivatives::step_jacobian_state(
            &m,
            m.integrator,
            &point,
            h,
            scm::derivatives::Coordinates::Embedded,
        )
        .expect("jacobian")
    };
    let step = || {
        m.step(&State::new(state.q.clone(), state.v.clone()), &u, &prm, h)
            .expect("step")
    };
    if let Some((what, n)) = profile {
        let mut f: Box<dyn FnMut()> = match what.as_str() {
            "pair" => Box::new(|| {
                for p in &m.pairs {
                    if let (Some(a), Some(b)) = (&m.colliders[p.a], &m.colliders[p.b]) {
                        let own = p.params(&prm);
                        black_box(pair_contact(a, &kin.frames[p.a], b, &kin.frames[p.b], &own));
                    }
                }
            }),
            "pair_kept" => {
                let mut kept = vec![scm::collision::CandidateMemo::default(); m.pairs.len()];
                let mut scratch = scm::collision::Scratch::default();
                Box::new(move || {
                    for (p, kept) in m.pairs.iter().zip(&mut kept) {
                        if let (Some(a), Some(b)) = (&m.colliders[p.a], &m.colliders[p.b]) {
                            let (fa, fb) = (&kin.frames[p.a], &kin.frames[p.b]);
                            let s = &mut scratch;
                            let own = p.params(&prm);
                            black_box(pair_contact_memo(a, fa, b, fb, &own, Some(kept), s));
                        }
                    }
                })
            }
            "proof" => {
                let mut scratch = scm::collision::Scratch::default();
                Box::new(move || {
                    for p in &m.pairs {
                        if let (Some(a), Some(b)) = (&m.colliders[p.a], &m.colliders[p.b]) {
                            let (fa, fb) = (&kin.frames[p.a], &kin.frames[p.b]);
                            let rels = [fa.relative_to(fb), fb.relative_to(fa)];
                            let reach = p.params(&prm).reach();
                            black_box(scm::collision::out_of_reach(
                                a,
                                b,
                                &rels,
                                &reach,
                                &mut scratch,
                            ));
                        }
                    }
                })
            }
            "step" => Box::new(|| drop(black_box(step()))),
            "jacobian" => Box::new(|| drop(black_box(jac()))),
            other => panic!("--profile {other}: pair, pair_kept, proof, step or jacobian"),
        };
        profiled_section(n, &mut f);
        return;
    }
    println!("state after {warmup} s: q = {:?}", state.q);
    for p in &m.pairs {
        let (Some(a), Some(b)) = (&m.colliders[p.a], &m.colliders[p.b]) else {
            continue;
        };
        let (fa, fb) = (&kin.frames[p.a], &kin.frames[p.b]);
        // The pair's own parameters (its ε1 from its spacing, its stiffness from the file).
        let own = p.params(&prm);
        let band = separation_band(a, fa, b, fb, own.eps1_sides(), own.eps2);
        let mut terms = 0;
        for e in &band.entries {
            let (q, fq, pl, fp) = if e.side == 0 {
                (a, fa, b, fb)
            } else {
                (b, fb, a, fa)
            };
            let (scm::collision::Collider::Aopc(qs), scm::collision::Collider::Aopc(ps)) = (q, pl)
            else {
                continue;
            };
            let rel = fq.relative_to(fp);
            let x = rel.rotation * qs.bvh().points[e.k as usize] + rel.translation;
            terms += count_terms(ps, &x, own.eps1_sides()[e.side as usize]);
        }
        let pc = pair_contact(a, fa, b, fb, &own);
        println!(
            "{} - {}: {} + {} points; band: {} evaluated, {} within the cutoff, {} points not in it, {} plane terms, min Φ {:.3e} m; D = {:.4e} m, force on a {:?}",
            m.tree.bodies[p.a].name,
            m.tree.bodies[p.b].name,
            a.len(),
            b.len(),
            band.evaluated,
            band.entries.len(),
            band.skipped,
            terms,
            band.min,
            pc.distance,
            pc.on_a.force.as_slice()
        );
        let rels = [fa.relative_to(fb), fb.relative_to(fa)];
        let (mut proof_scratch, mut scratch) = Default::default();
        let mut proof =
            move || scm::collision::out_of_reach(a, b, &rels, &own.reach(), &mut proof_scratch);
        let far = proof();
        let mut kept = scm::collision::CandidateMemo::default();
        let times = time_interleaved(
            0.05,
            &mut [
                &mut || {
                    black_box(proof());
                },
                &mut || {
                    black_box(pair_contact(a, fa, b, fb, &own));
                },
                &mut || {
                    let s = &mut scratch;
                    black_box(pair_contact_memo(a, fa, b, fb, &own, Some(&mut kept), s));
                },
            ],
        );
        println!(
            "  {}: proof {:.2} µs, pruned pair evaluation {:.2} µs ({:.2} µs with kept candidates, all served: the same pose again; {:?}, {} bytes kept)",
            if far { "out of reach" } else { "in reach" },
            times[0] * 1e6,
            times[1] * 1e6,
            times[2] * 1e6,
            kept.counts(),
            kept.heap_bytes()
        );
        if !long {
            continue;
        }
        let t = Instant::now();
        let nn = 5;
        for _ in 0..nn {
            black_box(pair_contact_naive(a, fa, b, fb, &own));
        }
        println!(
            "  naive pair evaluation: {:.1} µs",
            t.elapsed().as_secs_f64() / nn as f64 * 1e6
        );
    }
    let pair_all = || {
        for p in &m.pairs {
            if let (Some(a), Some(b)) = (&m.colliders[p.a], &m.colliders[p.b]) {
                let own = p.params(&prm);
                black_box(pair_contact(a, &kin.frames[p.a], b, &kin.frames[p.b], &own));
            }
        }
    };
    let times = time_interleaved(
        1.5,
        &mut [
            &mut || pair_all(),
            &mut || drop(black_box(step())),
            &mut || drop(black_box(jac())),
        ],
    );
    println!("pruned pairs {:.2} µs; step ({}) {:.2} µs; step Jacobian w.r.t. (q, v, u) {:.2} µs = {:.2} steps", times[0] * 1e6, m.integrator.name(), times[1] * 1e6, times[2] * 1e6, times[2] / times[1]);
}

/// What callgrind looks at (`--toggle-collect='*profiled_section*'`).
#[inline(never)]
fn profiled_section(n: usize, f: &mut dyn FnMut()) {
    for _ in 0..n {
        f();
    }
}

fn count_terms(s: &scm::geometry::Aopc, x: &nalgebra::Vector3<f64>, eps1: f64) -> usize {
    let mut n = 0;
    scm::geometry::ssdf::visit_relevant(s, x, eps1, |_, _| n += 1);
    n
}

//! Prints band statistics and timings of one scene's pairs at its initial state (a diagnostic
//! for the pruning; `cargo run --release --example pair_stats resources/scenes/t_push.xml`).
use scm::collision::separation_band;
use scm::contact::{pair_contact, pair_contact_naive};
use std::time::Instant;

fn main() {
    let path = std::env::args().nth(1).expect("scene path");
    let sc = scm::scene::load(std::path::Path::new(&path)).expect("scene");
    let m = &sc.model;
    let kin = m.tree.kinematics(&m.tree.q0(), &vec![0.0; m.tree.nv]);
    for p in &m.pairs {
        let (Some(a), Some(b)) = (&m.colliders[p.a], &m.colliders[p.b]) else { continue };
        let (fa, fb) = (&kin.frames[p.a], &kin.frames[p.b]);
        let band = separation_band(a, fa, b, fb, m.contact.eps1, m.contact.eps2);
        let mut terms = 0;
        for e in &band.entries {
            let (q, fq, pl, fp) = if e.side == 0 { (a, fa, b, fb) } else { (b, fb, a, fa) };
            let (scm::collision::Collider::Aopc(qs), scm::collision::Collider::Aopc(ps)) = (q, pl) else { continue };
            let rel = fq.relative_to(fp);
            let x = rel.rotation * qs.bvh().points[e.k as usize] + rel.translation;
            terms += count_terms(ps, &x, m.contact.eps1);
        }
        println!("plane terms per SSDF pass: {terms}; band min {:.4}", band.min);
        let n = 2000;
        let t = Instant::now();
        for _ in 0..n {
            std::hint::black_box(pair_contact(a, fa, b, fb, &m.contact));
        }
        let pruned = t.elapsed().as_secs_f64() / n as f64;
        let t = Instant::now();
        let nn = 20;
        for _ in 0..nn {
            std::hint::black_box(pair_contact_naive(a, fa, b, fb, &m.contact));
        }
        let naive = t.elapsed().as_secs_f64() / nn as f64;
        println!(
            "{} - {}: {} + {} points, {} evaluated, {} skipped; pruned {:.1} us, naive {:.1} us",
            m.tree.bodies[p.a].name, m.tree.bodies[p.b].name, a.len(), b.len(), band.entries.len(), band.skipped, pruned * 1e6, naive * 1e6
        );
    }
}

#[allow(dead_code)]
fn count_terms(s: &scm::geometry::Aopc, x: &nalgebra::Vector3<f64>, eps1: f64) -> usize {
    let mut n = 0;
    scm::geometry::ssdf::visit_relevant(s, x, eps1, s.bvh().nearest(x).1, |_, _| n += 1);
    n
}

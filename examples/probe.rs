use scm::geometry::{ssdf, Shape};
use nalgebra::Vector3;
fn main() {
    let shapes = [Shape::Sphere{radius:0.1}, Shape::Box{half: Vector3::new(0.1,0.06,0.04)}];
    for sh in shapes {
      for sp in [0.02, 0.01, 0.005] {
        let a = sh.sample(sp);
        for e1 in [0.1*sp*sp, 0.01*sp*sp] {
          // query points: random directions, band ±2 mm around the surface
          let mut maxe: f64 = 0.0; let mut seed = 12345u64;
          let mut rnd = || { seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); ((seed >> 11) as f64) / ((1u64<<53) as f64) };
          for _ in 0..400 {
            let d = Vector3::new(rnd()-0.5, rnd()-0.5, rnd()-0.5).normalize();
            // project to surface along d by bisection on exact sdf
            let (mut lo, mut hi) = (0.0, 1.0);
            for _ in 0..60 { let m = 0.5*(lo+hi); if sh.sdf(&(d*m)) > 0.0 { hi = m } else { lo = m } }
            let off = (rnd()-0.5)*0.004;
            let p = d*lo + d*off;
            let e = (ssdf(&a, &p, e1) - sh.sdf(&p)).abs();
            maxe = maxe.max(e);
          }
          println!("{:?} spacing {sp} n={} eps1 {e1}: max err {:.3e}", sh, a.len(), maxe);
        }
      }
    }
}

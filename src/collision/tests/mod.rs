//! Tests of the collision bounds (`bounds.rs`) and of the band walk and the reach proofs
//! against the naive evaluation (`band.rs`), with their shared samplers.

use super::bounds::*;
use super::reach::cloud_beyond_with;
use super::settle::seed_within;
use super::*;
use crate::geometry::Shape;

use crate::geometry::lcg;

fn vec3(s: &mut u64) -> Vector3<f64> {
    Vector3::new(lcg(s), lcg(s), lcg(s))
}

/// A point of the region: a random offset in the ball, projected into the slab along `m`.
fn sample_region(q: &QueryRegion, s: &mut u64) -> Vector3<f64> {
    loop {
        let y = vec3(s) * q.radius;
        let h = q.m.dot(&y);
        if y.norm() <= q.radius && h >= q.lo && h <= q.hi {
            return q.centre + y;
        }
        // Move it into the slab along m, keeping it in the ball when possible.
        let hc = h.clamp(q.lo, q.hi);
        let y2 = y + q.m * (hc - h);
        if y2.norm() <= q.radius {
            return q.centre + y2;
        }
    }
}

mod band;
mod bounds;
mod room;
mod shapes;

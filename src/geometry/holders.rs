//! Segments that hold a cloud: where a cloud carries a sphere's, a capsule's or a rounded
//! union's certificate ([`super::radial`], [`super::spine`], [`super::rounded`]), every one of
//! its points lies within a known distance of one of a few segments (a sphere's is a point).
//! With the distance between two segments in closed form ([`segment_distance`]), that bounds
//! from below the distance from every point of one cloud to a segment of another at once,
//! without walking either hierarchy (`collision::shapes`).

use super::bvh::Bvh;
use nalgebra::Vector3;

/// One segment holding part of a cloud: each of those points lies within `reach` (m) of the
/// segment from `start` to `end` (body frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Holder {
    /// One end (m).
    pub start: Vector3<f64>,
    /// The other end (m); `start` for a sphere.
    pub end: Vector3<f64>,
    /// The largest distance of a held point from the segment (m, rounded up).
    pub reach: f64,
}

/// The segments that hold every point of `bvh`'s cloud, from its certificates: a sampled
/// sphere's centre, a capsule's spine, each member of a rounded union that kept points (a
/// point's distance from its own spine point is at most the certificate's `r_hi`, and its
/// distance from the segment at most that). None for a cloud without one of those. Without
/// allocating: a proof asks at every forward.
pub fn holders(bvh: &Bvh) -> impl Iterator<Item = Holder> + '_ {
    let radial = bvh.radial.iter().map(|r| Holder {
        start: r.centre,
        end: r.centre,
        reach: r.r_hi,
    });
    let spine = bvh.spine.iter().map(|s| Holder {
        start: s.start,
        end: s.end,
        reach: s.r_hi,
    });
    let members = bvh
        .rounded
        .iter()
        .flat_map(|u| u.members.iter())
        .filter(|m| m.r_hi > 0.0)
        .map(|m| Holder {
            start: m.start,
            end: m.end,
            reach: m.r_hi,
        });
    radial.chain(spine).chain(members)
}

/// A lower bound of the distance (m) between the segments `a0`–`a1` and `b0`–`b1` (either
/// may be a point), to within a relative allowance of 1e-9 of their extent.
///
/// The squared distance `f(s, t) = |w + s u - t v|²` (`u = a1 - a0`, `v = b1 - b0`,
/// `w = a0 - b0`) is a convex quadratic over the square `[0, 1]²`, so its least value there is
/// either its unconstrained minimum, where that lies inside the square and is unique (the
/// segments not parallel), or the least over one of the four edges, each a convex parabola
/// whose minimum on `[0, 1]` is its vertex clamped. All five are taken. The allowance covers
/// the rounding of the closed forms, which leaves the points found slightly off the minimiser.
pub fn segment_distance(
    a0: &Vector3<f64>,
    a1: &Vector3<f64>,
    b0: &Vector3<f64>,
    b1: &Vector3<f64>,
) -> f64 {
    let (u, v, w) = (a1 - a0, b1 - b0, a0 - b0);
    let (uu, uv, vv) = (u.norm_squared(), u.dot(&v), v.norm_squared());
    let (uw, vw) = (u.dot(&w), v.dot(&w));
    let at = |s: f64, t: f64| (w + u * s - v * t).norm();
    // The best `t` for a fixed `s` (the edge `s` = 0 or 1), and the best `s` for a fixed `t`.
    let best_t = |s: f64| {
        if vv > 0.0 {
            ((vw + s * uv) / vv).clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    let best_s = |t: f64| {
        if uu > 0.0 {
            ((t * uv - uw) / uu).clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    let mut gap = at(0.0, best_t(0.0))
        .min(at(1.0, best_t(1.0)))
        .min(at(best_s(0.0), 0.0))
        .min(at(best_s(1.0), 1.0));
    let denom = uu * vv - uv * uv;
    if denom > 1e-12 * uu * vv {
        let s = (uv * vw - vv * uw) / denom;
        let t = (uu * vw - uv * uw) / denom;
        if (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t) {
            gap = gap.min(at(s, t));
        }
    }
    let extent = u.norm() + v.norm() + w.norm();
    (gap - 1e-9 * extent).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The least distance over a fine grid of both segments: at least the true distance, and
    /// within the grid's step of it.
    fn brute(a0: &Vector3<f64>, a1: &Vector3<f64>, b0: &Vector3<f64>, b1: &Vector3<f64>) -> f64 {
        let n = 400;
        let mut best = f64::INFINITY;
        for i in 0..=n {
            let p = a0 + (a1 - a0) * (i as f64 / n as f64);
            // The exact nearest point of the other segment to each grid point of this one.
            let v = b1 - b0;
            let t = if v.norm_squared() > 0.0 {
                (v.dot(&(p - b0)) / v.norm_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            best = best.min((p - (b0 + v * t)).norm());
        }
        best
    }

    #[test]
    fn segment_distance_is_the_least_distance_from_below() {
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for case in 0..3000 {
            let mut p = || Vector3::new(rnd(), rnd(), rnd());
            let (a0, mut a1, b0, mut b1) = (p(), p(), p(), p());
            match case % 6 {
                // Parallel, nearly parallel, a point, both points, crossing.
                0 => b1 = b0 + (a1 - a0) * 0.7,
                1 => b1 = b0 + (a1 - a0) * 0.7 + Vector3::new(1e-9, 0.0, 0.0),
                2 => a1 = a0,
                3 => (a1, b1) = (a0, b0),
                4 => b1 = a0 + (a0 - b0),
                _ => {}
            }
            let d = segment_distance(&a0, &a1, &b0, &b1);
            // The grid over `a` is exact along `b`, so it bounds the distance from above, and
            // from below to within half a grid step of `a` (Lipschitz 1).
            let grid = brute(&a0, &a1, &b0, &b1);
            let step = (a1 - a0).norm() / 400.0;
            assert!(
                d <= grid + 1e-12,
                "case {case}: {d} above the grid's {grid}"
            );
            assert!(
                d >= grid - step - 1e-8,
                "case {case}: {d} far below the grid's {grid}"
            );
            // Symmetric, and the same from either end of either segment.
            let e = segment_distance(&b1, &b0, &a1, &a0);
            assert!((d - e).abs() < 1e-8, "case {case}: {d} against {e}");
        }
    }
}

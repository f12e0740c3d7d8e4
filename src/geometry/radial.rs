//! Radial clouds: AOPCs whose points lie on rays from one centre with the rays as normals, and
//! whose quads, seen from the centre, cover every direction (a sphere's cubed-sphere sampling).
//! Over such a cloud the SSDF has a lower bound at every query point in closed form
//! ([`Radial::plane_bound`]), so the band walk proves a region out without walking the cloud's
//! hierarchy (`collision::aopc_exceeds`).
//!
//! # The bound
//! Write `p_i = o + R_i d_i` (`|d_i| = 1`, `R_i ∈ [R_lo, R_hi]`), `n_i = d_i + e_i` with
//! `|e_i| ≤ δ`, and let every direction `e` lie within the angle `α` of some `d_k`
//! (`cos α ≥ 0`). For a query point `x = o + s e` (`s ≥ 0`) the point `k` gives
//! `d_min(x) ≤ |x - p_k|² = s² + R_k² - 2 s R_k cos α_k ≤ s² + R_k² - 2 s R_k cos α`. A point
//! `i` carries a softmax weight above `e^{-M1}` only where `d_i(x) - d_min(x) ≤ M1 ε1 = m1`
//! (as in `collision::ssdf_exceeds_over`), so there
//! `2 s R_i cos α_i ≥ R_i² - R_k² + 2 s R_k cos α - m1`, and its plane
//! `v_i(x) = n_iᵀ(x - p_i) ≥ s cos α_i - R_i - δ (s + R_i)` is at least
//! `(R_i² - R_k²)/(2R_i) + s (R_k/R_i) cos α - m1/(2R_i) - R_i - δ (s + R_hi)`
//! `≥ s ((R_lo/R_hi) cos α - δ) - R_hi - (R_hi² - R_lo²)/(2R_lo) - m1/(2R_lo) - δ R_hi`.
//!
//! # The covering angle
//! Each quad `f` is split into the triangles `(d_f, u_a, u_b)` over its edges `(a, b)` (`u`
//! the directions of its vertices from `o`). When every directed edge has exactly one reversed
//! twin, these spherical triangles form a closed surface, and when each is positively oriented
//! (`det(d_f, u_a, u_b) > 0`) its map onto the sphere of directions has a positive degree, so
//! every direction lies in one of them. Such a triangle lies in the cap of angular radius
//! `max(∠(d_f, u_a), ∠(d_f, u_b))` about `d_f` when both are at most 90° (caps up to a
//! hemisphere are convex), so `cos α = min_f min_a d_fᵀu_a`.

use nalgebra::{Matrix3, Vector3};

/// A radial cloud's certificate (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Radial {
    /// The centre `o` (m).
    pub centre: Vector3<f64>,
    /// Smallest distance of a point from the centre (m, rounded down).
    pub r_lo: f64,
    /// Largest distance of a point from the centre (m, rounded up).
    pub r_hi: f64,
    /// `cos α`: every direction lies within `α` of a point's direction (rounded down).
    pub cos_cover: f64,
    /// `δ`: largest `|n_i - d_i|` (rounded up).
    pub normal_err: f64,
}

impl Radial {
    /// A lower bound of `n_iᵀ(x - p_i)` over the points `i` that can carry weight at `x`
    /// (`d_i(x) - d_min(x) ≤ m1`, m²), at every `x` at least `s_lo` (m) from the centre.
    pub fn plane_bound(&self, s_lo: f64, m1: f64) -> f64 {
        let (lo, hi, dl) = (self.r_lo, self.r_hi, self.normal_err);
        let slope = (lo / hi) * self.cos_cover - dl;
        let constant = hi + (hi * hi - lo * lo) / (2.0 * lo) + m1 / (2.0 * lo) + dl * hi;
        // `slope` may be negative only for a cloud too coarse to be useful; then the bound at
        // the largest distance is not the smallest, so give none.
        if slope < 0.0 {
            return f64::NEG_INFINITY;
        }
        s_lo.max(0.0) * slope - constant - 1e-12 * (s_lo.abs() + constant.abs())
    }
}

/// Whether the directed edges `a << 32 | b` of a quad mesh close a surface: every edge once,
/// with its reversed twin.
pub(super) fn closed(mut edges: Vec<u64>) -> bool {
    let mut twins: Vec<u64> = edges.iter().map(|e| e.rotate_left(32)).collect();
    edges.sort_unstable();
    twins.sort_unstable();
    !edges.windows(2).any(|w| w[0] == w[1]) && edges == twins
}

/// The certificate of a cloud (faces in the cloud's order, one point per face), if it is radial
/// about the point nearest its normals' lines (least squares), with `|n_i - d_i| ≤ 1e-6`.
pub fn find_radial(
    points: &[Vector3<f64>],
    normals: &[Vector3<f64>],
    vertices: &[Vector3<f64>],
    faces: &[[u32; 4]],
) -> Option<Radial> {
    if points.is_empty() || points.len() != faces.len() || normals.len() != points.len() {
        return None;
    }
    // The point nearest to the normals' lines in least squares: `Σ (I - n nᵀ)(o - p) = 0`.
    let (mut a, mut rhs) = (Matrix3::zeros(), Vector3::zeros());
    for (p, n) in points.iter().zip(normals) {
        let proj = Matrix3::identity() - n * n.transpose();
        a += proj;
        rhs += proj * p;
    }
    let centre = a.try_inverse()? * rhs;
    let (mut r_lo, mut r_hi, mut normal_err) = (f64::INFINITY, 0.0f64, 0.0f64);
    let mut dirs = Vec::with_capacity(points.len());
    for (p, n) in points.iter().zip(normals) {
        let r = (p - centre).norm();
        if r.is_nan() || r <= 0.0 {
            return None;
        }
        let d = (p - centre) / r;
        r_lo = r_lo.min(r);
        r_hi = r_hi.max(r);
        normal_err = normal_err.max((n - d).norm());
        dirs.push(d);
    }
    if normal_err > 1e-6 {
        return None;
    }
    let mut vdirs = Vec::with_capacity(vertices.len());
    for v in vertices {
        let r = (v - centre).norm();
        if r.is_nan() || r <= 0.0 {
            return None;
        }
        vdirs.push((v - centre) / r);
    }
    // Closed: every directed edge once, with its reversed twin.
    // Edges as `a << 32 | b` (sorting integers: a 146k-point sphere is checked in about half
    // the time its BVH takes to build).
    let mut edges: Vec<u64> = Vec::with_capacity(4 * faces.len());
    let mut cos_cover = 1.0f64;
    for (f, d) in faces.iter().zip(&dirs) {
        for k in 0..4 {
            let (a, b) = (f[k], f[(k + 1) % 4]);
            if a == b {
                continue; // a collapsed edge (a quad with a repeated corner) spans no triangle
            }
            let (ua, ub) = (vdirs.get(a as usize)?, vdirs.get(b as usize)?);
            // Positive orientation, well clear of rounding (unit vectors: errors ~1e-16).
            if d.dot(&ua.cross(ub)) <= 1e-12 {
                return None;
            }
            cos_cover = cos_cover.min(d.dot(ua));
            edges.push((a as u64) << 32 | b as u64);
        }
    }
    if !closed(edges) {
        return None;
    }
    // Round outwards: the distances and angles above carry a few ulps.
    let cos_cover = cos_cover - 1e-12;
    if cos_cover <= 0.0 {
        return None;
    }
    Some(Radial {
        centre,
        r_lo: r_lo * (1.0 - 1e-12),
        r_hi: r_hi * (1.0 + 1e-12),
        cos_cover,
        normal_err: normal_err + 1e-12,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;

    use crate::geometry::lcg;

    #[test]
    fn spheres_are_radial_and_other_shapes_are_not() {
        for spacing in [0.02, 0.005, 0.001] {
            let s = Shape::Sphere { radius: 0.05 }.sample(spacing);
            let r = find_radial(&s.points, &s.normals, &s.vertices, &s.faces)
                .expect("a sphere is radial");
            assert!(r.centre.norm() < 1e-15, "{:?}", r.centre);
            assert!(
                r.r_lo <= 0.05 && r.r_hi >= 0.05 - 1e-12 && r.normal_err < 1e-9,
                "{r:?}"
            );
            // The covering angle is about half a cell's diagonal.
            let alpha = r.cos_cover.acos();
            assert!(
                alpha > 0.3 * spacing / 0.05 && alpha < 1.5 * spacing / 0.05,
                "{alpha} at {spacing}"
            );
        }
        for shape in [
            Shape::Box {
                half: Vector3::repeat(0.05),
            },
            Shape::Ellipsoid {
                radii: Vector3::new(0.05, 0.04, 0.03),
            },
            Shape::Capsule {
                radius: 0.03,
                half_length: 0.05,
            },
            Shape::Cylinder {
                radius: 0.04,
                half_length: 0.05,
            },
        ] {
            let s = shape.sample(0.005);
            assert!(
                find_radial(&s.points, &s.normals, &s.vertices, &s.faces).is_none(),
                "{shape:?}"
            );
        }
    }

    #[test]
    fn a_broken_sphere_has_no_certificate() {
        let s = Shape::Sphere { radius: 0.05 }.sample(0.005);
        for (points, normals, faces) in crate::geometry::broken_copies(&s) {
            assert!(find_radial(&points, &normals, &s.vertices, &faces).is_none());
        }
    }

    #[test]
    fn the_plane_bound_holds_for_every_relevant_point() {
        // Brute force over query points near and far, inside and outside, at the softmax reaches
        // of sharp and scene ε: every point within m1 of the nearest has its plane above the bound.
        let mut st = 5u64;
        // A bumpy sphere too: points moved along their rays by up to ±20 % of a spacing.
        for (spacing, m1, bump) in [
            (0.01, 4.6e-8, 0.0),
            (0.004, 4.6e-8, 0.0),
            (0.004, 4.6e-4, 0.0),
            (0.002, 1e-6, 0.0),
            (0.004, 4.6e-8, 0.2),
            (0.002, 1e-6, 0.2),
            (0.004, 1e-5, 0.2),
        ] {
            let mut s = Shape::Sphere { radius: 0.05 }.sample(spacing);
            for p in s.points.iter_mut() {
                *p *= 1.0 + bump * spacing / 0.05 * lcg(&mut st);
            }
            let r = find_radial(&s.points, &s.normals, &s.vertices, &s.faces).unwrap();
            assert!(bump == 0.0 || r.r_hi - r.r_lo > bump * spacing, "{r:?}");
            let mut tight = f64::INFINITY;
            for _ in 0..400 {
                let e = Vector3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st)).normalize();
                // Half near the surface (where the bound is tight), half up to 15 mm off.
                let dist =
                    0.05 * (1.0 + if lcg(&mut st) > 0.0 { 0.3 } else { 0.01 } * lcg(&mut st));
                let x = r.centre + e * dist;
                let d: Vec<f64> = s.points.iter().map(|p| (x - p).norm_squared()).collect();
                let dmin = d.iter().cloned().fold(f64::INFINITY, f64::min);
                let bound = r.plane_bound(dist, m1);
                for (i, di) in d.iter().enumerate() {
                    if di - dmin <= m1 {
                        let v = s.normals[i].dot(&(x - s.points[i]));
                        assert!(v >= bound, "spacing {spacing}, m1 {m1}: plane {v} below the bound {bound} at {x:?}");
                        tight = tight.min(v - bound);
                    }
                }
            }
            // Not vacuous: on a true sphere the bound comes within a small part of the spacing
            // of some plane (a bumpy one is charged its spread of radii, twice).
            assert!(
                tight < 0.2 * spacing + 2.5 * (r.r_hi - r.r_lo) + m1 / 0.05,
                "slack {tight} at spacing {spacing}, bump {bump}"
            );
        }
    }
}

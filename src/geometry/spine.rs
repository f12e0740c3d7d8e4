//! Spine clouds: AOPCs whose points lie on rays from a segment (the spine), each ray leaving
//! from the point's own spine point with the ray as its normal, and whose quads tile the surface
//! (a capsule's sampling: hemispheres radial from the segment's ends, a side radial from the
//! segment). As over a sphere ([`super::radial`]), the SSDF then has a lower bound at every
//! query point in closed form ([`Spine::plane_bound`]), in the distance from the query point to
//! the segment, so the band walk and the reach proofs settle a region without walking the
//! cloud's hierarchy (`collision::aopc_exceeds`).
//!
//! # The bound
//! Write `p_i = c_i + R_i d_i`, `c_i` on the segment, `|d_i| = 1`, `R_i ∈ [R_lo, R_hi]`,
//! `n_i = d_i + e_i`, `|e_i| ≤ δ`. Take a query point `x`, `a` its nearest point on the segment,
//! `s = |x - a|`, `e = (x - a)/s`. The surface point `a + R e` lies under some quad `f` (below),
//! whose point has `|c_f - a| ≤ η` and `d_fᵀe ≥ cos α`, with `c_f - a` along the segment and `e`,
//! `d_f` across it whenever `c_f ≠ a` (a side quad; a cap quad has `c_f = a`, the segment's
//! end). So `d_min(x) ≤ |x - p_f|² = s² + R_f² + |c_f - a|² - 2 s R_f d_fᵀe`, at most
//! `s² + R_f² + η² - 2 s R_f cos α`. A point `i` carries a softmax weight above `e^{-M1}` only
//! where `d_i(x) - d_min(x) ≤ m1` (`collision::ssdf_exceeds_over`); with `|x - p_i|² =
//! |x - c_i|² + R_i² - 2 R_i d_iᵀ(x - c_i)` and `|x - c_i| ≥ s` (`c_i` is on the segment),
//! there `d_iᵀ(x - c_i) ≥ (R_i² - R_f²)/(2R_i) + s (R_f/R_i) cos α - (η² + m1)/(2R_i)`, and its
//! plane `v_i(x) = d_iᵀ(x - c_i) - R_i + e_iᵀ(x - p_i)`, with `|x - p_i| ≤ s + R_hi + η + √m1`,
//! is at least `s ((R_lo/R_hi) cos α - δ) - R_hi - (R_hi² - R_lo²)/(2R_lo) - (η² + m1)/(2R_lo)`
//! less `δ (R_hi + η + √m1)`.
//!
//! # The covering
//! Each quad `f` is split into the triangles `(p_f, v_a, v_b)` over its edges. When every
//! directed edge has exactly one reversed twin and every triangle faces outwards (its normal
//! has a positive product with the outward directions at its three corners), the triangles form
//! a closed surface whose nearest-point map onto the capsule has degree one, so every surface
//! point lies under one of them. A triangle whose corners all have the segment's end as spine
//! point (a cap's) maps to directions from that end inside the corners' cone; one whose corners'
//! directions are all across the segment (a side's) maps to points whose spine coordinate lies
//! between its corners' and whose directions lie between theirs; a cap's point and corners must
//! look out of its end (`±d·u ≥ 0`). Every other triangle refuses the certificate. So `cos α = min_f min_a d_fᵀu_a` and `η = max_f max_a |σ_a - σ_f|` (`u_a`,
//! `σ_a`: a corner's direction and spine coordinate).

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

/// A spine cloud's certificate (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Spine {
    /// One end of the segment (m).
    pub start: Vector3<f64>,
    /// The other end (m).
    pub end: Vector3<f64>,
    /// Smallest distance of a point from its spine point (m, rounded down).
    pub r_lo: f64,
    /// Largest distance of a point from its spine point (m, rounded up).
    pub r_hi: f64,
    /// `cos α` (rounded down).
    pub cos_cover: f64,
    /// `δ`: largest `|n_i - d_i|` (rounded up).
    pub normal_err: f64,
    /// `η`: how far along the segment a quad's corners' spine points are from its point's (m,
    /// rounded up).
    pub eta: f64,
}

impl Spine {
    /// The point of the segment nearest to `x`.
    pub fn nearest(&self, x: &Vector3<f64>) -> Vector3<f64> {
        nearest_on_segment(&self.start, &self.end, x)
    }

    /// A lower bound of `n_iᵀ(x - p_i)` over the points `i` that can carry weight at `x`
    /// (`d_i(x) - d_min(x) ≤ m1`, m²), at every `x` at least `s_lo` (m) from the segment.
    pub fn plane_bound(&self, s_lo: f64, m1: f64) -> f64 {
        let (lo, hi, dl, eta) = (self.r_lo, self.r_hi, self.normal_err, self.eta);
        let slope = (lo / hi) * self.cos_cover - dl;
        let constant = hi
            + (hi * hi - lo * lo) / (2.0 * lo)
            + (eta * eta + m1) / (2.0 * lo)
            + dl * (hi + eta + m1.max(0.0).sqrt());
        if slope < 0.0 {
            return f64::NEG_INFINITY;
        }
        s_lo.max(0.0) * slope - constant - 1e-12 * (s_lo.abs() + constant.abs())
    }
}

/// The point of the segment from `start` to `end` nearest to `x` (`start` when they coincide).
pub fn nearest_on_segment(
    start: &Vector3<f64>,
    end: &Vector3<f64>,
    x: &Vector3<f64>,
) -> Vector3<f64> {
    let axis = end - start;
    let len2 = axis.norm_squared();
    if len2 == 0.0 {
        return *start;
    }
    let t = (axis.dot(&(x - start)) / len2).clamp(0.0, 1.0);
    start + axis * t
}

/// Relative tolerance of the spine points' fit: a point's `p_i - R n_i` must lie this close
/// (times the radius) to the axis.
const FIT: f64 = 1e-9;

/// The certificate of a cloud (faces in the cloud's order, one point per face), if it is a spine
/// cloud with `|n_i - d_i| ≤ 1e-6` and a segment of positive length (a sphere is radial).
pub fn find_spine(
    points: &[Vector3<f64>],
    normals: &[Vector3<f64>],
    vertices: &[Vector3<f64>],
    faces: &[[u32; 4]],
) -> Option<Spine> {
    let n = points.len();
    if n < 8 || n != faces.len() || normals.len() != n {
        return None;
    }
    // The axis: the side's normals are across it, so it is the direction the normals least
    // point along (a clear gap to the next eigenvalue, or the cloud is no capsule).
    let m: Matrix3<f64> = normals.iter().map(|v| v * v.transpose()).sum();
    let eig = SymmetricEigen::new(m);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let (least, next) = (eig.eigenvalues[order[0]], eig.eigenvalues[order[1]]);
    if least.is_nan() || least >= 0.9 * next {
        return None;
    }
    let u: Vector3<f64> = eig.eigenvectors.column(order[0]).normalize();
    let o: Vector3<f64> = points.iter().sum::<Vector3<f64>>() / n as f64;
    let across = |w: Vector3<f64>| w - u * u.dot(&w);
    // The radius: the largest distance from the axis (reached on the side).
    let radius = points
        .iter()
        .map(|p| across(p - o).norm())
        .fold(0.0f64, f64::max);
    if !(radius > 0.0 && radius.is_finite()) {
        return None;
    }
    // Each point's spine coordinate `σ_i` (along `u` from `o`), radius and direction.
    let mut sigma = Vec::with_capacity(n);
    let (mut r_lo, mut r_hi, mut normal_err) = (f64::INFINITY, 0.0f64, 0.0f64);
    let mut dirs = Vec::with_capacity(n);
    for (p, nv) in points.iter().zip(normals) {
        let c = p - nv * radius;
        if across(c - o).norm() > FIT * radius {
            return None;
        }
        let s = u.dot(&(c - o));
        let ci = o + u * s;
        let r = (p - ci).norm();
        if r.is_nan() || r <= 0.0 {
            return None;
        }
        let d = (p - ci) / r;
        r_lo = r_lo.min(r);
        r_hi = r_hi.max(r);
        normal_err = normal_err.max((nv - d).norm());
        sigma.push(s);
        dirs.push(d);
    }
    if normal_err > 1e-6 {
        return None;
    }
    let (s_min, s_max) = sigma
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &s| {
            (a.min(s), b.max(s))
        });
    if s_max - s_min <= FIT * radius {
        return None; // a sphere: `super::radial`
    }
    let at_end = |s: f64| (s - s_min).abs() <= FIT * radius || (s - s_max).abs() <= FIT * radius;
    // Every vertex's spine coordinate (clamped to the segment) and direction.
    let mut vspine = Vec::with_capacity(vertices.len());
    for v in vertices {
        let s = u.dot(&(v - o)).clamp(s_min, s_max);
        let w = v - (o + u * s);
        let r = w.norm();
        if r.is_nan() || r <= 0.0 {
            return None;
        }
        vspine.push((s, w / r));
    }
    let across_u = |d: &Vector3<f64>| d.dot(&u).abs() <= FIT;
    let mut edges: Vec<u64> = Vec::with_capacity(4 * faces.len());
    let (mut cos_cover, mut eta) = (1.0f64, 0.0f64);
    for (k, f) in faces.iter().enumerate() {
        let (sf, df, pf) = (sigma[k], &dirs[k], &points[k]);
        // A cap's quad: its point and corners all hang from the same end of the segment; a
        // side's: its point's and corners' directions are all across the segment.
        let corners = f.map(|i| vspine.get(i as usize).copied());
        let corners: Option<Vec<(f64, Vector3<f64>)>> = corners.into_iter().collect();
        let corners = corners?;
        // A cap's point and corners also look out of its end (not back along the segment), so
        // that its triangles map onto the cap alone.
        let outward = if (sf - s_max).abs() <= FIT * radius {
            1.0
        } else {
            -1.0
        };
        let beyond = |d: &Vector3<f64>| outward * d.dot(&u) >= -FIT;
        let cap = at_end(sf)
            && beyond(df)
            && corners
                .iter()
                .all(|(s, d)| (s - sf).abs() <= FIT * radius && beyond(d));
        let side = across_u(df) && corners.iter().all(|(_, d)| across_u(d));
        if !(cap || side) {
            return None;
        }
        for j in 0..4 {
            let (a, b) = (f[j], f[(j + 1) % 4]);
            if a == b {
                continue; // a collapsed edge spans no triangle
            }
            let (va, vb) = (&vertices[a as usize], &vertices[b as usize]);
            let (sa, ua) = &corners[j];
            let (_, ub) = &corners[(j + 1) % 4];
            let normal = (va - pf).cross(&(vb - pf));
            let scale = (va - pf).norm() * (vb - pf).norm();
            if [df, ua, ub].iter().any(|d| d.dot(&normal) <= 1e-9 * scale) {
                return None; // faces inwards, or too thin to tell
            }
            cos_cover = cos_cover.min(df.dot(ua));
            eta = eta.max(if cap { 0.0 } else { (sa - sf).abs() });
            edges.push((a as u64) << 32 | b as u64);
        }
    }
    if !super::radial::closed(edges) {
        return None;
    }
    let cos_cover = cos_cover - 1e-12;
    if cos_cover <= 0.0 {
        return None;
    }
    let slack = FIT * radius;
    Some(Spine {
        start: o + u * s_min,
        end: o + u * s_max,
        r_lo: r_lo * (1.0 - 1e-12) - slack,
        r_hi: r_hi * (1.0 + 1e-12) + slack,
        cos_cover,
        normal_err: normal_err + 1e-12 + FIT,
        eta: eta + 2.0 * slack,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;

    use crate::geometry::lcg;

    fn capsule(radius: f64, half_length: f64, spacing: f64) -> crate::geometry::Aopc {
        Shape::Capsule {
            radius,
            half_length,
        }
        .sample(spacing)
    }

    #[test]
    fn capsules_have_a_spine_and_other_shapes_do_not() {
        for (r, h) in [(0.03, 0.05), (0.05, 0.01), (0.02, 0.2)] {
            for spacing in [0.02, 0.005, 0.002] {
                let s = capsule(r, h, spacing);
                let c = find_spine(&s.points, &s.normals, &s.vertices, &s.faces)
                    .unwrap_or_else(|| panic!("a capsule {r} {h} at {spacing} has a spine"));
                let ends = [c.start.z, c.end.z];
                assert!(
                    (ends[0].abs() - h).abs() < 1e-12 && (ends[1].abs() - h).abs() < 1e-12,
                    "{c:?}"
                );
                assert!(c.start.xy().norm() < 1e-12 && c.end.xy().norm() < 1e-12);
                assert!(
                    c.r_lo <= r && c.r_hi >= r && c.r_hi - c.r_lo < 3e-9 * r,
                    "{c:?}"
                );
                // The covering angle is about half a cell's diagonal, η about half a row.
                let alpha = c.cos_cover.acos();
                assert!(alpha < 1.5 * spacing / r, "{alpha} at {spacing}");
                assert!(c.eta <= 0.5 * spacing + 1e-9 && c.eta > 0.0, "{c:?}");
            }
        }
        for shape in [
            Shape::Sphere { radius: 0.05 },
            Shape::Box {
                half: Vector3::repeat(0.05),
            },
            Shape::Ellipsoid {
                radii: Vector3::new(0.05, 0.04, 0.03),
            },
            Shape::Cylinder {
                radius: 0.04,
                half_length: 0.05,
            },
        ] {
            let s = shape.sample(0.005);
            assert!(
                find_spine(&s.points, &s.normals, &s.vertices, &s.faces).is_none(),
                "{shape:?}"
            );
        }
    }

    #[test]
    fn a_broken_capsule_has_no_spine() {
        let s = capsule(0.03, 0.05, 0.005);
        for (points, normals, faces) in crate::geometry::broken_copies(&s) {
            assert!(find_spine(&points, &normals, &s.vertices, &faces).is_none());
        }
    }

    #[test]
    fn the_plane_bound_holds_for_every_relevant_point() {
        // Brute force over query points near and far, beside the side and beyond the caps, at
        // the softmax reaches of sharp and scene ε: every point within m1 of the nearest has its
        // plane above the bound, and the bound is not vacuous.
        let mut st = 11u64;
        for (r, h, spacing, m1) in [
            (0.03, 0.05, 0.01, 4.6e-8),
            (0.03, 0.05, 0.004, 4.6e-8),
            (0.03, 0.05, 0.004, 4.6e-4),
            (0.02, 0.1, 0.002, 1e-6),
            (0.05, 0.01, 0.004, 1e-5),
        ] {
            // Turned and moved, as a body frame holds a capsule given by `fromto`.
            let mut s = capsule(r, h, spacing);
            let axis = Vector3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st));
            let pose = nalgebra::Isometry3::new(Vector3::new(0.3, -0.1, 0.2), axis);
            for p in s.points.iter_mut().chain(s.vertices.iter_mut()) {
                *p = pose.transform_point(&(*p).into()).coords;
            }
            for n in s.normals.iter_mut() {
                *n = pose.rotation * *n;
            }
            let c = find_spine(&s.points, &s.normals, &s.vertices, &s.faces).unwrap();
            let mut tight = f64::INFINITY;
            for k in 0..600 {
                let e = Vector3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st)).normalize();
                let along = Vector3::new(0.0, 0.0, h * 1.2 * lcg(&mut st));
                // Near the surface (where the bound is tight), up to 0.3 R off, and inside.
                let dist = r * match k % 3 {
                    0 => 1.0 + 0.01 * lcg(&mut st),
                    1 => 1.0 + 0.3 * lcg(&mut st),
                    _ => 0.35 * (1.0 + lcg(&mut st)),
                };
                // A point at `dist` from the spine point nearest `along + e` (capsule frame).
                let local = c.nearest(&pose.transform_point(&(along + e).into()).coords);
                let a = pose.inverse_transform_point(&local.into()).coords;
                let x = pose
                    .transform_point(&(a + (along + e - a).normalize() * dist).into())
                    .coords;
                let s_x = (x - c.nearest(&x)).norm();
                let d: Vec<f64> = s.points.iter().map(|p| (x - p).norm_squared()).collect();
                let dmin = d.iter().cloned().fold(f64::INFINITY, f64::min);
                let bound = c.plane_bound(s_x, m1);
                for (i, di) in d.iter().enumerate() {
                    if di - dmin <= m1 {
                        let v = s.normals[i].dot(&(x - s.points[i]));
                        assert!(
                            v >= bound,
                            "{r} {h} {spacing} {m1}: plane {v} below {bound} at {x:?}"
                        );
                        tight = tight.min(v - bound);
                    }
                }
            }
            assert!(
                tight < 0.2 * spacing + m1 / r + spacing * spacing / r,
                "slack {tight} at spacing {spacing}"
            );
        }
    }
}

//! Cuboid clouds: AOPCs that are a sampled box, six flat patches ([`super::patch`]) on three
//! pairs of opposite planes with orthogonal normals, every point on one of them. Over such a
//! cloud the band walk settles a region in closed form ([`Cuboid::settles`]), as it does over
//! a sampled sphere with [`super::radial`], instead of walking the cloud's hierarchy near its
//! edges and corners, where one witness point or one face's covering bound is too coarse.
//!
//! # The bound
//! Work in the coordinates `x' = U x`, `U`'s rows `u_k` the unit normals of three faces
//! (`|U v|² = vᵀUᵀU v` within `η = ‖UUᵀ - I‖_F` of `|v|²`). Face `f` lies across axis `k_f`
//! with side `σ_f = ±1`, its points `p_i` in the box `[l_f, h_f]` (in `x'`), their normals
//! within `δ_f` of `σ_f u_{k_f}`.
//!
//! *Planes.* `n_iᵀ(x - p_i) ≥ σ_f (x'_{k} - p'_{ik}) - δ_f |x - p_i|`, so over a region whose
//! `x'` lie in a box `X` and whose `|x|` is at most `D`, every point of `f` has its plane at or
//! above `min_X σ_f x'_k - top_f - δ_f (D + P)` (`top_f = max σ_f p'_{ik}`, `P = max |p_i|`);
//! and it can be at or below `need` only where `σ_f x'_k ≤ need + top_f + δ_f (D + P)`, a cut of
//! `X` along one axis: `S_f`.
//!
//! *Irrelevance.* A point `i` of `f` carries a softmax weight above `e^{-M1}` only where
//! `d_i(x) - d_min(x) ≤ M1 ε1 = m1` (`collision::ssdf_exceeds_over`). Take another face `g`:
//! its quads tile its rectangle `R_g` (the patch's polygon, whose four edges are checked to lie
//! along `±u_j`, `j ≠ k_g`), so the point `z` of `g`'s plane whose in-plane coordinates are
//! `x'_j` clamped to `R_g` lies in a quad, whose centre `p_k` is within `a_{gj}` of `z` along
//! `u_j` (the quads' half extents). So `d_min(x) ≤ |x - p_k|² ≤ (1 + 2η) Σ_j E_{gj}(x'_j)²` with
//! `E_{gj}(y) = dist(y, R_{gj}) + a_{gj}` for `j ≠ k_g` and the largest distance from `y` to
//! `[l_{g k_g}, h_{g k_g}]` along `k_g`; and `d_i(x) ≥ (1 - 2η) Σ_j dist(x'_j, [l_{fj}, h_{fj}])²`.
//! The difference `Σ_j φ_j(x'_j)` is separable, so its minimum over the box `S_f` is the sum of
//! one-dimensional minima, and each `φ_j = D² - E²` is, between its breakpoints (the ends of the
//! intervals and the midpoint), a difference of squares of affine functions with slopes 0 or
//! ±1: linear, concave, or the square of a distance that vanishes only at a breakpoint, so its
//! minimum over an interval is at an end or a breakpoint. If that minimum, less the `η` and
//! rounding allowance, exceeds `m1` for some `g`, no point of `f` can carry weight where its
//! plane is at or below `need`.
//!
//! Why it settles what the walk cannot: below a box's bottom face, near an edge, a side face's
//! first row lies half a spacing behind the bottom's plane and is out by about that depth times
//! the height; one witness at the region's centre charges the region's radius times the
//! distance between witness and point instead, and the bottom's covering bound charges the
//! region's reach past the bottom face's other edges, though the side points lie far from there.

use nalgebra::{Matrix3, Vector3};

/// One face of a cuboid cloud (module documentation), in the cuboid's coordinates `x'`.
#[derive(Clone, Debug, PartialEq)]
pub struct Face {
    /// `k`: the face lies across the axis `u_k`.
    pub axis: usize,
    /// `σ`: its outward normal is `σ u_k`.
    pub sign: f64,
    /// Box of its points (rounded outwards).
    pub lo: Vector3<f64>,
    /// Box of its points (rounded outwards).
    pub hi: Vector3<f64>,
    /// `top = max σ p'_k` over its points (rounded up).
    pub top: f64,
    /// The rectangle its quads tile, along the two other axes (shrunk by the rounding of its
    /// edges' directions; the entries at `axis` are unused).
    pub rect_lo: Vector3<f64>,
    /// See `rect_lo`.
    pub rect_hi: Vector3<f64>,
    /// `a_j`: the largest distance along `u_j` from a quad's centre to its vertices, plus the
    /// patch's thickness (rounded up).
    pub half: Vector3<f64>,
    /// `δ`: largest `|n_i - σ u_k|` over its points (rounded up).
    pub normal_err: f64,
}

/// A cuboid cloud's certificate (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Cuboid {
    /// `U`: rows `u_k`, the unit normals of three faces.
    pub axes: Matrix3<f64>,
    /// `η = ‖UUᵀ - I‖_F` (rounded up).
    pub eta: f64,
    /// `P`: largest `|p_i|` (m, rounded up).
    pub reach: f64,
    /// `Z`: twice the largest `|v|` over the quads' vertices (m).
    pub size: f64,
    /// The six faces.
    pub faces: Vec<Face>,
}

impl Cuboid {
    /// Whether every point that can carry weight (`d_i - d_min ≤ m1`, m²) anywhere in a region
    /// has its plane above `need` (m) there, proven; `false` when not proven. The region is
    /// given by a box `[lo, hi]` holding its points' coordinates `x' = U x` and a bound `dist`
    /// on their `|x|`.
    pub fn settles(
        &self,
        lo: &Vector3<f64>,
        hi: &Vector3<f64>,
        dist: f64,
        need: f64,
        m1: f64,
    ) -> bool {
        let far = dist + self.reach;
        let mut lb = [0.0; 6];
        for (f, face) in self.faces.iter().enumerate() {
            let k = face.axis;
            let low = if face.sign > 0.0 { lo[k] } else { -hi[k] };
            lb[f] = low - face.top - face.normal_err * far - 1e-12 * far;
        }
        // The faces the region lies farthest in front of bound `d_min` best: try two of them
        // (the first three, by insertion: sorting all six cost 2.5 % of a box–box evaluation).
        let mut order = [usize::MAX; 3];
        for f in 0..6 {
            let mut k = 3;
            while k > 0 && (order[k - 1] == usize::MAX || lb[order[k - 1]] < lb[f]) {
                k -= 1;
            }
            if k < 3 {
                order.copy_within(k..2, k + 1);
                order[k] = f;
            }
        }
        // `d_i ≥ (1 - η)A`, `d_min ≤ (1 + 2η)B`, with `A` and `B` below `3 (D + P + Z)²`.
        let slack = (9.0 * self.eta + 1e-12) * (far + self.size).powi(2);
        for (f, face) in self.faces.iter().enumerate() {
            if lb[f] > need {
                continue; // every plane of the face is above `need` over the region
            }
            let k = face.axis;
            let cap = need + face.top + face.normal_err * far + 1e-12 * far;
            let (mut slo, mut shi) = (*lo, *hi);
            if face.sign > 0.0 {
                shi[k] = shi[k].min(cap);
            } else {
                slo[k] = slo[k].max(-cap);
            }
            if slo[k] > shi[k] {
                continue;
            }
            if !order
                .iter()
                .filter(|&&g| g != f)
                .take(2)
                .any(|&g| self.gap(face, &self.faces[g], &slo, &shi) - slack > m1)
            {
                return false;
            }
        }
        true
    }

    /// `min Σ_j φ_j(x'_j)` over the box `[lo, hi]` (module documentation): a lower bound of
    /// `d_i - d_min` for the points of `f`, by the quads of `g`, before the `η` allowance.
    fn gap(&self, f: &Face, g: &Face, lo: &Vector3<f64>, hi: &Vector3<f64>) -> f64 {
        let dist = |y: f64, a: f64, b: f64| (a - y).max(y - b).max(0.0);
        let mut total = 0.0;
        for j in 0..3 {
            let phi = |y: f64| {
                let d = dist(y, f.lo[j], f.hi[j]);
                let e = if j == g.axis {
                    (y - g.lo[j]).abs().max((y - g.hi[j]).abs())
                } else {
                    dist(y, g.rect_lo[j], g.rect_hi[j]) + g.half[j]
                };
                d * d - e * e
            };
            let (a, b) = (lo[j], hi[j]);
            let mut best = phi(a).min(phi(b));
            let breaks = if j == g.axis {
                [f.lo[j], f.hi[j], 0.5 * (g.lo[j] + g.hi[j]), f64::NAN]
            } else {
                [f.lo[j], f.hi[j], g.rect_lo[j], g.rect_hi[j]]
            };
            for y in breaks {
                if y > a && y < b {
                    best = best.min(phi(y));
                }
            }
            total += best;
        }
        total
    }
}

/// The certificate of a cloud (faces in the cloud's order, one point per face; `of` and
/// `patches` as found by [`super::patch::find_patches`]), if it is a cuboid.
pub fn find_cuboid(
    points: &[Vector3<f64>],
    normals: &[Vector3<f64>],
    vertices: &[Vector3<f64>],
    faces: &[[u32; 4]],
    of: &[u32],
    patches: &[super::patch::Patch],
) -> Option<Cuboid> {
    if patches.len() != 6
        || points.is_empty()
        || of.len() != points.len()
        || faces.len() != points.len()
        || of.iter().any(|&p| p as usize >= 6)
    {
        return None;
    }
    // Three faces with orthogonal normals, and each one's opposite.
    let mut axes: Vec<usize> = Vec::new();
    for (p, patch) in patches.iter().enumerate() {
        if axes
            .iter()
            .all(|&a| patches[a].normal.dot(&patch.normal).abs() <= 1e-9)
        {
            axes.push(p);
        }
    }
    if axes.len() != 3 {
        return None;
    }
    let u = Matrix3::from_rows(&[0, 1, 2].map(|k| patches[axes[k]].normal.transpose()));
    let eta = (u * u.transpose() - Matrix3::identity()).norm() + 1e-15;
    let mut side = [(usize::MAX, 0.0); 6];
    for (p, patch) in patches.iter().enumerate() {
        let c = u * patch.normal;
        let k = c.iamax();
        if (c[k].abs() - 1.0).abs() > 1e-9 {
            return None;
        }
        side[p] = (k, c[k].signum());
    }
    for k in 0..3 {
        for s in [-1.0, 1.0] {
            if side.iter().filter(|&&(a, b)| a == k && b == s).count() != 1 {
                return None;
            }
        }
    }
    let reach = points.iter().map(|p| p.norm()).fold(0.0, f64::max) * (1.0 + 1e-12);
    let big = 2.0 * vertices.iter().map(|v| v.norm()).fold(0.0, f64::max);
    let mut out = Vec::with_capacity(6);
    for (p, patch) in patches.iter().enumerate() {
        let (k, sign) = side[p];
        let axis: Vector3<f64> = u.row(k).transpose() * sign;
        let (mut lo, mut hi) = (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        );
        let (mut half, mut normal_err) = (Vector3::zeros(), 0.0f64);
        for i in (0..points.len()).filter(|&i| of[i] as usize == p) {
            let q = u * points[i];
            lo = lo.inf(&q);
            hi = hi.sup(&q);
            normal_err = normal_err.max((normals[i] - axis).norm());
            for &v in &faces[i] {
                let d = u * (vertices.get(v as usize)? - points[i]);
                half = half.sup(&d.abs());
            }
        }
        // The rectangle: the patch's edges lie along ±u_j, j ≠ k (a side may come as several
        // edges, nearly collinear hull vertices of a rotated face left in). An edge `mᵀz ≤ c`
        // holds wherever `±u_jᵀz ≤ c - |m ∓ u_j| Z`, `Z` bounding `|z|` on the face.
        let (mut rect_lo, mut rect_hi) = (
            Vector3::repeat(f64::NEG_INFINITY),
            Vector3::repeat(f64::INFINITY),
        );
        for (m, c) in &patch.edges {
            let e = u * m;
            let j = e.iamax();
            let s = e[j].signum();
            let err = (m - u.row(j).transpose() * s).norm();
            if j == k || err > 1e-9 {
                return None;
            }
            let bound = c - err * big - 1e-12 * big;
            if s > 0.0 {
                rect_hi[j] = rect_hi[j].min(bound);
            } else {
                rect_lo[j] = rect_lo[j].max(-bound);
            }
        }
        for j in (0..3).filter(|&j| j != k) {
            if !(rect_lo[j].is_finite() && rect_hi[j].is_finite() && rect_lo[j] <= rect_hi[j]) {
                return None; // a side without an edge
            }
        }
        let pad = 1e-12 * (reach + big);
        let top = if sign > 0.0 { hi[k] } else { -lo[k] } + pad;
        out.push(Face {
            axis: k,
            sign,
            lo: lo.add_scalar(-pad),
            hi: hi.add_scalar(pad),
            top,
            rect_lo,
            rect_hi,
            half: half * (1.0 + 1e-12) + Vector3::repeat(pad + patch.thickness),
            normal_err: normal_err + 1e-12,
        });
    }
    Some(Cuboid {
        axes: u,
        eta,
        reach,
        size: big,
        faces: out,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::union::sample_union;
    use crate::geometry::{Aopc, Shape};
    use nalgebra::{Isometry3, Rotation3, Translation3, UnitQuaternion};

    use crate::geometry::lcg;

    fn certificate(s: &Aopc) -> Option<Cuboid> {
        let (of, patches) =
            crate::geometry::patch::find_patches(&s.points, &s.normals, &s.vertices, &s.faces);
        find_cuboid(&s.points, &s.normals, &s.vertices, &s.faces, &of, &patches)
    }

    /// A box placed in its body by a rotation and an offset (a geom's `pos` and `quat`).
    fn placed_box(
        half: Vector3<f64>,
        spacing: f64,
        angles: (f64, f64, f64),
        offset: Vector3<f64>,
    ) -> Aopc {
        let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_euler_angles(
            angles.0, angles.1, angles.2,
        ));
        sample_union(
            &[(
                Shape::Box { half },
                Isometry3::from_parts(Translation3::from(offset), rot),
            )],
            spacing,
        )
    }

    #[test]
    fn boxes_are_cuboids_and_other_shapes_are_not() {
        for s in [
            Shape::Box {
                half: Vector3::new(0.1, 0.05, 0.02),
            }
            .sample(0.01),
            placed_box(
                Vector3::new(0.03, 0.04, 0.05),
                0.005,
                (0.3, -0.7, 1.1),
                Vector3::new(0.01, -0.2, 0.03),
            ),
        ] {
            let c = certificate(&s).expect("a box is a cuboid");
            assert!(c.eta < 1e-14, "{}", c.eta);
            let mut axes: Vec<(usize, f64)> = c.faces.iter().map(|f| (f.axis, f.sign)).collect();
            axes.sort_by(|a, b| a.partial_cmp(b).unwrap());
            assert_eq!(
                axes,
                vec![
                    (0, -1.0),
                    (0, 1.0),
                    (1, -1.0),
                    (1, 1.0),
                    (2, -1.0),
                    (2, 1.0)
                ]
            );
            for f in &c.faces {
                // The quads are half a spacing wide or less along each face, and the face's
                // rectangle holds its points.
                assert!(
                    f.normal_err < 1e-9
                        && (0..3).filter(|&j| j != f.axis).all(|j| f.half[j] > 0.0
                            && f.half[j] <= 0.0051
                            && f.rect_lo[j] <= f.lo[j] + 1e-9
                            && f.rect_hi[j] >= f.hi[j] - 1e-9),
                    "{f:?}"
                );
            }
        }
        for shape in [
            Shape::Sphere { radius: 0.05 },
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
            assert!(certificate(&shape.sample(0.005)).is_none(), "{shape:?}");
        }
        // The paper's T-block: two boxes of one body, one union; not a box.
        let t = sample_union(
            &[
                (
                    Shape::Box {
                        half: Vector3::new(0.1, 0.02, 0.02),
                    },
                    Isometry3::identity(),
                ),
                (
                    Shape::Box {
                        half: Vector3::new(0.02, 0.06, 0.02),
                    },
                    Isometry3::translation(0.0, -0.06, 0.0),
                ),
            ],
            0.005,
        );
        assert!(certificate(&t).is_none());
        // A box with a quad missing (its face is no longer a patch).
        let mut s = Shape::Box {
            half: Vector3::repeat(0.05),
        }
        .sample(0.01);
        s.points.pop();
        s.normals.pop();
        s.faces.pop();
        s.areas.pop();
        assert!(certificate(&s).is_none());
    }

    /// Brute force: wherever the certificate settles a region, every point that can carry
    /// weight at a sampled point of it (its squared distance within `m1` of the smallest) has
    /// its plane above `need` there. Regions near edges and corners, outside and inside the
    /// box, of radii from a tenth of a spacing to several spacings, at the softmax reaches of
    /// sharp and scene ε, on a box in its frame and on a rotated, offset one.
    #[test]
    fn a_settled_region_has_every_relevant_plane_above_need() {
        let mut st = 3u64;
        let cases = [
            (
                Shape::Box {
                    half: Vector3::new(0.05, 0.03, 0.02),
                }
                .sample(0.004),
                4.6e-8,
            ),
            (
                Shape::Box {
                    half: Vector3::new(0.05, 0.03, 0.02),
                }
                .sample(0.004),
                1e-5,
            ),
            (
                placed_box(
                    Vector3::new(0.04, 0.03, 0.025),
                    0.003,
                    (0.4, 0.2, -0.9),
                    Vector3::new(0.02, -0.01, 0.05),
                ),
                1e-6,
            ),
        ];
        let (mut settled, mut tight, mut refused, mut beside) = (0, 0, 0, 0);
        for (s, m1) in &cases {
            let c = certificate(s).unwrap();
            let u = c.axes;
            // The points of a face's first rows (within 4 mm of its edges).
            let rim: Vec<usize> = (0..s.points.len())
                .filter(|&i| {
                    let q = u * s.points[i];
                    let f = c
                        .faces
                        .iter()
                        .find(|f| (f.sign * q[f.axis] - f.top).abs() < 1e-9)
                        .unwrap();
                    (0..3)
                        .any(|j| j != f.axis && (q[j] - f.lo[j] < 0.004 || f.hi[j] - q[j] < 0.004))
                })
                .collect();
            for n in 0..1500 {
                // Near a random point of the surface (every other one on a face's rim), pushed
                // in or out.
                let pick =
                    |st: &mut u64, len: usize| ((lcg(st) + 1.0) * 0.5 * len as f64) as usize % len;
                let k = if n % 2 == 0 {
                    rim[pick(&mut st, rim.len())]
                } else {
                    pick(&mut st, s.points.len())
                };
                let dir = Vector3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st)).normalize();
                let centre = s.points[k]
                    + s.normals[k] * 0.012 * lcg(&mut st)
                    + dir * 0.015 * lcg(&mut st).abs();
                let r = 0.0003 + 0.012 * lcg(&mut st).abs().powi(2);
                let need = 0.004 * lcg(&mut st);
                let mid = u * centre;
                let reach = Vector3::from_fn(|j, _| r * u.row(j).norm() * (1.0 + 1e-12));
                if !c.settles(&(mid - reach), &(mid + reach), centre.norm() + r, need, *m1) {
                    refused += 1;
                    continue;
                }
                settled += 1;
                // Beside an edge or a corner: outside the box of the points along two axes.
                let (plo, phi) = c.faces.iter().fold(
                    (
                        Vector3::repeat(f64::INFINITY),
                        Vector3::repeat(f64::NEG_INFINITY),
                    ),
                    |(a, b), f| (a.inf(&f.lo), b.sup(&f.hi)),
                );
                beside += usize::from(
                    (0..3)
                        .filter(|&j| mid[j] < plo[j] || mid[j] > phi[j])
                        .count()
                        >= 2,
                );
                let mut closest = f64::INFINITY;
                for n in 0..40 {
                    // Every other sample on the sphere, where the extremes are.
                    let y = Vector3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st));
                    let x = centre
                        + if n % 2 == 0 {
                            y.normalize() * r
                        } else {
                            y * r / 3f64.sqrt()
                        };
                    let d: Vec<f64> = s.points.iter().map(|p| (x - p).norm_squared()).collect();
                    let dmin = d.iter().cloned().fold(f64::INFINITY, f64::min);
                    for (i, di) in d.iter().enumerate() {
                        if di - dmin <= *m1 {
                            let v = s.normals[i].dot(&(x - s.points[i]));
                            assert!(v > need, "plane {v} of point {i} at or below need {need} at {x:?} (region {centre:?}, r {r}, m1 {m1})");
                            closest = closest.min(v - need);
                        }
                    }
                }
                tight += usize::from(closest < 0.002);
            }
        }
        // Not vacuous: many regions settled, many of them with a relevant plane within 2 mm of
        // `need`, and the rest refused (where the truth may be either).
        assert!(settled > 1200 && tight > 150 && beside > 200 && refused > 1000, "settled {settled} ({tight} within 2 mm of need, {beside} beside an edge), refused {refused}");
    }
}

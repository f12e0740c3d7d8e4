//! Sampling the primitive shapes into AOPCs (docs/geometry.md): quad meshes whose edges follow
//! the shape's sharp edges (box edges, cylinder rims) and whose points are evenly spaced, the
//! curved surfaces from the equi-angular cubed sphere (see [`super::shapes`]), and the graded
//! grids of [`Spacing`] (fine at edges, coarser away from them).

use super::Aopc;
use nalgebra::Vector3;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// Number of quads along a length so that they are about `spacing` long (at least 1).
pub(crate) fn divisions(length: f64, spacing: f64) -> usize {
    ((length / spacing).round() as usize).max(1)
}

/// How finely a shape is sampled (docs/geometry.md, "Spacing per geom").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spacing {
    /// Quad length (m) at a box's edges and at the grid lines another geom of its body adds.
    pub fine: f64,
    /// Quad length (m) per axis of the shape's frame away from them; a curved shape or a mesh
    /// is sampled evenly at the smallest entry.
    pub coarse: Vector3<f64>,
}

impl Spacing {
    /// `spacing` (m) everywhere.
    pub fn uniform(spacing: f64) -> Self {
        Spacing {
            fine: spacing,
            coarse: Vector3::repeat(spacing),
        }
    }
}

/// Largest ratio of neighbouring quad lengths on a graded grid. Below 2, a point over a face
/// at `a` from its edge lies in a quad at most `2a` long (beyond the first, `fine`, one), so
/// its own face's nearest quad centre is no farther than the neighbouring face's nearest one:
/// the SSDF near an edge is what even sampling at `fine` gives (docs/geometry.md).
const GROWTH: f64 = 1.5;

/// Quad lengths along a grid window of `length` (m): `fine` at both ends, growing by at most
/// [`GROWTH`] per quad towards `coarse` in the middle; `divisions(length, fine)` equal quads
/// when `coarse` is not above `fine` or the window is too short to grow. Returns the ramp from
/// one end (mirrored at the other), then the number and the length of the middle quads (a
/// count, as `f64`, so that an estimate never allocates it).
pub(crate) fn graded(length: f64, fine: f64, coarse: f64) -> (Vec<f64>, f64, f64) {
    let mut ramp = Vec::new();
    let mut rest = length;
    let mut w = fine;
    // Each step leaves at least one more quad's length for the middle.
    while w < coarse && rest >= 3.0 * w {
        ramp.push(w);
        rest -= 2.0 * w;
        w = (w * GROWTH).min(coarse);
    }
    match ramp.last() {
        Some(&last) => {
            let m = (rest / coarse.min(GROWTH * last)).ceil().max(1.0);
            (ramp, m, rest / m)
        }
        None => {
            let m = divisions(length, fine) as f64;
            (ramp, m, length / m)
        }
    }
}

/// Cells per quarter turn of an arc of radius `r` (even, at least 2).
fn quarter_cells(r: f64, spacing: f64) -> usize {
    (((FRAC_PI_2 * r / spacing).ceil() as usize).max(1) + 1) & !1
}

/// Equi-angular coordinate: `tan(-π/4 + π/2 s)` for `s ∈ [0, 1]`.
#[inline]
fn equi(s: f64) -> f64 {
    (-FRAC_PI_4 + FRAC_PI_2 * s).tan()
}

/// The six faces of the cube: normal axis index, sign, tangent axes `(t1, t2)` with
/// `t1 × t2` = outward normal.
const CUBE_FACES: [(usize, f64, usize, usize); 6] = [
    (0, 1.0, 1, 2),
    (0, -1.0, 2, 1),
    (1, 1.0, 2, 0),
    (1, -1.0, 0, 2),
    (2, 1.0, 0, 1),
    (2, -1.0, 1, 0),
];

/// Quads of a cubed sphere stretched to an ellipsoid of semi-axes `radii` with `cells[k]`
/// cells along edges parallel to axis `k`, offset by `offset`; only quads whose centre
/// direction satisfies `keep`. Points lie on the ellipsoid at the quads' parametric centres,
/// normals are the ellipsoid's there; areas are the curved patches' (4×4 midpoint rule).
fn push_cubed(
    out: &mut Aopc,
    radii: &Vector3<f64>,
    cells: [usize; 3],
    offset: &Vector3<f64>,
    keep: impl Fn(&Vector3<f64>) -> bool,
) {
    for &(axis, sign, t1, t2) in &CUBE_FACES {
        let (n1, n2) = (cells[t1], cells[t2]);
        let dir = |a: f64, b: f64| {
            let mut d = Vector3::zeros();
            d[axis] = sign;
            d[t1] = equi(a);
            d[t2] = equi(b);
            d.normalize()
        };
        let on = |d: &Vector3<f64>| d.component_mul(radii) + offset;
        for i in 0..n1 {
            for j in 0..n2 {
                let (a0, a1) = (i as f64 / n1 as f64, (i + 1) as f64 / n1 as f64);
                let (b0, b1) = (j as f64 / n2 as f64, (j + 1) as f64 / n2 as f64);
                let dc = dir(0.5 * (a0 + a1), 0.5 * (b0 + b1));
                if !keep(&dc) {
                    continue;
                }
                let corners = [
                    on(&dir(a0, b0)),
                    on(&dir(a1, b0)),
                    on(&dir(a1, b1)),
                    on(&dir(a0, b1)),
                ];
                let normal = dc.component_div(radii).normalize();
                // Curved area: sum of small flat quads.
                let k = 4;
                let mut area = 0.0;
                for u in 0..k {
                    for v in 0..k {
                        let (s0, s1) = (
                            a0 + (a1 - a0) * u as f64 / k as f64,
                            a0 + (a1 - a0) * (u + 1) as f64 / k as f64,
                        );
                        let (r0, r1) = (
                            b0 + (b1 - b0) * v as f64 / k as f64,
                            b0 + (b1 - b0) * (v + 1) as f64 / k as f64,
                        );
                        let c = [
                            on(&dir(s0, r0)),
                            on(&dir(s1, r0)),
                            on(&dir(s1, r1)),
                            on(&dir(s0, r1)),
                        ];
                        area += 0.5 * (c[2] - c[0]).cross(&(c[3] - c[1])).norm();
                    }
                }
                out.push_face(corners, on(&dc), normal, area);
            }
        }
    }
}

/// Sphere or ellipsoid as a stretched cubed sphere.
///
/// Cell counts are even, so that four points surround each pole of the three axes. With an
/// odd count a point sits at the pole, and a sphere resting on a plane balances on that single
/// point: an unstable equilibrium (like a polyhedron on a vertex) from which it tips over onto
/// four points after a few seconds of growing rocking; measured, independent of integrator and
/// step.
pub(super) fn sample_ellipsoid(radii: &Vector3<f64>, spacing: f64) -> Aopc {
    let mut out = Aopc::default();
    let cells = [0, 1, 2].map(|k| quarter_cells(radii[k], spacing));
    push_cubed(&mut out, radii, cells, &Vector3::zeros(), |_| true);
    if radii.x == radii.y && radii.y == radii.z {
        // A sphere's area is known exactly: remove the midpoint rule's last digits.
        let total: f64 = out.areas.iter().sum();
        let exact = 4.0 * PI * radii.x * radii.x;
        out.areas.iter_mut().for_each(|a| *a *= exact / total);
    }
    out
}

/// Capsule: two hemispheres of a cubed sphere (its equator is a grid line) and a cylinder of
/// `4n` columns that meets them.
pub(super) fn sample_capsule(r: f64, h: f64, spacing: f64) -> Aopc {
    let mut out = Aopc::default();
    let n = quarter_cells(r, spacing);
    let radii = Vector3::repeat(r);
    push_cubed(
        &mut out,
        &radii,
        [n, n, n],
        &Vector3::new(0.0, 0.0, h),
        |d| d.z > 0.0,
    );
    push_cubed(
        &mut out,
        &radii,
        [n, n, n],
        &Vector3::new(0.0, 0.0, -h),
        |d| d.z < 0.0,
    );
    let hemi = 2.0 * PI * r * r;
    let total: f64 = out.areas.iter().sum();
    out.areas.iter_mut().for_each(|a| *a *= 2.0 * hemi / total);
    push_side(&mut out, r, h, n, spacing);
    out
}

/// The side of a cylinder along z: `4n` columns at the cubed sphere's equator angles, rows of
/// about `spacing`. Points on the surface at the cells' centres, radial normals, exact areas.
fn push_side(out: &mut Aopc, r: f64, h: f64, n: usize, spacing: f64) {
    if h <= 0.0 {
        return;
    }
    let cols = 4 * n;
    let rows = divisions(2.0 * h, spacing);
    let angle = |k: usize| -FRAC_PI_4 + FRAC_PI_2 * k as f64 / n as f64;
    let at = |t: f64, z: f64| Vector3::new(r * t.cos(), r * t.sin(), z);
    for k in 0..cols {
        for j in 0..rows {
            let (t0, t1) = (angle(k), angle(k + 1));
            let (z0, z1) = (
                -h + 2.0 * h * j as f64 / rows as f64,
                -h + 2.0 * h * (j + 1) as f64 / rows as f64,
            );
            let tc = 0.5 * (t0 + t1);
            let corners = [at(t0, z0), at(t1, z0), at(t1, z1), at(t0, z1)];
            out.push_face(
                corners,
                at(tc, 0.5 * (z0 + z1)),
                Vector3::new(tc.cos(), tc.sin(), 0.0),
                r * (t1 - t0) * (z1 - z0),
            );
        }
    }
}

/// Cylinder: the side, and two flat caps meshed as an "O-grid": a central square of `n × n`
/// cells (half-width r/2) and four ring patches joining each side of the square to a quarter of
/// the rim, whose vertices fall at the side's column angles (the rim is a quad edge, and no
/// cell is squashed against it).
pub(super) fn sample_cylinder(r: f64, h: f64, spacing: f64) -> Aopc {
    let mut out = Aopc::default();
    let n = quarter_cells(r, spacing);
    push_side(&mut out, r, h, n, spacing);
    let a = 0.5 * r;
    let layers = divisions(r - a, spacing);
    for sign in [1.0, -1.0] {
        let mut cap = Aopc::default();
        let mut quad = |c: [(f64, f64); 4]| {
            let mut c = c.map(|(x, y)| Vector3::new(x, y, sign * h));
            // Counter-clockwise seen from outside (from +z on top, from -z below).
            if (c[2] - c[0]).cross(&(c[3] - c[1])).z * sign < 0.0 {
                c.reverse();
            }
            cap.push_quad(c);
        };
        let g = |i: usize| -a + 2.0 * a * i as f64 / n as f64;
        for i in 0..n {
            for j in 0..n {
                quad([
                    (g(i), g(j)),
                    (g(i + 1), g(j)),
                    (g(i + 1), g(j + 1)),
                    (g(i), g(j + 1)),
                ]);
            }
        }
        for q in 0..4 {
            let rot = |(x, y): (f64, f64)| {
                let t = FRAC_PI_2 * q as f64;
                (x * t.cos() - y * t.sin(), x * t.sin() + y * t.cos())
            };
            let at = |i: usize, j: usize| {
                let (sx, sy) = (a, g(i));
                let th = -FRAC_PI_4 + FRAC_PI_2 * i as f64 / n as f64;
                let (rx, ry) = (r * th.cos(), r * th.sin());
                let f = j as f64 / layers as f64;
                rot((sx + (rx - sx) * f, sy + (ry - sy) * f))
            };
            for i in 0..n {
                for j in 0..layers {
                    quad([at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
                }
            }
        }
        let total: f64 = cap.areas.iter().sum();
        cap.areas.iter_mut().for_each(|x| *x *= PI * r * r / total);
        out.extend(&cap);
    }
    out
}

/// Box: each face cut into a grid of quads, so quad edges lie on the box's edges and corners,
/// on graded grids ([`graded`]): per axis and side, one set of grid lines shared by the faces
/// on that side, so that without `breaks` neighbouring faces meet quad edge to quad edge.
/// `breaks[axis][0|1]` lists extra grid lines (coordinates along `axis`) on the faces that span
/// that axis: where another geom's boundary crosses them, so no quad straddles it.
pub(crate) fn sample_box(
    half: &Vector3<f64>,
    spacing: &Spacing,
    breaks: &[[Vec<f64>; 2]; 3],
) -> Aopc {
    let mut out = Aopc::default();
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            // Tangent axes ordered so that t1 × t2 points outward.
            let (i1, i2) = ((axis + 1) % 3, (axis + 2) % 3);
            let (i1, i2) = if sign > 0.0 { (i1, i2) } else { (i2, i1) };
            let side = if sign > 0.0 { 0 } else { 1 };
            let lines = |t: usize| {
                let cuts = box_cuts(half[t], &breaks[t][side]);
                let mut out = vec![cuts[0]];
                for w in cuts.windows(2) {
                    let (ramp, m, _) = graded(w[1] - w[0], spacing.fine, spacing.coarse[t]);
                    // The ramps from both ends, summed from the ends; the middle in equal parts.
                    let (mut lo, mut hi) = (w[0], w[1]);
                    let mut top = Vec::with_capacity(ramp.len());
                    for r in &ramp {
                        lo += r;
                        out.push(lo);
                        top.push(hi);
                        hi -= r;
                    }
                    let m = m as usize;
                    out.extend((1..m).map(|k| lo + (hi - lo) * k as f64 / m as f64));
                    if ramp.is_empty() {
                        out.push(w[1]);
                    } else {
                        out.push(hi);
                        out.extend(top[1..].iter().rev());
                        out.push(w[1]);
                    }
                }
                out
            };
            let (g1, g2) = (lines(i1), lines(i2));
            for a in g1.windows(2) {
                for b in g2.windows(2) {
                    let corner = |x: f64, y: f64| {
                        let mut p = Vector3::zeros();
                        p[axis] = sign * half[axis];
                        p[i1] = x;
                        p[i2] = y;
                        p
                    };
                    out.push_quad([
                        corner(a[0], b[0]),
                        corner(a[1], b[0]),
                        corner(a[1], b[1]),
                        corner(a[0], b[1]),
                    ]);
                }
            }
        }
    }
    out
}

/// The grid lines a box face must have along an axis of half-extent `half`: its two ends and
/// the `breaks` between them, sorted, near-duplicates merged.
fn box_cuts(half: f64, breaks: &[f64]) -> Vec<f64> {
    let mut cuts = vec![-half, half];
    cuts.extend(breaks.iter().copied().filter(|&c| c > -half && c < half));
    cuts.sort_by(f64::total_cmp);
    cuts.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * half);
    cuts
}

/// The number of quads [`sample_box`] makes, counted without making them (as `f64`: an
/// estimate of a huge count must not overflow or allocate).
pub(crate) fn box_quads(
    half: &Vector3<f64>,
    spacing: &Spacing,
    breaks: &[[Vec<f64>; 2]; 3],
) -> f64 {
    let cells = |t: usize, side: usize| -> f64 {
        box_cuts(half[t], &breaks[t][side])
            .windows(2)
            .map(|w| {
                let (ramp, m, _) = graded(w[1] - w[0], spacing.fine, spacing.coarse[t]);
                2.0 * ramp.len() as f64 + m
            })
            .sum()
    };
    (0..3)
        .flat_map(|axis| [(axis, 0), (axis, 1)])
        .map(|(axis, side)| cells((axis + 1) % 3, side) * cells((axis + 2) % 3, side))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;

    #[test]
    fn graded_grids_tile_the_window_fine_at_its_ends_and_grow_slowly() {
        for (length, fine, coarse) in [
            (3.0, 0.01, 0.09375),
            (2.0, 0.01, 0.0625),
            (0.2, 0.01, 0.05),
            (0.05, 0.01, 0.5),
            (10.0, 0.001, 0.3),
            (0.021, 0.01, 0.2),
        ] {
            let (ramp, m, mid) = graded(length, fine, coarse);
            let mut cells = ramp.clone();
            cells.extend(std::iter::repeat_n(mid, m as usize));
            cells.extend(ramp.iter().rev());
            let total: f64 = cells.iter().sum();
            assert!(
                (total - length).abs() < 1e-12 * length,
                "{total} vs {length}"
            );
            assert!(cells
                .iter()
                .all(|&w| w > 0.0 && w <= coarse * (1.0 + 1e-12)));
            if !ramp.is_empty() {
                assert_eq!(ramp[0], fine, "{length} {fine} {coarse}");
            }
            // Neighbours within [1/2, GROWTH], and the property the SSDF needs: a quad other
            // than the two end ones, x from the nearer end, is at most 2x long.
            let mut x = 0.0f64;
            for (k, w) in cells.iter().enumerate() {
                if k > 0 {
                    let r = w / cells[k - 1];
                    assert!((0.5..=GROWTH * (1.0 + 1e-12)).contains(&r), "{r} at {k}");
                }
                if k > 0 && k + 1 < cells.len() {
                    let from_end = x.min(length - x - w);
                    assert!(*w <= 2.0 * from_end + 1e-12, "quad {k}: {w} at {from_end}");
                }
                x += w;
            }
        }
        // Not coarser than fine, or too short to grow: even quads, as `divisions` makes them.
        assert_eq!(graded(0.3, 0.01, 0.01), (vec![], 30.0, 0.3 / 30.0));
        assert_eq!(graded(0.025, 0.01, 0.1).0, Vec::<f64>::new());
        // A long window costs a ramp of logarithmic length and its middle at the coarse spacing.
        let (ramp, m, mid) = graded(3.0, 0.01, 0.09375);
        assert!(
            ramp.len() <= 6 && (mid - 0.09375).abs() < 0.01,
            "{ramp:?} {m} {mid}"
        );
    }

    #[test]
    fn box_quads_counts_what_sample_box_makes() {
        let half = Vector3::new(1.5, 1.0, 0.02);
        let graded = Shape::Box { half }.spacing_for(0.01, 16.0);
        let none: [[Vec<f64>; 2]; 3] = Default::default();
        // Grid lines of other boxes on some sides: each window graded from both of its ends.
        let mut some = none.clone();
        some[0][0] = vec![-0.4, 0.2, 0.2 + 1e-15, 7.0];
        some[1][1] = vec![0.5];
        some[2][0] = vec![0.0];
        for spacing in [graded, Spacing::uniform(0.01), Spacing::uniform(0.3)] {
            for breaks in [&none, &some] {
                let made = sample_box(&half, &spacing, breaks).faces.len() as f64;
                assert_eq!(
                    box_quads(&half, &spacing, breaks),
                    made,
                    "{spacing:?} {breaks:?}"
                );
            }
        }
    }
}

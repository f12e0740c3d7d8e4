//! The AOPC of a body made of several geoms: the surface of their union (docs/method.md, AOPC).
//!
//! Each geom is sampled on its own, then every face is classified against the other geoms:
//! - strictly inside another geom: dropped (interior points ruin the SSDF, paper Experiments A);
//! - on another geom's surface with the same outward normal (coplanar duplicate, e.g. two boxes
//!   flush on one side, or the caps of two capsules of one radius meeting at a joint): kept
//!   once, by the geom that comes first;
//! - on another geom's surface with the opposite normal (two geoms touching face to face): that
//!   surface is inside the union, dropped from both;
//! - straddling another geom's boundary: only the part outside is kept (the face's area is cut
//!   to it and its point moved to that part's centroid, from a 16×16 sub-sampling).
//!
//! A face is classified by 4×4 sub-samples, those of a sphere, capsule or cylinder moved onto
//! its surface (a chord's points lie inside it, and would read as inside a coinciding surface);
//! a face that straddles is measured again on 16×16.
//!
//! Boxes whose axes align with another box get extra grid lines where that box's faces cross
//! them, so that no quad straddles it: the union of aligned boxes (the T-block) is meshed exactly,
//! with the same quads as one box wherever the union is one box.

use super::mesh::box_distance;
use super::rounded::{find_rounded, MemberSampling};
use super::sample::{sample_box, Spacing};
use super::shapes::Shape;
use super::Aopc;
use nalgebra::{Isometry3, Point3, Vector3};

/// The union of `geoms` (shape and pose in the body frame) sampled at `spacing` (m).
pub fn sample_union(geoms: &[(Shape, Isometry3<f64>)], spacing: f64) -> Aopc {
    sample_union_spaced(geoms, &vec![Spacing::uniform(spacing); geoms.len()])
}

/// The union of `geoms`, each sampled at its own spacing (`spacings[k]`, as
/// [`Shape::sample_spaced`]).
pub fn sample_union_spaced(geoms: &[(Shape, Isometry3<f64>)], spacings: &[Spacing]) -> Aopc {
    sample_union_counted(geoms, spacings).0
}

/// [`sample_union_spaced`], with the number of the union's points that come from each geom
/// (its faces kept whole or in part: the faces inside another geom are dropped), in the order
/// of `geoms`.
pub fn sample_union_counted(
    geoms: &[(Shape, Isometry3<f64>)],
    spacings: &[Spacing],
) -> (Aopc, Vec<usize>) {
    assert_eq!(geoms.len(), spacings.len(), "one spacing per geom");
    let (size, tol) = size_and_tolerance(geoms, spacings);
    // Each geom's bounding ball in the body (an implicit shape's surface may pass its mesh's
    // vertices by a fraction of its grid: a tenth more): a point farther than `tol` outside it
    // is outside the geom, which the classification below then keeps it from, without its
    // signed distance (the work of loading a body of many geoms).
    let balls: Vec<(Vector3<f64>, f64)> = geoms
        .iter()
        .map(|(shape, pose)| {
            let grow = if matches!(shape, Shape::Implicit { .. }) {
                1.1
            } else {
                1.0
            };
            (pose.translation.vector, shape.size() * grow)
        })
        .collect();
    // Each mesh geom's bounding box in its own frame, once (the test below reads it first).
    let boxes: Vec<_> = geoms
        .iter()
        .map(|(shape, _)| shape.mesh().map(|m| m.bounds()))
        .collect();
    let mut out = Aopc::default();
    // Per geom: its full sampling and what became of each quad (the rounded certificate).
    let mut fates: Vec<(Aopc, Vec<Option<Vector3<f64>>>)> = Vec::new();
    for (k, ((shape, pose), spacing)) in geoms.iter().zip(spacings).enumerate() {
        let local = match shape {
            Shape::Box { half } if geoms.len() > 1 => {
                sample_box(half, spacing, &box_breaks(half, pose, geoms, k, tol))
            }
            _ => shape.sample_spaced(spacing),
        };
        let part = local.transformed(pose);
        let keep = |p: &Vector3<f64>, n: &Vector3<f64>| -> bool {
            geoms
                .iter()
                .enumerate()
                .filter(|(m, _)| *m != k)
                .all(|(m, (other, opose))| {
                    let (centre, radius) = &balls[m];
                    if (p - centre).norm() > radius + tol {
                        return true;
                    }
                    let q = (opose.inverse() * Point3::from(*p)).coords;
                    // A mesh's bounding box first: beyond `tol` from it (with room for the
                    // rounding of either distance), beyond `tol` from the mesh, so kept, as the
                    // exact distance (a pass over every triangle) would decide.
                    if let Some(b) = &boxes[m] {
                        if box_distance(b, &q) > tol * (1.0 + 1e-9) {
                            return true;
                        }
                    }
                    let d = other.sdf(&q);
                    if d < -tol {
                        return false;
                    }
                    if d > tol {
                        return true;
                    }
                    let g = opose.rotation * other.sdf_gradient(&q, 1e-6 * size);
                    let c = g.dot(n);
                    if c > 0.5 {
                        k < m // coplanar duplicate: the first geom keeps it
                    } else {
                        c >= -0.5 // face to face: inside the union
                    }
                })
        };
        let mut fate = Vec::with_capacity(part.faces.len());
        for (f, face) in part.faces.iter().enumerate() {
            let (p, n) = (part.points[f], part.normals[f]);
            let c = face.map(|i| part.vertices[i as usize]);
            // A face whose sub-samples cannot reach another geom is kept whole, as the
            // classification below would keep it: they lie in the quad's hull moved onto the
            // surface by at most the sagitta, so within twice the quad's radius of its centre.
            let centre = (c[0] + c[1] + c[2] + c[3]) / 4.0;
            let reach = 2.0 * c.iter().map(|v| (v - centre).norm()).fold(0.0, f64::max)
                + (p - centre).norm();
            let alone = balls.iter().enumerate().all(|(m, (other, radius))| {
                m == k || (centre - other).norm() > reach + radius + 2.0 * tol
            });
            if alone {
                out.push_face(c, p, n, part.areas[f]);
                fate.push(Some(p));
                continue;
            }
            // Sub-samples of the face (bilinear in its corners), on a curved shape moved onto its
            // surface: a chord's points lie inside by the sagitta, so where another geom's
            // surface coincides with this one (two capsules' caps around one joint) they read as
            // inside it, and the face was dropped from both geoms. 4×4 of them classify the
            // face; one that straddles another geom is measured again with 16×16, so that the
            // part kept (its area, its centroid) is within a sixteenth of a row of the cut.
            let sub_samples = |rows: usize| -> Vec<Vector3<f64>> {
                (0..rows * rows)
                    .map(|s| {
                        let (u, v) = (
                            ((s % rows) as f64 + 0.5) / rows as f64,
                            ((s / rows) as f64 + 0.5) / rows as f64,
                        );
                        onto_surface(
                            shape,
                            pose,
                            c[0] * ((1.0 - u) * (1.0 - v))
                                + c[1] * (u * (1.0 - v))
                                + c[2] * (u * v)
                                + c[3] * ((1.0 - u) * v),
                            size,
                        )
                    })
                    .collect()
            };
            let mut subs = sub_samples(4);
            let mut kept: Vec<bool> = subs.iter().map(|s| keep(s, &n)).collect();
            let mut nk = kept.iter().filter(|&&b| b).count();
            if nk > 0 && nk < 16 {
                let fine = sub_samples(16);
                let fine_kept: Vec<bool> = fine.iter().map(|s| keep(s, &n)).collect();
                let fine_nk = fine_kept.iter().filter(|&&b| b).count();
                // A sliver the finer grid misses keeps the coarse measure (a part kept must
                // have kept sub-samples to place its point at).
                if fine_nk > 0 {
                    (subs, kept, nk) = (fine, fine_kept, fine_nk);
                }
            }
            let rows2 = subs.len();
            if nk == rows2 && keep(&p, &n) {
                out.push_face(c, p, n, part.areas[f]);
                fate.push(Some(p));
            } else if nk > 0 {
                // Straddling: keep the part outside.
                let all = subs.iter().fold(Vector3::zeros(), |a, s| a + s) / rows2 as f64;
                let mine = subs
                    .iter()
                    .zip(&kept)
                    .filter(|(_, &b)| b)
                    .fold(Vector3::zeros(), |a, (s, _)| a + s)
                    / nk as f64;
                out.push_face(
                    c,
                    p + (mine - all),
                    n,
                    part.areas[f] * nk as f64 / rows2 as f64,
                );
                fate.push(Some(p + (mine - all)));
            } else {
                fate.push(None);
            }
        }
        fates.push((part, fate));
    }
    let counts = fates
        .iter()
        .map(|(_, fate)| fate.iter().flatten().count())
        .collect();
    // Every geom's points no face corner marks (a mesh in patches): the union's surface lies
    // within their geoms' hulls, so the bounding polytope keeps them all; where one geom has
    // them, the others' face corners join them (a cloud with a reach holds its surface in its
    // points and reach alone: `Polytope::of`).
    let any_reach = fates.iter().any(|(part, _)| !part.reach.is_empty());
    for (part, _) in &fates {
        match (any_reach, part.reach.is_empty()) {
            (true, true) => out.reach.extend_from_slice(&part.vertices),
            _ => out.reach.extend_from_slice(&part.reach),
        }
    }
    out.weld(tol);
    // Only a union of spheres and capsules has the rounded certificate: no work for others.
    let rounded = geoms
        .iter()
        .all(|(s, _)| matches!(s, Shape::Sphere { .. } | Shape::Capsule { .. }));
    if geoms.len() > 1 && rounded {
        let members: Vec<MemberSampling> = geoms
            .iter()
            .zip(fates)
            .map(|((shape, pose), (full, kept))| MemberSampling {
                shape,
                pose,
                full,
                kept,
            })
            .collect();
        let rounded = find_rounded(&members, &out.points);
        out.set_rounded(rounded);
    }
    (out, counts)
}

/// The union's size (m: the farthest reach of a geom from the body origin, at least the
/// coarsest spacing) and the tolerance its classification uses (1e-9 of it).
fn size_and_tolerance(geoms: &[(Shape, Isometry3<f64>)], spacings: &[Spacing]) -> (f64, f64) {
    let size = geoms
        .iter()
        .zip(spacings)
        .map(|((s, p), h)| (s.size() + p.translation.vector.norm()).max(h.coarse.max()))
        .fold(0.0, f64::max);
    (size, 1e-9 * size)
}

/// The number of quads box `k` of the union is sampled into, before the classification drops
/// any: on the grid lines the other boxes add ([`box_breaks`]), counted without making them.
pub(crate) fn box_quads_in_union(
    geoms: &[(Shape, Isometry3<f64>)],
    spacings: &[Spacing],
    k: usize,
) -> f64 {
    let (Shape::Box { half }, pose) = &geoms[k] else {
        return 0.0;
    };
    let (_, tol) = size_and_tolerance(geoms, spacings);
    super::sample::box_quads(half, &spacings[k], &box_breaks(half, pose, geoms, k, tol))
}

/// `x` (body frame) moved onto the shape's curved surface: along the SDF gradient for a sphere
/// or a capsule (their SDFs are exact and smooth off the centre and the axis), radially for a
/// point of a cylinder's side (inside, its SDF is the nearer of side and cap, which near the
/// rim would move a side's point onto the cap's plane); `x` itself otherwise (flat faces).
fn onto_surface(shape: &Shape, pose: &Isometry3<f64>, x: Vector3<f64>, size: f64) -> Vector3<f64> {
    let q = (pose.inverse() * Point3::from(x)).coords;
    let on = match shape {
        Shape::Sphere { .. } | Shape::Capsule { .. } => {
            q - shape.sdf_gradient(&q, 1e-6 * size) * shape.sdf(&q)
        }
        Shape::Cylinder {
            radius,
            half_length,
        } if q.z.abs() < half_length * (1.0 - 1e-9) && q.xy().norm() > 0.0 => {
            let s = radius / q.xy().norm();
            Vector3::new(q.x * s, q.y * s, q.z)
        }
        _ => return x,
    };
    (pose * Point3::from(on)).coords
}

/// Extra grid lines for box `k` (half-extents `half`, pose `pose`): for every other box whose
/// axes align with it, that box's extent along each axis, on the faces whose plane meets it.
fn box_breaks(
    half: &Vector3<f64>,
    pose: &Isometry3<f64>,
    geoms: &[(Shape, Isometry3<f64>)],
    k: usize,
    tol: f64,
) -> [[Vec<f64>; 2]; 3] {
    let mut breaks: [[Vec<f64>; 2]; 3] = Default::default();
    for (m, (other, opose)) in geoms.iter().enumerate() {
        let Shape::Box { half: oh } = other else {
            continue;
        };
        if m == k {
            continue;
        }
        let rel = pose.inverse() * opose;
        let r = rel.rotation.to_rotation_matrix().into_inner();
        if r.iter()
            .any(|x| x.abs() > 1e-9 && (x.abs() - 1.0).abs() > 1e-9)
        {
            continue; // not aligned: straddling faces are cut by sub-sampling instead
        }
        let c = rel.translation.vector;
        let e = r.abs() * oh;
        for axis in 0..3 {
            for (side, sign) in [(0, 1.0), (1, -1.0)] {
                // The face at `sign * half[axis]` meets the other box?
                let plane = sign * half[axis];
                if plane < c[axis] - e[axis] - tol || plane > c[axis] + e[axis] + tol {
                    continue;
                }
                for t in (0..3).filter(|&t| t != axis) {
                    breaks[t][side].extend([c[t] - e[t], c[t] + e[t]]);
                }
            }
        }
    }
    breaks
}

/// Volume of the union of `geoms` (m³), and whether it is exact: exact for one geom and for
/// boxes with aligned axes (inclusion–exclusion over their intersections, which are boxes);
/// otherwise a midpoint-rule estimate on a 128³ grid over the bounding box.
pub fn union_volume(geoms: &[(Shape, Isometry3<f64>)]) -> (f64, bool) {
    if geoms.len() == 1 {
        return (geoms[0].0.volume(), true);
    }
    // Aligned boxes: in the first box's frame each is an axis-aligned box.
    let frame = geoms[0].1;
    let boxes: Option<Vec<(Vector3<f64>, Vector3<f64>)>> = geoms
        .iter()
        .map(|(s, p)| {
            let Shape::Box { half } = s else { return None };
            let rel = frame.inverse() * p;
            let r = rel.rotation.to_rotation_matrix().into_inner();
            if r.iter()
                .any(|x| x.abs() > 1e-9 && (x.abs() - 1.0).abs() > 1e-9)
            {
                return None;
            }
            let e = r.abs() * half;
            Some((rel.translation.vector - e, rel.translation.vector + e))
        })
        .collect();
    if let Some(b) = boxes.filter(|b| b.len() <= 16) {
        let mut total = 0.0;
        for mask in 1u32..(1 << b.len()) {
            let (mut lo, mut hi) = (
                Vector3::repeat(f64::NEG_INFINITY),
                Vector3::repeat(f64::INFINITY),
            );
            for (i, (l, h)) in b.iter().enumerate() {
                if mask & (1 << i) != 0 {
                    lo = lo.sup(l);
                    hi = hi.inf(h);
                }
            }
            let v = (hi - lo).map(|x| x.max(0.0)).product();
            total += if mask.count_ones() % 2 == 1 { v } else { -v };
        }
        return (total, true);
    }
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for (s, p) in geoms {
        let c = p.translation.vector;
        lo = lo.inf(&(c - Vector3::repeat(s.size())));
        hi = hi.sup(&(c + Vector3::repeat(s.size())));
    }
    let n = 128;
    let step = (hi - lo) / n as f64;
    let centre = |i: usize, k: usize| lo[k] + (i as f64 + 0.5) * step[k];
    // Meshes: where each vertical grid line crosses the surface, from the triangles over it
    // (a winding number per grid point costs a pass over every triangle; a crossing list costs
    // a pass over the few triangles above each line). A line whose crossings are odd in
    // number (through an edge or a vertex) falls back to the winding number.
    let crossings: Vec<Option<Vec<Vec<f64>>>> = geoms
        .iter()
        .map(|(s, p)| {
            let m = s.mesh()?;
            let v: Vec<Vector3<f64>> = m
                .vertices
                .iter()
                .map(|x| p * Point3::from(*x))
                .map(|x| x.coords)
                .collect();
            let mut lines = vec![Vec::new(); n * n];
            for t in &m.triangles {
                let [a, b, c] = t.map(|i| v[i as usize]);
                let (tlo, thi) = (a.inf(&b).inf(&c), a.sup(&b).sup(&c));
                let range = |k: usize| {
                    let first = ((tlo[k] - lo[k]) / step[k] - 0.5).ceil().max(0.0) as usize;
                    let last = ((thi[k] - lo[k]) / step[k] - 0.5)
                        .floor()
                        .min(n as f64 - 1.0);
                    (first, last)
                };
                let ((i0, i1), (j0, j1)) = (range(0), range(1));
                if i1 < 0.0 || j1 < 0.0 {
                    continue;
                }
                let det = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
                if det == 0.0 {
                    continue; // seen edge-on from above: the line runs along it
                }
                for i in i0..=i1 as usize {
                    for j in j0..=j1 as usize {
                        let (x, y) = (centre(i, 0), centre(j, 1));
                        let u = ((x - a.x) * (c.y - a.y) - (c.x - a.x) * (y - a.y)) / det;
                        let w = ((b.x - a.x) * (y - a.y) - (x - a.x) * (b.y - a.y)) / det;
                        if u >= 0.0 && w >= 0.0 && u + w <= 1.0 {
                            lines[i * n + j].push(a.z + u * (b.z - a.z) + w * (c.z - a.z));
                        }
                    }
                }
            }
            Some(lines)
        })
        .collect();
    let mut inside = 0usize;
    let mut member = vec![false; n];
    for i in 0..n {
        for j in 0..n {
            member.fill(false);
            for (g, (s, p)) in geoms.iter().enumerate() {
                let along = crossings[g].as_ref().map(|l| &l[i * n + j]);
                match along {
                    Some(z) if z.len() % 2 == 0 => {
                        let mut z = z.clone();
                        z.sort_by(f64::total_cmp);
                        for pair in z.chunks(2) {
                            for (k, m) in member.iter_mut().enumerate() {
                                let zk = centre(k, 2);
                                *m |= pair[0] < zk && zk < pair[1];
                            }
                        }
                    }
                    _ => {
                        for (k, m) in member.iter_mut().enumerate() {
                            if !*m {
                                let x = Vector3::new(centre(i, 0), centre(j, 1), centre(k, 2));
                                *m = s.contains(&(p.inverse() * Point3::from(x)).coords);
                            }
                        }
                    }
                }
            }
            inside += member.iter().filter(|&&m| m).count();
        }
    }
    (inside as f64 * step.product(), false)
}

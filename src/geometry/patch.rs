//! Flat patches of an AOPC: sets of points whose quads lie in one plane and tile a convex
//! polygon (a box face, a cylinder's cap). Over such a patch the nearest point is known
//! to within the quads' size wherever a query projects into the polygon (and, charging the
//! distance to the polygon, a little past it: [`Patch::outside`]), which the band walk uses
//! to prove another face's points out of a softmax (`collision::covered_out`):
//!
//! if `x` projects into the polygon `Ω` (plane `nᵀy = o`, points and quad vertices within
//! `t` of it), it projects into some quad `Q_k`, and every point of `Q_k` is within `ρ` of
//! the quad's centre `p_k` (in the plane), so `d_min(x) ≤ |x - p_k|² ≤ (|u| + t)² + ρ²` with
//! `u = nᵀx - o`.
//!
//! A group of coplanar quads is a patch only when its union is provably a convex polygon:
//! every projected quad is convex and counter-clockwise seen from outside, no directed edge
//! belongs to two quads, every boundary edge (one that no quad of the group has reversed) lies
//! on the boundary of the convex hull `H` of the boundary's vertices, and the quads' areas add
//! up to the area of `H`. Then the covering number of a point of the plane (the sum over quads
//! of their winding numbers about it) equals the winding number of the boundary edges (the
//! interior edges cancel), a cycle on the boundary of `H`: a constant `k` inside `H`, 0
//! outside; the areas give `k = 1`, so every point of `H` lies in some quad (and every quad in
//! `H`, its covering number being at least 1).

use nalgebra::{Vector2, Vector3};

/// A flat patch (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Patch {
    /// Unit normal of the plane (the points' outward normal).
    pub normal: Vector3<f64>,
    /// `nᵀy` on the plane (m).
    pub offset: f64,
    /// Largest `|nᵀv - offset|` over the patch's points and quad vertices (m, rounded up).
    pub thickness: f64,
    /// Largest in-plane distance from a point to a vertex of its quad (m, rounded up).
    pub rho: f64,
    /// The polygon, as half-spaces `mᵀx ≤ c` (`m` a unit vector in the plane), rounded
    /// outwards.
    pub edges: Vec<(Vector3<f64>, f64)>,
    /// `k` such that a point of the plane that breaks the edges' half-planes by `w_e` lies
    /// within `√(k Σ w_e²)` of the polygon: `1 / (1 - c)²` with `c` the largest `-cos` of the
    /// angle between neighbouring edges' outward normals, when every interior angle is
    /// 90° or more up to `c ≤ 0.1` (rectangles, cylinder caps); `∞` otherwise.
    pub outside: f64,
}

/// Groups with fewer points are not worth a patch.
const MIN_POINTS: usize = 8;

/// The flat patches of a quad mesh whose face `k` has centre `points[k]` and outward normal
/// `normals[k]`: the patch index of each point (`u32::MAX` for none) and the patches.
/// Empty when the faces do not match the points one to one.
pub fn find_patches(
    points: &[Vector3<f64>],
    normals: &[Vector3<f64>],
    vertices: &[Vector3<f64>],
    faces: &[[u32; 4]],
) -> (Vec<u32>, Vec<Patch>) {
    let mut of = vec![u32::MAX; points.len()];
    let mut patches = Vec::new();
    if faces.len() != points.len()
        || faces
            .iter()
            .flatten()
            .any(|&v| v as usize >= vertices.len())
    {
        return (of, patches);
    }
    // Candidate groups: the same normal and plane offset to 1e-7 (quantised; a face split by
    // the quantisation only loses a patch, as each group is checked on its own). Sorting the
    // keys groups them without a hash map (a curved surface has one group per point).
    let mut keyed: Vec<([i64; 4], u32)> = points
        .iter()
        .zip(normals)
        .enumerate()
        .map(|(k, (p, n))| {
            (
                [n.x, n.y, n.z, n.dot(p)].map(|v| (v * 1e7).round() as i64),
                k as u32,
            )
        })
        .collect();
    keyed.sort_unstable();
    let mut members: Vec<usize> = Vec::new();
    for run in keyed.chunk_by(|a, b| a.0 == b.0) {
        if run.len() < MIN_POINTS {
            continue;
        }
        members.clear();
        members.extend(run.iter().map(|&(_, k)| k as usize));
        let members = &members[..];
        if let Some(patch) = check(points, normals, vertices, faces, members) {
            for &k in members {
                of[k] = patches.len() as u32;
            }
            patches.push(patch);
        }
    }
    (of, patches)
}

/// The patch of one group, if its quads pass the checks of the module documentation.
fn check(
    points: &[Vector3<f64>],
    normals: &[Vector3<f64>],
    vertices: &[Vector3<f64>],
    faces: &[[u32; 4]],
    members: &[usize],
) -> Option<Patch> {
    let n = members
        .iter()
        .fold(Vector3::zeros(), |s, &k| s + normals[k])
        .try_normalize(0.0)?;
    let offset = members.iter().map(|&k| n.dot(&points[k])).sum::<f64>() / members.len() as f64;
    // In-plane basis with e1 × e2 = n: counter-clockwise in (e1, e2) is counter-clockwise
    // seen from outside.
    let e1 = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = (e1 - n * n.dot(&e1)).normalize();
    let e2 = n.cross(&e1);
    let flat = |v: &Vector3<f64>| Vector2::new(e1.dot(v), e2.dot(v));
    let (mut thickness, mut rho, mut area, mut scale) = (0.0f64, 0.0f64, 0.0, 0.0f64);
    // Directed edges `(from << 32) | to`, sorted for the reverse-edge lookups.
    let mut directed: Vec<u64> = Vec::with_capacity(4 * members.len());
    for &k in members {
        let q = faces[k];
        let (pk, c) = (points[k], flat(&points[k]));
        thickness = thickness.max((n.dot(&pk) - offset).abs());
        scale = scale.max(pk.norm());
        let v: [Vector2<f64>; 4] = q.map(|i| flat(&vertices[i as usize]));
        for i in 0..4 {
            let vi = &vertices[q[i] as usize];
            thickness = thickness.max((n.dot(vi) - offset).abs());
            rho = rho.max((v[i] - c).norm());
            // Convex and counter-clockwise: every turn is to the left.
            let (a, b, d) = (v[i], v[(i + 1) % 4], v[(i + 2) % 4]);
            if (b - a).perp(&(d - b)) <= 0.0 {
                return None;
            }
            directed.push((q[i] as u64) << 32 | q[(i + 1) % 4] as u64);
        }
        area += 0.5 * (v[0].perp(&v[1]) + v[1].perp(&v[2]) + v[2].perp(&v[3]) + v[3].perp(&v[0]));
    }
    directed.sort_unstable();
    if directed.windows(2).any(|w| w[0] == w[1]) {
        return None; // two quads run along one edge the same way: a fold or a duplicate
    }
    // The boundary: edges of one quad only (no quad of the group has them reversed). The
    // union of the quads lies in the hull of the boundary's vertices (module documentation:
    // inside every quad the boundary's winding number is at least 1).
    let boundary: Vec<(u32, u32)> = directed
        .iter()
        .map(|&e| ((e >> 32) as u32, e as u32))
        .filter(|&(a, b)| {
            directed
                .binary_search(&((b as u64) << 32 | a as u64))
                .is_err()
        })
        .collect();
    let hull = convex_hull(
        boundary
            .iter()
            .map(|&(a, _)| flat(&vertices[a as usize]))
            .collect(),
    );
    if hull.len() < 3 {
        return None;
    }
    let hull_area: f64 = (0..hull.len())
        .map(|i| hull[i].perp(&hull[(i + 1) % hull.len()]))
        .sum::<f64>()
        * 0.5;
    let size = (0..hull.len())
        .map(|i| (hull[i] - hull[0]).norm())
        .fold(0.0, f64::max);
    if thickness > 1e-6 * size || (area - hull_area).abs() > 1e-9 * hull_area {
        return None;
    }
    // Hull edges as outward half-planes in (e1, e2), with a tolerance for "on the boundary".
    let tol = 1e-9 * (size + scale);
    let lines: Vec<(Vector2<f64>, f64)> = (0..hull.len())
        .map(|i| {
            let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
            let m = Vector2::new(b.y - a.y, a.x - b.x).normalize();
            (m, m.dot(&a).max(m.dot(&b)))
        })
        .collect();
    // Every boundary edge lies on one hull edge.
    for &(a, b) in &boundary {
        let (pa, pb) = (flat(&vertices[a as usize]), flat(&vertices[b as usize]));
        if !lines
            .iter()
            .any(|(m, c)| (m.dot(&pa) - c).abs() <= tol && (m.dot(&pb) - c).abs() <= tol)
        {
            return None;
        }
    }
    let pad = 1e-12 * (size + scale) + tol;
    let c = (0..lines.len())
        .map(|i| -lines[i].0.dot(&lines[(i + 1) % lines.len()].0))
        .fold(0.0, f64::max);
    Some(Patch {
        outside: if c <= 0.1 {
            (1.0 + 1e-12) / ((1.0 - c) * (1.0 - c))
        } else {
            f64::INFINITY
        },
        normal: n,
        offset,
        thickness: thickness * (1.0 + 1e-12) + pad,
        rho: rho * (1.0 + 1e-12) + pad,
        edges: lines
            .iter()
            .map(|(m, c)| (e1 * m.x + e2 * m.y, c + pad))
            .collect(),
    })
}

/// Convex hull, counter-clockwise, without collinear points (Andrew's monotone chain; a few
/// lines, so written here rather than pulled from a crate).
fn convex_hull(mut p: Vec<Vector2<f64>>) -> Vec<Vector2<f64>> {
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let mut h: Vec<Vector2<f64>> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = h.len();
        let iter: Box<dyn Iterator<Item = &Vector2<f64>>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for q in iter {
            while h.len() >= start + 2
                && (h[h.len() - 1] - h[h.len() - 2]).perp(&(q - h[h.len() - 1])) <= 0.0
            {
                h.pop();
            }
            h.push(*q);
        }
        h.pop();
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;

    #[test]
    fn a_box_has_six_patches_that_cover_its_faces() {
        let s = Shape::Box {
            half: Vector3::new(0.1, 0.05, 0.02),
        }
        .sample(0.01);
        let (of, patches) = find_patches(&s.points, &s.normals, &s.vertices, &s.faces);
        assert_eq!(patches.len(), 6);
        assert!(of.iter().all(|&p| p != u32::MAX));
        for (k, &p) in of.iter().enumerate() {
            let patch = &patches[p as usize];
            assert!((patch.normal - s.normals[k]).norm() < 1e-12);
            assert!(patch.thickness < 1e-9 && patch.rho < 0.01);
            // Every quad vertex of the face lies in the polygon; points just outside do not.
            for &v in &s.faces[k] {
                let x = s.vertices[v as usize];
                assert!(patch.edges.iter().all(|(m, c)| m.dot(&x) <= *c));
            }
        }
        // The +x face: its polygon is the 0.1 × 0.04 rectangle in y, z.
        let px = &patches[of[s.normals.iter().position(|n| n.x > 0.5).unwrap()] as usize];
        let inside = |x: Vector3<f64>| px.edges.iter().all(|(m, c)| m.dot(&x) <= *c);
        assert!(inside(Vector3::new(0.3, 0.049, -0.019)));
        assert!(!inside(Vector3::new(0.1, 0.051, 0.0)));
        assert!(!inside(Vector3::new(0.1, 0.0, 0.021)));
        // Rectangles: a point past a corner by (a, b) lies √(a² + b²) from the polygon.
        assert!(patches.iter().all(|p| (p.outside - 1.0).abs() < 1e-9));
    }

    #[test]
    fn curved_surfaces_have_no_patches_and_a_cylinder_has_its_caps() {
        let s = Shape::Sphere { radius: 0.05 }.sample(0.01);
        assert!(find_patches(&s.points, &s.normals, &s.vertices, &s.faces)
            .1
            .is_empty());
        let c = Shape::Cylinder {
            radius: 0.05,
            half_length: 0.1,
        }
        .sample(0.01);
        let (of, patches) = find_patches(&c.points, &c.normals, &c.vertices, &c.faces);
        assert_eq!(patches.len(), 2, "the two caps");
        for (k, &p) in of.iter().enumerate() {
            assert_eq!(p != u32::MAX, c.normals[k].z.abs() > 0.999);
        }
        // A cap is a polygon of many sides: every interior angle is obtuse.
        assert!(patches.iter().all(|p| (p.outside - 1.0).abs() < 1e-9));
    }

    /// A polygon with an acute corner gets no outside factor: past a 60° corner a point's
    /// distance to the polygon is up to twice the edges' excesses, not `√(w₁² + w₂²)`.
    #[test]
    fn a_polygon_with_an_acute_corner_bounds_no_point_outside_it() {
        // A 3 × 3 grid of rhombi with 60° and 120° angles in z = 0.
        let g: Vec<Vector3<f64>> = (0..16)
            .map(|i| {
                Vector3::new(
                    (i % 4) as f64 + 0.5 * (i / 4) as f64,
                    0.75f64.sqrt() * (i / 4) as f64,
                    0.0,
                )
            })
            .collect();
        let faces: Vec<[u32; 4]> = (0..9)
            .map(|q| (4 * (q / 3) + q % 3) as u32)
            .map(|b| [b, b + 1, b + 5, b + 4])
            .collect();
        let points: Vec<_> = faces
            .iter()
            .map(|f| f.iter().fold(Vector3::zeros(), |s, &i| s + g[i as usize]) / 4.0)
            .collect();
        let (_, patches) = find_patches(&points, &vec![Vector3::z(); 9], &g, &faces);
        assert_eq!(patches.len(), 1, "the rhombi tile a rhombus");
        assert_eq!(patches[0].outside, f64::INFINITY);
    }

    #[test]
    fn a_group_whose_quads_do_not_tile_a_convex_polygon_is_not_a_patch() {
        // A 3 × 3 grid of unit squares in z = 0 (normal +z) is a patch; without a corner
        // quad (an L) or the centre one (a hole), with a quad twice or one flipped, it is not.
        let g: Vec<Vector3<f64>> = (0..16)
            .map(|i| Vector3::new((i % 4) as f64, (i / 4) as f64, 0.0))
            .collect();
        let quad = |q: usize| {
            let b = (4 * (q / 3) + q % 3) as u32;
            [b, b + 1, b + 5, b + 4]
        };
        let centre =
            |f: &[u32; 4]| f.iter().fold(Vector3::zeros(), |s, &i| s + g[i as usize]) / 4.0;
        let patches_of = |faces: &[[u32; 4]]| {
            let points: Vec<_> = faces.iter().map(centre).collect();
            find_patches(&points, &vec![Vector3::z(); faces.len()], &g, faces)
                .1
                .len()
        };
        let mut gf: Vec<[u32; 4]> = (0..9).map(quad).collect();
        assert_eq!(patches_of(&gf), 1);
        assert_eq!(patches_of(&(0..8).map(quad).collect::<Vec<_>>()), 0, "an L");
        assert_eq!(
            patches_of(&(0..9).filter(|&q| q != 4).map(quad).collect::<Vec<_>>()),
            0,
            "a hole"
        );
        let mut twice = gf.clone();
        twice.push(gf[4]);
        assert_eq!(patches_of(&twice), 0, "a quad twice");
        gf[4] = [gf[4][0], gf[4][3], gf[4][2], gf[4][1]];
        assert_eq!(patches_of(&gf), 0, "a flipped quad");
    }
}

//! The 3-D quickhull behind [`TriMesh::convex_hull`](super::TriMesh::convex_hull), written
//! here for two properties a library did not give together:
//! - **exact**: every decision (is a point above a facet?) is an exact orientation test
//!   (Shewchuk's adaptive predicates, the `robust` crate), so nearly coplanar vertices, common
//!   in CAD exports, never give crossing or missing facets;
//! - **the same hull on every run**: facets and points are visited in index order, and the one
//!   hash map is only looked up, never iterated. (The hull crate used before visited sets in
//!   hash order, whose seed changes from run to run: a mesh with coplanar vertices got a hull
//!   of 859 corners in one run and 858 in the next, and a simulation's contacts changed with
//!   it.)
//!
//! Floating-point arithmetic only chooses which point goes next (the farthest above a facet);
//! a wrong choice through rounding costs time, never correctness.

use nalgebra::Vector3;
use std::collections::HashMap;

/// A triangle of the hull being built, counter-clockwise seen from outside.
struct Facet {
    v: [u32; 3],
    /// The points strictly above this facet and above no facet made before it (each point
    /// waits on one facet only).
    above: Vec<u32>,
    alive: bool,
    /// The last apex for which this facet was found visible (`u32::MAX`: none).
    seen_from: u32,
}

struct Hull<'a> {
    p: &'a [Vector3<f64>],
    facets: Vec<Facet>,
    /// The facet on the left of each directed edge (a closed, oriented surface has each
    /// directed edge once): looked up, never iterated.
    edges: HashMap<(u32, u32), u32>,
}

impl Hull<'_> {
    /// Exact orientation of point `d` against facet `v`: negative when `d` is strictly above
    /// (outside), zero on its plane, positive below.
    fn orient(&self, v: [u32; 3], d: u32) -> f64 {
        let c = |i: u32| {
            let q = &self.p[i as usize];
            robust::Coord3D {
                x: q.x,
                y: q.y,
                z: q.z,
            }
        };
        robust::orient3d(c(v[0]), c(v[1]), c(v[2]), c(d))
    }

    fn is_above(&self, f: usize, d: u32) -> bool {
        self.orient(self.facets[f].v, d) < 0.0
    }

    fn add(&mut self, v: [u32; 3]) {
        let f = self.facets.len() as u32;
        for k in 0..3 {
            self.edges.insert((v[k], v[(k + 1) % 3]), f);
        }
        self.facets.push(Facet {
            v,
            above: Vec::new(),
            alive: true,
            seen_from: u32::MAX,
        });
    }

    fn remove(&mut self, f: usize) {
        let v = self.facets[f].v;
        for k in 0..3 {
            self.edges.remove(&(v[k], v[(k + 1) % 3]));
        }
        self.facets[f].alive = false;
    }

    /// The facet across edge `k` of facet `f`.
    fn neighbour(&self, f: usize, k: usize) -> usize {
        let v = self.facets[f].v;
        self.edges[&(v[(k + 1) % 3], v[k])] as usize
    }

    /// Gives each of `points` to the first facet from `first` on that it is strictly above;
    /// a point above none is inside the hull and leaves.
    fn assign(&mut self, first: usize, points: impl IntoIterator<Item = u32>) {
        for q in points {
            if let Some(f) = (first..self.facets.len()).find(|&f| self.is_above(f, q)) {
                self.facets[f].above.push(q);
            }
        }
    }

    /// The point of facet `f`'s waiting points farthest above its plane (the first of equals).
    fn farthest(&self, f: usize) -> u32 {
        let [a, b, c] = self.facets[f].v.map(|i| self.p[i as usize]);
        let n = (b - a).cross(&(c - a));
        let height = |q: u32| n.dot(&(self.p[q as usize] - a));
        let above = &self.facets[f].above;
        let mut best = above[0];
        for &q in &above[1..] {
            if height(q) > height(best) {
                best = q;
            }
        }
        best
    }
}

/// The triangles (indices into `points`, counter-clockwise seen from outside) of the convex
/// hull of `points`, or why there is none (fewer than four points, or no volume). Points on
/// the hull's surface that are not needed as corners may or may not be corners, but always
/// the same way for the same input.
pub(super) fn quickhull(points: &[Vector3<f64>]) -> Result<Vec<[u32; 3]>, String> {
    let n = points.len();
    if n < 4 {
        return Err(format!("{n} vertices span no volume"));
    }
    // The first of the largest by a key: the initial simplex does not depend on ties' order.
    let first_max = |key: &dyn Fn(usize) -> f64| {
        (0..n).fold(0, |best, i| if key(i) > key(best) { i } else { best })
    };
    let i0 = first_max(&|i| -points[i].x);
    let i1 = first_max(&|i| (points[i] - points[i0]).norm_squared());
    let axis = points[i1] - points[i0];
    if axis.norm_squared() == 0.0 {
        return Err("all vertices coincide".into());
    }
    let i2 = first_max(&|i| (points[i] - points[i0]).cross(&axis).norm_squared());
    let mut hull = Hull {
        p: points,
        facets: Vec::new(),
        edges: HashMap::new(),
    };
    let base = [i0 as u32, i1 as u32, i2 as u32];
    let i3 = first_max(&|i| hull.orient(base, i as u32).abs());
    if hull.orient(base, i3 as u32) == 0.0 {
        return Err("the vertices lie in one plane: they span no volume".into());
    }
    // The tetrahedron, each face oriented with the fourth corner below it.
    let t = [i0 as u32, i1 as u32, i2 as u32, i3 as u32];
    for o in 0..4 {
        let mut v = [0u32; 3];
        for (slot, k) in (0..4).filter(|&k| k != o).enumerate() {
            v[slot] = t[k];
        }
        if hull.orient(v, t[o]) < 0.0 {
            v.swap(1, 2);
        }
        hull.add(v);
    }
    hull.assign(0, (0..n as u32).filter(|q| !t.contains(q)));

    let mut f = 0;
    while f < hull.facets.len() {
        if !hull.facets[f].alive || hull.facets[f].above.is_empty() {
            f += 1;
            continue;
        }
        let apex = hull.farthest(f);
        // The facets the apex is strictly above: connected, found by walking across edges.
        let mut visible = vec![f];
        hull.facets[f].seen_from = apex;
        let mut i = 0;
        while i < visible.len() {
            let g = visible[i];
            i += 1;
            for k in 0..3 {
                let h = hull.neighbour(g, k);
                if hull.facets[h].seen_from != apex && hull.is_above(h, apex) {
                    hull.facets[h].seen_from = apex;
                    visible.push(h);
                }
            }
        }
        // The horizon: edges between a visible facet and one that is not, which the apex
        // joins in new facets.
        let mut horizon = Vec::new();
        for &g in &visible {
            for k in 0..3 {
                if hull.facets[hull.neighbour(g, k)].seen_from != apex {
                    let v = hull.facets[g].v;
                    horizon.push((v[k], v[(k + 1) % 3]));
                }
            }
        }
        let mut waiting = Vec::new();
        for &g in &visible {
            waiting.append(&mut hull.facets[g].above);
            hull.remove(g);
        }
        let first = hull.facets.len();
        for (a, b) in horizon {
            hull.add([a, b, apex]);
        }
        hull.assign(first, waiting.into_iter().filter(|&q| q != apex));
    }
    Ok(hull
        .facets
        .iter()
        .filter(|f| f.alive)
        .map(|f| f.v)
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// What any convex hull of `points` must be: a closed, oriented surface (each directed
    /// edge once, and its reverse once), with every point on or below every facet (exactly),
    /// and no facet of zero area (exactly: its corners not collinear).
    fn assert_is_hull(points: &[Vector3<f64>], tris: &[[u32; 3]]) {
        let hull = Hull {
            p: points,
            facets: Vec::new(),
            edges: HashMap::new(),
        };
        let mut edges = std::collections::BTreeMap::new();
        for t in tris {
            for k in 0..3 {
                let e = (t[k], t[(k + 1) % 3]);
                assert!(edges.insert(e, ()).is_none(), "edge {e:?} twice");
            }
            for q in 0..points.len() as u32 {
                assert!(hull.orient(*t, q) >= 0.0, "point {q} above facet {t:?}");
            }
            let [a, b, c] = t.map(|i| points[i as usize]);
            let off = (0..points.len() as u32).any(|q| hull.orient(*t, q) != 0.0);
            assert!(off && a != b && b != c && c != a, "degenerate facet {t:?}");
        }
        for &(a, b) in edges.keys() {
            assert!(edges.contains_key(&(b, a)), "edge ({a}, {b}) has no twin");
        }
    }

    /// The points of a 4 × 4 × 4 grid: most lie on the hull's faces and edges, the
    /// degenerate case where a hull's corners depend on the order of its choices.
    fn grid() -> Vec<Vector3<f64>> {
        (0..64)
            .map(|i| Vector3::new((i % 4) as f64, (i / 4 % 4) as f64, (i / 16) as f64) * 0.1)
            .collect()
    }

    /// The same points give the same triangles, call after call (the hull crate used before
    /// did not: its hash sets' order changed between calls), and a rotated copy of a
    /// degenerate set still gives a valid hull.
    #[test]
    fn a_degenerate_set_gives_the_same_valid_hull_on_every_call() {
        let points = grid();
        let first = quickhull(&points).unwrap();
        assert_is_hull(&points, &first);
        for _ in 0..8 {
            assert_eq!(quickhull(&points).unwrap(), first);
        }
        let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.7, 1.1);
        let turned: Vec<_> = points.iter().map(|p| r * p).collect();
        assert_is_hull(&turned, &quickhull(&turned).unwrap());
        // A cube's grid has volume 0.3³ (signed tetrahedra from a corner).
        let volume: f64 = first
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| points[i as usize]);
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum();
        assert!((volume - 0.027).abs() < 1e-15, "{volume}");
    }

    #[test]
    fn too_few_coincident_and_flat_points_have_no_hull() {
        let z = Vector3::zeros();
        assert!(quickhull(&[z; 3]).is_err());
        assert!(quickhull(&[z; 6]).unwrap_err().contains("coincide"));
        let flat: Vec<_> = (0..9)
            .map(|i| Vector3::new((i % 3) as f64, (i / 3) as f64, 0.0))
            .collect();
        assert!(quickhull(&flat).unwrap_err().contains("one plane"));
    }

    proptest! {
        /// Random points, on a coarse integer lattice (many coplanar and collinear) or
        /// anywhere, give a valid hull, the same on a second call.
        #[test]
        fn random_points_give_a_valid_hull(
            raw in proptest::collection::vec((-3i32..4, -3i32..4, -3i32..4, -1e3f64..1e3), 4..60),
            lattice in any::<bool>(),
        ) {
            let points: Vec<Vector3<f64>> = raw
                .iter()
                .map(|&(x, y, z, w)| {
                    let v = Vector3::new(x as f64, y as f64, z as f64);
                    if lattice { v } else { v * w.sin() + Vector3::new(w.cos(), w, 0.0) * 1e-3 }
                })
                .collect();
            match quickhull(&points) {
                Ok(tris) => {
                    assert_is_hull(&points, &tris);
                    prop_assert_eq!(quickhull(&points).unwrap(), tris);
                }
                Err(e) => prop_assert!(e.contains("plane") || e.contains("coincide"), "{}", e),
            }
        }
    }
}

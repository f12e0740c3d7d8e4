//! A mesh's AOPC at the spacing a scene asks for: the mesh simplified within a fraction of
//! the spacing, then one point per triangle no longer than the spacing and three quads per
//! longer one (docs/geometry.md, "Meshes finer than the spacing").

use super::{bounds, closest_on_triangle, tri_normal, TriMesh};
use crate::geometry::Aopc;
use nalgebra::Vector3;
use std::collections::{BinaryHeap, HashMap};

/// The simplification tolerance, as a fraction of the spacing a mesh is sampled at: the
/// simplified surface stays within `SIMPLIFY_TOLERANCE × spacing` of the file's (0.5 mm at the
/// default 1 cm). Sampling itself departs from a curved surface by the sagitta `s² / 8R` (1.25
/// mm on a 1 cm radius at 1 cm), so the tolerance is below what the spacing already costs.
pub const SIMPLIFY_TOLERANCE: f64 = 0.05;

/// The largest relative change of the enclosed volume a simplification may make: a tolerance
/// of half a millimetre is small for an arm's link and coarse for a 2 cm finger (measured:
/// up to 8 % of a finger link's volume), so a simplification that moves the volume further is
/// tried again within half the tolerance. 2 %, what `scm check` allows a cloud's volume: at 1 %
/// robosuite's Jaco arm (its links lose 0.9 to 1.3 % at 0.5 mm) was held to 0.25 mm and took
/// 161 MB and 8.0 s for a 2 ms step, at 2 % 99 MB and 4.8 s, with no hand's link flagged.
pub const SIMPLIFY_VOLUME: f64 = 0.02;

/// Simplifications tried, each within half the last one's tolerance ([`TriMesh::simplified`]).
pub const SIMPLIFY_TRIES: u32 = 6;

/// A mesh simplified for sampling ([`TriMesh::simplified`]).
#[derive(Clone, Debug)]
pub struct Simplified {
    /// The simplified mesh (a subset of the file's vertices), without its folds.
    pub mesh: TriMesh,
    /// meshoptimizer's estimate of the largest distance from the file's surface (m).
    pub error: f64,
    /// The tolerance it was simplified within (m).
    pub tolerance: f64,
    /// Triangles the simplification folded over to face into the part, dropped from
    /// [`Simplified::mesh`] (which is then closed but for them).
    pub folds: usize,
    /// Triangles of no area the simplification left, dropped from [`Simplified::mesh`].
    pub flat: usize,
}

impl TriMesh {
    /// The AOPC of the surface at about `spacing` (m) between points (module documentation):
    /// of the mesh simplified within [`SIMPLIFY_TOLERANCE`] of the spacing where that leaves
    /// fewer triangles ([`TriMesh::simplified`]), of the mesh as it is otherwise.
    pub fn sample(&self, spacing: f64) -> Aopc {
        match self.simplified(spacing) {
            Some(s) => s.mesh.sample_as_is(spacing),
            None => self.sample_as_is(spacing),
        }
    }

    /// The mesh with its triangles merged where the surface stays within
    /// `SIMPLIFY_TOLERANCE × spacing` of this one (meshoptimizer's quadric edge collapse, which
    /// keeps the topology), so that a mesh finer than the scene asks for is sampled at the
    /// scene's spacing rather than at its own triangulation (a robot link of 12,516 triangles
    /// at 0.9 mm, asked for 1 cm). `None` when that would not leave fewer triangles, or when
    /// no tolerance tried gives a closed, consistently oriented surface within
    /// [`SIMPLIFY_VOLUME`] of the file's volume (the mesh is then sampled as it is). The result
    /// may be pinched (an edge of four triangles where two sheets meet): it is for sampling,
    /// not a file's mesh.
    pub fn simplified(&self, spacing: f64) -> Option<Simplified> {
        let tolerance = SIMPLIFY_TOLERANCE * spacing;
        if tolerance.is_nan() || tolerance <= 0.0 || self.triangles.len() <= 4 {
            return None;
        }
        // Positions in f32 about the mesh's centre (meshoptimizer's input); the result indexes
        // the f64 vertices, so no vertex moves.
        let (lo, hi) = bounds(&self.vertices);
        let centre = (lo + hi) * 0.5;
        let bytes: Vec<u8> = self
            .vertices
            .iter()
            .flat_map(|v| {
                let d = v - centre;
                [d.x, d.y, d.z]
            })
            .flat_map(|x| (x as f32).to_le_bytes())
            .collect();
        let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0).ok()?;
        let indices: Vec<u32> = self.triangles.iter().flatten().copied().collect();
        let volume = self.mass_properties().volume;
        let normals = self.vertex_normals();
        for tries in 0..SIMPLIFY_TRIES {
            let within = tolerance / f64::from(1u32 << tries);
            let mut error = 0.0f32;
            let kept = meshopt::simplify(
                &indices,
                &adapter,
                0,
                within as f32,
                meshopt::SimplifyOptions::ErrorAbsolute,
                Some(&mut error),
            );
            if kept.len() / 3 >= self.triangles.len() * 9 / 10 || kept.is_empty() {
                return None; // not worth it (and a tighter tolerance keeps more)
            }
            // Only the vertices still used, in their first use's order.
            let mut index = vec![u32::MAX; self.vertices.len()];
            let mut vertices = Vec::new();
            let triangles = kept
                .chunks_exact(3)
                .map(|t| {
                    [0, 1, 2].map(|k| {
                        let i = t[k] as usize;
                        if index[i] == u32::MAX {
                            index[i] = vertices.len() as u32;
                            vertices.push(self.vertices[i]);
                        }
                        index[i]
                    })
                })
                .collect();
            // What sampling needs is a closed, oriented surface: every edge run as often one
            // way as the other (triangles of no area are dropped below). A collapse may pinch two sheets
            // of a thin part together (an edge of four triangles): sampling takes that as it
            // is. A volume further off than SIMPLIFY_VOLUME means the tolerance was coarse for
            // the part; then the tolerance is halved, a few times, before the mesh is sampled
            // as it is.
            let mesh = TriMesh {
                file: self.file.clone(),
                vertices,
                triangles,
                sampling: self.sampling,
            };
            let off = (mesh.mass_properties().volume - volume).abs();
            if !mesh.is_closed_and_oriented() || off > SIMPLIFY_VOLUME * volume.abs() {
                continue;
            }
            // A collapse can also fold a triangle over onto its neighbours, facing into the
            // part: closed and oriented still, the volume unchanged, but its points' planes
            // face the wrong way, and the SSDF beside them is deeply negative far outside the
            // part (measured: a fold on the flat top of TIAGo's arm link, seen 0.6 m away as
            // 0.25 m of penetration). Folds come at every tolerance (robosuite's Inspire hand:
            // 1 to 38 per link at each of the six tolerances tried), so they are dropped, not
            // retried: the neighbours a fold lies on still cover its place, facing out.
            // A collapse can also leave a triangle of no area (three vertices on a line: the
            // grid-cut surfaces of MuJoCo's SDF shapes, measured, keep 8 of 7,252 at 0.5 mm):
            // it adds nothing to the surface and has no normal, so it is dropped too, and the
            // rest stays closed (its edges lie along the ones its neighbours share).
            let mut mesh = mesh;
            let before = mesh.triangles.len();
            let own: Vec<[u32; 3]> = kept.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
            let flat: Vec<bool> = mesh.triangles.iter().map(mesh.flat_triangle()).collect();
            let mut k = 0;
            let mut folds = 0;
            mesh.triangles.retain(|_| {
                k += 1;
                if flat[k - 1] {
                    return false;
                }
                let fold = self.folds(&own[k - 1], &normals);
                folds += usize::from(fold);
                !fold
            });
            return Some(Simplified {
                folds,
                flat: before - folds - mesh.triangles.len(),
                mesh,
                error: error as f64,
                tolerance: within,
            });
        }
        None
    }

    /// Whether triangle `t` (of this mesh's vertices, from a simplification) faces against
    /// this mesh's surface: against the vertices' `normals` ([`TriMesh::vertex_normals`]) and
    /// against this mesh's triangle nearest its centroid.
    fn folds(&self, t: &[u32; 3], normals: &[Vector3<f64>]) -> bool {
        let n = tri_normal(&self.vertices, t);
        let around: Vector3<f64> = t.iter().map(|&i| normals[i as usize]).sum();
        if n.dot(&around) >= 0.0 {
            return false;
        }
        let corners = t.map(|i| self.vertices[i as usize]);
        let centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
        let distance = |u: &[u32; 3]| {
            let p = closest_on_triangle(&centroid, &u.map(|i| self.vertices[i as usize]));
            (p - centroid).norm_squared()
        };
        self.triangles
            .iter()
            .min_by(|u, v| distance(u).total_cmp(&distance(v)))
            .is_some_and(|u| n.dot(&tri_normal(&self.vertices, u)) < 0.0)
    }

    /// The unit normal of the surface at each vertex: the mean of its triangles' normals,
    /// weighted by their areas (zero at a vertex no triangle uses).
    fn vertex_normals(&self) -> Vec<Vector3<f64>> {
        let mut n = vec![Vector3::zeros(); self.vertices.len()];
        for t in &self.triangles {
            let a = tri_normal(&self.vertices, t);
            for &i in t {
                n[i as usize] += a;
            }
        }
        n.iter()
            .map(|v| v.try_normalize(0.0).unwrap_or_else(Vector3::zeros))
            .collect()
    }

    /// Whether a triangle of this mesh has no area (below 1e-12 of the square of the mesh's
    /// extent): its corners on a line.
    fn flat_triangle(&self) -> impl Fn(&[u32; 3]) -> bool + '_ {
        let (lo, hi) = bounds(&self.vertices);
        let least = 1e-12 * (hi - lo).norm_squared();
        move |t| tri_normal(&self.vertices, t).norm() <= least
    }

    /// Whether every edge is run as often in one direction as in the other (a closed, oriented
    /// surface, possibly pinched) and some triangle has an area.
    fn is_closed_and_oriented(&self) -> bool {
        let flat = self.flat_triangle();
        if self.triangles.iter().all(&flat) {
            return false;
        }
        let mut runs: HashMap<(u32, u32), i32> = HashMap::new();
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *runs.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
            }
        }
        runs.values().all(|&r| r == 0)
    }

    /// The AOPC of this mesh's own triangles at `spacing` (m), without simplifying them first:
    /// a triangle no longer than the spacing gives one point, at its centroid, with its normal
    /// and area (a quad with its last corner repeated); a longer one is refined (edges of at
    /// most 5 × the spacing) and cut into three quads through its centroid and edge midpoints.
    pub fn sample_as_is(&self, spacing: f64) -> Aopc {
        let (verts, tris) = refine(&self.vertices, &self.triangles, 5.0 * spacing);
        let mut out = Aopc::default();
        for t in &tris {
            let [a, b, c] = t.map(|i| verts[i as usize]);
            if (a - b).norm().max((b - c).norm()).max((c - a).norm()) <= spacing {
                out.push_quad([a, b, c, c]);
                continue;
            }
            let g = (a + b + c) / 3.0;
            let (mab, mbc, mca) = ((a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5);
            out.push_quad([a, mab, g, mca]);
            out.push_quad([b, mbc, g, mab]);
            out.push_quad([c, mca, g, mbc]);
        }
        out
    }
}

/// Longest-edge bisection of a closed manifold mesh until no edge exceeds `max_len`: the
/// longest edge is split at its midpoint together with both triangles on it (the mesh stays
/// conforming and keeps its orientation and its shape).
fn refine(
    vertices: &[Vector3<f64>],
    triangles: &[[u32; 3]],
    max_len: f64,
) -> (Vec<Vector3<f64>>, Vec<[u32; 3]>) {
    let mut v = vertices.to_vec();
    let mut t = triangles.to_vec();
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (i, tri) in t.iter().enumerate() {
        for k in 0..3 {
            edges
                .entry(key(tri[k], tri[(k + 1) % 3]))
                .or_default()
                .push(i as u32);
        }
    }
    // Max-heap of edges by length (bits of a positive f64 order like the value).
    let mut heap: BinaryHeap<(u64, u32, u32)> = BinaryHeap::new();
    let len = |v: &[Vector3<f64>], a: u32, b: u32| (v[a as usize] - v[b as usize]).norm();
    for &(a, b) in edges.keys() {
        let l = len(&v, a, b);
        if l > max_len {
            heap.push((l.to_bits(), a, b));
        }
    }
    while let Some((_, a, b)) = heap.pop() {
        let Some(on) = edges.remove(&key(a, b)) else {
            continue;
        };
        let m = v.len() as u32;
        v.push((v[a as usize] + v[b as usize]) * 0.5);
        for &ti in &on {
            let tri = t[ti as usize];
            let k = (0..3)
                .find(|&k| key(tri[k], tri[(k + 1) % 3]) == key(a, b))
                .expect("the edge belongs to the triangle");
            let (p, q, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            // (p, q, c) becomes (p, m, c) in place and (m, q, c) as a new triangle.
            let tn = t.len() as u32;
            t[ti as usize] = [p, m, c];
            t.push([m, q, c]);
            edges.entry(key(p, m)).or_default().push(ti);
            edges.entry(key(m, q)).or_default().push(tn);
            let mc = edges.entry(key(m, c)).or_default();
            mc.push(ti);
            mc.push(tn);
            if let Some(list) = edges.get_mut(&key(q, c)) {
                for x in list.iter_mut() {
                    if *x == ti {
                        *x = tn;
                    }
                }
            }
            let lc = len(&v, m, c);
            if lc > max_len {
                heap.push((lc.to_bits(), m, c));
            }
        }
        let half = len(&v, a, m);
        if half > max_len {
            heap.push((half.to_bits(), a, m));
            heap.push((len(&v, m, b).to_bits(), m, b));
        }
    }
    (v, t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::mesh::MeshSampling;

    fn tetra(o: Vector3<f64>, first: u32) -> (Vec<Vector3<f64>>, Vec<[u32; 3]>) {
        let v = vec![o, o + Vector3::x(), o + Vector3::y(), o + Vector3::z()];
        let t = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        (v, t.iter().map(|t| t.map(|i| i + first)).collect())
    }

    #[test]
    fn a_pinched_surface_is_closed_and_an_open_one_is_not() {
        // Two tetrahedra sharing the corner edge along x: that edge has four triangles, run
        // twice each way. Sampling takes it; a file's checks would refuse it (not manifold).
        let (mut v, mut t) = tetra(Vector3::zeros(), 0);
        let (w, u) = tetra(Vector3::zeros(), 4);
        // The second one mirrored through the x axis shares the edge (0,0,0)-(1,0,0).
        v.extend(w.iter().map(|p| Vector3::new(p.x, -p.y, -p.z)));
        // Mirroring twice keeps the orientation; the shared vertices are 0 and 1.
        let share = |i: u32| match i {
            4 => 0,
            5 => 1,
            _ => i,
        };
        t.extend(u.iter().map(|t| t.map(share)));
        let pinched = TriMesh {
            file: "pinched".into(),
            vertices: v,
            triangles: t.clone(),
            sampling: MeshSampling::default(),
        };
        assert!(pinched.is_closed_and_oriented());
        assert!(TriMesh::new("pinched", pinched.vertices.clone(), t.clone()).is_err());
        // Its AOPC: closed, with both tetrahedra's volumes (1/6 each).
        let cloud = pinched.sample_as_is(10.0);
        assert!(cloud.closure_defect().norm() < 1e-15);
        assert!((cloud.enclosed_volume() - 2.0 / 6.0).abs() < 1e-15);
        // One triangle gone: open. One turned over: not oriented.
        let mut open = pinched.clone();
        open.triangles.pop();
        assert!(!open.is_closed_and_oriented());
        let mut flipped = pinched.clone();
        flipped.triangles[0].swap(1, 2);
        assert!(!flipped.is_closed_and_oriented());
    }

    /// A triangle facing into the part is a fold; the same triangle facing out, and one
    /// facing out across a corner region of other faces, are not.
    #[test]
    fn a_triangle_turned_into_the_part_is_a_fold() {
        // A unit cube whose top face (z = 1: corners 4, 5, 7, 6) is a fan about its centre.
        let (mut v, t) = super::super::tests::cube();
        v.push(Vector3::new(0.5, 0.5, 1.0));
        let c = 8;
        let mut triangles: Vec<[u32; 3]> = t
            .into_iter()
            .filter(|t| !t.iter().all(|i| (4..8).contains(i)))
            .collect();
        triangles.extend([[c, 4, 5], [c, 5, 7], [c, 7, 6], [c, 6, 4]]);
        let mesh = TriMesh::new("fan", v, triangles).unwrap().0;
        let normals = mesh.vertex_normals();
        assert!((normals[c as usize] - Vector3::z()).norm() < 1e-15);
        assert!(!mesh.folds(&[c, 5, 7], &normals));
        assert!(mesh.folds(&[c, 7, 5], &normals));
        // Across the x = 1 face: facing +x, out; facing -x, into the part.
        assert!(!mesh.folds(&[5, 3, 7], &normals));
        assert!(mesh.folds(&[5, 7, 3], &normals));
    }

    #[test]
    fn a_triangle_finer_than_the_spacing_gives_one_point_and_a_coarser_one_three() {
        let (v, t) = tetra(Vector3::zeros(), 0);
        let mesh = TriMesh {
            file: "tetra".into(),
            vertices: v,
            triangles: t,
            sampling: MeshSampling::default(),
        };
        // Longest edges √2: one point per face at a spacing of 2, three quads each at 1.2.
        let fine = mesh.sample_as_is(2.0);
        assert_eq!(fine.len(), 4);
        for (k, t) in mesh.triangles.iter().enumerate() {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
            assert!((fine.points[k] - (a + b + c) / 3.0).norm() < 1e-15);
            let n = (b - a).cross(&(c - a));
            assert!((fine.normals[k] - n.normalize()).norm() < 1e-15);
            assert!((fine.areas[k] - 0.5 * n.norm()).abs() < 1e-15);
        }
        let coarse = mesh.sample_as_is(1.2);
        assert_eq!(coarse.len(), 4 * 3); // every face has an edge of √2 > 1.2
        for cloud in [&fine, &coarse] {
            assert!(cloud.closure_defect().norm() < 1e-15);
            assert!((cloud.enclosed_volume() - 1.0 / 6.0).abs() < 1e-15);
        }
    }
}

//! Articulated oriented point clouds: a surface as the centres and outward normals of the faces
//! of a quad mesh, with the quads kept (vertex indices) for the soft top-K contact points.

use super::bvh::Bvh;
use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use std::sync::{Arc, OnceLock};

/// A closed surface as oriented planes `(p_i, n_i)` in its body's frame (docs/method.md, AOPC).
///
/// A bounding-volume hierarchy over the points is built on first use (pruned queries) and kept;
/// change the fields only before the first query, or call [`Aopc::invalidate`].
#[derive(Clone, Debug)]
pub struct Aopc {
    /// Face centres `p_i` (m, body frame).
    pub points: Vec<Vector3<f64>>,
    /// Outward unit normals `n_i` (body frame).
    pub normals: Vec<Vector3<f64>>,
    /// Face areas (m²).
    pub areas: Vec<f64>,
    /// Quad-mesh vertices (m, body frame).
    pub vertices: Vec<Vector3<f64>>,
    /// Quads as four indices into `vertices`, counter-clockwise seen from outside.
    pub faces: Vec<[u32; 4]>,
    /// Points of the surface that no face corner marks (m, body frame): a mesh sampled in
    /// patches, whose faces are rectangles standing for their pieces, keeps its vertices here,
    /// so that the bounding polytope ([`super::polytope`]) holds the whole surface.
    pub reach: Vec<Vector3<f64>>,
    /// The hierarchy over `points`, built on first use.
    bvh: OnceLock<Arc<Bvh>>,
    /// The pruning tolerance of softmax sums over the points and of the contacts they make
    /// ([`Bvh::tolerance`]).
    tolerance: f64,
    /// The certificate of a union of spheres and capsules ([`super::rounded`]), set by
    /// [`super::union::sample_union`], with a fingerprint of the points and normals it holds
    /// for: the hierarchy takes it only while they are unchanged (the fields are public).
    rounded: Option<(u64, Arc<super::rounded::Rounded>)>,
    /// How far below its polytope's proof the floor under its planes lies (a scene's
    /// `scm_floor`, [`super::polytope::FloorKind`]).
    floor: super::polytope::FloorKind,
}

impl PartialEq for Aopc {
    fn eq(&self, o: &Self) -> bool {
        self.points == o.points
            && self.normals == o.normals
            && self.areas == o.areas
            && self.vertices == o.vertices
            && self.faces == o.faces
            && self.reach == o.reach
            && self.floor == o.floor
    }
}

impl Default for Aopc {
    /// No points, at the default pruning tolerance.
    fn default() -> Self {
        Aopc::new(Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new())
    }
}

impl Aopc {
    /// An AOPC from its parts.
    pub fn new(
        points: Vec<Vector3<f64>>,
        normals: Vec<Vector3<f64>>,
        areas: Vec<f64>,
        vertices: Vec<Vector3<f64>>,
        faces: Vec<[u32; 4]>,
    ) -> Aopc {
        Aopc {
            points,
            normals,
            areas,
            vertices,
            faces,
            reach: Vec::new(),
            bvh: OnceLock::new(),
            tolerance: crate::scalar::PRUNE_TOLERANCE,
            rounded: None,
            floor: Default::default(),
        }
    }

    /// The bounding-volume hierarchy over the points (built on first use).
    pub fn bvh(&self) -> &Bvh {
        debug_assert!(
            self.bvh.get().is_none_or(|b| b.len() == self.points.len()),
            "AOPC changed after its BVH was built"
        );
        self.bvh.get_or_init(|| {
            let mut b = Bvh::build(&self.points, &self.normals);
            if !self.points.is_empty() {
                b.set_tolerance(self.tolerance);
            }
            b.set_surface(
                &self.points,
                &self.normals,
                &self.vertices,
                &self.faces,
                &self.reach,
                self.floor,
            );
            b.rounded = self
                .rounded
                .as_ref()
                .filter(|(f, _)| *f == fingerprint(&self.points, &self.normals))
                .map(|(_, r)| r.clone());
            Arc::new(b)
        })
    }

    /// Forgets the hierarchy (after changing the points or normals), and the rounded union's
    /// certificate, which held for the old points only.
    pub fn invalidate(&mut self) {
        self.bvh = OnceLock::new();
        self.rounded = None;
    }

    /// The pruning tolerance `τ` ([`Bvh::tolerance`]).
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }

    /// Sets the pruning tolerance `τ` of this cloud's softmax sums and of the contacts its
    /// points make ([`Bvh::set_tolerance`]): a scene's `scm_prune_tolerance`. The hierarchy is
    /// built again on its next use.
    pub fn set_tolerance(&mut self, tolerance: f64) {
        if tolerance != self.tolerance {
            self.tolerance = tolerance;
            self.bvh = OnceLock::new();
        }
    }

    /// Sets the floor under the cloud's planes ([`super::polytope::FloorKind`]): tight for a
    /// mesh's cloud, or a scene's `scm_floor`. The hierarchy is built again on its next use.
    pub fn set_floor(&mut self, floor: super::polytope::FloorKind) {
        if floor != self.floor {
            self.floor = floor;
            self.bvh = OnceLock::new();
        }
    }

    /// The floor under the cloud's planes.
    pub fn floor(&self) -> super::polytope::FloorKind {
        self.floor
    }

    /// Attaches the certificate of a rounded union (before the hierarchy is built).
    pub(super) fn set_rounded(&mut self, rounded: Option<super::rounded::Rounded>) {
        self.bvh = OnceLock::new();
        let f = fingerprint(&self.points, &self.normals);
        self.rounded = rounded.map(|r| (f, Arc::new(r)));
    }

    /// Number of points `I`.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the AOPC has no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The same surface moved by `pose` (e.g. a geom's pose in its body).
    pub fn transformed(&self, pose: &Isometry3<f64>) -> Aopc {
        let tp = |v: &Vector3<f64>| (pose * Point3::from(*v)).coords;
        let mut out = Aopc::new(
            self.points.iter().map(tp).collect(),
            self.normals.iter().map(|n| pose.rotation * n).collect(),
            self.areas.clone(),
            self.vertices.iter().map(tp).collect(),
            self.faces.clone(),
        );
        out.reach = self.reach.iter().map(tp).collect();
        out.tolerance = self.tolerance;
        out.floor = self.floor;
        out
    }

    /// Appends another AOPC (vertex indices renumbered).
    pub fn extend(&mut self, other: &Aopc) {
        self.invalidate();
        let base = self.vertices.len() as u32;
        self.points.extend_from_slice(&other.points);
        self.normals.extend_from_slice(&other.normals);
        self.areas.extend_from_slice(&other.areas);
        self.vertices.extend_from_slice(&other.vertices);
        self.faces
            .extend(other.faces.iter().map(|f| f.map(|i| i + base)));
        // A cloud with a reach holds its surface in its points and reach alone (its faces'
        // corners may stand past it: [`super::polytope::Polytope::of`]); the corners of the
        // other's faces join it there where only one of them has one.
        match (self.reach.is_empty(), other.reach.is_empty()) {
            (true, false) => {
                self.reach = self.vertices[..base as usize].to_vec();
                self.reach.extend_from_slice(&other.reach);
            }
            (false, true) => self.reach.extend_from_slice(&other.vertices),
            _ => self.reach.extend_from_slice(&other.reach),
        }
    }

    /// The faces whose centre satisfies `keep` (vertices are kept whole; unused ones are
    /// harmless to the soft top-K, which weighs vertices by the faces that use them).
    pub fn retain(&self, keep: impl Fn(&Vector3<f64>) -> bool) -> Aopc {
        let mut out = Aopc {
            vertices: self.vertices.clone(),
            reach: self.reach.clone(),
            tolerance: self.tolerance,
            floor: self.floor,
            ..Default::default()
        };
        for i in 0..self.len() {
            if keep(&self.points[i]) {
                out.points.push(self.points[i]);
                out.normals.push(self.normals[i]);
                out.areas.push(self.areas[i]);
                out.faces.push(self.faces[i]);
            }
        }
        out
    }

    /// `Σ n_i·area_i`: zero for a closed surface (divergence theorem).
    pub fn closure_defect(&self) -> Vector3<f64> {
        self.normals
            .iter()
            .zip(&self.areas)
            .map(|(n, a)| n * *a)
            .sum()
    }

    /// Enclosed volume `⅓ Σ (p_i·n_i) area_i` (divergence theorem on the faces).
    pub fn enclosed_volume(&self) -> f64 {
        self.points
            .iter()
            .zip(&self.normals)
            .zip(&self.areas)
            .map(|((p, n), a)| p.dot(n) * a)
            .sum::<f64>()
            / 3.0
    }

    /// Median distance from a point to its nearest neighbour (m): the achieved spacing.
    pub fn spacing(&self) -> f64 {
        if self.len() < 2 {
            return 0.0;
        }
        let bvh = self.bvh();
        let mut nn: Vec<f64> = (0..bvh.len())
            .map(|k| bvh.nearest_except(&bvh.points[k], k).1.sqrt())
            .collect();
        nn.sort_by(|a, b| a.total_cmp(b));
        nn[nn.len() / 2]
    }

    /// Adds one face: its four corners (counter-clockwise seen from outside), the AOPC point
    /// and outward normal, and its area (m²).
    pub fn push_face(
        &mut self,
        corners: [Vector3<f64>; 4],
        point: Vector3<f64>,
        normal: Vector3<f64>,
        area: f64,
    ) {
        self.invalidate();
        let base = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&corners);
        self.faces.push([base, base + 1, base + 2, base + 3]);
        self.points.push(point);
        self.normals.push(normal);
        self.areas.push(area);
    }

    /// Adds one planar quad given its corners (counter-clockwise seen from outside): the point
    /// is its area centroid, the normal and area from its diagonals.
    pub fn push_quad(&mut self, c: [Vector3<f64>; 4]) {
        let cross = (c[2] - c[0]).cross(&(c[3] - c[1]));
        let area = 0.5 * cross.norm();
        // Area centroid of the two triangles (0,1,2) and (0,2,3).
        let (t1, t2) = (
            0.5 * (c[1] - c[0]).cross(&(c[2] - c[0])).norm(),
            0.5 * (c[2] - c[0]).cross(&(c[3] - c[0])).norm(),
        );
        let centroid = if t1 + t2 > 0.0 {
            ((c[0] + c[1] + c[2]) * t1 + (c[0] + c[2] + c[3]) * t2) / (3.0 * (t1 + t2))
        } else {
            (c[0] + c[1] + c[2] + c[3]) / 4.0
        };
        self.push_face(
            c,
            centroid,
            cross.try_normalize(0.0).unwrap_or_else(Vector3::z),
            area,
        );
    }

    /// Merges vertices closer than `tol` (m), so that neighbouring quads share them (the soft
    /// top-K sums a vertex's weight over the faces that use it), and drops unused ones.
    pub fn weld(&mut self, tol: f64) {
        use rustc_hash::FxHashMap as HashMap;
        let key = |v: &Vector3<f64>| v.map(|x| (x / tol).round() as i64);
        let mut map: HashMap<[i64; 3], u32> = HashMap::default();
        let mut remap = vec![u32::MAX; self.vertices.len()];
        let mut kept: Vec<Vector3<f64>> = Vec::new();
        for f in &self.faces {
            for &i in f {
                if remap[i as usize] != u32::MAX {
                    continue;
                }
                let v = self.vertices[i as usize];
                let k = key(&v);
                // Look in the neighbouring cells too, so that rounding at a cell boundary does
                // not split a vertex.
                let mut found = None;
                'search: for dx in -1..=1 {
                    for dy in -1..=1 {
                        for dz in -1..=1 {
                            if let Some(&j) = map.get(&[k.x + dx, k.y + dy, k.z + dz]) {
                                if (kept[j as usize] - v).norm() <= tol {
                                    found = Some(j);
                                    break 'search;
                                }
                            }
                        }
                    }
                }
                remap[i as usize] = found.unwrap_or_else(|| {
                    kept.push(v);
                    let j = kept.len() as u32 - 1;
                    map.insert([k.x, k.y, k.z], j);
                    j
                });
            }
        }
        for f in &mut self.faces {
            *f = f.map(|i| remap[i as usize]);
        }
        self.vertices = kept;
    }
}

/// Rotation taking the z axis to `dir` (for shapes defined along z).
pub fn z_to(dir: &Vector3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::rotation_between(&Vector3::z(), dir).unwrap_or_else(|| {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    })
}

/// A hash of the bits of `points` and `normals` (and their number): what a certificate computed
/// from them was computed from.
fn fingerprint(points: &[Vector3<f64>], normals: &[Vector3<f64>]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    points.len().hash(&mut h);
    for v in points.iter().chain(normals) {
        v.iter().for_each(|x| x.to_bits().hash(&mut h));
    }
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::geometry::Shape;

    #[test]
    fn sphere_aopc_is_closed_outward_and_on_the_surface() {
        let s = Shape::Sphere { radius: 0.1 }.sample(0.01);
        assert_eq!(s.len() % 6, 0);
        for (p, n) in s.points.iter().zip(&s.normals) {
            assert!((p.norm() - 0.1).abs() < 1e-12);
            assert!((n - p / 0.1).norm() < 1e-12);
        }
        assert!(s.closure_defect().norm() < 1e-6 * 0.1 * 0.1);
        let v = Shape::Sphere { radius: 0.1 }.volume();
        assert!((s.enclosed_volume() - v).abs() < 1e-3 * v);
        assert!(
            (s.spacing() - 0.01).abs() < 0.004,
            "spacing {}",
            s.spacing()
        );
    }

    #[test]
    fn box_aopc_quads_meet_the_edges() {
        let half = Vector3::new(0.1, 0.05, 0.02);
        let s = Shape::Box { half }.sample(0.01);
        // 20x10 on ±z, 20x4 on ±y, 10x4 on ±x.
        assert_eq!(s.len(), 2 * (200 + 80 + 40));
        assert!(s.closure_defect().norm() < 1e-12);
        let v = Shape::Box { half }.volume();
        assert!((s.enclosed_volume() - v).abs() < 1e-12);
        // Every vertex lies on the box surface; corners of the box are vertices.
        for y in &s.vertices {
            assert!(Shape::Box { half }.sdf(y).abs() < 1e-12);
        }
        assert!(s.vertices.iter().any(|y| (y - half).norm() < 1e-12));
        // Normals are unit, outward, and each face's winding agrees with its normal.
        for (f, n) in s.faces.iter().zip(&s.normals) {
            let c: Vec<_> = f.iter().map(|&i| s.vertices[i as usize]).collect();
            assert!((c[2] - c[0]).cross(&(c[3] - c[1])).dot(n) > 0.0);
        }
    }
}

//! Articulated oriented point clouds: a surface as the centres and outward normals of the faces
//! of a quad mesh, with the quads kept (vertex indices) for the soft top-K contact points.

use super::bvh::Bvh;
use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use std::sync::{Arc, OnceLock};
use std::f64::consts::FRAC_PI_4;

/// A closed surface as oriented planes `(p_i, n_i)` in its body's frame (SPEC §2, AOPC).
///
/// A bounding-volume hierarchy over the points is built on first use (pruned queries) and kept;
/// change the fields only before the first query, or call [`Aopc::invalidate`].
#[derive(Clone, Debug, Default)]
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
    /// The hierarchy over `points`, built on first use.
    bvh: OnceLock<Arc<Bvh>>,
}

impl PartialEq for Aopc {
    fn eq(&self, o: &Self) -> bool {
        self.points == o.points && self.normals == o.normals && self.areas == o.areas && self.vertices == o.vertices && self.faces == o.faces
    }
}

/// A primitive shape, in its own frame (centred at the origin; capsule/cylinder along z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// Sphere of the given radius (m).
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// Box with the given half-extents (m).
    Box {
        /// Half-extents along the axes (m).
        half: Vector3<f64>,
    },
}

impl Shape {
    /// Exact signed distance of a point (shape frame): negative inside.
    pub fn sdf(&self, p: &Vector3<f64>) -> f64 {
        match *self {
            Shape::Sphere { radius } => p.norm() - radius,
            Shape::Box { half } => {
                let q = p.abs() - half;
                let outside = q.map(|x| x.max(0.0)).norm();
                outside + q.max().min(0.0)
            }
        }
    }

    /// Enclosed volume (m³).
    pub fn volume(&self) -> f64 {
        match *self {
            Shape::Sphere { radius } => 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3),
            Shape::Box { half } => 8.0 * half.x * half.y * half.z,
        }
    }

    /// Samples the surface as an AOPC with faces about `spacing` (m) apart.
    pub fn sample(&self, spacing: f64) -> Aopc {
        match *self {
            Shape::Sphere { radius } => sample_sphere(radius, spacing),
            Shape::Box { half } => sample_box(&half, spacing),
        }
    }
}

impl Aopc {
    /// An AOPC from its parts.
    pub fn new(points: Vec<Vector3<f64>>, normals: Vec<Vector3<f64>>, areas: Vec<f64>, vertices: Vec<Vector3<f64>>, faces: Vec<[u32; 4]>) -> Aopc {
        Aopc { points, normals, areas, vertices, faces, bvh: OnceLock::new() }
    }

    /// The bounding-volume hierarchy over the points (built on first use).
    pub fn bvh(&self) -> &Bvh {
        debug_assert!(self.bvh.get().is_none_or(|b| b.len() == self.points.len()), "AOPC changed after its BVH was built");
        self.bvh.get_or_init(|| Arc::new(Bvh::build(&self.points, &self.normals)))
    }

    /// Forgets the hierarchy (after changing the points or normals).
    pub fn invalidate(&mut self) {
        self.bvh = OnceLock::new();
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
        Aopc::new(self.points.iter().map(tp).collect(), self.normals.iter().map(|n| pose.rotation * n).collect(), self.areas.clone(), self.vertices.iter().map(tp).collect(), self.faces.clone())
    }

    /// Appends another AOPC (vertex indices renumbered).
    pub fn extend(&mut self, other: &Aopc) {
        self.invalidate();
        let base = self.vertices.len() as u32;
        self.points.extend_from_slice(&other.points);
        self.normals.extend_from_slice(&other.normals);
        self.areas.extend_from_slice(&other.areas);
        self.vertices.extend_from_slice(&other.vertices);
        self.faces.extend(other.faces.iter().map(|f| f.map(|i| i + base)));
    }

    /// The faces whose centre satisfies `keep` (vertices are kept whole; unused ones are
    /// harmless to the soft top-K, which weighs vertices by the faces that use them).
    pub fn retain(&self, keep: impl Fn(&Vector3<f64>) -> bool) -> Aopc {
        let mut out = Aopc { vertices: self.vertices.clone(), ..Default::default() };
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
        self.normals.iter().zip(&self.areas).map(|(n, a)| n * *a).sum()
    }

    /// Enclosed volume `⅓ Σ (p_i·n_i) area_i` (divergence theorem on the faces).
    pub fn enclosed_volume(&self) -> f64 {
        self.points.iter().zip(&self.normals).zip(&self.areas).map(|((p, n), a)| p.dot(n) * a).sum::<f64>() / 3.0
    }

    /// Median distance from a point to its nearest neighbour (m): the achieved spacing.
    pub fn spacing(&self) -> f64 {
        if self.len() < 2 {
            return 0.0;
        }
        let bvh = self.bvh();
        let mut nn: Vec<f64> = (0..bvh.len()).map(|k| bvh.nearest_except(&bvh.points[k], k).1.sqrt()).collect();
        nn.sort_by(|a, b| a.total_cmp(b));
        nn[nn.len() / 2]
    }

    /// Adds one quad given its four corners (counter-clockwise seen from outside), with the
    /// face centre and normal computed from the corners (or given, for curved surfaces).
    fn push_quad(&mut self, corners: [Vector3<f64>; 4], centre_normal: Option<(Vector3<f64>, Vector3<f64>)>) {
        self.invalidate();
        let base = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&corners);
        self.faces.push([base, base + 1, base + 2, base + 3]);
        // Area and normal of a planar-or-not quad from its diagonals.
        let cross = (corners[2] - corners[0]).cross(&(corners[3] - corners[1]));
        let area = 0.5 * cross.norm();
        let (centre, normal) = centre_normal.unwrap_or_else(|| ((corners[0] + corners[1] + corners[2] + corners[3]) / 4.0, cross.normalize()));
        self.points.push(centre);
        self.normals.push(normal);
        self.areas.push(area);
    }
}

/// Number of quads along a length so that they are at most about `spacing` long (at least 1).
fn divisions(length: f64, spacing: f64) -> usize {
    ((length / spacing).round() as usize).max(1)
}

/// Sphere as a cube mapped onto the sphere with equal angles per quad (an equi-angular cubed
/// sphere): six patches of `n × n` quads, the most even quad mesh of a sphere that stays simple.
/// Points are the projections of the quad centres on the sphere, normals are radial.
///
/// `n` is even, so that four points surround each pole of the three axes. With an odd `n` a
/// point sits at the pole, and a sphere resting on a plane balances on that single point: an
/// unstable equilibrium (like a polyhedron on a vertex) from which it tips over onto four
/// points after a few seconds of growing rocking; measured, independent of integrator and step.
fn sample_sphere(radius: f64, spacing: f64) -> Aopc {
    let n = (((std::f64::consts::FRAC_PI_2 * radius / spacing).ceil() as usize).max(1) + 1) & !1;
    let mut out = Aopc::default();
    // Each cube face: normal axis and two tangent axes with t1 × t2 = normal (outward order).
    let faces = [
        (Vector3::x(), Vector3::y(), Vector3::z()),
        (-Vector3::x(), Vector3::z(), Vector3::y()),
        (Vector3::y(), Vector3::z(), Vector3::x()),
        (-Vector3::y(), Vector3::x(), Vector3::z()),
        (Vector3::z(), Vector3::x(), Vector3::y()),
        (-Vector3::z(), Vector3::y(), Vector3::x()),
    ];
    let on_sphere = |axis: &Vector3<f64>, t1: &Vector3<f64>, t2: &Vector3<f64>, a: f64, b: f64| {
        let u = (-FRAC_PI_4 + std::f64::consts::FRAC_PI_2 * a).tan();
        let v = (-FRAC_PI_4 + std::f64::consts::FRAC_PI_2 * b).tan();
        (axis + t1 * u + t2 * v).normalize() * radius
    };
    for (axis, t1, t2) in &faces {
        for i in 0..n {
            for j in 0..n {
                let (a0, a1) = (i as f64 / n as f64, (i + 1) as f64 / n as f64);
                let (b0, b1) = (j as f64 / n as f64, (j + 1) as f64 / n as f64);
                let corners = [
                    on_sphere(axis, t1, t2, a0, b0),
                    on_sphere(axis, t1, t2, a1, b0),
                    on_sphere(axis, t1, t2, a1, b1),
                    on_sphere(axis, t1, t2, a0, b1),
                ];
                let centre = on_sphere(axis, t1, t2, 0.5 * (a0 + a1), 0.5 * (b0 + b1));
                out.push_quad(corners, Some((centre, centre / radius)));
            }
        }
    }
    // Quads of a sphere are slightly curved: scale areas so that Σ area is the sphere's area.
    let total: f64 = out.areas.iter().sum();
    let exact = 4.0 * std::f64::consts::PI * radius * radius;
    for a in &mut out.areas {
        *a *= exact / total;
    }
    out
}

/// Box: each face cut into a grid of quads, so quad edges lie on the box's edges and corners.
fn sample_box(half: &Vector3<f64>, spacing: f64) -> Aopc {
    let mut out = Aopc::default();
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            // Tangent axes ordered so that t1 × t2 points outward.
            let (i1, i2) = ((axis + 1) % 3, (axis + 2) % 3);
            let (i1, i2) = if sign > 0.0 { (i1, i2) } else { (i2, i1) };
            let (l1, l2) = (2.0 * half[i1], 2.0 * half[i2]);
            let (n1, n2) = (divisions(l1, spacing), divisions(l2, spacing));
            let corner = |a: f64, b: f64| {
                let mut p = Vector3::zeros();
                p[axis] = sign * half[axis];
                p[i1] = -half[i1] + l1 * a;
                p[i2] = -half[i2] + l2 * b;
                p
            };
            for i in 0..n1 {
                for j in 0..n2 {
                    let (a0, a1) = (i as f64 / n1 as f64, (i + 1) as f64 / n1 as f64);
                    let (b0, b1) = (j as f64 / n2 as f64, (j + 1) as f64 / n2 as f64);
                    let mut normal = Vector3::zeros();
                    normal[axis] = sign;
                    let corners = [corner(a0, b0), corner(a1, b0), corner(a1, b1), corner(a0, b1)];
                    let centre = (corners[0] + corners[2]) / 2.0;
                    out.push_quad(corners, Some((centre, normal)));
                }
            }
        }
    }
    out
}

/// Rotation taking the z axis to `dir` (for shapes defined along z).
pub fn z_to(dir: &Vector3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::rotation_between(&Vector3::z(), dir).unwrap_or_else(|| UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI))
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert!((s.spacing() - 0.01).abs() < 0.004, "spacing {}", s.spacing());
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

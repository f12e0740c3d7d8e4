//! Shapes of MJCF geoms (docs/mjcf.md) in their own frame (centred at the origin; capsule and
//! cylinder along z): exact signed distance, mass properties, and AOPC sampling as a quad mesh
//! whose edges follow the shape's sharp edges (box edges, cylinder rims) and whose points are
//! evenly spaced (the samplers: [`super::sample`]).
//!
//! Curved surfaces come from the equi-angular cubed sphere: each face of a cube is cut into a
//! grid at equal angles and projected on the sphere (or stretched onto an ellipsoid). With an
//! even number of cells per axis its equator is a grid line of uniformly spaced vertices, which
//! is what a capsule's hemispheres and a cylinder's side meet.

use super::implicit::ImplicitShape;
use super::mesh::{MeshSampling, TriMesh};
use super::sample::{sample_box, sample_capsule, sample_cylinder, sample_ellipsoid, Spacing};
use super::Aopc;
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::PI;
use std::sync::Arc;

/// A geom's shape, in its own frame.
#[derive(Clone, Debug, PartialEq)]
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
    /// Capsule along z: a cylinder of half-length `half_length` capped by hemispheres.
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Half-length of the cylindrical part (m).
        half_length: f64,
    },
    /// Cylinder along z with flat caps.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Half-length (m).
        half_length: f64,
    },
    /// Ellipsoid with the given semi-axes along x, y, z.
    Ellipsoid {
        /// Semi-axes (m).
        radii: Vector3<f64>,
    },
    /// A closed triangle mesh (checked and oriented, see [`TriMesh`]).
    Mesh(Arc<TriMesh>),
    /// A shape given by a distance function (one of MuJoCo's SDF plugins), with the closed
    /// surface cut from it ([`ImplicitShape::surface`]): it weighs as that mesh does; its
    /// points whose surface patch faces more than 10° away from the function's normal are put
    /// back on the function's zero level with the function's normal, the others keep their place
    /// and normal ([`ImplicitShape::settle`]).
    Implicit {
        /// The distance function.
        shape: ImplicitShape,
        /// Its surface on MuJoCo's grid.
        mesh: Arc<TriMesh>,
    },
}

/// Mass properties of a solid of unit density: volume, centre of mass and the inertia about
/// the centre of mass (multiply by the density, or by `mass / volume`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassProperties {
    /// Volume (m³).
    pub volume: f64,
    /// Centre of mass (m, shape frame).
    pub com: Vector3<f64>,
    /// `∫ (|r|² 1 - r rᵀ) dV` about the centre of mass (m⁵): the inertia per unit density.
    pub inertia: Matrix3<f64>,
}

impl MassProperties {
    /// The half-sizes of the uniform box with this volume's inertia along its principal axes
    /// (MuJoCo's "inertia box"), smallest first: `aᵢ² = 3 (Iⱼ + Iₖ - Iᵢ) / 2V`. `None` for a
    /// solid without a positive volume (an open surface's).
    pub fn inertia_box(&self) -> Option<Vector3<f64>> {
        if self.volume.is_nan() || self.volume <= 0.0 {
            return None;
        }
        let i = self.inertia.symmetric_eigen().eigenvalues;
        let sum = i.sum();
        let mut half: Vec<f64> = (0..3)
            .map(|k| (1.5 * (sum - 2.0 * i[k]) / self.volume).max(0.0).sqrt())
            .collect();
        half.sort_by(f64::total_cmp);
        let half = Vector3::new(half[0], half[1], half[2]);
        half.iter().all(|x| x.is_finite()).then_some(half)
    }
}

/// A mesh sampled by default gets at least this many points across its thinnest extent (its
/// inertia box's smallest side): a spacing of that extent over it where the scene's is coarser
/// ([`Shape::spacing_within`]).
pub const MESH_POINTS_ACROSS: f64 = 5.0;

/// The finest spacing (m) [`MESH_POINTS_ACROSS`] gives a thin mesh.
pub const MESH_FINEST_SPACING: f64 = 1e-3;

/// `x` (m) floored to a tenth of a millimetre: a spacing a person can read and set.
fn tenth_mm(x: f64) -> f64 {
    (x * 1e4).floor() / 1e4
}

impl TriMesh {
    /// The spacing (m) that puts [`MESH_POINTS_ACROSS`] points across the mesh's thinnest
    /// extent (its inertia box's smallest side), floored to a tenth of a millimetre and no finer
    /// than [`MESH_FINEST_SPACING`]; `None` for a mesh without a positive volume.
    pub fn thin_spacing(&self) -> Option<f64> {
        let thinnest = 2.0 * self.mass_properties().inertia_box()?.x;
        Some(tenth_mm(thinnest / MESH_POINTS_ACROSS).max(MESH_FINEST_SPACING))
    }
}

impl Shape {
    /// Exact signed distance of a point (shape frame, m): negative inside.
    pub fn sdf(&self, p: &Vector3<f64>) -> f64 {
        match self {
            Shape::Sphere { radius } => p.norm() - radius,
            Shape::Box { half } => {
                let q = p.abs() - half;
                let outside = q.map(|x| x.max(0.0)).norm();
                outside + q.max().min(0.0)
            }
            Shape::Capsule {
                radius,
                half_length,
            } => {
                let z = p.z.clamp(-half_length, *half_length);
                (p - Vector3::new(0.0, 0.0, z)).norm() - radius
            }
            Shape::Cylinder {
                radius,
                half_length,
            } => {
                let (dx, dz) = (p.xy().norm() - radius, p.z.abs() - half_length);
                dx.max(dz).min(0.0) + (dx.max(0.0).powi(2) + dz.max(0.0).powi(2)).sqrt()
            }
            Shape::Ellipsoid { radii } => ellipsoid_sdf(radii, p),
            Shape::Mesh(m) | Shape::Implicit { mesh: m, .. } => m.sdf(p),
        }
    }

    /// The closed triangle mesh of a mesh shape or of a shape given by a distance function.
    pub fn mesh(&self) -> Option<&Arc<TriMesh>> {
        match self {
            Shape::Mesh(m) | Shape::Implicit { mesh: m, .. } => Some(m),
            _ => None,
        }
    }

    /// Whether a point is strictly inside (shape frame).
    pub fn contains(&self, p: &Vector3<f64>) -> bool {
        match self {
            Shape::Ellipsoid { radii } => p.component_div(radii).norm_squared() < 1.0,
            Shape::Mesh(m) | Shape::Implicit { mesh: m, .. } => m.winding_number(p) > 0.5,
            _ => self.sdf(p) < 0.0,
        }
    }

    /// Outward unit normal of the surface nearest to `p`: the gradient of the SDF by central
    /// differences of step `h` (m).
    pub fn sdf_gradient(&self, p: &Vector3<f64>, h: f64) -> Vector3<f64> {
        let g = Vector3::from_fn(|k, _| {
            let mut e = Vector3::zeros();
            e[k] = h;
            (self.sdf(&(p + e)) - self.sdf(&(p - e))) / (2.0 * h)
        });
        g.try_normalize(1e-12).unwrap_or_else(Vector3::zeros)
    }

    /// Enclosed volume (m³).
    pub fn volume(&self) -> f64 {
        self.mass_properties().volume
    }

    /// A length that characterizes the shape (its bounding radius, m).
    pub fn size(&self) -> f64 {
        match self {
            Shape::Sphere { radius } => *radius,
            Shape::Box { half } => half.norm(),
            Shape::Capsule {
                radius,
                half_length,
            } => radius + half_length,
            Shape::Cylinder {
                radius,
                half_length,
            } => radius.hypot(*half_length),
            Shape::Ellipsoid { radii } => radii.max(),
            Shape::Mesh(m) | Shape::Implicit { mesh: m, .. } => {
                m.vertices.iter().map(|v| v.norm()).fold(0.0, f64::max)
            }
        }
    }

    /// Volume, centre of mass and inertia of the solid at unit density (closed forms; a mesh by
    /// its signed tetrahedra, exact for the polyhedron).
    pub fn mass_properties(&self) -> MassProperties {
        let diag = |v: f64, i: Vector3<f64>| MassProperties {
            volume: v,
            com: Vector3::zeros(),
            inertia: Matrix3::from_diagonal(&i),
        };
        match self {
            Shape::Sphere { radius: r } => {
                let v = 4.0 / 3.0 * PI * r.powi(3);
                diag(v, Vector3::repeat(0.4 * v * r * r))
            }
            Shape::Box { half: h } => {
                let v = 8.0 * h.x * h.y * h.z;
                let (x2, y2, z2) = (h.x * h.x, h.y * h.y, h.z * h.z);
                diag(v, Vector3::new(y2 + z2, x2 + z2, x2 + y2) * (v / 3.0))
            }
            Shape::Ellipsoid { radii: a } => {
                let v = 4.0 / 3.0 * PI * a.x * a.y * a.z;
                let (x2, y2, z2) = (a.x * a.x, a.y * a.y, a.z * a.z);
                diag(v, Vector3::new(y2 + z2, x2 + z2, x2 + y2) * (v / 5.0))
            }
            Shape::Cylinder {
                radius: r,
                half_length: h,
            } => {
                let v = PI * r * r * 2.0 * h;
                let t = v * (3.0 * r * r + 4.0 * h * h) / 12.0;
                diag(v, Vector3::new(t, t, v * r * r / 2.0))
            }
            Shape::Capsule {
                radius: r,
                half_length: h,
            } => {
                // Cylinder plus two hemispheres. A hemisphere of mass m has the transverse
                // inertia (2/5) m r² about its flat face's centre and its centre of mass 3r/8
                // from it; moved to the capsule's centre (h + 3r/8 away):
                // (2/5) m r² + m (h² + 3hr/4).
                let vc = PI * r * r * 2.0 * h;
                let vh = 2.0 / 3.0 * PI * r.powi(3);
                let t = vc * (3.0 * r * r + 4.0 * h * h) / 12.0
                    + 2.0 * (0.4 * vh * r * r + vh * (h * h + 0.75 * h * r));
                let a = vc * r * r / 2.0 + 2.0 * 0.4 * vh * r * r;
                diag(vc + 2.0 * vh, Vector3::new(t, t, a))
            }
            Shape::Mesh(m) | Shape::Implicit { mesh: m, .. } => m.mass_properties(),
        }
    }

    /// The length (m) that sets how finely the shape must be sampled (docs/geometry.md,
    /// "Spacing per geom"), per axis of its frame: a box's half-extent along each axis (its
    /// faces are flat, so only the distance to their edges matters); the smallest radius of
    /// curvature of a curved shape on every axis (a sphere's, capsule's or cylinder's radius,
    /// an ellipsoid's `min r² / max r`); zero for a mesh, whose smallest feature is not known
    /// from its size, so that it is sampled at the scene's spacing.
    pub fn feature_length(&self) -> Vector3<f64> {
        match self {
            Shape::Box { half } => *half,
            Shape::Sphere { radius }
            | Shape::Capsule { radius, .. }
            | Shape::Cylinder { radius, .. } => Vector3::repeat(*radius),
            Shape::Ellipsoid { radii } => Vector3::repeat(radii.min().powi(2) / radii.max()),
            Shape::Mesh(_) | Shape::Implicit { .. } => Vector3::zeros(),
        }
    }

    /// How finely the shape is sampled when its scene asks for `spacing` (m) between points
    /// and `resolution` quads per feature length (docs/geometry.md, "Spacing per geom"): on
    /// each axis the larger of `spacing` and [`feature_length`](Self::feature_length) /
    /// `resolution`, `spacing` itself at a box's edges. A small shape gets `spacing`
    /// everywhere; a large one as many quads as a shape of `resolution × spacing` would (plus a
    /// box's graded rows), so that a 3 m table top is not sampled at 1 cm.
    pub fn spacing_for(&self, spacing: f64, resolution: f64) -> Spacing {
        Spacing {
            fine: spacing,
            coarse: self.feature_length().map(|l| (l / resolution).max(spacing)),
        }
    }

    /// [`spacing_for`](Self::spacing_for), a smooth shape (a sphere, a capsule, an ellipsoid:
    /// curved everywhere, no edge) sampled evenly at no less than the spacing whose sagitta
    /// on its smallest radius of curvature `ρ` is `sagitta` (m): neighbouring points `s` apart
    /// on an arc of radius `ρ` stand `s² / 8ρ` off the chord between them, so
    /// `s = √(8 ρ sagitta)`, floored to 0.1 mm (docs/geometry.md, "Spacing per geom"). A mesh
    /// thinner than [`MESH_POINTS_ACROSS`] spacings is sampled finer, at
    /// [`TriMesh::thin_spacing`]: with patches as wide as its sides, a point beside it read the
    /// plane of a patch round its edge (robosuite's inspire hand: fingers 4.7 mm apart read
    /// 3.2 mm inside each other at 1 cm). A box and a cylinder (whose rims are edges) keep
    /// `spacing_for`'s.
    pub fn spacing_within(&self, spacing: f64, resolution: f64, sagitta: f64) -> Spacing {
        let smooth = matches!(
            self,
            Shape::Sphere { .. } | Shape::Capsule { .. } | Shape::Ellipsoid { .. }
        );
        let even = match self {
            _ if smooth => spacing.max(tenth_mm(
                (8.0 * self.feature_length().min() * sagitta).sqrt(),
            )),
            Shape::Mesh(m) => spacing.min(m.thin_spacing().unwrap_or(spacing)),
            _ => spacing,
        };
        Spacing {
            fine: even,
            coarse: self.spacing_for(even, resolution).coarse,
        }
    }

    /// Samples the surface as an AOPC with faces about `spacing` (m) apart (see the module
    /// documentation). Vertices shared by neighbouring quads are merged.
    pub fn sample(&self, spacing: f64) -> Aopc {
        self.sample_spaced(&Spacing::uniform(spacing))
    }

    /// [`sample`](Self::sample) at a [`Spacing`]: a box on graded grids (`sample_box`), a
    /// curved shape or a mesh evenly at the smallest coarse spacing.
    pub fn sample_spaced(&self, spacing: &Spacing) -> Aopc {
        let uniform = spacing.coarse.min();
        let mut out = match self {
            Shape::Sphere { radius } => sample_ellipsoid(&Vector3::repeat(*radius), uniform),
            Shape::Ellipsoid { radii } => sample_ellipsoid(radii, uniform),
            Shape::Box { half } => sample_box(
                half,
                spacing,
                &[[vec![], vec![]], [vec![], vec![]], [vec![], vec![]]],
            ),
            Shape::Capsule {
                radius,
                half_length,
            } => sample_capsule(*radius, *half_length, uniform),
            Shape::Cylinder {
                radius,
                half_length,
            } => sample_cylinder(*radius, *half_length, uniform),
            Shape::Mesh(m) => match m.sampling {
                MeshSampling::Patches => m.sample_patches(uniform),
                MeshSampling::Triangles => m.sample(uniform),
            },
            Shape::Implicit { shape, mesh } => shape.settle(mesh.sample(uniform)),
        };
        out.weld(1e-9 * self.size().max(1e-9));
        out
    }
}

/// Exact signed distance to an ellipsoid: the closest point `x_i = a_i² y_i/(t + a_i²)` with
/// `t` the root of `Σ (a_i y_i/(t + a_i²))² = 1` (Eberly's formulation), found by bisection
/// (t > 0 outside, `-min a_i² < t < 0` inside).
fn ellipsoid_sdf(a: &Vector3<f64>, p: &Vector3<f64>) -> f64 {
    let scale = a.max();
    // A zero coordinate along the shortest axis makes the root degenerate; a nudge of 1e-12
    // of the size changes the distance by at most that much.
    let y = p.abs().map(|v| v.max(1e-12 * scale));
    let f = |t: f64| {
        (0..3)
            .map(|i| (a[i] * y[i] / (t + a[i] * a[i])).powi(2))
            .sum::<f64>()
            - 1.0
    };
    let amin2 = a.min().powi(2);
    let (mut lo, mut hi) = if f(0.0) > 0.0 {
        (0.0, y.norm() * scale + scale * scale)
    } else {
        (-amin2, 0.0)
    };
    for _ in 0..200 {
        let m = 0.5 * (lo + hi);
        if m == lo || m == hi {
            break;
        }
        if f(m) > 0.0 {
            lo = m
        } else {
            hi = m
        }
    }
    let t = 0.5 * (lo + hi);
    let x = Vector3::from_fn(|i, _| a[i] * a[i] * y[i] / (t + a[i] * a[i]));
    let d = (x - y).norm();
    if p.component_div(a).norm_squared() < 1.0 {
        -d
    } else {
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spacing_follows_the_feature_length_and_never_goes_below_the_scenes() {
        let table = Shape::Box {
            half: Vector3::new(1.5, 1.0, 0.02),
        };
        assert_eq!(
            table.spacing_for(0.01, 16.0),
            Spacing {
                fine: 0.01,
                coarse: Vector3::new(1.5 / 16.0, 1.0 / 16.0, 0.01)
            }
        );
        let big = Shape::Sphere { radius: 0.8 };
        assert_eq!(big.spacing_for(0.01, 16.0).coarse, Vector3::repeat(0.05));
        let small = Shape::Capsule {
            radius: 0.05,
            half_length: 2.0,
        };
        assert_eq!(small.spacing_for(0.01, 16.0), Spacing::uniform(0.01));
        // An ellipsoid by its sharpest curvature: radii 1, 1, 0.2 curve with radius 0.04.
        let lens = Shape::Ellipsoid {
            radii: Vector3::new(1.0, 1.0, 0.2),
        };
        assert!((lens.feature_length().x - 0.04).abs() < 1e-15);
        assert!((lens.spacing_for(0.001, 16.0).coarse - Vector3::repeat(0.0025)).norm() < 1e-15);
    }

    #[test]
    fn a_graded_box_is_closed_and_meets_itself_edge_to_edge() {
        let half = Vector3::new(1.5, 1.0, 0.02);
        let s = Shape::Box { half }.sample_spaced(&Shape::Box { half }.spacing_for(0.01, 16.0));
        let area: f64 = s.areas.iter().sum();
        let exact = 8.0 * (half.x * half.y + half.y * half.z + half.x * half.z);
        assert!((area - exact).abs() < 1e-12 * exact, "{area} vs {exact}");
        assert!(s.closure_defect().norm() < 1e-12 * exact);
        // Welded: every vertex is shared by the quads around it, as on an even grid (a quad
        // edge meeting a neighbour's vertex halfway would leave more vertices than that).
        assert_eq!(
            s.vertices.len(),
            s.faces.len() + 2,
            "a closed quad mesh of genus 0"
        );
        assert!(s.len() < 4000, "{} points", s.len());
    }
}

//! Closed triangle meshes (OBJ through tobj, STL through stl_io): checks with clear errors, mass
//! properties, exact signed distance (`distance.rs`), and the AOPC of the surface.
//!
//! A mesh becomes an AOPC after it is simplified within a small fraction of the spacing where
//! that leaves fewer triangles ([`TriMesh::simplified`], `sample.rs`). A file's mesh is then
//! cut into pieces grouped in patches of about the spacing, each taking in only pieces that
//! face within 26° of its first, one point per patch (`patches.rs`,
//! [`TriMesh::sample_patches`]). A height field's, an implicit shape's (even triangles from its
//! distance function), or any where the scene asks (`scm_mesh_sampling`) keeps one point per
//! triangle no longer than the spacing and three quads per longer one ([`TriMesh::sample`]);
//! [`MeshSampling`] says which.

use super::MassProperties;
use nalgebra::{Matrix3, Vector3};
use std::collections::HashMap;
use std::path::Path;

/// What is wrong with a mesh file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("mesh {file}: {problem}")]
pub struct MeshError {
    /// The mesh file, as named in the scene (resolved path).
    pub file: String,
    /// What is wrong.
    pub problem: MeshProblem,
    /// What else was noticed while reading the file (warnings a successful load would have
    /// given, e.g. polygons split otherwise than MuJoCo splits them).
    pub notes: Vec<String>,
}

/// The kinds of mesh problems.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshProblem {
    /// The file cannot be read.
    #[error("cannot read the file: {0}")]
    Missing(String),
    /// The file is not a valid OBJ or STL.
    #[error("cannot parse the file: {0}")]
    Parse(String),
    /// Neither `.obj`, `.stl` nor MuJoCo's `.msh`.
    #[error("unsupported mesh format '{0}' (use .obj, .stl or MuJoCo's .msh)")]
    Format(String),
    /// No triangles.
    #[error("the mesh has no triangles")]
    Empty,
    /// A vertex coordinate is NaN or infinite.
    #[error("vertex {0} has a non-finite coordinate")]
    NonFinite(usize),
    /// Triangles of zero area or with a repeated vertex.
    #[error("{count} degenerate triangle(s) (zero area or a repeated vertex); the first is triangle {first}")]
    Degenerate {
        /// How many.
        count: usize,
        /// Index of the first (0-based, in file order).
        first: usize,
    },
    /// Edges that belong to a single triangle: the surface has holes.
    #[error("the mesh is open (not watertight): {count} edge(s) belong to a single triangle, e.g. the edge between vertices {a} and {b}")]
    Open {
        /// Number of boundary edges.
        count: usize,
        /// One boundary edge (vertex indices after merging duplicates).
        a: u32,
        /// Its other end.
        b: u32,
    },
    /// An edge shared by more than two triangles.
    #[error("the mesh is not manifold: the edge between vertices {a} and {b} belongs to {count} triangles")]
    NonManifold {
        /// Vertex index.
        a: u32,
        /// Vertex index.
        b: u32,
        /// Number of triangles on that edge.
        count: usize,
    },
    /// Two neighbouring triangles wound in opposite senses (their normals disagree).
    #[error("inconsistent normals: triangles {t1} and {t2} run their shared edge between vertices {a} and {b} the same way (one of them is flipped)")]
    Inconsistent {
        /// A triangle.
        t1: usize,
        /// Its neighbour.
        t2: usize,
        /// Edge vertex.
        a: u32,
        /// Edge vertex.
        b: u32,
    },
    /// The enclosed volume is zero (a flat or doubled surface).
    #[error("the mesh encloses no volume ({0:.3e} m³)")]
    ZeroVolume(f64),
    /// The vertices have no convex hull with a volume (they lie in one plane or on one line).
    #[error("its vertices have no convex hull with a volume ({0})")]
    NoHull(String),
}

impl MeshProblem {
    /// Whether the file was read but its surface is not a closed, oriented manifold with a
    /// volume (as opposed to a file that cannot be read or parsed).
    pub fn is_of_the_surface(&self) -> bool {
        matches!(
            self,
            MeshProblem::Degenerate { .. }
                | MeshProblem::Open { .. }
                | MeshProblem::NonManifold { .. }
                | MeshProblem::Inconsistent { .. }
                | MeshProblem::ZeroVolume(_)
        )
    }
}

/// How a mesh file's vertices are placed in the mesh frame (MuJoCo's `<mesh refpos refquat
/// scale>`): `x = scale ∘ (refquat⁻¹ (v - refpos))`, the file's coordinates taken relative to
/// the reference frame `(refpos, refquat)`, then scaled axis by axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// The reference position (file coordinates).
    pub refpos: Vector3<f64>,
    /// The reference orientation.
    pub refquat: nalgebra::UnitQuaternion<f64>,
    /// The scale per axis (applied last).
    pub scale: Vector3<f64>,
}

impl Placement {
    /// Only a scale.
    pub fn scaled(scale: Vector3<f64>) -> Placement {
        Placement {
            refpos: Vector3::zeros(),
            refquat: nalgebra::UnitQuaternion::identity(),
            scale,
        }
    }

    /// A vertex of the file, placed.
    pub fn apply(&self, v: &Vector3<f64>) -> Vector3<f64> {
        (self.refquat.inverse_transform_vector(&(v - self.refpos))).component_mul(&self.scale)
    }
}

/// A closed, consistently outward-oriented triangle mesh (m, mesh frame).
#[derive(Clone, Debug, PartialEq)]
pub struct TriMesh {
    /// The file it came from (for messages).
    pub file: String,
    /// Vertices (m), duplicates merged.
    pub vertices: Vec<Vector3<f64>>,
    /// Triangles, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// How it becomes an AOPC ([`MeshSampling`]).
    pub sampling: MeshSampling,
}

/// How a mesh becomes an AOPC (docs/geometry.md, "Patches of a mesh").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MeshSampling {
    /// In patches of about the spacing ([`TriMesh::sample_patches`]): as many points as the
    /// spacing asks, whatever the triangles' shapes (a file's mesh, by default).
    #[default]
    Patches,
    /// Triangle by triangle ([`TriMesh::sample`]): one point per triangle no longer than the
    /// spacing, three quads per longer one; keeps a mesh's own symmetry and regular grid (a
    /// height field's, an implicit shape's, or a file's when the scene asks
    /// `scm_mesh_sampling` = `triangles`).
    Triangles,
}

impl TriMesh {
    /// Builds a mesh from vertices and triangles (any winding), merging duplicate vertices,
    /// checking that it is a closed manifold with consistent orientation and a volume, and
    /// turning inward-facing shells outward (with a warning).
    pub fn new(
        file: &str,
        vertices: Vec<Vector3<f64>>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<(TriMesh, Vec<String>), MeshError> {
        let err = |problem| MeshError {
            file: file.to_string(),
            problem,
            notes: Vec::new(),
        };
        if let Some(i) = vertices
            .iter()
            .position(|v| !v.iter().all(|x| x.is_finite()))
        {
            return Err(err(MeshProblem::NonFinite(i)));
        }
        if triangles.is_empty() {
            return Err(err(MeshProblem::Empty));
        }
        if let Some(t) = triangles
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= vertices.len()))
        {
            return Err(err(MeshProblem::Parse(format!(
                "triangle {t} refers to a vertex that does not exist"
            ))));
        }
        // Merge vertices with equal coordinates (STL repeats them per triangle).
        let mut map: HashMap<[u64; 3], u32> = HashMap::new();
        let mut merged = Vec::new();
        let remap: Vec<u32> = vertices
            .iter()
            .map(|v| {
                *map.entry([v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
                    .or_insert_with(|| {
                        merged.push(*v);
                        merged.len() as u32 - 1
                    })
            })
            .collect();
        let mut tris: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| remap[i as usize]))
            .collect();
        let (lo, hi) = bounds(&merged);
        let size = (hi - lo).norm();
        // Degenerate triangles.
        let degenerate: Vec<usize> = tris
            .iter()
            .enumerate()
            .filter(|(_, t)| {
                t[0] == t[1]
                    || t[1] == t[2]
                    || t[0] == t[2]
                    || tri_normal(&merged, t).norm() <= 1e-12 * size * size
            })
            .map(|(i, _)| i)
            .collect();
        if let Some(&first) = degenerate.first() {
            return Err(err(MeshProblem::Degenerate {
                count: degenerate.len(),
                first,
            }));
        }
        // Edges: each undirected edge in exactly two triangles, run in opposite directions.
        let mut edges: HashMap<(u32, u32), Vec<(usize, bool)>> = HashMap::new();
        for (ti, t) in tris.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                edges
                    .entry((a.min(b), a.max(b)))
                    .or_default()
                    .push((ti, a < b));
            }
        }
        let mut keys: Vec<_> = edges.keys().copied().collect();
        keys.sort_unstable();
        let open: Vec<_> = keys.iter().filter(|k| edges[k].len() == 1).collect();
        if let Some(&&(a, b)) = open.first() {
            return Err(err(MeshProblem::Open {
                count: open.len(),
                a,
                b,
            }));
        }
        if let Some(&(a, b)) = keys.iter().find(|k| edges[k].len() > 2) {
            return Err(err(MeshProblem::NonManifold {
                a,
                b,
                count: edges[&(a, b)].len(),
            }));
        }
        if let Some(&(a, b)) = keys.iter().find(|k| edges[k][0].1 == edges[k][1].1) {
            let e = &edges[&(a, b)];
            let (t1, t2) = (e[0].0.min(e[1].0), e[0].0.max(e[1].0));
            return Err(err(MeshProblem::Inconsistent { t1, t2, a, b }));
        }
        // Connected shells (union–find over shared edges), each oriented outward unless it is
        // a cavity inside another shell.
        let mut parent: Vec<usize> = (0..tris.len()).collect();
        fn find(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        for e in edges.values() {
            let (a, b) = (find(&mut parent, e[0].0), find(&mut parent, e[1].0));
            parent[a] = b;
        }
        let roots: Vec<usize> = (0..tris.len()).map(|i| find(&mut parent, i)).collect();
        let mut shells: Vec<usize> = roots.clone();
        shells.sort_unstable();
        shells.dedup();
        let mut warnings = Vec::new();
        let centre = (lo + hi) * 0.5;
        let shell_volume = |tris: &[[u32; 3]], s: usize| -> f64 {
            tris.iter()
                .zip(&roots)
                .filter(|(_, &r)| r == s)
                .map(|(t, _)| signed_tet_volume(&merged, t, &centre))
                .sum()
        };
        for &s in &shells {
            if shell_volume(&tris, s) >= 0.0 {
                continue;
            }
            // Inside another shell (an odd number of other shells around it): a cavity, whose
            // normals rightly point into it.
            let probe = merged[tris[roots
                .iter()
                .position(|&r| r == s)
                .expect("a shell has triangles")][0] as usize];
            let around: f64 = shells
                .iter()
                .filter(|&&o| o != s)
                .map(|&o| {
                    winding(
                        &merged,
                        tris.iter()
                            .zip(&roots)
                            .filter(|(_, &r)| r == o)
                            .map(|(t, _)| t),
                        &probe,
                    )
                    .abs()
                })
                .sum();
            if around.round() as i64 % 2 == 1 {
                continue;
            }
            for (t, &r) in tris.iter_mut().zip(&roots) {
                if r == s {
                    t.swap(1, 2);
                }
            }
            warnings.push(format!(
                "mesh {file}: {} triangles faced inward; their orientation was flipped",
                roots.iter().filter(|&&r| r == s).count()
            ));
        }
        let mesh = TriMesh {
            file: file.to_string(),
            vertices: merged,
            triangles: tris,
            sampling: MeshSampling::default(),
        };
        let volume = mesh.mass_properties().volume;
        if volume <= 1e-9 * size.powi(3) {
            return Err(err(MeshProblem::ZeroVolume(volume)));
        }
        Ok((mesh, warnings))
    }

    /// Volume, centre of mass and inertia at unit density, by signed tetrahedra from a point
    /// near the mesh (exact for the polyhedron): for a tetrahedron `(0, a, b, c)` with
    /// `D = aᵀ(b × c)`, volume `D/6`, first moment `D (a + b + c)/24` and second moment
    /// `∫ x xᵀ = D/120 (a aᵀ + b bᵀ + c cᵀ + s sᵀ)`, `s = a + b + c`.
    pub fn mass_properties(&self) -> MassProperties {
        let o = self.vertices.iter().fold(Vector3::zeros(), |a, v| a + v)
            / self.vertices.len().max(1) as f64;
        let (mut vol, mut first, mut second) = (0.0, Vector3::zeros(), Matrix3::zeros());
        for t in &self.triangles {
            let [a, b, c] = t.map(|i| self.vertices[i as usize] - o);
            let d = a.dot(&b.cross(&c));
            let s = a + b + c;
            vol += d / 6.0;
            first += s * (d / 24.0);
            second +=
                (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose())
                    * (d / 120.0);
        }
        let com = if vol != 0.0 {
            first / vol
        } else {
            Vector3::zeros()
        };
        let about_com = second - com * com.transpose() * vol;
        let inertia = Matrix3::identity() * about_com.trace() - about_com;
        MassProperties {
            volume: vol,
            com: com + o,
            inertia,
        }
    }

    /// MuJoCo's default mesh inertia (`inertia="legacy"`) of this mesh's triangles
    /// ([`legacy_mass_properties`]).
    pub fn legacy_mass_properties(&self) -> Option<MassProperties> {
        legacy_mass_properties(&self.vertices, &self.triangles)
    }

    /// MuJoCo's shell inertia of this mesh's triangles ([`shell_mass_properties`]).
    pub fn shell_mass_properties(&self) -> Option<MassProperties> {
        shell_mass_properties(&self.vertices, &self.triangles)
    }
}

fn tri_normal(v: &[Vector3<f64>], t: &[u32; 3]) -> Vector3<f64> {
    (v[t[1] as usize] - v[t[0] as usize]).cross(&(v[t[2] as usize] - v[t[0] as usize]))
}

fn signed_tet_volume(v: &[Vector3<f64>], t: &[u32; 3], o: &Vector3<f64>) -> f64 {
    let [a, b, c] = t.map(|i| v[i as usize] - o);
    a.dot(&b.cross(&c)) / 6.0
}

mod distance;
mod hull;
mod mass;
mod patches;
mod quickhull;
mod read;
mod sample;

pub use distance::box_distance;
use distance::{closest_on_triangle, winding};
pub use mass::{legacy_mass_properties, shell_mass_properties};
pub use patches::{PATCH_ANGLE_COSINE, PATCH_RADIUS};
pub use read::signed_volume;
pub use sample::{Simplified, SIMPLIFY_TOLERANCE, SIMPLIFY_TRIES, SIMPLIFY_VOLUME};

/// The corners of the points' bounding box, lowest and highest.
fn bounds(points: &[Vector3<f64>]) -> (Vector3<f64>, Vector3<f64>) {
    let lo = points
        .iter()
        .fold(Vector3::repeat(f64::INFINITY), |a, v| a.inf(v));
    let hi = points
        .iter()
        .fold(Vector3::repeat(f64::NEG_INFINITY), |a, v| a.sup(v));
    (lo, hi)
}

/// The diagonal of the points' bounding box (the size the mesh checks' tolerances scale with).
fn box_diagonal(points: &[Vector3<f64>]) -> f64 {
    let (lo, hi) = bounds(points);
    (hi - lo).norm()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_placement_takes_the_file_relative_to_its_reference_frame_then_scales() {
        // The reference frame at (1, 2, 3) turned 90 degrees about z: the file's point one
        // along y from it lies along the frame's x, then doubled by the scale along x.
        let p = Placement {
            refpos: Vector3::new(1.0, 2.0, 3.0),
            refquat: nalgebra::UnitQuaternion::from_axis_angle(
                &Vector3::z_axis(),
                std::f64::consts::FRAC_PI_2,
            ),
            scale: Vector3::new(2.0, 1.0, 1.0),
        };
        let x = p.apply(&Vector3::new(1.0, 3.0, 3.0));
        assert!((x - Vector3::new(2.0, 0.0, 0.0)).norm() < 1e-15, "{x}");
        let s = Placement::scaled(Vector3::new(1.0, 2.0, 3.0));
        assert_eq!(s.apply(&Vector3::repeat(1.0)), Vector3::new(1.0, 2.0, 3.0));
    }

    #[test]
    fn a_thin_shell_weighs_by_its_area() {
        // The unit cube's surface as a shell: area 6, centre at the middle; about an axis x
        // through it, each of the two unit plates normal to x gives (1 + 1)/12 = 1/6, each of
        // the four others 1/12 (its extent across x) + (1/2)² (its distance): 1/3, so I_xx =
        // 2/6 + 4/3 = 5/3.
        let (v, t) = cube();
        let mp = shell_mass_properties(&v, &t).unwrap();
        assert!((mp.volume - 6.0).abs() < 1e-12);
        assert!((mp.com - Vector3::new(0.5, 0.5, 0.5)).norm() < 1e-12);
        for k in 0..3 {
            assert!(
                (mp.inertia[(k, k)] - 5.0 / 3.0).abs() < 1e-12,
                "{}",
                mp.inertia
            );
        }
        assert!(mp.inertia[(0, 1)].abs() < 1e-12);
        // Open (one face removed): centre moves away from the missing face.
        let open: Vec<[u32; 3]> = t[2..].to_vec();
        let mp = shell_mass_properties(&v, &open).unwrap();
        assert!(
            (mp.volume - 5.0).abs() < 1e-12 && (mp.com.z - 0.6).abs() < 1e-12,
            "{mp:?}"
        );
    }

    /// A unit cube as 12 triangles, outward.
    pub(crate) fn cube() -> (Vec<Vector3<f64>>, Vec<[u32; 3]>) {
        let v: Vec<_> = (0..8)
            .map(|i| Vector3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let t = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        (v, t)
    }

    #[test]
    fn cube_mesh_mass_properties_and_quads() {
        let (v, t) = cube();
        let (m, w) = TriMesh::new("cube", v, t).unwrap();
        assert!(w.is_empty(), "{w:?}");
        let mp = m.mass_properties();
        assert!((mp.volume - 1.0).abs() < 1e-12 && (mp.com - Vector3::repeat(0.5)).norm() < 1e-12);
        assert!(
            (mp.inertia - Matrix3::identity() / 6.0).norm() < 1e-12,
            "{}",
            mp.inertia
        );
        let s = m.sample(0.1);
        assert!(s.closure_defect().norm() < 1e-12);
        assert!((s.enclosed_volume() - 1.0).abs() < 1e-12);
        assert!((s.spacing() - 0.1).abs() < 0.04, "spacing {}", s.spacing());
        // Quad edges follow the cube's edges: no quad normal is off an axis.
        assert!(s.normals.iter().all(|n| n.abs().max() > 1.0 - 1e-12));
        assert!(
            (m.sdf(&Vector3::new(0.5, 0.5, 0.2)) + 0.2).abs() < 1e-12
                && (m.sdf(&Vector3::new(0.5, 0.5, 1.3)) - 0.3).abs() < 1e-12
        );
    }
}

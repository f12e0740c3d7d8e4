//! Geometry: oriented point clouds (AOPC) sampled from shapes, and the soft signed distance
//! function (SSDF) over them (paper, Methods A).
//!
//! Everything here lives in a body's own frame; poses are applied by the caller.

pub mod aopc;
pub mod bvh;
pub mod cuboid;
mod gear_profile;
pub mod holders;
pub mod implicit;
pub mod mesh;
pub mod patch;
pub mod polytope;
pub mod radial;
pub mod relevant;
pub mod rounded;
pub mod sample;
pub mod shapes;
pub mod spine;
pub mod ssdf;
pub mod union;

pub use aopc::Aopc;
pub use mesh::{MeshError, Placement, TriMesh};
pub use sample::Spacing;
pub use shapes::{MassProperties, Shape};
pub use ssdf::{ssdf, ssdf_naive, ssdf_weights_sum};

/// Uniform numbers in [-1, 1) for the unit tests (a fixed linear congruential sequence: a test
/// is the same every run).
#[cfg(test)]
pub(crate) fn lcg(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*state >> 11) as f64) / ((1u64 << 52) as f64) - 1.0
}

/// Three broken copies of a sampled cloud, as (points, normals, faces) over its vertices, for
/// the unit tests of the certificates: a hole (one quad missing: edges without twins), a tilted
/// normal, a quad turned inside out. None may be certified.
#[cfg(test)]
pub(crate) type Broken = (
    Vec<nalgebra::Vector3<f64>>,
    Vec<nalgebra::Vector3<f64>>,
    Vec<[u32; 4]>,
);

/// See [`Broken`].
#[cfg(test)]
pub(crate) fn broken_copies(s: &Aopc) -> [Broken; 3] {
    let n = s.points.len() - 1;
    let hole = (
        s.points[..n].to_vec(),
        s.normals[..n].to_vec(),
        s.faces[..n].to_vec(),
    );
    let mut normals = s.normals.clone();
    normals[7] = (normals[7] + nalgebra::Vector3::new(1e-3, 0.0, 0.0)).normalize();
    let tilted = (s.points.clone(), normals, s.faces.clone());
    let mut faces = s.faces.clone();
    faces[3].reverse();
    let inside_out = (s.points.clone(), s.normals.clone(), faces);
    [hole, tilted, inside_out]
}

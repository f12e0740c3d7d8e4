//! Geometry: oriented point clouds (AOPC) sampled from shapes, and the soft signed distance
//! function (SSDF) over them (paper, Methods A).
//!
//! Everything here lives in a body's own frame; poses are applied by the caller.

pub mod aopc;
pub mod bvh;
pub mod cuboid;
pub mod mesh;
pub mod patch;
pub mod radial;
pub mod shapes;
pub mod spine;
pub mod ssdf;
pub mod union;

pub use aopc::Aopc;
pub use mesh::{MeshError, TriMesh};
pub use shapes::{MassProperties, Shape};
pub use ssdf::{ssdf, ssdf_naive, ssdf_weights_sum};

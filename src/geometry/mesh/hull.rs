//! The convex hull of a mesh's vertices: what MuJoCo collides a mesh geom by, and what SCM
//! samples for a colliding mesh whose own surface is not closed (docs/mjcf.md, "Meshes").
//!
//! The hull comes from the `chull` crate's exact-arithmetic quickhull (its orientation tests
//! run on the coordinates as big integers), so that coplanar and nearly coplanar vertices,
//! common in CAD exports, never give a hull with crossing or missing faces; its triangles then
//! go through [`TriMesh::new`]'s checks like any file's.

use super::*;

impl TriMesh {
    /// The closed, outward-oriented triangle mesh of the convex hull of `vertices` (named
    /// `file` in messages). Fails where the vertices span no volume.
    pub fn convex_hull(file: &str, vertices: &[Vector3<f64>]) -> Result<TriMesh, MeshError> {
        let err = |problem| MeshError {
            file: file.to_string(),
            problem,
        };
        let points: Vec<Vec<f64>> = vertices.iter().map(|v| vec![v.x, v.y, v.z]).collect();
        let hull = chull::ConvexHullWrapper::try_new(&points, None)
            .map_err(|e| err(MeshProblem::NoHull(e.to_string())))?;
        let (corners, indices) = hull.vertices_indices();
        let corners = corners
            .iter()
            .map(|p| Vector3::new(p[0], p[1], p[2]))
            .collect();
        let triangles = indices
            .chunks_exact(3)
            .map(|t| [t[0] as u32, t[1] as u32, t[2] as u32])
            .collect();
        let (mesh, _) = TriMesh::new(file, corners, triangles)?;
        Ok(mesh)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hull of a cube's corners, its centre and points on its faces is the cube: volume 1,
    /// every corner kept, nothing inside.
    #[test]
    fn the_hull_of_a_cube_with_inner_and_face_points_is_the_cube() {
        let mut points: Vec<Vector3<f64>> = (0..8)
            .map(|i| Vector3::new((i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2 & 1) as f64))
            .collect();
        points.push(Vector3::new(0.5, 0.5, 0.5));
        points.push(Vector3::new(0.5, 0.5, 1.0));
        points.push(Vector3::new(0.0, 0.25, 0.75));
        let hull = TriMesh::convex_hull("cube", &points).unwrap();
        let mp = hull.mass_properties();
        assert!((mp.volume - 1.0).abs() < 1e-12, "{}", mp.volume);
        assert!((mp.com - Vector3::repeat(0.5)).norm() < 1e-12);
        for corner in &points[..8] {
            assert!(hull.vertices.iter().any(|v| v == corner), "{corner:?}");
        }
    }

    /// Vertices in one plane span no volume: refused, saying so.
    #[test]
    fn flat_vertices_have_no_hull() {
        let points = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
            Vector3::new(1.0, 1.0, 0.0),
        ];
        let e = TriMesh::convex_hull("flat", &points).unwrap_err();
        assert!(e.to_string().contains("convex hull"), "{e}");
    }
}

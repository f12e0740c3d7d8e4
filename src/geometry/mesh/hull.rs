//! The convex hull of a mesh's vertices: what MuJoCo collides a mesh geom by, and what SCM
//! samples for a colliding mesh whose own surface is not closed (docs/mjcf.md, "Meshes").
//!
//! The hull comes from this crate's quickhull (`quickhull.rs`): exact orientation tests, so
//! that coplanar and nearly coplanar vertices, common in CAD exports, never give a hull with
//! crossing or missing faces, and the same hull on every run. Its triangles then go through
//! [`TriMesh::new`]'s checks like any file's.

use super::*;

impl TriMesh {
    /// The closed, outward-oriented triangle mesh of the convex hull of `vertices` (named
    /// `file` in messages). Fails where the vertices span no volume.
    pub fn convex_hull(file: &str, vertices: &[Vector3<f64>]) -> Result<TriMesh, MeshError> {
        let err = |problem| MeshError {
            file: file.to_string(),
            problem,
            notes: Vec::new(),
        };
        let mut points: Vec<Vector3<f64>> = vertices.to_vec();
        // Nearly collinear hull corners (CAD exports: a vertex a hair off the edge between two
        // others) give exact but sliver facets, which a closed mesh's checks take as
        // degenerate: the middle corner of each sliver (the one at its widest angle, within
        // about 2·area/edge of that edge: below 1e-12 of the mesh's size) is dropped and the
        // hull taken again, a few rounds at most.
        for _round in 0..32 {
            let hull =
                super::quickhull::quickhull(&points).map_err(|e| err(MeshProblem::NoHull(e)))?;
            // The corners: the points the hull's triangles use, in the points' order.
            let mut index = vec![u32::MAX; points.len()];
            for t in &hull {
                for &i in t {
                    index[i as usize] = 0;
                }
            }
            let mut corners: Vec<Vector3<f64>> = Vec::new();
            for (i, slot) in index.iter_mut().enumerate() {
                if *slot == 0 {
                    *slot = corners.len() as u32;
                    corners.push(points[i]);
                }
            }
            let triangles: Vec<[u32; 3]> =
                hull.iter().map(|t| t.map(|i| index[i as usize])).collect();
            let slivers = sliver_middles(&corners, &triangles);
            if slivers.is_empty() {
                let (mesh, _) = TriMesh::new(file, corners, triangles)?;
                return Ok(mesh);
            }
            // The hull's corners are input points: drop them (and their duplicates).
            let drop: Vec<Vector3<f64>> = slivers.iter().map(|&i| corners[i]).collect();
            points.retain(|p| !drop.contains(p));
        }
        Err(err(MeshProblem::NoHull(
            "its hull keeps sliver facets after dropping nearly collinear corners".into(),
        )))
    }
}

/// The middle corner (at the widest angle) of every hull facet that [`TriMesh::new`] would
/// take as degenerate: area at most 1e-12 of the squared size of the corners' box.
fn sliver_middles(corners: &[Vector3<f64>], triangles: &[[u32; 3]]) -> Vec<usize> {
    let size = box_diagonal(corners);
    let mut out: Vec<usize> = triangles
        .iter()
        .filter(|t| tri_normal(corners, t).norm() <= 1e-12 * size * size)
        .map(|t| {
            // The corner opposite the longest edge.
            let side = |k: usize| {
                (corners[t[(k + 1) % 3] as usize] - corners[t[(k + 2) % 3] as usize]).norm()
            };
            let k = (0..3)
                .max_by(|&a, &b| side(a).total_cmp(&side(b)))
                .unwrap_or(0);
            t[k] as usize
        })
        .collect();
    out.sort_unstable();
    out.dedup();
    out
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
    /// A point in the plane of a cube's face, a hair (1e-13 of the size) outside the middle of
    /// one of its edges, is a corner of the exact hull with sliver facets beside it; the hull
    /// drops it and is the cube (the kind of vertex that stopped five of MuJoCo Menagerie's
    /// robots, CAD exports of Kinova, PAL and Trossen parts). A point well off stays a corner.
    #[test]
    fn nearly_collinear_corners_do_not_leave_sliver_facets() {
        let mut points: Vec<Vector3<f64>> = (0..8)
            .map(|i| Vector3::new((i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2 & 1) as f64))
            .collect();
        points.push(Vector3::new(0.5, -1e-13, 0.0));
        let hull = TriMesh::convex_hull("hair", &points).unwrap();
        assert_eq!(hull.vertices.len(), 8);
        assert!((hull.mass_properties().volume - 1.0).abs() < 1e-12);
        points.push(Vector3::new(0.5, 0.5, 1.2));
        let hull = TriMesh::convex_hull("roof", &points).unwrap();
        assert_eq!(hull.vertices.len(), 9);
    }

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

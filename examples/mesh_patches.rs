//! Points and SSDF error of mesh files sampled at a spacing, three ways: the file's own
//! triangles (`sample_as_is`), the simplified mesh triangle by triangle (`sample`, what
//! `scm_mesh_sampling` = `triangles` gives), and in patches (`sample_patches`, the default). The error: the largest and the mean
//! `|SSDF - signed distance|` at a sharp ε1 over points from 2 mm inside to 5 mm outside,
//! spread over the surface by area (docs/geometry.md, "Patches of a mesh").
//!
//! `cargo run --release --example mesh_patches -- SPACING FILE...`

use nalgebra::Vector3;
use scm::geometry::mesh::{Placement, TriMesh};
use scm::geometry::{ssdf, Aopc};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let spacing: f64 = args[0].parse().expect("a spacing (m)");
    for file in &args[1..] {
        let (mesh, _) = TriMesh::load(
            std::path::Path::new(file),
            &Placement::scaled(Vector3::repeat(1.0)),
        )
        .expect("a mesh");
        let clouds: [(&str, Aopc); 3] = [
            ("file's triangles", mesh.sample_as_is(spacing)),
            ("per triangle", mesh.sample(spacing)),
            ("patches", mesh.sample_patches(spacing)),
        ];
        let area: f64 = clouds[0].1.areas.iter().sum();
        println!(
            "{file}: {} triangles, area / spacing² = {:.0}",
            mesh.triangles.len(),
            area / spacing / spacing
        );
        let queries = queries(&mesh, 400);
        for (name, cloud) in &clouds {
            let (mut worst, mut sum) = (0.0f64, 0.0);
            for p in &queries {
                let e = (ssdf(cloud, p, 1e-8) - mesh.sdf(p)).abs();
                worst = worst.max(e);
                sum += e;
            }
            println!(
                "  {name:>16}: {:6} points, SSDF error max {:.3} mm, mean {:.3} mm, volume {:+.2} %",
                cloud.len(),
                worst * 1e3,
                sum / queries.len() as f64 * 1e3,
                (cloud.enclosed_volume() / mesh.mass_properties().volume - 1.0) * 100.0
            );
        }
    }
}

/// Points near the surface: on triangles chosen by area, moved along the normal by -2 to 5 mm.
fn queries(mesh: &TriMesh, n: usize) -> Vec<Vector3<f64>> {
    let mut state = 7u64;
    let mut u = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let tris: Vec<[Vector3<f64>; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|i| mesh.vertices[i as usize]))
        .collect();
    let areas: Vec<f64> = tris
        .iter()
        .map(|[a, b, c]| 0.5 * (b - a).cross(&(c - a)).norm())
        .collect();
    let total: f64 = areas.iter().sum();
    (0..n)
        .map(|_| {
            let mut pick = u() * total;
            let k = areas
                .iter()
                .position(|&a| {
                    pick -= a;
                    pick <= 0.0
                })
                .unwrap_or(areas.len() - 1);
            let [a, b, c] = tris[k];
            let (mut s, mut t) = (u(), u());
            if s + t > 1.0 {
                (s, t) = (1.0 - s, 1.0 - t);
            }
            let n = (b - a).cross(&(c - a)).normalize();
            a + (b - a) * s + (c - a) * t + n * (-0.002 + 0.007 * u())
        })
        .collect()
}

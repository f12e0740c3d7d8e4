//! MuJoCo's mesh inertias other than the exact solid's ([`super::TriMesh::mass_properties`]):
//! its default `inertia="legacy"` and its thin shell, each from a triangle soup.

use super::MassProperties;
use nalgebra::{Matrix3, Vector3};

/// MuJoCo's default mesh inertia, `inertia="legacy"`, of a triangle soup (any winding, open or
/// closed), by the rule MuJoCo's compiler applies (written here, not taken from a library:
/// equivalence with MuJoCo is the point). Every triangle is the base of a pyramid whose volume counts
/// positive whichever side the apex is on: first with its apex at the area-weighted centroid of
/// the triangles, which places the centre of mass (each pyramid's at 3/4 of the way from apex
/// to base centre); then with its apex at that centre of mass, which gives the volume and the
/// inertia. For a convex closed mesh this is its exact volume and inertia; for a non-convex one
/// the pyramids that stick out count twice, and for an open one the missing faces count
/// nothing, as in MuJoCo. Triangles of area below 1e-15 m² add nothing (MuJoCo's threshold).
/// `None` if the surface or the volume is below that threshold.
pub fn legacy_mass_properties(
    vertices: &[Vector3<f64>],
    triangles: &[[u32; 3]],
) -> Option<MassProperties> {
    const TINY: f64 = 1e-15;
    // Area, unit normal and centre of each triangle that has an area.
    let faces: Vec<(f64, Vector3<f64>, [Vector3<f64>; 3])> = triangles
        .iter()
        .filter_map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            let cross = (b - a).cross(&(c - a));
            let len = cross.norm();
            (len >= TINY).then(|| (0.5 * len, cross / len, [a, b, c]))
        })
        .collect();
    let centre = |v: &[Vector3<f64>; 3]| (v[0] + v[1] + v[2]) / 3.0;
    let area: f64 = faces.iter().map(|f| f.0).sum();
    if area < TINY {
        return None;
    }
    let apex = faces
        .iter()
        .fold(Vector3::zeros(), |s, (a, _, v)| s + centre(v) * *a)
        / area;
    let pyramid = |apex: &Vector3<f64>, (a, n, v): &(f64, Vector3<f64>, [Vector3<f64>; 3])| {
        ((centre(v) - apex).dot(n) * a / 3.0).abs()
    };
    let (mut volume, mut moment) = (0.0, Vector3::zeros());
    for f in &faces {
        let vol = pyramid(&apex, f);
        volume += vol;
        moment += (centre(&f.2) * 0.75 + apex * 0.25) * vol;
    }
    if volume < TINY {
        return None;
    }
    let com = moment / volume;
    let (mut volume, mut second) = (0.0, Matrix3::zeros());
    for f in &faces {
        let vol = pyramid(&com, f);
        let [d, e, g] = f.2.map(|x| x - com);
        let s = d + e + g;
        volume += vol;
        second += (d * d.transpose() + e * e.transpose() + g * g.transpose() + s * s.transpose())
            * (vol / 20.0);
    }
    Some(MassProperties {
        volume,
        com,
        inertia: Matrix3::identity() * second.trace() - second,
    })
}

/// MuJoCo's shell inertia of a mesh (`inertia="shell"`): the surface as a thin shell of unit
/// areal density, written here from MuJoCo's rule (equivalence with MuJoCo is the point). Its
/// "volume" is the area (a geom's mass is its density times it), its centre of mass the
/// area-weighted centroid of the triangles, and its second moment about that centre
/// `Σ A (DDᵀ + EEᵀ + FFᵀ + SSᵀ)/12` over triangles `D, E, F` (from the centre, `S = D + E +
/// F`), the exact second moment of a uniform triangle. Open or closed, any winding. `None` if
/// the area is below 1e-15 m² (MuJoCo refuses such a mesh).
pub fn shell_mass_properties(
    vertices: &[Vector3<f64>],
    triangles: &[[u32; 3]],
) -> Option<MassProperties> {
    const TINY: f64 = 1e-15;
    let faces: Vec<(f64, [Vector3<f64>; 3])> = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            (0.5 * (b - a).cross(&(c - a)).norm(), [a, b, c])
        })
        .collect();
    let area: f64 = faces.iter().map(|f| f.0).sum();
    if area < TINY {
        return None;
    }
    let com = faces.iter().fold(Vector3::zeros(), |s, (a, v)| {
        s + (v[0] + v[1] + v[2]) * (a / 3.0)
    }) / area;
    let mut second = Matrix3::zeros();
    for (a, v) in &faces {
        let [d, e, f] = v.map(|x| x - com);
        let s = d + e + f;
        second += (d * d.transpose() + e * e.transpose() + f * f.transpose() + s * s.transpose())
            * (a / 12.0);
    }
    Some(MassProperties {
        volume: area,
        com,
        inertia: Matrix3::identity() * second.trace() - second,
    })
}

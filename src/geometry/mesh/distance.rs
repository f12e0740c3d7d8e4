//! A mesh's exact signed distance (the nearest triangle, the sign by the winding number) and
//! the bounds that spare it: its bounding box gives the sign outside it and a floor of the
//! distance.

use super::{bounds, TriMesh};
use nalgebra::Vector3;

impl TriMesh {
    /// Generalized winding number of the surface around `p`: 1 inside, 0 outside.
    pub fn winding_number(&self, p: &Vector3<f64>) -> f64 {
        winding(&self.vertices, self.triangles.iter(), p)
    }

    /// The vertices' bounding box (m): `(lower corner, upper corner)`.
    pub fn bounds(&self) -> (Vector3<f64>, Vector3<f64>) {
        bounds(&self.vertices)
    }

    /// A lower bound of the distance from `p` to the mesh (m): the distance to its bounding
    /// box, 0 inside it.
    pub fn distance_floor(&self, p: &Vector3<f64>) -> f64 {
        box_distance(&self.bounds(), p)
    }

    /// Exact signed distance (m): distance to the nearest triangle, negative inside.
    pub fn sdf(&self, p: &Vector3<f64>) -> f64 {
        let d = self
            .triangles
            .iter()
            .map(|t| {
                (closest_on_triangle(p, &t.map(|i| self.vertices[i as usize])) - p).norm_squared()
            })
            .fold(f64::INFINITY, f64::min)
            .sqrt();
        // Outside the vertices' bounding box a closed mesh winds 0 times around `p`: its sign
        // without the solid angles (an `atan2` per triangle, most of a body's union sampling,
        // whose geoms ask about every point in their bounding balls).
        let (lo, hi) = self.bounds();
        let outside = (0..3).any(|k| p[k] < lo[k] || p[k] > hi[k]);
        if !outside && self.winding_number(p) > 0.5 {
            -d
        } else {
            d
        }
    }
}

/// The distance from `p` to the box `(lo, hi)` (m), 0 inside it: a floor of the distance to
/// anything the box holds.
pub fn box_distance((lo, hi): &(Vector3<f64>, Vector3<f64>), p: &Vector3<f64>) -> f64 {
    (lo - p).sup(&(p - hi)).sup(&Vector3::zeros()).norm()
}

/// Σ of the triangles' solid angles seen from `p`, over 4π (Van Oosterom and Strackee).
pub(super) fn winding<'a>(
    v: &[Vector3<f64>],
    tris: impl Iterator<Item = &'a [u32; 3]>,
    p: &Vector3<f64>,
) -> f64 {
    let mut total = 0.0;
    for t in tris {
        let [a, b, c] = t.map(|i| v[i as usize] - p);
        let (la, lb, lc) = (a.norm(), b.norm(), c.norm());
        let num = a.dot(&b.cross(&c));
        let den = la * lb * lc + a.dot(&b) * lc + a.dot(&c) * lb + b.dot(&c) * la;
        total += 2.0 * num.atan2(den);
    }
    total / (4.0 * std::f64::consts::PI)
}

/// Closest point to `p` on the triangle `t` (Ericson, Real-Time Collision Detection, 5.1.5).
pub(super) fn closest_on_triangle(p: &Vector3<f64>, t: &[Vector3<f64>; 3]) -> Vector3<f64> {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

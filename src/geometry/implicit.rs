//! Shapes given by a signed distance function (MuJoCo's SDF plugins: `mujoco.sdf.torus`,
//! `bowl`, `bolt` and `nut`) and their closed triangle surface, so that they weigh and collide as
//! any closed mesh does (docs/geometry.md, "Shapes given by a distance function").
//!
//! The surface is the distance's zero level on MuJoCo's own grid (its box split into about
//! 300 cells over the three half-widths together), cut by marching tetrahedra: each cell into
//! six tetrahedra around its main diagonal, which every neighbour splits the same way, so the
//! pieces join into a closed surface; every crossing is placed on its grid edge by linear
//! interpolation, as MuJoCo's marching cubes places it. Written here rather than taken from a
//! crate: the tetrahedra need no case table, and the crossings shared by index make the
//! surface closed by construction.

use std::collections::HashMap;

use nalgebra::Vector3;

use super::mesh::{MeshError, TriMesh};

/// A shape of one of MuJoCo's SDF plugins, by its configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ImplicitShape {
    /// `mujoco.sdf.torus`: a torus about the z axis, tube centre at `major` from the axis,
    /// tube radius `minor` (`radius1`, `radius2`).
    Torus {
        /// Radius of the tube's centre line (m).
        major: f64,
        /// Radius of the tube (m).
        minor: f64,
    },
    /// `mujoco.sdf.bolt`: a hexagonal head (faces 0.5 from the axis) on a shaft of radius
    /// `radius` carrying a single-start thread of pitch 1/12 m, as the plugin builds it from
    /// half-spaces, cones and a triangle wave (not a true distance; its zero level is the
    /// shape).
    Bolt {
        /// The shaft's radius (m; `radius`).
        radius: f64,
    },
    /// `mujoco.sdf.nut`: a hexagonal nut whose threaded hole, of radius `radius`, fits the
    /// bolt's thread.
    Nut {
        /// The hole's radius (m; `radius`).
        radius: f64,
    },
    /// `mujoco.sdf.bowl`: a spherical shell of radius `radius` about the origin and thickness
    /// `2 thickness`, cut by the plane `z = height` (the part below it kept) and rounded at
    /// the rim (`height`, `radius`, `thickness`).
    Bowl {
        /// Height of the rim's plane (m).
        height: f64,
        /// Radius of the sphere (m).
        radius: f64,
        /// Half the shell's thickness (m).
        thickness: f64,
    },
}

impl ImplicitShape {
    /// The signed distance at `p` (negative inside), as the plugin defines it.
    pub fn distance(&self, p: &Vector3<f64>) -> f64 {
        let radial = p.x.hypot(p.y);
        match *self {
            ImplicitShape::Torus { major, minor } => (radial - major).hypot(p.z) - minor,
            ImplicitShape::Bowl {
                height,
                radius,
                thickness,
            } => {
                // The rim's circle (radial `width`, height `height`) and the sphere: points
                // beyond the cone through the rim are nearest the rim, the others the sphere.
                let width = (radius * radius - height * height).sqrt();
                let shell = if height * radial < width * p.z {
                    (radial - width).hypot(p.z - height)
                } else {
                    (p.norm() - radius).abs()
                };
                shell - thickness
            }
            ImplicitShape::Bolt { radius } => {
                let r = radial - radius;
                let shaft = (r - thread(p) / SCREW) * HALF_SQRT2;
                // The shaft between z = -1 and 0, its end bevelled by a cone.
                let shaft = shaft.max(-(0.5 - (p.z + 0.5).abs()));
                let shaft = shaft.max(-((p.z - r) * HALF_SQRT2 + HALF_SQRT2));
                let head = hexagon(p)
                    .max((p.z + 0.25).abs() - 0.25)
                    .max((p.z + r - 0.22) * HALF_SQRT2);
                shaft.min(head)
            }
            ImplicitShape::Nut { radius } => {
                let r = radial - radius;
                let threaded = (r - thread(p) / SCREW) * HALF_SQRT2;
                let cone = (p.z - r) * HALF_SQRT2;
                let hole = threaded
                    .max(-(cone + 0.5 * HALF_SQRT2))
                    .min(-cone - 0.05 * HALF_SQRT2);
                let body = hexagon(p)
                    .max((p.z + 0.25).abs() - 0.25)
                    .max((p.z + r - 0.22) * HALF_SQRT2);
                body.max(-hole)
            }
        }
    }

    /// The box the plugin declares around the shape: centre and half-widths.
    pub fn bounds(&self) -> (Vector3<f64>, Vector3<f64>) {
        let half = match *self {
            ImplicitShape::Torus { major, minor } => {
                Vector3::new(major + minor, major + minor, minor)
            }
            ImplicitShape::Bowl {
                radius, thickness, ..
            } => Vector3::repeat(radius + thickness),
            ImplicitShape::Bolt { .. } | ImplicitShape::Nut { .. } => Vector3::new(0.6, 0.6, 1.0),
        };
        (Vector3::zeros(), half)
    }

    /// The closed triangle surface of the shape on MuJoCo's grid (module doc), with the
    /// warnings [`TriMesh::new`] gives; `label` names it in messages.
    pub fn surface(&self, label: &str) -> Result<(TriMesh, Vec<String>), MeshError> {
        let (vertices, triangles) = self.triangles();
        TriMesh::new(label, vertices, triangles)
    }

    /// The vertices and triangles of [`ImplicitShape::surface`].
    pub fn triangles(&self) -> (Vec<Vector3<f64>>, Vec<[u32; 3]>) {
        let (centre, half) = self.bounds();
        let total = half.sum();
        let n = half.map(|h| (300.0 / total * h).floor() as usize + 1);
        let point = |i: usize, j: usize, k: usize| {
            let at = |c: usize, v: usize| {
                centre[c] - half[c] + 2.0 * half[c] * (v as f64) / ((n[c] - 1) as f64)
            };
            Vector3::new(at(0, i), at(1, j), at(2, k))
        };
        let index = |i: usize, j: usize, k: usize| i + n[0] * (j + n[1] * k);
        // The field at every grid point; a value exactly zero counts as outside.
        let mut field = vec![0.0; n[0] * n[1] * n[2]];
        for k in 0..n[2] {
            for j in 0..n[1] {
                for i in 0..n[0] {
                    field[index(i, j, k)] = self.distance(&point(i, j, k));
                }
            }
        }
        let mut cutter = Cutter {
            vertices: Vec::new(),
            triangles: Vec::new(),
            crossings: HashMap::new(),
        };
        // A cell's corners by their bits (x, y, z); its six tetrahedra share the diagonal
        // 0-7 and go round it through 1, 3, 2, 6, 4, 5.
        const RING: [usize; 7] = [1, 3, 2, 6, 4, 5, 1];
        for k in 0..n[2].saturating_sub(1) {
            for j in 0..n[1].saturating_sub(1) {
                for i in 0..n[0].saturating_sub(1) {
                    let corner = |c: usize| {
                        let (a, b, d) = (i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2));
                        let g = index(a, b, d);
                        (g, field[g], point(a, b, d))
                    };
                    let corners: [(usize, f64, Vector3<f64>); 8] = std::array::from_fn(corner);
                    if corners.iter().all(|c| c.1 < 0.0) || corners.iter().all(|c| c.1 >= 0.0) {
                        continue;
                    }
                    for w in RING.windows(2) {
                        cutter.tetrahedron([corners[0], corners[7], corners[w[0]], corners[w[1]]]);
                    }
                }
            }
        }
        (cutter.vertices, cutter.triangles)
    }
}

/// Turns of the bolt's and the nut's thread per metre along the axis (the plugins' `screw`).
const SCREW: f64 = 12.0;
const HALF_SQRT2: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// The thread's profile at `p`: a triangle wave in `12 z - φ/2π` (`φ` the azimuth), between 0
/// and ½, so that its crest winds once round the axis per 1/12 m.
fn thread(p: &Vector3<f64>) -> f64 {
    let u = SCREW * p.z - p.y.atan2(p.x) / std::f64::consts::TAU;
    ((u - u.floor()) - 0.5).abs()
}

/// The signed distance to the hexagon of apothem ½ about the z axis, in the plane: the point
/// turned into the sextant facing +x, then its x less ½.
fn hexagon(p: &Vector3<f64>) -> f64 {
    let k = 6.0 / std::f64::consts::TAU;
    let angle = -(p.y.atan2(p.x) * k + 0.5).floor() / k;
    angle.cos() * p.x - angle.sin() * p.y - 0.5
}

/// The surface's pieces as the tetrahedra are cut: vertices (one per crossed grid edge, by the
/// edge's two grid points) and outward triangles.
struct Cutter {
    vertices: Vec<Vector3<f64>>,
    triangles: Vec<[u32; 3]>,
    crossings: HashMap<(usize, usize), u32>,
}

/// A grid point: its index, the field's value there and its position.
type Corner = (usize, f64, Vector3<f64>);

impl Cutter {
    /// The vertex where the field crosses zero on the edge `a`-`b` (one inside, one out).
    fn crossing(&mut self, a: &Corner, b: &Corner) -> u32 {
        let key = (a.0.min(b.0), a.0.max(b.0));
        if let Some(&v) = self.crossings.get(&key) {
            return v;
        }
        // Interpolated from the lower-indexed end, so that both cells sharing the edge place
        // it at the same bits.
        let (p, q) = if a.0 < b.0 { (a, b) } else { (b, a) };
        // Kept a thousandth of the edge from its ends (2 µm on MuJoCo's grid of a 1 m shape),
        // so that a crossing next to a grid point does not collapse a triangle onto it.
        let t = (p.1 / (p.1 - q.1)).clamp(1e-3, 1.0 - 1e-3);
        self.vertices.push(p.2 + (q.2 - p.2) * t);
        let v = (self.vertices.len() - 1) as u32;
        self.crossings.insert(key, v);
        v
    }

    /// Adds the triangle `t`, turned to face from `inside` toward `outside` (points of the
    /// tetrahedron on either side).
    fn add(&mut self, mut t: [u32; 3], inside: Vector3<f64>, outside: Vector3<f64>) {
        let [a, b, c] = t.map(|v| self.vertices[v as usize]);
        if (b - a).cross(&(c - a)).dot(&(outside - inside)) < 0.0 {
            t.swap(1, 2);
        }
        self.triangles.push(t);
    }

    fn tetrahedron(&mut self, v: [Corner; 4]) {
        let (inside, outside): (Vec<&Corner>, Vec<&Corner>) = v.iter().partition(|c| c.1 < 0.0);
        let mean = |cs: &[&Corner]| cs.iter().map(|c| c.2).sum::<Vector3<f64>>() / cs.len() as f64;
        match (inside.len(), outside.len()) {
            (1, 3) | (3, 1) => {
                let (lone, others) = if inside.len() == 1 {
                    (inside[0], &outside)
                } else {
                    (outside[0], &inside)
                };
                let t = [0, 1, 2].map(|k| self.crossing(lone, others[k]));
                self.add(t, mean(&inside), mean(&outside));
            }
            (2, 2) => {
                let (a, b, c, d) = (inside[0], inside[1], outside[0], outside[1]);
                let (ac, ad, bd, bc) = (
                    self.crossing(a, c),
                    self.crossing(a, d),
                    self.crossing(b, d),
                    self.crossing(b, c),
                );
                let (i, o) = (mean(&inside), mean(&outside));
                self.add([ac, ad, bd], i, o);
                self.add([ac, bd, bc], i, o);
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn the_torus_surface_is_closed_and_encloses_the_torus_volume() {
        let (major, minor) = (0.35, 0.15);
        let shape = ImplicitShape::Torus { major, minor };
        assert!((shape.distance(&Vector3::new(0.5, 0.0, 0.0))).abs() < 1e-15);
        assert!((shape.distance(&Vector3::new(0.0, 0.0, 0.0)) - 0.2).abs() < 1e-15);
        let (mesh, _) = shape.surface("torus").expect("a closed surface");
        let exact = 2.0 * PI * PI * major * minor * minor;
        let v = mesh.mass_properties().volume;
        // The grid's cells are 2.2 mm: the cut surface's volume is within a few parts in 1e4.
        assert!((v - exact).abs() < 1e-3 * exact, "{v} vs {exact}");
    }

    #[test]
    fn the_thread_winds_once_per_twelfth_of_a_metre() {
        // The thread's profile is invariant under the screw motion: turned by θ about z and
        // moved θ / (2π · 12) along it; the nut's and the bolt's surfaces are closed.
        let p = Vector3::new(0.23, -0.11, -0.37);
        for theta in [0.3, 1.0, 2.5, -4.0] {
            let (c, s) = (f64::cos(theta), f64::sin(theta));
            let q = Vector3::new(
                c * p.x - s * p.y,
                s * p.x + c * p.y,
                p.z + theta / (2.0 * PI * 12.0),
            );
            assert!((thread(&q) - thread(&p)).abs() < 1e-12, "{theta}");
        }
        assert!((thread(&(p + Vector3::z() / 12.0)) - thread(&p)).abs() < 1e-12);
        for shape in [
            ImplicitShape::Bolt { radius: 0.255 },
            ImplicitShape::Nut { radius: 0.26 },
        ] {
            shape.surface("threaded").expect("a closed surface");
        }
        // The hexagon's faces lie 0.5 from the axis, one facing +x; the nut's body ends there.
        let h = ImplicitShape::Nut { radius: 0.26 };
        assert!(hexagon(&Vector3::new(0.5, 0.0, -0.2)).abs() < 1e-15);
        assert!((hexagon(&Vector3::new(0.6, 0.0, 0.0)) - 0.1).abs() < 1e-15);
        assert!(h.distance(&Vector3::new(0.55, 0.0, -0.25)) > 0.0);
    }

    #[test]
    fn the_bowl_distance_is_its_shell_and_rim() {
        let shape = ImplicitShape::Bowl {
            height: 0.4,
            radius: 1.0,
            thickness: 0.02,
        };
        // On the sphere below the rim: -thickness; at the bottom, outside by 0.1: 0.08.
        assert!((shape.distance(&Vector3::new(0.0, 0.0, -1.0)) + 0.02).abs() < 1e-15);
        assert!((shape.distance(&Vector3::new(0.0, 0.0, -1.1)) - 0.08).abs() < 1e-12);
        // Above the rim, nearest the rim circle.
        let width = (1.0f64 - 0.16).sqrt();
        let d = shape.distance(&Vector3::new(width, 0.0, 0.5));
        assert!((d - (0.1 - 0.02)).abs() < 1e-12, "{d}");
        let (mesh, _) = shape.surface("bowl").expect("a closed surface");
        // The shell's volume: the spherical shell below the rim, thickness 2t, about
        // 2t times the cap's area 2πR(R + h), plus the rounded rim.
        let shell = 0.04 * 2.0 * PI * 1.0 * 1.4;
        let v = mesh.mass_properties().volume;
        assert!((v - shell).abs() < 0.02 * shell, "{v} vs {shell}");
    }
}

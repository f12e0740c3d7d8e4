//! Shapes given by a signed distance function (MuJoCo's SDF plugins: `mujoco.sdf.torus`,
//! `bowl`, `bolt`, `nut` and `gear`) and their closed triangle surface, so that they weigh and collide as
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

use super::gear_profile::gear_profile;
use super::mesh::{MeshError, TriMesh};
use super::Aopc;

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
    /// `mujoco.sdf.gear`: a spur gear about the z axis, extruded `thickness` along it, with
    /// involute teeth and the plugin's smoothed roots and tips (MuJoCo's plugin: its pressure
    /// angle a quadratic in the number of teeth, addendum `diameter / teeth`, whole depth 2.2
    /// times that, its bore `innerdiameter` or, when that is negative, what the plugin derives).
    Gear {
        /// The gear's turn about z (rad), added to the azimuth as the plugin adds it.
        alpha: f64,
        /// Pitch diameter (m).
        diameter: f64,
        /// Number of teeth.
        teeth: f64,
        /// Extent along z (m).
        thickness: f64,
        /// The bore's diameter (m); negative: the plugin's own.
        inner: f64,
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
            ImplicitShape::Gear {
                alpha,
                diameter,
                teeth,
                thickness,
                inner,
            } => {
                // The profile's distance in the plane, extruded (exact outside the slab's
                // edges, as the plugin's extrusion).
                let (w0, w1) = (
                    gear_profile((alpha, diameter, teeth, inner), p.x, p.y, radial),
                    p.z.abs() - thickness / 2.0,
                );
                w0.max(w1).min(0.0) + w0.max(0.0).hypot(w1.max(0.0))
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
            ImplicitShape::Gear {
                diameter,
                thickness,
                ..
            } => Vector3::new(0.625 * diameter, 0.625 * diameter, 0.55 * thickness),
        };
        (Vector3::zeros(), half)
    }

    /// The cloud of this shape's surface (sampled from [`ImplicitShape::surface`]) with each
    /// point moved onto the function's zero level and given the function's normal there
    /// (docs/geometry.md, "Shapes given by a distance function"). The grid's surface cuts the
    /// thread's sharp crests with chords and notches whose facets face anywhere (measured on
    /// MuJoCo's bolt: facets facing along the axis on a crest whose flanks face 45° from it);
    /// far from the part, the SSDF reads the plane of the nearest point alone, and such a
    /// facet's plane read a nut 9 cm away as 2 cm inside the bolt. The function's own normal
    /// at a crest is one flank's, or their mean exactly on it: a plane that never reads a
    /// point beyond the crest as inside. Only points whose quad faces more than 10° from
    /// the function's normal there move (16 % of the bolt's at 1 cm); a
    /// point whose projection does not settle within a nanometre of the zero level, or would
    /// move further than its quad's size, is kept as sampled. A point's area grows by the cosine its normal turned (down to a half: a facet
    /// across a crest stands for the flank it settles on, seen face on), then all are scaled
    /// by the least change that keeps the cloud closed; vertices stay the mesh's.
    pub fn settle(&self, mut cloud: Aopc) -> Aopc {
        let mut settled = 0;
        for k in 0..cloud.points.len() {
            let along = self.gradient(&cloud.points[k]).try_normalize(1e-9);
            if along.is_some_and(|g| g.dot(&cloud.normals[k]) >= KEPT_COSINE) {
                continue;
            }
            let reach = cloud.faces[k]
                .iter()
                .map(|&v| (cloud.vertices[v as usize] - cloud.points[k]).norm())
                .fold(0.0, f64::max);
            if let Some((p, n)) = self.project(&cloud.points[k], reach) {
                let turned = cloud.normals[k].dot(&n);
                cloud.points[k] = p;
                cloud.normals[k] = n;
                cloud.areas[k] /= turned.max(0.5);
                settled += 1;
            }
        }
        if settled == 0 {
            return cloud;
        }
        // A closed surface has Σ a n = 0. Points settled on either side of a crest leave a
        // little of it (0.3 % of the nut's area, the thread's crests settling more often on
        // one flank); each area is scaled by 1 + n·μ, the least change that closes it again
        // (μ from the 3×3 system Σ a n nᵀ μ = -Σ a n).
        let (mut residual, mut spread) = (Vector3::zeros(), nalgebra::Matrix3::zeros());
        for (n, a) in cloud.normals.iter().zip(&cloud.areas) {
            residual += n * *a;
            spread += n * n.transpose() * *a;
        }
        if let Some(inverse) = spread.try_inverse() {
            let mu = -(inverse * residual);
            for (n, a) in cloud.normals.iter().zip(cloud.areas.iter_mut()) {
                *a *= 1.0 + n.dot(&mu);
            }
        }
        cloud
    }

    /// `p` moved onto the zero level along the gradient (Newton's steps), and the unit
    /// gradient there; `None` when it does not settle within `reach` of `p`.
    fn project(&self, p: &Vector3<f64>, reach: f64) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let mut x = *p;
        for _ in 0..PROJECTION_STEPS {
            let f = self.distance(&x);
            let g = self.gradient(&x);
            if f.abs() <= PROJECTION_TOLERANCE {
                let n = g.try_normalize(1e-9)?;
                return ((x - p).norm() <= reach).then_some((x, n));
            }
            let g2 = g.norm_squared();
            if g2 < 1e-12 {
                return None;
            }
            x -= g * (f / g2);
        }
        None
    }

    /// The function's gradient by central differences of [`GRADIENT_STEP`]: the functions are
    /// minima and maxima of smooth pieces, so the gradient is a piece's (its analytic form
    /// would be one per piece and per plugin), and on a kink it is the mean of the two pieces'
    /// (a normal between the two faces that meet there).
    fn gradient(&self, x: &Vector3<f64>) -> Vector3<f64> {
        Vector3::from_fn(|k, _| {
            let mut e = Vector3::zeros();
            e[k] = GRADIENT_STEP;
            (self.distance(&(x + e)) - self.distance(&(x - e))) / (2.0 * GRADIENT_STEP)
        })
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

/// A sampled point whose quad faces within this cosine (10°) of the function's normal keeps
/// its place and normal ([`ImplicitShape::settle`]): the mesh is as good as the sampling there.
const KEPT_COSINE: f64 = 0.984_807_753_012_208;
/// Newton's steps that put a sampled point on the zero level ([`ImplicitShape::settle`]).
const PROJECTION_STEPS: usize = 12;
/// How far from the zero level a settled point may be (m).
const PROJECTION_TOLERANCE: f64 = 1e-9;
/// The central differences' step of the gradient (m): the functions are of order 1 over the
/// shapes' metre, so their rounding (1e-16) costs 1e-9 of the gradient.
const GRADIENT_STEP: f64 = 1e-7;

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
    fn settled_points_lie_on_the_thread_and_read_it_from_afar() {
        // The bolt's cloud at 1 cm: every point but a few (those that do not settle, in the
        // corner where the thread meets the head) faces within 10° of the function's normal:
        // kept as sampled where its quad did, else put on the zero level (within 1e-9 m) with
        // the function's normal.
        let bolt = ImplicitShape::Bolt { radius: 0.255 };
        let (mesh, _) = bolt.surface("bolt").expect("a closed surface");
        // The grid's surface simplifies (it keeps a few triangles of no area, dropped).
        let simple = mesh.simplified(0.01).expect("a simplified surface");
        assert!(simple.mesh.triangles.len() * 10 < mesh.triangles.len());
        assert!(simple.flat > 0);
        let sampled = mesh.sample(0.01);
        let cloud = bolt.settle(sampled.clone());
        let (mut facing, mut moved) = (0, 0);
        for ((p, n), before) in cloud.points.iter().zip(&cloud.normals).zip(&sampled.points) {
            let along = bolt.gradient(p).normalize().dot(n);
            if p != before {
                assert!(bolt.distance(p).abs() <= 1e-9 && along > 1.0 - 1e-12);
                moved += 1;
            }
            facing += usize::from(along >= KEPT_COSINE);
        }
        let n = cloud.points.len();
        assert!(facing >= n * 999 / 1000, "{facing} of {n}");
        assert!(moved > 0 && moved < n / 4, "{moved} of {n}");
        // Still closed, and enclosing the mesh's volume within 1 % (measured: 2e-5).
        let area: f64 = cloud.areas.iter().sum();
        assert!(cloud.closure_defect().norm() < 1e-12 * area);
        let (v, exact) = (cloud.enclosed_volume(), mesh.mass_properties().volume);
        assert!((v - exact).abs() < 0.01 * exact, "{v} against {exact}");
        // Read from 8 to 15 cm outside the thread's crests, all round the shaft: the settled
        // cloud reads the query outside, at least a third as far as the function does
        // (measured: 0.45 at worst, a flank's plane read across the crest); the
        // grid's cloud, whose crest facets face along the axis, reads some of them inside.
        let (mut least, mut grid_least) = (f64::INFINITY, f64::INFINITY);
        for k in 0..400 {
            let (angle, z) = (k as f64 * 0.37, -0.55 - 0.4 * (k as f64 / 400.0));
            let r = 0.38 + 0.07 * ((k * 7) % 10) as f64 / 10.0;
            let x = Vector3::new(r * angle.cos(), r * angle.sin(), z);
            let truth = bolt.distance(&x);
            least = least.min(crate::geometry::ssdf(&cloud, &x, 1e-5) / truth);
            grid_least = grid_least.min(crate::geometry::ssdf(&sampled, &x, 1e-5));
        }
        assert!(least > 1.0 / 3.0, "{least}");
        assert!(grid_least < 0.0, "{grid_least}");
    }

    #[test]
    fn the_gear_has_its_teeth_round_its_pitch_circle() {
        // MuJoCo's default gear: 25 teeth on a pitch diameter of 2.8 m, 0.2 m thick.
        let gear = ImplicitShape::Gear {
            alpha: 0.0,
            diameter: 2.8,
            teeth: 25.0,
            thickness: 0.2,
            inner: -1.0,
        };
        // Round the pitch circle in the mid-plane, the profile enters and leaves a tooth once
        // per tooth; inside the root circle it is solid, beyond the tips empty, and the bore
        // (the plugin's own: tip - depth - 0.14 d = 0.874 m) is empty.
        let crossings = (0..5000)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 5000.0;
                gear.distance(&Vector3::new(1.4 * a.cos(), 1.4 * a.sin(), 0.0)) < 0.0
            })
            .collect::<Vec<_>>()
            .windows(2)
            .filter(|w| w[0] != w[1])
            .count();
        assert!(crossings.abs_diff(50) <= 1, "{crossings}");
        assert!(gear.distance(&Vector3::new(1.2, 0.0, 0.0)) < 0.0);
        assert!(gear.distance(&Vector3::new(0.0, 1.6, 0.0)) > 0.0);
        assert!(gear.distance(&Vector3::new(0.8, 0.0, 0.0)) > 0.0);
        assert!((gear.distance(&Vector3::new(1.2, 0.0, 0.15)) - 0.05).abs() < 1e-12);
        let (mesh, _) = gear.surface("gear").expect("a closed surface");
        // Its volume: the annulus from the bore to the root circle and 25 teeth, 0.2 m thick.
        let v = mesh.mass_properties().volume;
        let (bore, root, tip) = (0.874, 1.4 - 1.2 / (25.0 / 2.8), 1.4 + 2.8 / 25.0);
        let annulus = std::f64::consts::PI * (root * root - bore * bore) * 0.2;
        let all = std::f64::consts::PI * (tip * tip - bore * bore) * 0.2;
        assert!(v > annulus && v < all, "{v}: {annulus} to {all}");
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

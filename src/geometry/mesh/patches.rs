//! A mesh's AOPC with its points as far apart as the spacing asks, whatever the shapes of its
//! triangles (docs/geometry.md, "Patches of a mesh"): the surface is cut into pieces no longer
//! than half the spacing; pieces along sharp edges first, then the rest in a space-filling
//! order, start patches where no patch near enough would take them (within [`PATCH_RADIUS`] of
//! its first piece, facing within [`PATCH_ANGLE_COSINE`] of it); every piece joins the nearest
//! patch that would; each patch gives one point: its area centroid, its summed area vector as
//! normal and area, and as face a square in its plane whose corners lie at its reach. The mesh's
//! vertices are kept as the cloud's `reach`, so that its bounding polytope holds the surface.
//!
//! Summing area vectors keeps the cloud closed (`Σ n·area` is the mesh's, zero) whatever the
//! grouping; a flat patch stands for its pieces exactly (one plane), a curved one departs from
//! them by about its sagitta, and its share of the cloud's enclosed volume (`⅓ p·A`) falls
//! short of its pieces' by about `φ²/3` for a patch spanning `±φ` of a cylinder. A CAD mesh's
//! thin triangles (a cylinder's side cut into slivers 7 cm long and a few millimetres wide)
//! gave three quads each, two to four times the points the spacing asks on robosuite's Franka;
//! a patch takes in pieces of several slivers.

use super::TriMesh;
use crate::geometry::aopc::z_to;
use crate::geometry::spine::nearest_on_segment;
use crate::geometry::Aopc;
use nalgebra::Vector3;
use rustc_hash::FxHashMap as HashMap;

/// A patch's radius, as a fraction of the spacing: no piece's centre lies further from its
/// patch's first piece.
pub const PATCH_RADIUS: f64 = 0.9;

/// The least cosine between a patch's first piece's normal and any other piece's it takes in
/// (about 26°): a sharp edge (a box's 90°, a chamfer's 45°) separates patches; a cylinder of
/// 2 cm radius turns by that much over 0.9 cm, so patches on it are still about the spacing.
pub const PATCH_ANGLE_COSINE: f64 = 0.9;

/// A piece of a triangle: its centroid, its triangle's unit normal and its area, and whether
/// it lies along a sharp edge of its triangle.
struct Piece {
    centre: Vector3<f64>,
    normal: Vector3<f64>,
    area: f64,
    /// The largest distance from the centre to a corner.
    radius: f64,
    by_edge: bool,
}

impl TriMesh {
    /// The AOPC of the surface in patches of about `spacing` (m) (module documentation): of the
    /// mesh simplified as [`TriMesh::sample`] simplifies it, or of the mesh as it is.
    pub fn sample_patches(&self, spacing: f64) -> Aopc {
        match self.simplified(spacing) {
            Some(s) => s.mesh.sample_in_patches(spacing),
            None => self.sample_in_patches(spacing),
        }
    }

    /// The AOPC of this mesh's surface in patches of about `spacing` (m) (module documentation),
    /// without simplifying the mesh first.
    pub fn sample_in_patches(&self, spacing: f64) -> Aopc {
        let normals: Vec<Option<Vector3<f64>>> = self
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize]);
                (b - a).cross(&(c - a)).try_normalize(0.0)
            })
            .collect();
        let sharp = self.sharp_edges(&normals);
        let mut pieces = Vec::new();
        for (k, (t, normal)) in self.triangles.iter().zip(&normals).enumerate() {
            let Some(normal) = normal else { continue };
            let from = pieces.len();
            cut(
                &mut pieces,
                t.map(|i| self.vertices[i as usize]),
                normal,
                0.5 * spacing,
            );
            for p in &mut pieces[from..] {
                p.by_edge = sharp[k].iter().any(|&(a, b)| {
                    let (a, b) = (&self.vertices[a as usize], &self.vertices[b as usize]);
                    (p.centre - nearest_on_segment(a, b, &p.centre)).norm() <= 0.25 * spacing
                });
            }
        }
        // Pieces along sharp edges first, so that patches start there and end at the edge on
        // both sides (as a primitive's quads do: a sharp ε1 reads the plane of the nearest
        // point, and near an edge that must be the face the query is beyond); then a
        // space-filling order (cells of half the spacing along a Morton curve), so that
        // patches grow from neighbours and their first pieces spread evenly.
        let cell = 0.5 * spacing;
        let key = |p: &Vector3<f64>| p.map(|x| (x / cell).floor() as i64);
        // (Keys computed once per piece: a robot's link has 10⁵ pieces.)
        pieces.sort_by_cached_key(|p| (!p.by_edge, morton(key(&p.centre))));
        let radius = PATCH_RADIUS * spacing;
        let grid_key = |p: &Vector3<f64>| p.map(|x| (x / radius).floor() as i64);
        // First pieces of the patches, and a grid of them by cells of the radius.
        let mut firsts: Vec<usize> = Vec::new();
        let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::default();
        // The first pieces in the 27 cells around a cell, with their centres and normals (read
        // contiguously, not through the pieces), gathered once for a run of pieces in the same
        // cell: the Morton order keeps a cell's pieces together, and a dense mesh has tens in
        // a cell (the 27 lookups per piece and the reads through two indices were a third of a
        // robot's load).
        type Candidate = (Vector3<f64>, Vector3<f64>, u32);
        let around = |grid: &HashMap<[i64; 3], Vec<u32>>,
                      firsts: &[usize],
                      k: [i64; 3],
                      out: &mut Vec<Candidate>| {
            out.clear();
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        if let Some(list) = grid.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                            out.extend(list.iter().map(|&s| {
                                let f = &pieces[firsts[s as usize]];
                                (f.centre, f.normal, s)
                            }));
                        }
                    }
                }
            }
        };
        // The nearest first piece within the radius whose normal is near the piece's, the
        // least index among equals (so the order of the candidates does not matter). The
        // square root only where the squared distance can pass (the same test, bit for bit).
        let near_sq = radius * radius * (1.0 + 1e-9);
        let nearest = |candidates: &[Candidate], p: &Piece| {
            let mut best: Option<(f64, u32)> = None;
            for (centre, normal, s) in candidates {
                let d2 = (centre - p.centre).norm_squared();
                if d2 > near_sq {
                    continue;
                }
                let d = d2.sqrt();
                if d <= radius
                    && normal.dot(&p.normal) >= PATCH_ANGLE_COSINE
                    && best.is_none_or(|(bd, bs)| d < bd || (d == bd && *s < bs))
                {
                    best = Some((d, *s));
                }
            }
            best.map(|(_, s)| s)
        };
        let key_of = |p: &Piece| {
            let k = grid_key(&p.centre);
            [k.x, k.y, k.z]
        };
        let (mut cached, mut candidates) = (None, Vec::new());
        for (i, p) in pieces.iter().enumerate() {
            let k = key_of(p);
            if cached != Some(k) {
                around(&grid, &firsts, k, &mut candidates);
                cached = Some(k);
            }
            if nearest(&candidates, p).is_none() {
                // A new first, in this very cell: the cached neighbourhood holds it too.
                let s = firsts.len() as u32;
                grid.entry(k).or_default().push(s);
                candidates.push((p.centre, p.normal, s));
                firsts.push(i);
            }
        }
        // Each piece joins the nearest patch that would take it (its own, if it is a first).
        // Per patch: area, first moment, area vector.
        let mut sums = vec![(0.0, Vector3::zeros(), Vector3::zeros()); firsts.len()];
        let mut of = Vec::with_capacity(pieces.len());
        cached = None;
        for p in &pieces {
            let k = key_of(p);
            if cached != Some(k) {
                around(&grid, &firsts, k, &mut candidates);
                cached = Some(k);
            }
            let s = nearest(&candidates, p).expect("every piece is within reach of a patch");
            let (area, moment, vector) = &mut sums[s as usize];
            *area += p.area;
            *moment += p.centre * p.area;
            *vector += p.normal * p.area;
            of.push(s as usize);
        }
        // Each patch's reach: the largest distance from its point (the area centroid) to a
        // corner of its pieces, bounded by a piece's centre distance plus its radius.
        let mut reach = vec![0.0f64; sums.len()];
        for (p, &s) in pieces.iter().zip(&of) {
            let (area, moment, _) = &sums[s];
            let centroid = moment / *area;
            reach[s] = reach[s].max((p.centre - centroid).norm() + p.radius);
        }
        let mut out = Aopc::default();
        for ((area, moment, vector), r) in sums.into_iter().zip(reach) {
            let (Some(normal), true) = (vector.try_normalize(0.0), area > 0.0) else {
                continue;
            };
            let size = vector.norm();
            // The area centroid: the plane through it leaves its pieces above and below it with
            // a zero mean. (A plane moved to hold the pieces' volume, `p·A = Σ a (c·n)`, lies
            // beyond a convex patch: on a sphere at `R Σa / |A|` from the centre. Measured,
            // it doubled the mean SSDF error on robosuite's Franka link5.)
            let point = moment / area;
            // The face: a square in the patch's plane whose corners lie at its reach (what the
            // bounding polytope's cover radius reads: how far the patch's plane stands for the
            // surface), counter-clockwise seen from outside (`u × v = n`).
            let rot = z_to(&normal);
            let (u, v) = (rot * Vector3::x() * r, rot * Vector3::y() * r);
            let corners = [point + u, point + v, point - u, point - v];
            out.push_face(corners, point, normal, size);
        }
        // The surface's vertices: the faces stand for their pieces in their planes only, and
        // the bounding polytope must hold the whole surface.
        out.reach = self.vertices.clone();
        out
    }
}

impl TriMesh {
    /// Each triangle's sharp edges (vertex pairs): edges whose two triangles face more than
    /// [`PATCH_ANGLE_COSINE`] apart, or that have not exactly two triangles.
    fn sharp_edges(&self, normals: &[Option<Vector3<f64>>]) -> Vec<Vec<(u32, u32)>> {
        let mut on: HashMap<(u32, u32), Vec<usize>> = HashMap::default();
        for (k, t) in self.triangles.iter().enumerate() {
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                on.entry((a.min(b), a.max(b))).or_default().push(k);
            }
        }
        let mut sharp = vec![Vec::new(); self.triangles.len()];
        for (&edge, tris) in &on {
            let is_sharp = match tris[..] {
                [i, j] => match (normals[i], normals[j]) {
                    (Some(a), Some(b)) => a.dot(&b) < PATCH_ANGLE_COSINE,
                    _ => true,
                },
                _ => true,
            };
            if is_sharp {
                for &k in tris {
                    sharp[k].push(edge);
                }
            }
        }
        for list in &mut sharp {
            list.sort_unstable();
        }
        sharp
    }
}

/// Cuts a triangle by longest-edge bisection until no edge is longer than `max_len`, pushing
/// its pieces (each with the triangle's normal).
fn cut(out: &mut Vec<Piece>, t: [Vector3<f64>; 3], normal: &Vector3<f64>, max_len: f64) {
    let mut stack = vec![t];
    while let Some(t) = stack.pop() {
        let len = |k: usize| (t[(k + 1) % 3] - t[k]).norm();
        let k = (0..3)
            .max_by(|&i, &j| len(i).total_cmp(&len(j)))
            .unwrap_or(0);
        if len(k) <= max_len {
            out.push(Piece {
                centre: (t[0] + t[1] + t[2]) / 3.0,
                normal: *normal,
                area: 0.5 * (t[1] - t[0]).cross(&(t[2] - t[0])).norm(),
                radius: t
                    .iter()
                    .map(|v| (v - (t[0] + t[1] + t[2]) / 3.0).norm())
                    .fold(0.0, f64::max),
                by_edge: false,
            });
            continue;
        }
        let (p, q, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
        let m = (p + q) * 0.5;
        stack.push([p, m, c]);
        stack.push([m, q, c]);
    }
}

/// The Morton code of a cell (21 bits per axis, offset to be non-negative).
fn morton(k: Vector3<i64>) -> u64 {
    let spread = |x: i64| {
        let mut v = (x + (1 << 20)).clamp(0, (1 << 21) - 1) as u64;
        v = (v | (v << 32)) & 0x1f00000000ffff;
        v = (v | (v << 16)) & 0x1f0000ff0000ff;
        v = (v | (v << 8)) & 0x100f00f00f00f00f;
        v = (v | (v << 4)) & 0x10c30c30c30c30c3;
        (v | (v << 2)) & 0x1249249249249249
    };
    spread(k.x) | (spread(k.y) << 1) | (spread(k.z) << 2)
}

//! A cloud's bounding polytope, and the floor it puts under every distance the contact model
//! reads (docs/method.md, "Departure 3").
//!
//! Far from a cloud, ε1's softmax keeps only the nearest point, and that point's plane is
//! infinite: beside the edge of a flat face it passes close to a query that is far from the
//! surface, and reads it touching or inside. The polytope proves where that cannot be so.
//!
//! The polytope is the 26-sided bounding volume of the surface (the supporting planes
//! `u_kᵀy ≤ h_k` for the 26 directions of the cube's faces, edges and corners): of the quad
//! mesh's points and corners, or, for a cloud with a `reach` (`Aopc::reach`: a mesh in patches
//! keeps its vertices there), of its points and reach, whose patches' square faces reach past
//! the surface's edges. The surface
//! lies inside it, so at any point `x` its largest plane value `max_k (u_kᵀx - h_k)` is at
//! most the surface's signed distance: outside, the distance to the polytope is at least
//! that, and the surface is farther still; inside, the depth in the surface is at least the
//! depth in the polytope. [`Floor`] smooths that maximum (log-sum-exp, which stays below it once
//! `T ln 26` is taken off) and lowers it by a margin of one and a half cover radii `r`, the
//! largest distance from a face's point to its corners, which is how far an SSDF plane can
//! honestly read below the true distance. Its temperature is `T = r/80`.
//!
//! Under that margin, wherever a plane is as good as the sampling allows, the floor is at least `r/2 = 40 T`
//! below it, and a distance `φ` is left exactly as it is. Only a reading more than `r/2`
//! below what the polytope proves is raised, smoothly, by the soft maximum
//! `φ' = φ + T s⁺(b - φ)` (the softplus of width `T`, `b` the floor): `φ' ≥ max(φ, b)`.
//!
//! A plane's own reading is held to its own face's floor: margin `1.5 r_k`, with `r_k` the
//! largest distance from that face's point to its corners, at the temperature of the cloud's
//! smallest face, `T_p = min r_k / 80` (no less than `T/64`), so that a plane's reading within
//! `r_k` of the truth is left as it is (every face's, down to `r/64`). A plane
//! honestly reads below the truth by its own face's extent, not by the cloud's largest face's:
//! on a mesh in patches of unequal size (a finger's flat sides in large patches, its rounded
//! parts in small ones), the cloud's largest `r` let a small face's plane read a point beside
//! the finger millimetres inside it (docs/method.md, departure 3, "Each plane's own margin").
//! The separation field's entries, each a softmax over many planes, keep the cloud's floor;
//! every plane's lies above it (`r_k ≤ r`), so what it proves holds for them all.
//!
//! A mesh's cloud in patches has the tight floor ([`FloorKind::Tight`]; a scene's `scm_floor`
//! sets one kind for every cloud): no margin, and the
//! planes' temperature a quarter of the above, so that no plane reads a point nearer than the
//! polytope proves, less `T_p ln 26`; a reading at the polytope's face is then no longer left
//! as it is, but raised by 0.038 of its temperature (`T_p` a plane's, `T` a separation
//! entry's). Robot links a fraction of a millimetre apart read each
//! other millimetres inside round their edges under the margin, and push (docs/mjcf.md,
//! "Contact on, against MuJoCo's spread"); a primitive's cloud keeps the margin, under which its
//! readings at a face are exact.

use crate::scalar::{c, re3, softplus, Scalar};
use nalgebra::Vector3;

/// The 13 directions whose two signs give the polytope's 26 (unit vectors).
const AXES: [[f64; 3]; 13] = {
    const S2: f64 = std::f64::consts::FRAC_1_SQRT_2;
    const S3: f64 = 0.577_350_269_189_625_8;
    [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [S2, S2, 0.0],
        [S2, -S2, 0.0],
        [S2, 0.0, S2],
        [S2, 0.0, -S2],
        [0.0, S2, S2],
        [0.0, S2, -S2],
        [S3, S3, S3],
        [S3, S3, -S3],
        [S3, -S3, S3],
        [S3, -S3, -S3],
    ]
};

/// A reading this many temperatures above the floor is left untouched: the softplus would add
/// less than `e^-40 T`, below the rounding of any distance the model reads.
const UNTOUCHED: f64 = 40.0;

/// The 26-sided bounding polytope of a cloud's quad mesh, with its cover radius.
#[derive(Clone, Debug, PartialEq)]
pub struct Polytope {
    /// `h_k` for `+u_k` (first 13) and `-u_k` (last 13), m.
    support: [f64; 26],
    /// Largest distance from a face's point to its corners (m): the cover radius `r`.
    cover: f64,
    /// Per face, its own cover radius `r_k` (m), in the cloud's order until
    /// [`Polytope::reorder`].
    covers: Vec<f64>,
    /// The planes' floors' temperature `T_p` (m): the smallest face's cover radius over 80,
    /// and no less than the cloud's temperature over 64; a quarter of that under
    /// [`FloorKind::Tight`].
    plane_temperature: f64,
    /// The floor's margin below the polytope, in cover radii: 1.5, or 0 under
    /// [`FloorKind::Tight`].
    margin: f64,
}

/// How far below the polytope's proof a cloud's floor lies: tight for a mesh's cloud in
/// patches, the margin for the others, or a scene's `scm_floor` for all (docs/method.md,
/// departure 3, "A tight floor").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FloorKind {
    /// One and a half cover radii below (each plane's own face's), at `T_p = min r_k/80`: a
    /// reading as good as the sampling allows is left exactly as it is (a cloud's own default;
    /// the scene's for a cloud without a reach).
    #[default]
    Margin,
    /// At the polytope's proof itself, at a quarter of that temperature: no plane reads a point
    /// nearer than the polytope proves, less `T_p ln 26` (robot links a fraction of a millimetre
    /// apart, whose planes read each other millimetres inside round their edges); a plane's
    /// reading at the polytope's own face is raised by `T_p s⁺(-ln 26)` = 0.038 `T_p`, a
    /// separation entry's by 0.038 `T`. The polytope is the sampled surface's: near a curved
    /// shape turned off its 26 directions a plane's floor may stand up to a sagitta above the
    /// exact distance. The scene's default for a cloud with a reach (a mesh in patches).
    Tight,
}

impl Polytope {
    /// The polytope of a quad mesh (`points` its face centres, `vertices`, `faces` and
    /// `reach`, the surface's points no corner marks, as in [`super::Aopc`]), with the floor
    /// `kind`; `None` without faces or with a zero cover radius (a cloud given as bare points:
    /// nothing to bound its planes by). Where a cloud has a `reach` (a mesh in patches), the
    /// points and the reach hold its surface, and the faces' corners are left out: a patch's
    /// face is a square at its reach, whose corners stand past the surface's edges (up to
    /// 6 mm at 1 cm patches, which lowered the floor by up to as much).
    pub fn of(
        points: &[Vector3<f64>],
        vertices: &[Vector3<f64>],
        faces: &[[u32; 4]],
        reach: &[Vector3<f64>],
        kind: FloorKind,
    ) -> Option<Polytope> {
        let mut covers = Vec::with_capacity(faces.len());
        for (p, f) in points.iter().zip(faces) {
            let mut r: f64 = 0.0;
            for &v in f {
                r = r.max((vertices.get(v as usize)? - p).norm());
            }
            covers.push(r);
        }
        let cover = covers.iter().copied().fold(0.0, f64::max);
        if faces.len() != points.len() || cover <= 0.0 || !cover.is_finite() {
            return None;
        }
        let mut support = [f64::NEG_INFINITY; 26];
        let corners = if reach.is_empty() { vertices } else { &[] };
        for y in corners.iter().chain(points).chain(reach) {
            for (k, u) in AXES.iter().enumerate() {
                let d = u[0] * y.x + u[1] * y.y + u[2] * y.z;
                support[k] = support[k].max(d);
                support[13 + k] = support[13 + k].max(-d);
            }
        }
        // Rounded up, so that rounding never puts a vertex outside.
        for h in &mut support {
            *h += 1e-12 * (1.0 + h.abs());
        }
        let smallest = covers.iter().copied().fold(cover, f64::min);
        let (margin, sharper) = match kind {
            FloorKind::Margin => (1.5, 1.0),
            FloorKind::Tight => (0.0, 4.0),
        };
        Some(Polytope {
            support,
            cover,
            covers,
            plane_temperature: smallest.max(cover / 64.0) / 80.0 / sharper,
            margin,
        })
    }

    /// Puts the faces' margins in the order `index` gives (`index[k]` the cloud's face of the
    /// `k`-th plane: a hierarchy's leaf order, in which the planes are read).
    pub fn reorder(&mut self, index: &[u32]) {
        let covers = index
            .iter()
            .map(|&i| self.covers.get(i as usize).copied().unwrap_or(self.cover))
            .collect();
        self.covers = covers;
    }

    /// The cover radius `r` (m).
    pub fn cover(&self) -> f64 {
        self.cover
    }

    /// How far plane `k`'s floor lies at least above the cloud's (m):
    /// `m (r - r_k) + (T - T_p) ln 26` (`m` the margin in cover radii), to add to a lower bound of the cloud's floor
    /// ([`Floor::lower`]) for one of plane `k`'s (a smooth maximum less `T ln 26` takes at most
    /// that off the largest plane value).
    #[inline]
    pub fn lift_of(&self, k: usize) -> f64 {
        self.margin * (self.cover - self.cover_of(k))
            + (self.temperature() - self.plane_temperature) * 26f64.ln()
    }

    /// Plane `k`'s own cover radius `r_k` (m; the cloud's for a plane it does not know).
    #[inline]
    fn cover_of(&self, k: usize) -> f64 {
        self.covers.get(k).copied().unwrap_or(self.cover)
    }

    /// The floor at `x` (the polytope's frame), evaluated lazily: most readings are far above
    /// it and never need more than its cheap upper bound.
    pub fn floor<T: Scalar>(&self, x: &Vector3<T>) -> Floor<'_, T> {
        Floor {
            polytope: self,
            x: *x,
            upper: self.upper(&re3(x)),
            smooth: None,
            planes: None,
        }
    }

    /// A lower bound of the floor `b` over a ball (centre `c`, radius `rho`; the polytope's
    /// frame): each plane value falls by at most `rho` within it.
    pub fn floor_over_ball(&self, c: &Vector3<f64>, rho: f64) -> f64 {
        self.lower(self.upper(c)) - rho * (1.0 + 1e-12)
    }

    /// The 13 dot products `u_kᵀx`, each `u_k[0] x + u_k[1] y + u_k[2] z` summed in that order,
    /// with the zero components' products left out and the products shared between the
    /// directions: the same value at every finite `x` (a zero product adds nothing but, at
    /// most, a zero's sign), in 16 operations instead of 65.
    #[inline]
    fn dots(x: &Vector3<f64>) -> [f64; 13] {
        let [s2, s3] = [AXES[3][0], AXES[9][0]];
        let (ax, ay, az) = (s2 * x.x, s2 * x.y, s2 * x.z);
        let (bx, by, bz) = (s3 * x.x, s3 * x.y, s3 * x.z);
        let (plus, minus) = (bx + by, bx - by);
        [
            x.x,
            x.y,
            x.z,
            ax + ay,
            ax - ay,
            ax + az,
            ax - az,
            ay + az,
            ay - az,
            plus + bz,
            plus - bz,
            minus + bz,
            minus - bz,
        ]
    }

    /// The 26 plane values `u_kᵀx - h_k` at `x` (`+u_k` first, then `-u_k`).
    fn plane_values(&self, x: &Vector3<f64>) -> [f64; 26] {
        let mut values = [0.0; 26];
        for (k, d) in Self::dots(x).into_iter().enumerate() {
            values[k] = d - self.support[k];
            values[13 + k] = -d - self.support[13 + k];
        }
        values
    }

    /// An upper bound of `b` at `x`: the largest plane value less the margin. Every band point
    /// and point force takes it, so the values are not stored: four running maxima by
    /// comparison as they are made (not one `f64::max` chain), which is the same value in any
    /// order (a NaN is never taken, as `f64::max` leaves it). With [`Polytope::dots`],
    /// `box_stack`'s step in contact took 7 % fewer instructions (docs/performance.md).
    fn upper(&self, x: &Vector3<f64>) -> f64 {
        let keep = |m: &mut f64, v: f64| {
            if v > *m {
                *m = v;
            }
        };
        let (d, h) = (Self::dots(x), &self.support);
        let mut m = [f64::NEG_INFINITY; 4];
        // Four scalars, so that they stay in registers (an index computed per direction kept
        // them in memory: 14 % more instructions here).
        let [m0, m1, m2, m3] = &mut m;
        for k in (0..12).step_by(2) {
            keep(m0, d[k] - h[k]);
            keep(m1, -d[k] - h[13 + k]);
            keep(m2, d[k + 1] - h[k + 1]);
            keep(m3, -d[k + 1] - h[14 + k]);
        }
        keep(m0, d[12] - h[12]);
        keep(m1, -d[12] - h[25]);
        let top = if m[0] > m[1] { m[0] } else { m[1] };
        let other = if m[2] > m[3] { m[2] } else { m[3] };
        (if top > other { top } else { other }) - self.margin * self.cover
    }

    /// A lower bound of the floor `b` at `x` from the six axis planes alone (`±u_k` for the
    /// three axes, a box's own faces): their largest value is at most the largest of all 26,
    /// so this is at most [`Floor::lower`], for about a sixth of its cost. A band walk proves
    /// points above the cutoff by it first and makes the full floor only for the rest
    /// (`box_stack` in contact: 42 % of the points that reached the floor, 2.8 % of the step's
    /// instructions; `t_push`, whose far points the kept candidates settle first, 0.8 % more).
    pub fn floor_by_axes(&self, x: &Vector3<f64>) -> f64 {
        let h = &self.support;
        let values = [
            x.x - h[0],
            x.y - h[1],
            x.z - h[2],
            -x.x - h[13],
            -x.y - h[14],
            -x.z - h[15],
        ];
        let top = values
            .into_iter()
            .fold(f64::NEG_INFINITY, |m, v| if v > m { v } else { m });
        self.lower(top - self.margin * self.cover)
    }

    /// A lower bound of `b` from its upper bound `upper`: the smoothing takes at most `T ln 26`
    /// off the maximum (and a little more for rounding).
    fn lower(&self, upper: f64) -> f64 {
        upper - self.temperature() * 26f64.ln() - 1e-12 * (1.0 + upper.abs())
    }

    /// The temperature `T = r/80` (m).
    fn temperature(&self) -> f64 {
        self.cover / 80.0
    }
}

/// The floor `b(x)` of one query point: `b = T ln(Σ_k exp((u_kᵀx - h_k)/T)) - T ln 26 - m r`,
/// at most the surface's signed distance at `x` less `m r` (`m` the margin in cover radii, 1.5
/// or 0: [`FloorKind`]).
#[derive(Clone, Debug)]
pub struct Floor<'p, T: Scalar> {
    polytope: &'p Polytope,
    x: Vector3<T>,
    /// An upper bound of `b` (real part): the plane maximum less the margin.
    upper: f64,
    /// `b` and its gradient (real part), once needed.
    smooth: Option<(T, Vector3<f64>)>,
    /// The planes' floors less their margins, `b_k + m r_k`, and their gradient (real
    /// part), once needed.
    planes: Option<(T, Vector3<f64>)>,
}

impl<T: Scalar> Floor<'_, T> {
    /// A lower bound of `b` (real part): the smoothing takes at most `T ln 26` off the maximum
    /// (and a little more for rounding). Every plane's own floor lies above it too.
    pub fn lower(&self) -> f64 {
        self.polytope.lower(self.upper)
    }

    /// Whether a reading `phi` (real part) is left exactly as it is.
    #[inline]
    pub fn leaves(&self, phi: f64) -> bool {
        phi >= self.upper + UNTOUCHED * self.polytope.temperature()
    }

    /// Whether plane `k`'s reading `phi` (real part) is left exactly as it is by its own floor
    /// ([`Floor::raise_plane`]).
    #[inline]
    pub fn leaves_plane(&self, phi: f64, k: usize) -> bool {
        let p = self.polytope;
        phi >= self.upper + p.margin * (p.cover - p.cover_of(k)) + UNTOUCHED * p.plane_temperature
    }

    /// `b` and its gradient with respect to `x` (real part).
    pub fn value(&mut self) -> (T, Vector3<f64>) {
        if let Some(v) = self.smooth {
            return v;
        }
        let p = self.polytope;
        let v = self.smooth_max(p.temperature(), p.margin * p.cover);
        self.smooth = Some(v);
        v
    }

    /// The polytope's smooth maximum at temperature `t` less `m`,
    /// `t ln(Σ_k exp((u_kᵀx - h_k)/t)) - t ln 26 - m`, and its gradient (real part). The
    /// planes more than `40 t` below the largest are left out of the sum (each would add less
    /// than `e^-40` to a sum of at least 1, and their `exp` would mostly underflow, slowly).
    fn smooth_max(&self, t: f64, m: f64) -> (T, Vector3<f64>) {
        let p = self.polytope;
        let top = self.upper + p.margin * p.cover;
        let mut sum = T::zero();
        let mut grad = Vector3::zeros();
        // The plane values again: few readings need the smooth floor, and the upper bound
        // every reading takes does not keep them.
        let values = p.plane_values(&re3(&self.x));
        for (k, value) in values.iter().enumerate() {
            if *value < top - UNTOUCHED * t {
                continue;
            }
            let (axis, sign) = if k < 13 { (k, 1.0) } else { (k - 13, -1.0) };
            let u = Vector3::new(AXES[axis][0], AXES[axis][1], AXES[axis][2]) * sign;
            let d: T = self.x.x * c::<T>(u.x) + self.x.y * c::<T>(u.y) + self.x.z * c::<T>(u.z);
            let w: T = ((d - c::<T>(p.support[k] + top)) / c::<T>(t)).exp();
            sum += w;
            grad += u * w.re();
        }
        let b: T = c::<T>(top) + sum.ln() * c::<T>(t) - c::<T>(t * 26f64.ln() + m);
        (b, grad / sum.re())
    }

    /// Plane `k`'s floor `b_k` and its gradient (real part).
    fn plane_floor(&mut self, k: usize) -> (T, Vector3<f64>) {
        let (b, grad) = match self.planes {
            Some(v) => v,
            None => {
                let v = self.smooth_max(self.polytope.plane_temperature, 0.0);
                self.planes = Some(v);
                v
            }
        };
        let p = self.polytope;
        (b - c::<T>(p.margin * p.cover_of(k)), grad)
    }

    /// The reading `phi` raised to the floor, `φ' = φ + T s⁺(b - φ)`, and `∂φ'/∂b` (real
    /// part; 0 where `phi` is left as it is, and then `φ'` is `phi` bit for bit).
    #[inline]
    pub fn raise(&mut self, phi: T) -> (T, f64) {
        if self.leaves(phi.re()) {
            return (phi, 0.0);
        }
        let (b, _) = self.value();
        raised(phi, b, self.polytope.temperature())
    }

    /// Plane `k`'s reading `phi` raised to its own floor `b_k`: the polytope's smooth maximum
    /// at the planes' temperature `T_p` less `m r_k` (module documentation),
    /// `φ' = φ + T_p s⁺(b_k - φ)`, with `∂φ'/∂b_k` and `∇b_k` (real parts; `0` and no gradient
    /// where `phi` is left as it is, bit for bit).
    #[inline]
    pub fn raise_plane(&mut self, phi: T, k: usize) -> (T, f64, Vector3<f64>) {
        if self.leaves_plane(phi.re(), k) {
            return (phi, 0.0, Vector3::zeros());
        }
        let (b, grad) = self.plane_floor(k);
        let (raised, s) = raised(phi, b, self.polytope.plane_temperature);
        (raised, s, grad)
    }

    /// The gradient of `b` with respect to `x` (real part).
    pub fn gradient(&mut self) -> Vector3<f64> {
        self.value().1
    }
}

/// `φ' = φ + t s⁺(b - φ)` and `∂φ'/∂b`, the logistic of `(b - φ)/t` (real part).
#[inline]
fn raised<T: Scalar>(phi: T, b: T, t: f64) -> (T, f64) {
    let t = c::<T>(t);
    let z = (b - phi) / t;
    let s = 1.0 / (1.0 + (-z.re()).exp());
    (phi + softplus(b - phi, t), s)
}

#[cfg(test)]
#[path = "polytope_tests.rs"]
mod tests;

//! A cloud's bounding polytope, and the floor it puts under every distance the contact model
//! reads (docs/method.md, "Departure 3").
//!
//! Far from a cloud, ε1's softmax keeps only the nearest point, and that point's plane is
//! infinite: beside the edge of a flat face it passes close to a query that is far from the
//! surface, and reads it touching or inside. The polytope proves where that cannot be so.
//!
//! The polytope is the 26-sided bounding volume of the quad mesh and of the surface points no
//! corner marks (a mesh in patches keeps its vertices there: `Aopc::reach`) (the supporting planes
//! `u_kᵀy ≤ h_k` for the 26 directions of the cube's faces, edges and corners). The surface
//! lies inside it, so at any point `x` its largest plane value `max_k (u_kᵀx - h_k)` is at
//! most the surface's signed distance: outside, the distance to the polytope is at least
//! that, and the surface is farther still; inside, the depth in the surface is at least the
//! depth in the polytope. [`Floor`] smooths that maximum (log-sum-exp, which stays below it once
//! `T ln 26` is taken off) and lowers it by a margin of one and a half cover radii `r`, the
//! largest distance from a face's point to its corners, which is how far an SSDF plane can
//! honestly read below the true distance. Its temperature is `T = r/80`.
//!
//! Wherever a plane is as good as the sampling allows, the floor is at least `r/2 = 40 T`
//! below it, and a distance `φ` is left exactly as it is. Only a reading more than `r/2`
//! below what the polytope proves is raised, smoothly, by the soft maximum
//! `φ' = φ + T s⁺(b - φ)` (the softplus of width `T`, `b` the floor): `φ' ≥ max(φ, b)`.

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
}

impl Polytope {
    /// The polytope of a quad mesh (`points` its face centres, `vertices`, `faces` and
    /// `reach`, the surface's points no corner marks, as in [`super::Aopc`]); `None` without
    /// faces or with a zero cover radius (a cloud given as bare points: nothing to bound its
    /// planes by).
    pub fn of(
        points: &[Vector3<f64>],
        vertices: &[Vector3<f64>],
        faces: &[[u32; 4]],
        reach: &[Vector3<f64>],
    ) -> Option<Polytope> {
        let mut cover: f64 = 0.0;
        for (p, f) in points.iter().zip(faces) {
            for &v in f {
                cover = cover.max((vertices.get(v as usize)? - p).norm());
            }
        }
        if faces.len() != points.len() || cover <= 0.0 || !cover.is_finite() {
            return None;
        }
        let mut support = [f64::NEG_INFINITY; 26];
        for y in vertices.iter().chain(points).chain(reach) {
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
        Some(Polytope { support, cover })
    }

    /// The cover radius `r` (m).
    pub fn cover(&self) -> f64 {
        self.cover
    }

    /// The floor at `x` (the polytope's frame), evaluated lazily: most readings are far above
    /// it and never need more than its cheap upper bound.
    pub fn floor<T: Scalar>(&self, x: &Vector3<T>) -> Floor<'_, T> {
        let values = self.plane_values(&re3(x));
        Floor {
            polytope: self,
            x: *x,
            values,
            upper: self.upper(&values),
            smooth: None,
        }
    }

    /// A lower bound of the floor `b` over a ball (centre `c`, radius `rho`; the polytope's
    /// frame): each plane value falls by at most `rho` within it.
    pub fn floor_over_ball(&self, c: &Vector3<f64>, rho: f64) -> f64 {
        self.lower(self.upper(&self.plane_values(c))) - rho * (1.0 + 1e-12)
    }

    /// The 26 plane values `u_kᵀx - h_k` at `x` (`+u_k` first, then `-u_k`).
    fn plane_values(&self, x: &Vector3<f64>) -> [f64; 26] {
        let mut values = [0.0; 26];
        for (k, u) in AXES.iter().enumerate() {
            let d = u[0] * x.x + u[1] * x.y + u[2] * x.z;
            values[k] = d - self.support[k];
            values[13 + k] = -d - self.support[13 + k];
        }
        values
    }

    /// An upper bound of `b` from its plane values: their maximum less the margin. Four
    /// running maxima by comparison, not one `f64::max` chain: every band point and point force
    /// takes it (a tenth of a pushing pair's evaluation was this fold), and the maximum is the
    /// same value in any order (a NaN is never taken, as `f64::max` leaves it).
    fn upper(&self, values: &[f64; 26]) -> f64 {
        let mut m = [f64::NEG_INFINITY; 4];
        for chunk in values.chunks(4) {
            for (m, &v) in m.iter_mut().zip(chunk) {
                if v > *m {
                    *m = v;
                }
            }
        }
        let top = if m[0] > m[1] { m[0] } else { m[1] };
        let other = if m[2] > m[3] { m[2] } else { m[3] };
        (if top > other { top } else { other }) - 1.5 * self.cover
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

/// The floor `b(x)` of one query point: `b = T ln(Σ_k exp((u_kᵀx - h_k)/T)) - T ln 26 - 1.5 r`,
/// at most the surface's signed distance at `x` less `1.5 r`.
#[derive(Clone, Debug)]
pub struct Floor<'p, T: Scalar> {
    polytope: &'p Polytope,
    x: Vector3<T>,
    /// The 26 plane values `u_kᵀx - h_k` (real parts; `+u_k` first, then `-u_k`).
    values: [f64; 26],
    /// An upper bound of `b` (real part): the plane maximum less the margin.
    upper: f64,
    /// `b` and its gradient (real part), once needed.
    smooth: Option<(T, Vector3<f64>)>,
}

impl<T: Scalar> Floor<'_, T> {
    /// A lower bound of `b` (real part): the smoothing takes at most `T ln 26` off the maximum
    /// (and a little more for rounding).
    pub fn lower(&self) -> f64 {
        self.polytope.lower(self.upper)
    }

    /// Whether a reading `phi` (real part) is left exactly as it is.
    #[inline]
    pub fn leaves(&self, phi: f64) -> bool {
        phi >= self.upper + UNTOUCHED * self.polytope.temperature()
    }

    /// `b` and its gradient with respect to `x` (real part). The planes more than `40 T` below
    /// the largest are left out of the sum (each would add less than `e^-40` to a sum of at
    /// least 1, and their `exp` would mostly underflow, slowly).
    pub fn value(&mut self) -> (T, Vector3<f64>) {
        if let Some(v) = self.smooth {
            return v;
        }
        let p = self.polytope;
        let t = p.temperature();
        let top = self.upper + 1.5 * p.cover;
        let mut sum = T::zero();
        let mut grad = Vector3::zeros();
        for (k, value) in self.values.iter().enumerate() {
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
        let b: T = c::<T>(top) + sum.ln() * c::<T>(t) - c::<T>(t * 26f64.ln() + 1.5 * p.cover);
        let v = (b, grad / sum.re());
        self.smooth = Some(v);
        v
    }

    /// The reading `phi` raised to the floor, `φ' = φ + T s⁺(b - φ)`, and `∂φ'/∂b` (real
    /// part; 0 where `phi` is left as it is, and then `φ'` is `phi` bit for bit).
    #[inline]
    pub fn raise(&mut self, phi: T) -> (T, f64) {
        if self.leaves(phi.re()) {
            return (phi, 0.0);
        }
        let t = c::<T>(self.polytope.temperature());
        let (b, _) = self.value();
        let z = (b - phi) / t;
        let s = 1.0 / (1.0 + (-z.re()).exp());
        (phi + softplus(b - phi, t), s)
    }

    /// The gradient of `b` with respect to `x` (real part).
    pub fn gradient(&mut self) -> Vector3<f64> {
        self.value().1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;
    use num_dual::Dual64;

    fn boxed() -> crate::geometry::Aopc {
        Shape::Box {
            half: Vector3::new(0.05, 0.03, 0.02),
        }
        .sample(0.01)
    }

    /// The exact signed distance of the box above.
    fn box_sdf(x: &Vector3<f64>) -> f64 {
        let q = x.abs() - Vector3::new(0.05, 0.03, 0.02);
        q.map(|v| v.max(0.0)).norm() + q.max().min(0.0)
    }

    #[test]
    fn the_floor_lies_below_the_surface_everywhere_and_margin_below_near_it() {
        let s = boxed();
        let p = Polytope::of(&s.points, &s.vertices, &s.faces, &s.reach).expect("a quad mesh");
        assert!(
            p.cover() > 0.004 && p.cover() < 0.0075,
            "cover {}",
            p.cover()
        );
        let mut state = 7u64;
        for _ in 0..2000 {
            let x = Vector3::new(
                0.2 * crate::geometry::lcg(&mut state),
                0.2 * crate::geometry::lcg(&mut state),
                0.2 * crate::geometry::lcg(&mut state),
            );
            let mut f = p.floor(&x);
            let (b, _) = f.value();
            let sdf = box_sdf(&x);
            assert!(
                b <= sdf - 1.5 * p.cover() + 1e-12,
                "{x:?}: floor {b} sdf {sdf}"
            );
            assert!(
                f.lower() <= b + 1e-15 && b <= f.upper + 1e-15,
                "bounds of b"
            );
        }
    }

    #[test]
    fn a_reading_near_the_truth_is_left_bit_for_bit_and_one_far_below_is_raised() {
        let s = boxed();
        let p = Polytope::of(&s.points, &s.vertices, &s.faces, &s.reach).unwrap();
        // Beside the top face's edge, 4 cm out in its plane: the top plane reads 0.
        let x = Vector3::new(0.09, 0.0, 0.02);
        let mut f = p.floor(&x);
        let (b, _) = f.value();
        assert!(b > 0.02, "the polytope proves 4 cm less the margin: {b}");
        let (raised, s) = f.raise(0.0);
        assert!(raised >= b && raised < b + 1e-6 && s > 0.99);
        // The true distance, or anything within half a cover radius below it, is untouched.
        for phi in [0.04, 0.04 - 0.5 * p.cover()] {
            assert_eq!(f.raise(phi), (phi, 0.0));
        }
    }

    #[test]
    fn the_raised_reading_and_floor_match_central_differences() {
        let s = boxed();
        let p = Polytope::of(&s.points, &s.vertices, &s.faces, &s.reach).unwrap();
        let x0 = Vector3::new(0.061, 0.033, 0.018);
        let h = 1e-7;
        for dir in 0..3 {
            let at = |e: f64| {
                let mut x = x0.map(Dual64::from);
                x[dir] += Dual64::new(e, 1.0);
                let mut f = p.floor(&x);
                // A reading that depends on x too, near the floor (the soft part).
                let phi = x[0] - Dual64::from(0.06);
                let (b, g) = f.value();
                let (r, _) = f.raise(phi);
                (b, g[dir], r)
            };
            let (b, g, r) = at(0.0);
            let fd_b = (at(h).0.re - at(-h).0.re) / (2.0 * h);
            let fd_r = (at(h).2.re - at(-h).2.re) / (2.0 * h);
            assert!((b.eps - fd_b).abs() < 1e-6, "db: {} vs {fd_b}", b.eps);
            assert!((g - fd_b).abs() < 1e-6, "gradient: {g} vs {fd_b}");
            assert!((r.eps - fd_r).abs() < 1e-6, "dφ': {} vs {fd_r}", r.eps);
        }
    }
}

//! MuJoCo's ellipsoid fluid model (`fluidshape="ellipsoid"`): each such geom is taken as the
//! ellipsoid of its semi-axes `s` and feels, in its own frame at its centre, with `v`, `ω` its
//! velocity and angular velocity relative to the still medium there (docs/mjcf.md, the
//! `<option density viscosity>` row):
//!
//! - the forces of the fluid it carries along (added mass, velocity terms only, as MuJoCo's:
//!   its acceleration term is left out there): with the momenta `p = ρ m_v ∘ v` and
//!   `L = ρ I_v ∘ ω`, the force `p × ω` and the torque `p × v + L × ω`;
//! - Magnus lift `c_M ρ V (ω × v)`; Kutta–Joukowski lift `(c_K ρ cos α A_p (n × v)) × v`, `n`
//!   the normal of the cross-section the ellipsoid shows along `v` (not unit), `A_p` its area;
//! - drag, linear (Stokes, of the sphere of mean diameter `D = 2(s₀+s₁+s₂)/3`) plus quadratic:
//!   the force `-(3πβD + ρ|v|(c_B A_p + c_S (A_max - A_p))) v`, the torque
//!   `-(πβD³ + ρ|m|) ω` with `m_i = ω_i (c_A I_i + c_S (I_max - I_i))`;
//!
//! `c_B, c_S, c_A, c_K, c_M` the geom's `fluidcoef` (blunt and slender drag, angular drag,
//! Kutta and Magnus lift; MuJoCo's default `0.5 0.25 1.5 1 1`), and the virtual mass `m_v` and
//! inertia `I_v` of the ellipsoid in a potential flow, from the integrals `κ` below. The
//! quadratic terms are C¹ in the velocity and vanish with their first derivatives at rest.

use crate::collision::Frame;
use crate::contact::Wrench;
use crate::scalar::{c, Scalar};
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::PI;

/// MuJoCo's `mjMINVAL`, the floor of the denominators of the cross-section's area and angle.
const MIN_VALUE: f64 = 1e-15;
/// MuJoCo's `mjEPS`, the floor of the virtual mass and inertia's denominators.
const EPS: f64 = 1e-14;

/// A geom of MuJoCo's ellipsoid fluid model.
#[derive(Clone, Debug, PartialEq)]
pub struct EllipsoidGeom {
    /// Its body.
    pub body: usize,
    /// Its centre, body coordinates (m).
    pub pos: Vector3<f64>,
    /// Its axes, as columns, in body coordinates.
    pub rot: Matrix3<f64>,
    /// Semi-axes of its ellipsoid (m): MuJoCo's for its type (a sphere's radius thrice; a
    /// capsule's radius, radius, half-length plus radius; a cylinder's radius, radius,
    /// half-length; a box's and an ellipsoid's sizes).
    pub semiaxes: Vector3<f64>,
    /// `fluidcoef`: blunt drag, slender drag, angular drag, Kutta lift, Magnus lift.
    pub coefs: [f64; 5],
    /// Virtual mass per unit density along each axis (m³).
    pub virtual_mass: Vector3<f64>,
    /// Virtual moment of inertia per unit density about each axis (m⁵).
    pub virtual_inertia: Vector3<f64>,
}

/// `x`, or `lo` where `x`'s real part is below it (MuJoCo's `max(mjMINVAL, x)`).
fn floor<T: Scalar>(x: T, lo: f64) -> T {
    if x.re() < lo {
        c(lo)
    } else {
        x
    }
}

/// Carlson's symmetric elliptic integral `R_D(x, y, z) = 3/2 ∫₀^∞ dt / ((t+x)(t+y))^½ (t+z)^{3/2}`
/// by its duplication theorem, to rounding. Written here (no elliptic-integral crate among the
/// dependencies): MuJoCo's compiler takes the same integrals by a 15-point quadrature, which
/// agrees to 1e-8 on round shapes and to 2e-6 on a 20:1 flat one.
fn carlson_rd(mut x: f64, mut y: f64, mut z: f64) -> f64 {
    let (mut sum, mut factor) = (0.0, 1.0);
    loop {
        let mu = (x + y + 3.0 * z) / 5.0;
        let (dx, dy, dz) = ((mu - x) / mu, (mu - y) / mu, (mu - z) / mu);
        if dx.abs().max(dy.abs()).max(dz.abs()) < 1e-4 {
            // The series in the small deviations, to fifth order (error below 1e-20).
            let ea = dx * dy;
            let eb = dz * dz;
            let ec = ea - eb;
            let ed = ea - 6.0 * eb;
            let ee = ed + ec + ec;
            let series = 1.0
                + ed * (-3.0 / 14.0 + 9.0 / 88.0 * ed - 4.5 / 26.0 * dz * ee)
                + dz * (ee / 6.0 + dz * (-9.0 / 22.0 * ec + 3.0 / 26.0 * dz * ea));
            return 3.0 * sum + factor * series / (mu * mu.sqrt());
        }
        let (sx, sy, sz) = (x.sqrt(), y.sqrt(), z.sqrt());
        let lambda = sx * (sy + sz) + sy * sz;
        sum += factor / (sz * (z + lambda));
        factor *= 0.25;
        x = 0.25 * (x + lambda);
        y = 0.25 * (y + lambda);
        z = 0.25 * (z + lambda);
    }
}

/// `κ` of the axis of semi-axis `a` (the others `b`, `c`): `a b c ∫₀^∞ dl / ((a²+l)^{3/2}
/// (b²+l)^{1/2} (c²+l)^{1/2})`, the potential-flow coefficient behind the virtual mass along
/// that axis (2/3 for a sphere).
fn kappa(a: f64, b: f64, c: f64) -> f64 {
    a * b * c * 2.0 / 3.0 * carlson_rd(b * b, c * c, a * a)
}

impl EllipsoidGeom {
    /// The geom of body `body` centred at `pos` with axes `rot` (body coordinates), of
    /// semi-axes `semiaxes` and `fluidcoef` `coefs`, with its virtual mass and inertia as
    /// MuJoCo's compiler computes them: `m_v,i = V κ_i / (2 - κ_i)` and
    /// `I_v,x = V (b² - c²)² |κ_z - κ_y| / (5 |2(b² - c²) + (b² + c²)(κ_y - κ_z)|)` (and in turn),
    /// `V` the ellipsoid's volume.
    pub fn new(
        body: usize,
        pos: Vector3<f64>,
        rot: Matrix3<f64>,
        semiaxes: Vector3<f64>,
        coefs: [f64; 5],
    ) -> EllipsoidGeom {
        let s = semiaxes;
        let volume = 4.0 / 3.0 * PI * s.x * s.y * s.z;
        let k = Vector3::new(
            kappa(s.x, s.y, s.z),
            kappa(s.y, s.z, s.x),
            kappa(s.z, s.x, s.y),
        );
        let virtual_mass = k.map(|ki| volume * ki / (2.0 - ki).max(EPS));
        let factor = |i: usize| {
            let (j, l) = ((i + 1) % 3, (i + 2) % 3);
            let (bj, bl) = (s[j] * s[j], s[l] * s[l]);
            let num = (bj - bl).powi(2) * (k[l] - k[j]).abs();
            let den = (2.0 * (bj - bl) + (bj + bl) * (k[j] - k[l])).abs().max(EPS);
            volume * num / den / 5.0
        };
        EllipsoidGeom {
            body,
            pos,
            rot,
            semiaxes,
            coefs,
            virtual_mass,
            virtual_inertia: Vector3::new(factor(0), factor(1), factor(2)),
        }
    }

    /// The force and torque on the geom in its own frame (module documentation), for velocity
    /// `v` and angular velocity `w` in that frame, in a medium of density `rho` and viscosity
    /// `beta`.
    fn local_wrench<T: Scalar>(
        &self,
        rho: f64,
        beta: f64,
        v: &Vector3<T>,
        w: &Vector3<T>,
    ) -> (Vector3<T>, Vector3<T>) {
        let s = &self.semiaxes;
        let [blunt, slender, angular, kutta, magnus] = self.coefs;
        // Added mass: the momentum of the fluid carried along.
        let p = v.component_mul(&self.virtual_mass.map(|m| c::<T>(rho * m)));
        let l = w.component_mul(&self.virtual_inertia.map(|i| c::<T>(rho * i)));
        let mut force = p.cross(w);
        let mut torque = p.cross(v) + l.cross(w);
        let volume = 4.0 / 3.0 * PI * s.x * s.y * s.z;
        force += w.cross(v) * c::<T>(magnus * rho * volume);
        // Stokes drag of the sphere of mean diameter.
        let d = 2.0 / 3.0 * (s.x + s.y + s.z);
        force -= v * c::<T>(beta * 3.0 * PI * d);
        torque -= w * c::<T>(beta * PI * d * d * d);
        // Quadratic terms: zero with their first derivatives at rest, where |v| has none.
        if v.iter().any(|x| x.re() != 0.0) {
            let (d_max, d_min) = (s.max(), s.min());
            let d_mid = s.x + s.y + s.z - d_max - d_min;
            let a_max = PI * d_max * d_mid;
            // The cross-section along v: its (not unit) normal n and its area.
            let q = Vector3::new(s.y * s.z, s.z * s.x, s.x * s.y);
            let n = v.component_mul(&q.map(|x| c::<T>(x * x)));
            let num = v.component_mul(&q.map(c::<T>)).map(|x| x * x).sum();
            let den = v
                .component_mul(&q.map(|x| c::<T>(x * x)))
                .map(|x| x * x)
                .sum();
            let speed = v.norm();
            let area = (den / floor(num, MIN_VALUE)).sqrt() * PI;
            let cos_alpha = num / floor(speed * den, MIN_VALUE);
            let circulation = n.cross(v) * (cos_alpha * area * (kutta * rho));
            force += circulation.cross(v);
            let drag = speed * rho * (area * blunt + (c::<T>(a_max) - area) * slender);
            force -= v * drag;
        }
        if w.iter().any(|x| x.re() != 0.0) {
            let (d_max, d_min) = (s.max(), s.min());
            let d_mid = s.x + s.y + s.z - d_max - d_min;
            let i_max = 8.0 / 15.0 * PI * d_mid * d_max.powi(4);
            let moment = |i: usize| {
                let (j, l) = ((i + 1) % 3, (i + 2) % 3);
                let ii = 8.0 / 15.0 * PI * s[i] * s[j].max(s[l]).powi(4);
                angular * ii + slender * (i_max - ii)
            };
            let m = Vector3::new(w.x * moment(0), w.y * moment(1), w.z * moment(2));
            torque -= w * (m.norm() * rho);
        }
        (force, torque)
    }

    /// Adds the geom's fluid wrench to its body's in `out` (world frame, torque about the body
    /// origin); `frames`: the bodies' poses and velocities.
    pub fn add_wrench<T: Scalar>(
        &self,
        rho: f64,
        beta: f64,
        frames: &[Frame<T>],
        out: &mut [Wrench<T>],
    ) {
        let f = &frames[self.body];
        let axes = f.rotation * self.rot.map(c::<T>);
        let arm = f.rotation * self.pos.map(c::<T>);
        let v = axes.transpose() * (f.linvel + f.angvel.cross(&arm));
        let w = axes.transpose() * f.angvel;
        let (force, torque) = self.local_wrench(rho, beta, &v, &w);
        let (force, torque) = (axes * force, axes * torque);
        out[self.body].torque += torque + arm.cross(&force);
        out[self.body].force += force;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spheres_virtual_mass_is_half_its_volume_and_kappa_sums_to_two() {
        // A sphere carries half its volume of fluid (κ = 2/3 on every axis); for any
        // ellipsoid the three κ add up to 2 (the potential-flow identity).
        let g = EllipsoidGeom::new(
            0,
            Vector3::zeros(),
            Matrix3::identity(),
            Vector3::repeat(0.3),
            [0.0; 5],
        );
        let volume = 4.0 / 3.0 * PI * 0.027;
        assert!((g.virtual_mass - Vector3::repeat(0.5 * volume)).amax() < 1e-14 * volume);
        for (a, b, c) in [(0.3, 0.1, 0.02), (1.0, 2.0, 3.0), (0.05, 0.05, 0.4)] {
            let sum = kappa(a, b, c) + kappa(b, c, a) + kappa(c, a, b);
            assert!((sum - 2.0).abs() < 1e-13, "{sum}");
        }
    }

    #[test]
    fn the_wrench_is_c1_at_rest_and_its_dual_derivative_is_the_central_difference() {
        use num_dual::Dual64;
        let g = EllipsoidGeom::new(
            0,
            Vector3::zeros(),
            Matrix3::identity(),
            Vector3::new(0.2, 0.05, 0.01),
            [0.5, 0.25, 1.5, 1.0, 1.0],
        );
        let x0 = [0.7, -0.3, 1.1, 2.0, -1.5, 0.4];
        let eval = |x: &[f64; 6]| {
            let (f, t) = g.local_wrench(
                1.2,
                1.8e-5,
                &Vector3::new(x[0], x[1], x[2]),
                &Vector3::new(x[3], x[4], x[5]),
            );
            [f.x, f.y, f.z, t.x, t.y, t.z]
        };
        for k in 0..6 {
            let mut xd = x0.map(Dual64::from);
            xd[k].eps = 1.0;
            let (f, t) = g.local_wrench(
                1.2,
                1.8e-5,
                &Vector3::new(xd[0], xd[1], xd[2]),
                &Vector3::new(xd[3], xd[4], xd[5]),
            );
            let dual = [f.x, f.y, f.z, t.x, t.y, t.z].map(|d| d.eps);
            let h = 1e-6;
            let (mut up, mut down) = (x0, x0);
            up[k] += h;
            down[k] -= h;
            let (a, b) = (eval(&up), eval(&down));
            for i in 0..6 {
                let fd = (a[i] - b[i]) / (2.0 * h);
                assert!(
                    (dual[i] - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                    "d{i}/dx{k}: {} vs {fd}",
                    dual[i]
                );
            }
        }
        // At rest the wrench and its first derivative vanish but for the linear terms.
        let zero = [0.0; 6];
        let tiny = [1e-9, 0.0, 0.0, 0.0, 0.0, 0.0];
        let (a, b) = (eval(&zero), eval(&tiny));
        let linear = 1.8e-5 * 3.0 * PI * 2.0 / 3.0 * 0.26 * 1e-9;
        assert!(a.iter().all(|&x| x == 0.0));
        assert!(
            (b[0] + linear).abs() < 1e-6 * linear,
            "{} vs {}",
            b[0],
            -linear
        );
    }
}

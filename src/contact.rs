//! The soft-minimum contact model (paper, Methods B; SPEC §2): the point–plane force, and its
//! soft-minimum averages over an SSDF (point–SSDF) and over a separation distribution
//! (SSDF–SSDF), giving the wrench each body of a pair receives.
//!
//! Naming follows `quantity_shape1_shape2`: [`point_plane_force`] is the force between a point
//! and a plane, [`pair_contact`] the contact between two colliders.

use crate::collision::{separation_band, separation_field_naive, Collider, Frame, Relative, SeparationDistribution};
use crate::geometry::ssdf::visit_relevant;
use crate::scalar::{c, lift3, re3, smooth_norm, softplus, Scalar, SoftminSum};
use nalgebra::Vector3;

/// The dissipation factor `d(s)` of the point–plane force, `s = v_n / v_d`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Dissipation {
    /// The paper's (and IDTO's) piecewise `d`: `1 - s` for `s ≤ 0`, `(s - 2)²/4` on `(0, 2]`,
    /// `0` after. Only C¹: its second derivative jumps at `s = 0` and `s = 2`.
    #[default]
    Paper,
    /// C² variant: the same values and slopes at both ends, joined by
    /// `1 - s + s³/4 - s⁴/16` on `[0, 2]`, whose second derivative vanishes at both ends.
    Smooth,
}

impl Dissipation {
    /// Name used in scenes (`scm_dissipation`) and the FMU.
    pub fn name(self) -> &'static str {
        match self {
            Dissipation::Paper => "paper",
            Dissipation::Smooth => "smooth",
        }
    }

    /// Parses a scene's `scm_dissipation` value.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "paper" => Some(Dissipation::Paper),
            "smooth" => Some(Dissipation::Smooth),
            _ => None,
        }
    }

    /// `d(s)`.
    #[inline]
    pub fn factor<T: Scalar>(self, s: T) -> T {
        let x = s.re();
        if x <= 0.0 {
            T::one() - s
        } else if x <= 2.0 {
            match self {
                Dissipation::Paper => (s - 2.0) * (s - 2.0) * 0.25,
                Dissipation::Smooth => {
                    let s2 = s * s;
                    T::one() - s + s2 * s * 0.25 - s2 * s2 * (1.0 / 16.0)
                }
            }
        } else {
            T::zero()
        }
    }
}

/// Parameters of the contact model. Every field but `dissipation` is a scalar so that
/// derivatives with respect to it come out of the same code.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactParams<T> {
    /// SSDF softmax temperature ε1 (m²).
    pub eps1: T,
    /// Separation-distribution softmax temperature ε2 (m).
    pub eps2: T,
    /// Softplus smoothing of the penetration ε3 (m).
    pub eps3: T,
    /// Contact stiffness k (N/m).
    pub stiffness: T,
    /// Dissipation velocity v_d (m/s): the approach speed at which damping cancels the spring.
    pub dissipation_velocity: T,
    /// Stiction velocity v_s (m/s): the sliding speed below which friction fades to zero.
    pub stiction_velocity: T,
    /// Friction coefficient μ (1).
    pub friction: T,
    /// Which dissipation factor `d(s)` to use.
    pub dissipation: Dissipation,
}

impl Default for ContactParams<f64> {
    fn default() -> Self {
        ContactParams {
            eps1: 1e-5,
            eps2: 1e-3,
            eps3: 1e-4,
            stiffness: 1e4,
            dissipation_velocity: 0.1,
            stiction_velocity: 1e-2,
            friction: 0.5,
            dissipation: Dissipation::Paper,
        }
    }
}

impl ContactParams<f64> {
    /// The same parameters in another scalar type (constants: zero derivative).
    pub fn lift<T: Scalar>(&self) -> ContactParams<T> {
        ContactParams {
            eps1: c(self.eps1),
            eps2: c(self.eps2),
            eps3: c(self.eps3),
            stiffness: c(self.stiffness),
            dissipation_velocity: c(self.dissipation_velocity),
            stiction_velocity: c(self.stiction_velocity),
            friction: c(self.friction),
            dissipation: self.dissipation,
        }
    }
}

/// Point–plane force (Kurtz & Lin 2023; paper eqs. 17–22; SPEC §2) on a point at offset `r`
/// from the plane point `p_i` (so `φ = nᵀr`), moving with velocity `v` relative to the plane's
/// material point. Returns `λ`, which acts on the point; `-λ` acts on the plane's body.
#[inline]
pub fn point_plane_force<T: Scalar>(r: &Vector3<T>, n: &Vector3<T>, v: &Vector3<T>, prm: &ContactParams<T>) -> Vector3<T> {
    let phi = n.dot(r);
    // Far outside the plane the spring term underflows to exactly zero, and the whole force
    // (normal and friction both scale with it) with it: return that zero without the work.
    if phi.re() > 746.0 * prm.eps3.re() {
        return Vector3::zeros();
    }
    let spring = prm.stiffness * softplus(-phi, prm.eps3);
    let vn = n.dot(v);
    let lambda_n = spring * prm.dissipation.factor(vn / prm.dissipation_velocity);
    let vt = v - n * vn;
    let lambda_t = vt * (-prm.friction * lambda_n / smooth_norm(&vt, prm.stiction_velocity));
    n * lambda_n + lambda_t
}

/// A rigid-body wrench in the world frame: force, and torque about the body's origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wrench<T: Scalar> {
    /// Force (N, world frame).
    pub force: Vector3<T>,
    /// Torque about the body's origin (N·m, world frame).
    pub torque: Vector3<T>,
}

impl<T: Scalar> Wrench<T> {
    /// The zero wrench.
    pub fn zero() -> Self {
        Wrench { force: Vector3::zeros(), torque: Vector3::zeros() }
    }
}

/// Result of the contact between the bodies `a` and `b` of a pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairContact<T: Scalar> {
    /// Wrench on body `a`.
    pub on_a: Wrench<T>,
    /// Wrench on body `b`.
    pub on_b: Wrench<T>,
    /// Smooth separation distance `D = Wᵀ Φ` (m).
    pub distance: T,
}

/// Accumulated point–SSDF force on one query point: `F = Σ σ_i λ_i` and the moment about the
/// plane body's origin of the reactions, `G = Σ σ_i p_i × λ_i` (plane body's frame).
struct PointForce<T: Scalar> {
    force: Vector3<T>,
    moment: Vector3<T>,
}

/// Point–SSDF force (paper eq. 23–24 with the sign corrected, SPEC §2): the softmin-weighted
/// average of point–plane forces on a query point `x` with velocity `v` (plane body's frame,
/// `v` relative to the plane body's frame origin motion, see [`Frame`]), against `planes`.
/// With `naive`, every plane is summed; otherwise the planes of
/// [`visit_relevant`](crate::geometry::ssdf::visit_relevant) (the SSDF's pruning bound).
/// `dmin` is the smallest squared distance from `x` to the planes' points, if known.
fn point_ssdf_force<T: Scalar>(planes: &Collider, x: &Vector3<T>, v_point: &Vector3<T>, angvel_planes: &Vector3<T>, prm: &ContactParams<T>, naive: bool, dmin: Option<f64>) -> PointForce<T> {
    match planes {
        Collider::HalfSpace { point, normal } => {
            let p = point.map(c::<T>);
            let n = normal.map(c::<T>);
            let v = v_point - angvel_planes.cross(&p);
            let lambda = point_plane_force(&(x - p), &n, &v, prm);
            PointForce { force: lambda, moment: p.cross(&lambda) }
        }
        Collider::Aopc(s) => {
            let xr = re3(x);
            let (mut force, mut moment) = (Vector3::zeros(), Vector3::zeros());
            let dmin = match dmin {
                Some(d) => d,
                None if naive => s.points.iter().map(|q| (xr - q).norm_squared()).fold(f64::INFINITY, f64::min),
                None => s.bvh().nearest(&xr).1,
            };
            let mut sum = SoftminSum::new(c(dmin), prm.eps1);
            let mut term = |q: &Vector3<f64>, nq: &Vector3<f64>| {
                let p = lift3::<T>(q);
                let r = x - p;
                let w = sum.add(r.dot(&r));
                let v = v_point - angvel_planes.cross(&p);
                let lambda = point_plane_force(&r, &lift3(nq), &v, prm) * w;
                force += lambda;
                moment += p.cross(&lambda);
            };
            if naive {
                s.points.iter().zip(&s.normals).for_each(|(q, n)| term(q, n));
            } else {
                visit_relevant(s, &xr, prm.eps1.re(), dmin, term);
            }
            let inv = sum.weight.recip();
            PointForce { force: force * inv, moment: moment * inv }
        }
    }
}

/// Accumulated wrenches of one side of a pair (query points of one body against the planes of
/// the other), in the plane body's frame.
struct SideSums<T: Scalar> {
    f_q: Vector3<T>,
    t_q: Vector3<T>,
    f_p: Vector3<T>,
    t_p: Vector3<T>,
}

impl<T: Scalar> SideSums<T> {
    fn zero() -> Self {
        SideSums { f_q: Vector3::zeros(), t_q: Vector3::zeros(), f_p: Vector3::zeros(), t_p: Vector3::zeros() }
    }

    /// Adds query point `p` (query body frame) with separation weight `w`.
    #[allow(clippy::too_many_arguments)]
    fn add(&mut self, planes: &Collider, rel: &Relative<T>, p: &Vector3<f64>, w: T, prm: &ContactParams<T>, naive: bool, dmin: Option<f64>) {
        let arm = rel.rotation * lift3::<T>(p); // query point relative to the query body origin
        let x = arm + rel.translation;
        let v = rel.linvel + rel.angvel.cross(&arm);
        let pf = point_ssdf_force(planes, &x, &v, &rel.angvel_planes, prm, naive, dmin);
        let fw = pf.force * w;
        self.f_q += fw;
        self.t_q += arm.cross(&fw);
        self.f_p -= fw;
        self.t_p -= pf.moment * w;
    }

    /// Adds these sums, rotated from the plane body's frame to the world, to the pair's
    /// wrenches.
    fn finish(self, pf: &Frame<T>, q_is_a: bool, on_a: &mut Wrench<T>, on_b: &mut Wrench<T>) {
        let r = &pf.rotation;
        let wq = Wrench { force: r * self.f_q, torque: r * self.t_q };
        let wp = Wrench { force: r * self.f_p, torque: r * self.t_p };
        let (wa, wb) = if q_is_a { (wq, wp) } else { (wp, wq) };
        on_a.force += wa.force;
        on_a.torque += wa.torque;
        on_b.force += wb.force;
        on_b.torque += wb.torque;
    }
}

/// SSDF–SSDF contact (paper eq. 25; SPEC §2) between collider `a` on a body with pose/motion
/// `fa` and collider `b` with `fb`: points of `a` against the planes of `b` and points of `b`
/// against the planes of `a`, weighted by the separation distribution.
///
/// Pruned to a proven bound (SPEC §3): only the query points of the
/// [`separation_band`] are visited (whole BVH nodes of points whose separation weight is below
/// τ/(I1 + I2) relative to the largest are never evaluated), points whose weight is below that
/// bound contribute no force, and each point–SSDF force sums only the planes of
/// [`visit_relevant`](crate::geometry::ssdf::visit_relevant). Skipped forces total less than τ
/// times the largest point force. Memory is O(I1 + I2) at most (the band), never I1×I2.
/// [`pair_contact_naive`] is the unpruned reference.
pub fn pair_contact<T: Scalar>(a: &Collider, fa: &Frame<T>, b: &Collider, fb: &Frame<T>, prm: &ContactParams<T>) -> PairContact<T> {
    let band = separation_band(a, fa, b, fb, prm.eps1, prm.eps2);
    let dist = SeparationDistribution::from_band(&band, prm.eps2);
    let (mut on_a, mut on_b) = (Wrench::zero(), Wrench::zero());
    if !dist.min.is_finite() {
        return PairContact { on_a, on_b, distance: dist.distance };
    }
    let cutoff = dist.min + band.margin * dist.eps.re();
    for (side, query, qf, planes, pf) in [(0u8, a, fa, b, fb), (1u8, b, fb, a, fa)] {
        let Collider::Aopc(s) = query else { continue };
        let rel = qf.relative_to(pf);
        let bvh = s.bvh();
        let mut sums = SideSums::zero();
        for e in band.entries.iter().filter(|e| e.side == side && e.phi.re() <= cutoff) {
            sums.add(planes, &rel, &bvh.points[e.k as usize], dist.weight(0, e.phi), prm, false, Some(e.dmin));
        }
        sums.finish(pf, side == 0, &mut on_a, &mut on_b);
    }
    PairContact { on_a, on_b, distance: dist.distance }
}

/// [`pair_contact`] without any pruning: every point of both bodies, every plane (the
/// reference; O(I1·I2) time, O(I1 + I2) memory).
pub fn pair_contact_naive<T: Scalar>(a: &Collider, fa: &Frame<T>, b: &Collider, fb: &Frame<T>, prm: &ContactParams<T>) -> PairContact<T> {
    let field = separation_field_naive(a, fa, b, fb, prm.eps1);
    let dist = SeparationDistribution::new(&field, prm.eps2);
    let (mut on_a, mut on_b) = (Wrench::zero(), Wrench::zero());
    if !dist.min.is_finite() {
        return PairContact { on_a, on_b, distance: dist.distance };
    }
    for (query, qf, planes, pf, phis, q_is_a) in [(a, fa, b, fb, &field.of_a, true), (b, fb, a, fa, &field.of_b, false)] {
        let Collider::Aopc(s) = query else { continue };
        let rel = qf.relative_to(pf);
        let mut sums = SideSums::zero();
        for (p, &phi) in s.points.iter().zip(phis) {
            sums.add(planes, &rel, p, dist.weight(0, phi), prm, true, None);
        }
        sums.finish(pf, q_is_a, &mut on_a, &mut on_b);
    }
    PairContact { on_a, on_b, distance: dist.distance }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::Dual64;

    #[test]
    fn dissipation_variants_agree_at_the_ends() {
        for kind in [Dissipation::Paper, Dissipation::Smooth] {
            assert_eq!(kind.factor(0.0), 1.0);
            assert!(kind.factor(2.0f64).abs() < 1e-15);
            assert_eq!(kind.factor(2.5), 0.0);
            assert_eq!(kind.factor(-1.0), 2.0);
            let slope = |s: f64| kind.factor(Dual64::new(s, 1.0)).eps;
            assert!((slope(-1e-12) + 1.0).abs() < 1e-9 && (slope(1e-12) + 1.0).abs() < 1e-9);
            assert!(slope(2.0 - 1e-12).abs() < 1e-9);
        }
    }

    #[test]
    fn smooth_dissipation_is_c2() {
        use num_dual::second_derivative;
        let d2 = |s: f64| second_derivative(|x| Dissipation::Smooth.factor(x), s).2;
        for s in [0.0, 2.0] {
            assert!((d2(s - 1e-9) - d2(s + 1e-9)).abs() < 1e-6, "jump at {s}");
        }
        let p2 = |s: f64| second_derivative(|x| Dissipation::Paper.factor(x), s).2;
        assert!((p2(-1e-9) - p2(1e-9)).abs() > 0.4, "the paper's d is only C1 at 0");
    }

    #[test]
    fn point_plane_force_pushes_out_and_opposes_sliding() {
        let prm = ContactParams::default();
        let n = Vector3::z();
        let r = Vector3::new(0.0, 0.0, -1e-3);
        let f = point_plane_force(&r, &n, &Vector3::new(0.1, 0.0, 0.0), &prm);
        assert!(f.z > 0.0 && f.x < 0.0 && f.y == 0.0);
        // Friction bounded by μ λ_n.
        assert!(f.x.abs() <= prm.friction * f.z);
        // Separating fast (s > 2): no force.
        let f = point_plane_force(&r, &n, &Vector3::new(0.0, 0.0, 1.0), &prm);
        assert_eq!(f, Vector3::zeros());
    }
}

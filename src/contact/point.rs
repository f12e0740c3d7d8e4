//! The force on one query point: the point–plane force (paper eqs. 17–22) with the distance
//! its spring reads, and its soft-minimum average over an SSDF's planes, the point–SSDF force
//! (paper eqs. 23–24; docs/method.md).

use super::ContactParams;
use crate::collision::{Collider, Relative};
use crate::geometry::polytope::Floor;
use crate::scalar::{c, lift3, re3, smooth_norm, softplus, Scalar, SoftminSum};
use nalgebra::Vector3;

/// Point–plane force (Kurtz & Lin 2023; paper eqs. 17–22; docs/method.md) on a point at offset `r`
/// from the plane point `p_i` (so `φ = nᵀr`), moving with velocity `v` relative to the plane's
/// material point. Returns `λ`, which acts on the point; `-λ` acts on the plane's body.
#[inline]
pub fn point_plane_force<T: Scalar>(
    r: &Vector3<T>,
    n: &Vector3<T>,
    v: &Vector3<T>,
    prm: &ContactParams<T>,
) -> Vector3<T> {
    point_plane_force_at(n.dot(r), n, v, prm)
}

/// [`point_plane_force`] given the distance `phi` the spring reads (the plane's `nᵀr`, or that
/// raised to the floor of the plane body's polytope, [`crate::geometry::polytope`]), less the
/// pair's margin ([`ContactParams::margin`]).
#[inline]
pub fn point_plane_force_at<T: Scalar>(
    phi: T,
    n: &Vector3<T>,
    v: &Vector3<T>,
    prm: &ContactParams<T>,
) -> Vector3<T> {
    match spring_at(phi, prm) {
        Some(spring) => force_of_spring(spring, n, v, None, prm),
        None => Vector3::zeros(),
    }
}

/// What of a point–plane force does not depend on the velocity: the spring `c` the
/// dissipation factor and the friction scale, and the adhesion's pull `p` (0 without).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Spring<T> {
    pub(crate) c: T,
    pub(crate) pull: T,
}

impl Spring<f64> {
    /// The same spring on scalar `T` (no derivative part).
    pub(crate) fn lift<T: Scalar>(&self) -> Spring<T> {
        Spring {
            c: c(self.c),
            pull: c(self.pull),
        }
    }
}

impl<T: Scalar> Spring<T> {
    /// Real parts.
    pub(crate) fn re(&self) -> Spring<f64> {
        Spring {
            c: self.c.re(),
            pull: self.pull.re(),
        }
    }
}

/// The spring of a plane whose reading is `phi` ([`point_plane_force_at`]): `c = k s⁺_ε3(m - φ)`,
/// no pull; with adhesion δ and gap g (docs/method.md, departure 7), with `y = φ - m` and the
/// window `W = σ((g - y)/ε3)`, `c = W k s⁺_ε3(δ/k - y)` and `p = W δ`; with the adhesion
/// actuators' pull `a` (departure 9) `p = W (δ + a)`, the spring unchanged by `a`. `None` far outside the
/// plane, where the spring (and the window) underflow to exactly zero and the whole force
/// (normal and friction both scale with them) with it.
#[inline]
pub(crate) fn spring_at<T: Scalar>(phi: T, prm: &ContactParams<T>) -> Option<Spring<T>> {
    // The spring reads the distance past the margin, where it rests.
    let phi = phi - prm.margin;
    if prm.adhesive() {
        return adhesive_spring(phi, prm);
    }
    (phi.re() <= 746.0 * prm.eps3.re()).then(|| Spring {
        c: prm.stiffness * softplus(-phi, prm.eps3),
        pull: T::zero(),
    })
}

/// [`spring_at`] of an adhesive pair, `y` the reading less the margin.
#[inline]
fn adhesive_spring<T: Scalar>(y: T, prm: &ContactParams<T>) -> Option<Spring<T>> {
    let reach = prm.bound_margin() - prm.margin.re();
    if y.re() > reach + 746.0 * prm.eps3.re() {
        return None;
    }
    let window = logistic((c::<T>(prm.gap) - y) / prm.eps3);
    let pull = match prm.pull {
        Some(a) => a + prm.adhesion,
        None => c(prm.adhesion),
    };
    let spring = if prm.adhesion > 0.0 {
        let shift = c::<T>(prm.adhesion) / prm.stiffness;
        window * prm.stiffness * softplus(shift - y, prm.eps3)
    } else {
        // The actuators' pull alone: the plain spring.
        prm.stiffness * softplus(-y, prm.eps3)
    };
    Some(Spring {
        c: spring,
        pull: window * pull,
    })
}

/// The logistic function `1 / (1 + e^{-x})`, 0 and 1 at the ends without overflow.
#[inline]
pub(crate) fn logistic<T: Scalar>(x: T) -> T {
    if x.re() >= 0.0 {
        (T::one() + (-x).exp()).recip()
    } else {
        let e = x.exp();
        e / (T::one() + e)
    }
}

/// The point–plane force of a plane whose spring is `spring` ([`spring_at`]) on a point moving
/// with `v` relative to the plane body's material point: the spring times the dissipation
/// factor, less the adhesion's pull, along the normal, and the regularized Coulomb friction
/// of the spring times the factor (MuJoCo's friction budget `μ (f_N + δ)`). `surface`: the
/// moving surfaces' relative flow at the point ([`Relative::surface`]), which the friction
/// reads in the plane's tangent plane and the normal part does not (docs/method.md,
/// departure 8).
#[inline]
pub(crate) fn force_of_spring<T: Scalar>(
    spring: Spring<T>,
    n: &Vector3<T>,
    v: &Vector3<T>,
    surface: Option<&Vector3<T>>,
    prm: &ContactParams<T>,
) -> Vector3<T> {
    let Spring { c: spring, pull } = spring;
    let vn = n.dot(v);
    let vd = prm.dissipation_velocity_at(spring, vn);
    // An infinite dissipation velocity (MuJoCo's undamped `solref="-k -0"`): no damping, `s = 0`
    // with no derivative; on dual numbers `vn / ∞` would carry `∞ · 0`, not a number.
    let s = if vd.re().is_infinite() {
        T::zero()
    } else {
        vn / vd
    };
    let pressed = spring * prm.dissipation.factor(s);
    let vt = match surface {
        None => v - n * vn,
        Some(s) => {
            let slide = v + s;
            slide - n * n.dot(&slide)
        }
    };
    let lambda_t = vt * (-prm.friction * pressed / smooth_norm(&vt, prm.stiction_velocity));
    let lambda_n = if prm.adhesive() {
        pressed - pull
    } else {
        pressed
    };
    n * lambda_n + lambda_t
}

/// The distance a plane's spring reads at a query point: the plane's `nᵀr` (`phi`) raised to
/// plane `k`'s floor (leaf order) under the plane body's polytope, if any (docs/method.md,
/// departure 3), and its gradient with respect to the query point (real part): `n` where the
/// floor leaves it, `(1 - s) n + s ∇b_k` where it raises it.
#[inline]
pub(crate) fn plane_reading<T: Scalar>(
    floor: &mut Option<Floor<'_, T>>,
    phi: T,
    n: &Vector3<f64>,
    k: usize,
) -> (T, Vector3<f64>) {
    match floor {
        Some(f) if !f.leaves_plane(phi.re(), k) => {
            let (raised, s, grad) = f.raise_plane(phi, k);
            (raised, n * (1.0 - s) + grad * s)
        }
        _ => (phi, *n),
    }
}

/// Accumulated point–SSDF force on one query point `x`: `F = Σ σ_i λ_i` and the moment about
/// the plane body's origin of its reaction, `G = x × F` (plane body's frame): the reaction acts
/// on the plane body's material point at `x`, on the line of `F` (docs/method.md, departure 6).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PointForce<T: Scalar> {
    pub(crate) force: Vector3<T>,
    pub(crate) moment: Vector3<T>,
}

/// The velocity of a query point `x` moving with `v_point` relative to the material point of
/// the plane body at `x`, which turns with `angvel_planes` (plane body's frame): the sliding
/// velocity every plane of that body reads at `x` (docs/method.md, departure 6).
#[inline]
pub(crate) fn sliding_velocity<T: Scalar>(
    x: &Vector3<T>,
    v_point: &Vector3<T>,
    angvel_planes: &Vector3<T>,
) -> Vector3<T> {
    v_point - angvel_planes.cross(x)
}

/// The moving surfaces' relative flow at the query point `x` ([`Relative::surface`]), if any.
#[inline]
pub(crate) fn surface_at<T: Scalar>(rel: &Relative<T>, x: &Vector3<T>) -> Option<Vector3<T>> {
    rel.surface.as_ref().map(|f| f.at(x))
}

/// The force of one half-space on a query point `x` moving with `v_point` (plane body's frame),
/// `spring` the spring of its distance from the plane with normal `n` ([`spring_at`]), the
/// bodies' motion `rel`: the point–plane force, not weighted, and its reaction's moment about
/// the plane body's origin; with the point's velocity relative to the plane body's material
/// point at `x` (returned too). Written once for the live evaluation ([`point_force`]) and the
/// tape's replay (`PairTape::replay`), so the two cannot drift apart.
#[inline]
pub(crate) fn half_space_force<T: Scalar>(
    x: &Vector3<T>,
    n: &Vector3<T>,
    spring: Option<Spring<T>>,
    v_point: &Vector3<T>,
    rel: &Relative<T>,
    prm: &ContactParams<T>,
) -> (PointForce<T>, Vector3<T>) {
    let v = sliding_velocity(x, v_point, &rel.angvel_planes);
    let surface = surface_at(rel, x);
    let lambda = spring.map_or_else(Vector3::zeros, |c| {
        force_of_spring(c, n, &v, surface.as_ref(), prm)
    });
    let pf = PointForce {
        force: lambda,
        moment: x.cross(&lambda),
    };
    (pf, v)
}

/// The softmin-weighted average of point–plane forces on one query point (paper eq. 23–24),
/// summed term by term: the one place this arithmetic is written, for the live evaluation
/// ([`point_force`]) and the tape's replay (`PairTape::replay`) alike, so a replay at the
/// recorded velocity equals the evaluation bit for bit by construction.
pub(crate) struct SoftAverage<'a, T: Scalar> {
    /// The query point and its velocity relative to the plane body's material point there
    /// (plane body's frame).
    x: Vector3<T>,
    v: Vector3<T>,
    /// The moving surfaces' relative flow at `x`, if any.
    surface: Option<Vector3<T>>,
    prm: &'a ContactParams<T>,
    force: Vector3<T>,
    weight: T,
}

impl<'a, T: Scalar> SoftAverage<'a, T> {
    /// No term yet, for a query point `x` moving with `v_point` against the planes of the
    /// bodies' motion `rel`.
    #[inline]
    pub(crate) fn new(
        x: Vector3<T>,
        v_point: &Vector3<T>,
        rel: &Relative<T>,
        prm: &'a ContactParams<T>,
    ) -> Self {
        SoftAverage {
            v: sliding_velocity(&x, v_point, &rel.angvel_planes),
            surface: surface_at(rel, &x),
            x,
            prm,
            force: Vector3::zeros(),
            weight: T::zero(),
        }
    }

    /// The query point's velocity relative to the plane body's material point at it, which
    /// every term reads.
    #[inline]
    pub(crate) fn velocity(&self) -> &Vector3<T> {
        &self.v
    }

    /// Adds the term of the plane with normal `n`, softmax weight `w`, whose spring reads
    /// `phi` ([`plane_reading`]); returns the spring ([`spring_at`]), for a replay.
    #[inline]
    pub(crate) fn add(&mut self, w: T, n: &Vector3<T>, phi: T) -> Option<Spring<T>> {
        let spring = spring_at(phi, self.prm);
        self.add_spring(w, n, spring);
        spring
    }

    /// Adds the term of the plane with normal `n`, softmax weight `w` and spring `spring`
    /// ([`spring_at`]): the sum [`SoftAverage::add`] makes, without the spring's work.
    #[inline]
    pub(crate) fn add_spring(&mut self, w: T, n: &Vector3<T>, spring: Option<Spring<T>>) {
        self.weight += w;
        if let Some(c) = spring {
            self.force += force_of_spring(c, n, &self.v, self.surface.as_ref(), self.prm) * w;
        }
    }

    /// The average: the weighted sum divided by the total weight, and its reaction's moment.
    #[inline]
    pub(crate) fn finish(self) -> PointForce<T> {
        let force = self.force * self.weight.recip();
        PointForce {
            moment: self.x.cross(&force),
            force,
        }
    }
}

/// One term of a point–SSDF force, real parts: softmax weight `w` (1 for a half-space), offset
/// `r = x - p` from the plane point `p` with normal `n`, the velocity `v` of the query point
/// relative to the plane body's material point at `x`, and the distance `phi` the spring reads
/// with its gradient `dphi` with respect to `x` ([`plane_reading`]), and the spring
/// ([`spring_at`]).
pub(crate) struct PlaneTerm<'a> {
    pub(crate) w: f64,
    pub(crate) r: Vector3<f64>,
    pub(crate) n: &'a Vector3<f64>,
    pub(crate) v: Vector3<f64>,
    pub(crate) phi: f64,
    pub(crate) spring: Option<Spring<f64>>,
    pub(crate) dphi: &'a Vector3<f64>,
}

/// Receives every term of a point–SSDF force, for derivatives computed alongside the value
/// (`LocalJacobian`) or a replay at other velocities (the tape).
pub(crate) trait ForceSink {
    /// Whether the sink does anything (when `false`, the calls compile away).
    const ON: bool;
    /// One term.
    fn term(&mut self, t: &PlaneTerm);
}

pub(crate) struct NoForceSink;

impl ForceSink for NoForceSink {
    const ON: bool = false;
    #[inline(always)]
    fn term(&mut self, _: &PlaneTerm) {}
}

/// Point–SSDF force (paper eq. 23–24 with the sign corrected, docs/method.md): the softmin-weighted
/// average of point–plane forces on a query point `x` with velocity `v_point` (plane body's
/// frame, relative to the plane body's origin; see [`Relative`]), against `planes`, over the
/// `terms` of the SSDF at `x`: each relevant plane's leaf-order index and softmax weight, as
/// [`ssdf_over`](crate::geometry::ssdf::ssdf_over) gives them (the SSDF's pruning bound,
/// [`Relevant`]). Unused against a half-space.
#[inline]
pub(crate) fn point_force<T: Scalar, S: ForceSink>(
    planes: &Collider,
    x: &Vector3<T>,
    v_point: &Vector3<T>,
    rel: &Relative<T>,
    prm: &ContactParams<T>,
    terms: &[(u32, T)],
    sink: &mut S,
) -> PointForce<T> {
    match planes {
        Collider::HalfSpace { point, normal } => {
            let p = lift3::<T>(point);
            let r = x - p;
            let n = lift3::<T>(normal);
            let phi = n.dot(&r);
            let spring = spring_at(phi, prm);
            let (pf, v) = half_space_force(x, &n, spring, v_point, rel, prm);
            if S::ON {
                sink.term(&PlaneTerm {
                    w: 1.0,
                    r: re3(&r),
                    n: normal,
                    v: re3(&v),
                    phi: phi.re(),
                    spring: spring.map(|c| c.re()),
                    dphi: normal,
                });
            }
            pf
        }
        Collider::Aopc(s) => {
            let bvh = s.bvh();
            let mut floor = bvh.polytope.as_ref().map(|p| p.floor(x));
            let mut average = SoftAverage::new(*x, v_point, rel, prm);
            let v = re3(average.velocity());
            for &(k, w) in terms {
                let (q, nq) = (&bvh.points[k as usize], &bvh.normals[k as usize]);
                let p = lift3::<T>(q);
                let r = x - p;
                let n = lift3::<T>(nq);
                let (phi, dphi) = plane_reading(&mut floor, n.dot(&r), nq, k as usize);
                let spring = average.add(w, &n, phi);
                if S::ON {
                    sink.term(&PlaneTerm {
                        w: w.re(),
                        r: re3(&r),
                        n: nq,
                        v,
                        phi: phi.re(),
                        spring: spring.map(|c| c.re()),
                        dphi: &dphi,
                    });
                }
            }
            average.finish()
        }
    }
}

/// [`point_force`] summed over every plane, whose SSDF reads `eps1` (m²; the reference for
/// [`pair_contact_naive`]).
pub(crate) fn point_force_naive<T: Scalar>(
    planes: &Collider,
    x: &Vector3<T>,
    v_point: &Vector3<T>,
    rel: &Relative<T>,
    prm: &ContactParams<T>,
    eps1: T,
) -> PointForce<T> {
    match planes {
        Collider::HalfSpace { .. } => {
            point_force(planes, x, v_point, rel, prm, &[], &mut NoForceSink)
        }
        Collider::Aopc(s) => {
            // Every plane, in the hierarchy's leaf order, whose index each plane's floor takes.
            let bvh = s.bvh();
            let xr = re3(x);
            let mut force = Vector3::zeros();
            let v = sliding_velocity(x, v_point, &rel.angvel_planes);
            let surface = surface_at(rel, x);
            let dmin = bvh
                .points
                .iter()
                .map(|q| (xr - q).norm_squared())
                .fold(f64::INFINITY, f64::min);
            let mut sum = SoftminSum::new(c(dmin), eps1);
            let mut floor = bvh.polytope.as_ref().map(|p| p.floor(x));
            for (k, (q, nq)) in bvh.points.iter().zip(&bvh.normals).enumerate() {
                let p = lift3::<T>(q);
                let r = x - p;
                let w = sum.add(r.dot(&r));
                let n = lift3::<T>(nq);
                let (phi, _) = plane_reading(&mut floor, n.dot(&r), nq, k);
                if let Some(spring) = spring_at(phi, prm) {
                    force += force_of_spring(spring, &n, &v, surface.as_ref(), prm) * w;
                }
            }
            let force = force * sum.weight.recip();
            PointForce {
                moment: x.cross(&force),
                force,
            }
        }
    }
}

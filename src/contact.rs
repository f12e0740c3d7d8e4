//! The soft-minimum contact model (paper, Methods B; docs/method.md): the point–plane force, and its
//! soft-minimum averages over an SSDF (point–SSDF) and over a separation distribution
//! (SSDF–SSDF), giving the wrench each body of a pair receives.
//!
//! Naming follows `quantity_shape1_shape2`: [`point_plane_force`] is the force between a point
//! and a plane, [`pair_contact`] the contact between two colliders.

use crate::collision::{
    band_of, separation_field_naive, Collider, Frame, Relative, SeparationBand,
    SeparationDistribution,
};
use crate::geometry::ssdf::Relevant;
use crate::geometry::Aopc;
use crate::scalar::{c, lift3, re3, smooth_norm, softplus, Scalar, SoftminSum, PRUNE_TOLERANCE};
use nalgebra::{Matrix3, Vector3};

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

    /// `d(s)` and `d'(s)` in `f64`.
    pub fn factor_slope(self, s: f64) -> (f64, f64) {
        if s <= 0.0 {
            (1.0 - s, -1.0)
        } else if s <= 2.0 {
            match self {
                Dissipation::Paper => ((s - 2.0) * (s - 2.0) * 0.25, (s - 2.0) * 0.5),
                Dissipation::Smooth => {
                    let s2 = s * s;
                    (
                        1.0 - s + s2 * s * 0.25 - s2 * s2 * (1.0 / 16.0),
                        -1.0 + 0.75 * s2 - 0.25 * s2 * s,
                    )
                }
            }
        } else {
            (0.0, 0.0)
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

impl<T: Scalar> ContactParams<T> {
    /// Real parts.
    pub fn re(&self) -> ContactParams<f64> {
        ContactParams {
            eps1: self.eps1.re(),
            eps2: self.eps2.re(),
            eps3: self.eps3.re(),
            stiffness: self.stiffness.re(),
            dissipation_velocity: self.dissipation_velocity.re(),
            stiction_velocity: self.stiction_velocity.re(),
            friction: self.friction.re(),
            dissipation: self.dissipation,
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

/// A tunable contact parameter (`scm.<name>`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Param {
    /// ε1 (m²).
    Eps1,
    /// ε2 (m).
    Eps2,
    /// ε3 (m).
    Eps3,
    /// k (N/m).
    Stiffness,
    /// v_d (m/s).
    DissipationVelocity,
    /// v_s (m/s).
    StictionVelocity,
    /// μ (1).
    Friction,
}

impl Param {
    /// Every parameter, in table order.
    pub const ALL: [Param; 7] = [
        Param::Eps1,
        Param::Eps2,
        Param::Eps3,
        Param::Stiffness,
        Param::DissipationVelocity,
        Param::StictionVelocity,
        Param::Friction,
    ];

    /// `(name, unit, description)`.
    pub fn describe(self) -> (&'static str, &'static str, &'static str) {
        match self {
            Param::Eps1 => ("eps1", "m2", "SSDF softmax temperature over squared distances (smaller: sharper surfaces)"),
            Param::Eps2 => ("eps2", "m", "separation-distribution softmax temperature (smaller: force concentrates on the deepest points)"),
            Param::Eps3 => ("eps3", "m", "softplus smoothing of the penetration (force at zero penetration is k*eps3*ln 2)"),
            Param::Stiffness => ("stiffness", "N/m", "contact stiffness k"),
            Param::DissipationVelocity => ("dissipation_velocity", "m/s", "approach speed at which damping cancels the spring (v_d)"),
            Param::StictionVelocity => ("stiction_velocity", "m/s", "sliding speed below which friction fades (v_s); also smooths joint frictionloss"),
            Param::Friction => ("friction", "1", "friction coefficient mu"),
        }
    }

    /// The parameter's slot.
    pub fn get<T: Copy>(self, p: &ContactParams<T>) -> T {
        match self {
            Param::Eps1 => p.eps1,
            Param::Eps2 => p.eps2,
            Param::Eps3 => p.eps3,
            Param::Stiffness => p.stiffness,
            Param::DissipationVelocity => p.dissipation_velocity,
            Param::StictionVelocity => p.stiction_velocity,
            Param::Friction => p.friction,
        }
    }

    /// The parameter's slot, for writing.
    pub fn slot<T>(self, p: &mut ContactParams<T>) -> &mut T {
        match self {
            Param::Eps1 => &mut p.eps1,
            Param::Eps2 => &mut p.eps2,
            Param::Eps3 => &mut p.eps3,
            Param::Stiffness => &mut p.stiffness,
            Param::DissipationVelocity => &mut p.dissipation_velocity,
            Param::StictionVelocity => &mut p.stiction_velocity,
            Param::Friction => &mut p.friction,
        }
    }

    /// Whether `value` is allowed (finite; positive, or non-negative for friction).
    pub fn accepts(self, value: f64) -> bool {
        value.is_finite()
            && if self == Param::Friction {
                value >= 0.0
            } else {
                value > 0.0
            }
    }
}

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
        Wrench {
            force: Vector3::zeros(),
            torque: Vector3::zeros(),
        }
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
#[derive(Clone, Copy, Debug)]
struct PointForce<T: Scalar> {
    force: Vector3<T>,
    moment: Vector3<T>,
}

/// Receives the real parts of every term of a point–SSDF force, for derivatives computed
/// alongside the value (`LocalJacobian`).
trait ForceSink {
    /// Whether the sink does anything (when `false`, the calls compile away).
    const ON: bool;
    /// One term: softmax weight `w` (1 for a half-space), offset `r = x - p` from the plane
    /// point `p` with normal `n`, and the velocity `v` of the query point relative to the
    /// plane's material point.
    fn term(
        &mut self,
        w: f64,
        r: &Vector3<f64>,
        n: &Vector3<f64>,
        p: &Vector3<f64>,
        v: &Vector3<f64>,
    );
}

struct NoForceSink;

impl ForceSink for NoForceSink {
    const ON: bool = false;
    #[inline(always)]
    fn term(
        &mut self,
        _: f64,
        _: &Vector3<f64>,
        _: &Vector3<f64>,
        _: &Vector3<f64>,
        _: &Vector3<f64>,
    ) {
    }
}

/// Point–SSDF force (paper eq. 23–24 with the sign corrected, docs/method.md): the softmin-weighted
/// average of point–plane forces on a query point `x` with velocity `v_point` (plane body's
/// frame, relative to the plane body's origin; see [`Relative`]), against `planes`, over the
/// planes `rel` found relevant at `x` (the SSDF's pruning bound, [`Relevant`]).
#[inline]
fn point_force<T: Scalar, S: ForceSink>(
    planes: &Collider,
    x: &Vector3<T>,
    v_point: &Vector3<T>,
    angvel_planes: &Vector3<T>,
    prm: &ContactParams<T>,
    rel: &Relevant,
    sink: &mut S,
) -> PointForce<T> {
    match planes {
        Collider::HalfSpace { point, normal } => {
            let p = lift3::<T>(point);
            let v = v_point - angvel_planes.cross(&p);
            let r = x - p;
            let lambda = point_plane_force(&r, &lift3(normal), &v, prm);
            if S::ON {
                sink.term(1.0, &re3(&r), normal, point, &re3(&v));
            }
            PointForce {
                force: lambda,
                moment: p.cross(&lambda),
            }
        }
        Collider::Aopc(s) => {
            let bvh = s.bvh();
            let (mut force, mut moment) = (Vector3::zeros(), Vector3::zeros());
            let mut sum = SoftminSum::new(c(rel.dmin), prm.eps1);
            for &(k, _) in &rel.items {
                let (q, nq) = (&bvh.points[k as usize], &bvh.normals[k as usize]);
                let p = lift3::<T>(q);
                let r = x - p;
                let w = sum.add(r.dot(&r));
                let v = v_point - angvel_planes.cross(&p);
                let lambda = point_plane_force(&r, &lift3(nq), &v, prm) * w;
                force += lambda;
                moment += p.cross(&lambda);
                if S::ON {
                    sink.term(w.re(), &re3(&r), nq, q, &re3(&v));
                }
            }
            let inv = sum.weight.recip();
            PointForce {
                force: force * inv,
                moment: moment * inv,
            }
        }
    }
}

/// [`point_force`] summed over every plane (the reference for [`pair_contact_naive`]).
fn point_force_naive<T: Scalar>(
    planes: &Collider,
    x: &Vector3<T>,
    v_point: &Vector3<T>,
    angvel_planes: &Vector3<T>,
    prm: &ContactParams<T>,
) -> PointForce<T> {
    match planes {
        Collider::HalfSpace { .. } => point_force(
            planes,
            x,
            v_point,
            angvel_planes,
            prm,
            &Relevant::default(),
            &mut NoForceSink,
        ),
        Collider::Aopc(s) => {
            let xr = re3(x);
            let (mut force, mut moment) = (Vector3::zeros(), Vector3::zeros());
            let dmin = s
                .points
                .iter()
                .map(|q| (xr - q).norm_squared())
                .fold(f64::INFINITY, f64::min);
            let mut sum = SoftminSum::new(c(dmin), prm.eps1);
            for (q, nq) in s.points.iter().zip(&s.normals) {
                let p = lift3::<T>(q);
                let r = x - p;
                let w = sum.add(r.dot(&r));
                let v = v_point - angvel_planes.cross(&p);
                let lambda = point_plane_force(&r, &lift3(nq), &v, prm) * w;
                force += lambda;
                moment += p.cross(&lambda);
            }
            let inv = sum.weight.recip();
            PointForce {
                force: force * inv,
                moment: moment * inv,
            }
        }
    }
}

/// Accumulated wrenches of one side of a pair (query points of one body against the planes of
/// the other), in the plane body's frame.
#[derive(Clone, Copy, Debug)]
struct SideSums<T: Scalar> {
    f_q: Vector3<T>,
    t_q: Vector3<T>,
    f_p: Vector3<T>,
    t_p: Vector3<T>,
}

impl<T: Scalar> SideSums<T> {
    fn zero() -> Self {
        SideSums {
            f_q: Vector3::zeros(),
            t_q: Vector3::zeros(),
            f_p: Vector3::zeros(),
            t_p: Vector3::zeros(),
        }
    }

    /// Adds the point force `pf` of query point `arm` (relative to the query body's origin,
    /// plane body's axes) with separation weight `w`.
    fn add(&mut self, arm: &Vector3<T>, pf: &PointForce<T>, w: T) {
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
        let wq = Wrench {
            force: r * self.f_q,
            torque: r * self.t_q,
        };
        let wp = Wrench {
            force: r * self.f_p,
            torque: r * self.t_p,
        };
        let (wa, wb) = if q_is_a { (wq, wp) } else { (wp, wq) };
        on_a.force += wa.force;
        on_a.torque += wa.torque;
        on_b.force += wb.force;
        on_b.torque += wb.torque;
    }

    /// The twelve numbers `f_q, t_q, f_p, t_p`.
    fn flat(&self) -> [T; 12] {
        let mut out = [T::zero(); 12];
        for (i, v) in [&self.f_q, &self.t_q, &self.f_p, &self.t_p]
            .into_iter()
            .enumerate()
        {
            out[3 * i..3 * i + 3].copy_from_slice(v.as_slice());
        }
        out
    }

    fn from_flat(x: &[T]) -> Self {
        let v = |i: usize| Vector3::new(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
        SideSums {
            f_q: v(0),
            t_q: v(1),
            f_p: v(2),
            t_p: v(3),
        }
    }
}

/// The point forces of a pair that can matter (the force bound of [`pair_contact`]): calls
/// `eval(i)` for each entry `i` of the band whose force is evaluated, the one with the largest
/// bound first; `eval` returns the size of that entry's summand `W_f |F_f|` (real part).
/// `bounds` is scratch space.
#[allow(clippy::too_many_arguments)]
fn for_each_force<T: Scalar>(
    a: &Collider,
    b: &Collider,
    rels: &[Relative<T>; 2],
    band: &SeparationBand<T>,
    dist: &SeparationDistribution<T>,
    prm: &ContactParams<T>,
    bounds: &mut Vec<(usize, f64)>,
    mut eval: impl FnMut(usize) -> f64,
) {
    let prm_re = prm.re();
    let cutoff = dist.min + band.margin * dist.eps.re();
    let fric = (1.0 + prm_re.friction * prm_re.friction).sqrt();
    let inv_vd = 1.0 / prm_re.dissipation_velocity.abs();
    let (e2, norm) = (dist.eps.re(), dist.normaliser.re());
    // Per side: rotation, origin velocity, angular velocities (real parts), the query AOPC and
    // the largest distance of a plane point from its body's origin.
    type Side<'s> = Option<(Matrix3<f64>, Vector3<f64>, Vector3<f64>, f64, &'s Aopc)>;
    let sides: [Side; 2] = [(a, b, &rels[0]), (b, a, &rels[1])].map(|(q, p, rel)| {
        let Collider::Aopc(s) = q else { return None };
        let reach = match p {
            Collider::Aopc(o) => o.bvh().max_norm,
            Collider::HalfSpace { point, .. } => point.norm(),
        };
        Some((
            rel.rotation.map(|x| x.re()),
            re3(&rel.linvel),
            re3(&rel.angvel),
            re3(&rel.angvel_planes).norm() * reach,
            s,
        ))
    });
    bounds.clear();
    for (i, e) in band.entries.iter().enumerate() {
        let phi = e.phi.re();
        if phi > cutoff {
            continue;
        }
        let Some((rot, u, wq, spin, s)) = &sides[e.side as usize] else {
            continue;
        };
        let w = (-(phi - dist.min) / e2).exp() / norm;
        let spring = prm_re.stiffness.abs() * e.springs;
        if w == 0.0 || spring == 0.0 {
            continue; // zero or subnormal (doc of `pair_contact`)
        }
        let arm = rot * s.bvh().points[e.k as usize];
        let speed = (u + wq.cross(&arm)).norm() + spin;
        bounds.push((i, w * spring * (1.0 + speed * inv_vd) * fric));
    }
    let Some(first) = (0..bounds.len()).max_by(|&x, &y| bounds[x].1.total_cmp(&bounds[y].1)) else {
        return;
    };
    let tol = PRUNE_TOLERANCE / bounds.len() as f64;
    let mut largest = eval(bounds[first].0);
    for (j, &(i, bound)) in bounds.iter().enumerate() {
        if j != first && bound >= tol * largest {
            largest = largest.max(eval(i));
        }
    }
}

/// What [`pair_sides`] leaves besides the wrenches: the band, its distribution, and (for
/// derivatives) the entries whose force was evaluated.
struct PairParts<T: Scalar> {
    sums: [SideSums<T>; 2],
    band: SeparationBand<T>,
    dist: SeparationDistribution<T>,
}

/// The SSDF–SSDF contact of a pair in the plane frames of both sides (module documentation of
/// [`pair_contact`]), given each body's motion in the other's frame. `on_force(i, W_f, F, s)`
/// is called for every evaluated point force (entry `i` of the band) with the sink that saw its
/// terms (made by `sink()`); `grads` receives `∇Φ_f` of every band entry.
#[allow(clippy::too_many_arguments)]
fn pair_sides<T: Scalar, S: ForceSink>(
    a: &Collider,
    b: &Collider,
    rels: &[Relative<T>; 2],
    prm: &ContactParams<T>,
    scratch: &mut Relevant,
    grads: Option<&mut Vec<Vector3<f64>>>,
    mut sink: impl FnMut() -> S,
    mut on_force: impl FnMut(usize, T, &PointForce<T>, S),
) -> PairParts<T> {
    let band = band_of(
        a,
        b,
        rels,
        prm.eps1,
        prm.eps2,
        prm.eps3.re(),
        scratch,
        grads,
    );
    let dist = SeparationDistribution::from_band(&band, prm.eps2);
    let mut sums = [SideSums::zero(), SideSums::zero()];
    if !dist.min.is_finite() {
        return PairParts { sums, band, dist };
    }
    let mut bounds = Vec::new();
    for_each_force(a, b, rels, &band, &dist, prm, &mut bounds, |i| {
        let e = &band.entries[i];
        let side = e.side as usize;
        let (query, planes) = if side == 0 { (a, b) } else { (b, a) };
        let Collider::Aopc(s) = query else { return 0.0 };
        let rel = &rels[side];
        let arm = rel.rotation * lift3::<T>(&s.bvh().points[e.k as usize]);
        let x = arm + rel.translation;
        let v = rel.linvel + rel.angvel.cross(&arm);
        if let Collider::Aopc(o) = planes {
            scratch.find(o, &re3(&x), prm.eps1.re(), e.nearest as usize);
        }
        let mut snk = sink();
        let pf = point_force(planes, &x, &v, &rel.angvel_planes, prm, scratch, &mut snk);
        let w = dist.weight(0, e.phi);
        sums[side].add(&arm, &pf, w);
        let size = w.re() * re3(&pf.force).norm();
        on_force(i, w, &pf, snk);
        size
    });
    PairParts { sums, band, dist }
}

/// SSDF–SSDF contact (paper eq. 25; docs/method.md) between collider `a` on a body with pose/motion
/// `fa` and collider `b` with `fb`: points of `a` against the planes of `b` and points of `b`
/// against the planes of `a`, weighted by the separation distribution.
///
/// Pruned to proven bounds (docs/method.md, numerical rules): only the query points of the [`separation_band`](crate::collision::separation_band) are
/// visited (whole BVH nodes of points whose separation weight is below τ/(I1 + I2) relative to
/// the largest are never evaluated), each SSDF sums only the planes of [`Relevant`], and only
/// the point forces that can matter are evaluated: a point force whose bound is provably below
/// τ/N of the largest evaluated one, or exactly zero, is skipped (see the bound below). Skipped
/// forces total less than τ times the largest point force. Memory is O(I1 + I2) at most (the
/// band), never I1×I2. [`pair_contact_naive`] is the unpruned reference.
///
/// With a first-order dual scalar (`Dual64`, `DualSVec64<N>`) and constant contact parameters,
/// the derivatives are not carried through every term: the wrenches' exact Jacobian with
/// respect to the two bodies' relative motion is computed once in `f64` (hand-derived,
/// [`pair_jacobian`]) and chained with the duals' derivative parts ([`ChainRule`](crate::scalar::ChainRule)). Every other
/// scalar runs [`pair_contact_generic`].
///
/// # The force bound
/// An entry of the band contributes `W_f F_f` to the force on each body (and `W_f arm_f × F_f`,
/// `W_f G_f` to the torques), where `F_f = Σ_i σ_i λ_i` is its point–SSDF force and
/// `G_f = Σ_i σ_i p_i × λ_i`. Each `|λ_i| = c_i d(s_i) |n_i - μ u_i|` with the spring
/// `c_i = k s⁺_ε3(-φ_i)`, `d(s) ≤ 1 + max(0, -s) ≤ 1 + V_f/v_d` (`|v_i| ≤ V_f = |v_f| + |ω_p|
/// max_i |p_i|`) and `|n_i - μ u_i| ≤ √(1 + μ²)` (`u_i ⊥ n_i`, `|u_i| < 1`), so
/// `|F_f| ≤ Λ_f := k B_f (1 + V_f/v_d) √(1 + μ²)` and `|G_f| ≤ Λ_f max_i |p_i|`, with
/// `B_f ≥ Σ_i σ_i s⁺_ε3(-φ_i)` bounded while the SSDF is summed ([`BandEntry::springs`](crate::collision::BandEntry::springs)).
/// An entry is skipped when its separation weight is below the band's cutoff, when `W_f Λ_f`
/// is zero in `f64` (every term's `w_i e^{-φ_i/ε3}` is below e^-745, so its force is zero or
/// subnormal: `B_f < I ε3 e^-745`), or when
/// `W_f Λ_f < (τ/N) M`, `M` the largest summand `W_g |F_g|` evaluated so far (the entry with
/// the largest bound is evaluated first) and `N` the number of entries within the cutoff: each
/// skipped summand is below the relative weight τ/N of the largest, and all of them together
/// change the force by less than `τ M`, the torques by less than `τ M` times the bodies' size.
///
/// # Example
///
/// Two 10 cm boxes, one resting 1 mm into the other: the pair pushes them apart along z with
/// equal and opposite forces, and nothing acts sideways.
///
/// ```
/// use std::path::Path;
/// use scm::contact::pair_contact;
///
/// let xml = r#"<mujoco><worldbody>
///   <body name="low"><geom type="box" size="0.05 0.05 0.05"/></body>
///   <body name="high" pos="0 0 0.099"><freejoint/><geom type="box" size="0.05 0.05 0.05"/></body>
/// </worldbody></mujoco>"#;
/// let model = scm::scene::load_str(xml, Path::new("boxes.xml"))?.model;
/// let kin = model.tree.kinematics(&model.q0, &model.v0);
/// let pair = &model.pairs[0];
/// let (ca, cb) = (model.colliders[pair.a].as_ref(), model.colliders[pair.b].as_ref());
/// let pc = pair_contact(ca.unwrap(), &kin.frames[pair.a], cb.unwrap(), &kin.frames[pair.b], &model.contact);
/// let (fa, fb) = (pc.on_a.force, pc.on_b.force);
/// assert!(fb.z > 0.0 && fa.z < 0.0, "the upper box is pushed up");
/// assert!((fa + fb).norm() < 1e-9 * fb.norm(), "action = reaction");
/// assert!(fb.x.abs() + fb.y.abs() < 1e-6 * fb.z, "no sideways force on a centred stack");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn pair_contact<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    prm: &ContactParams<T>,
) -> PairContact<T> {
    let constant = [
        prm.eps1,
        prm.eps2,
        prm.eps3,
        prm.stiffness,
        prm.dissipation_velocity,
        prm.stiction_velocity,
        prm.friction,
    ]
    .iter()
    .all(|x| x.is_constant());
    if T::FIRST_ORDER && constant {
        pair_contact_chained(a, fa, b, fb, prm)
    } else {
        pair_contact_generic(a, fa, b, fb, prm)
    }
}

/// [`pair_contact`] with every derivative carried by the scalar type through every term (no
/// chain rule): the reference for [`pair_jacobian`], and the path of second-order scalars.
pub fn pair_contact_generic<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    prm: &ContactParams<T>,
) -> PairContact<T> {
    let rels = [fa.relative_to(fb), fb.relative_to(fa)];
    let parts = pair_sides(
        a,
        b,
        &rels,
        prm,
        &mut Relevant::default(),
        None,
        || NoForceSink,
        |_, _, _, _| {},
    );
    let (mut on_a, mut on_b) = (Wrench::zero(), Wrench::zero());
    let [s0, s1] = parts.sums;
    s0.finish(fb, true, &mut on_a, &mut on_b);
    s1.finish(fa, false, &mut on_a, &mut on_b);
    PairContact {
        on_a,
        on_b,
        distance: parts.dist.distance,
    }
}

/// Number of inputs of [`pair_jacobian`] per side: the rotation (9 entries, row-major), the
/// translation, the linear velocity, the query body's and the plane body's angular velocities
/// of a [`Relative`].
pub const SIDE_INPUTS: usize = 21;
/// Number of outputs of [`pair_jacobian`]: per side the force and torque on the query body and
/// on the plane body (plane body's frame), then the distance.
pub const PAIR_OUTPUTS: usize = 25;

fn relative_inputs<T: Scalar>(r: &Relative<T>) -> [T; SIDE_INPUTS] {
    let mut out = [T::zero(); SIDE_INPUTS];
    for j in 0..3 {
        for k in 0..3 {
            out[3 * j + k] = r.rotation[(j, k)];
        }
    }
    for (i, v) in [&r.translation, &r.linvel, &r.angvel, &r.angvel_planes]
        .into_iter()
        .enumerate()
    {
        out[9 + 3 * i..12 + 3 * i].copy_from_slice(v.as_slice());
    }
    out
}

fn pair_contact_chained<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    prm: &ContactParams<T>,
) -> PairContact<T> {
    let rels = [fa.relative_to(fb), fb.relative_to(fa)];
    let mut inputs = [T::zero(); 2 * SIDE_INPUTS];
    inputs[..SIDE_INPUTS].copy_from_slice(&relative_inputs(&rels[0]));
    inputs[SIDE_INPUTS..].copy_from_slice(&relative_inputs(&rels[1]));
    let (values, jac) = pair_jacobian(a, b, &[rels[0].re(), rels[1].re()], &prm.re());
    let mut out = [T::zero(); PAIR_OUTPUTS];
    if !T::chain(&values, &jac, &inputs, &mut out) {
        return pair_contact_generic(a, fa, b, fb, prm);
    }
    let (mut on_a, mut on_b) = (Wrench::zero(), Wrench::zero());
    SideSums::from_flat(&out[..12]).finish(fb, true, &mut on_a, &mut on_b);
    SideSums::from_flat(&out[12..24]).finish(fa, false, &mut on_a, &mut on_b);
    PairContact {
        on_a,
        on_b,
        distance: out[24],
    }
}

/// `[v]×`, the matrix of `w ↦ v × w`.
fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// `λ` of [`point_plane_force`] (`f64`) with its exact derivatives `∂λ/∂φ` (with `φ = nᵀr`)
/// and `∂λ/∂v` (3×3), hand-derived: `λ = c(φ) d(s) e` with `c = k s⁺_ε3(-φ)`,
/// `s = nᵀv/v_d`, `e = n - μ u`, `u = v_t/N`, `N = sqrt(v_s² + |v_t|²)`, so
/// `∂λ/∂φ = c'(φ) d e` with `c' = -k / (1 + exp(φ/ε3))`, and
/// `∂λ/∂v = c (d'(s)/v_d) e nᵀ - (c μ d / N)(I - n nᵀ - u uᵀ)`.
pub fn point_plane_force_jacobian(
    r: &Vector3<f64>,
    n: &Vector3<f64>,
    v: &Vector3<f64>,
    prm: &ContactParams<f64>,
) -> (Vector3<f64>, Vector3<f64>, Matrix3<f64>) {
    let phi = n.dot(r);
    if phi > 746.0 * prm.eps3 {
        return (Vector3::zeros(), Vector3::zeros(), Matrix3::zeros());
    }
    let spring = prm.stiffness * softplus(-phi, prm.eps3);
    let dspring = -prm.stiffness / (1.0 + (phi / prm.eps3).exp());
    let vn = n.dot(v);
    let (d, dd) = prm.dissipation.factor_slope(vn / prm.dissipation_velocity);
    let lambda_n = spring * d;
    let vt = v - n * vn;
    let norm = smooth_norm(&vt, prm.stiction_velocity);
    let lambda = n * lambda_n + vt * (-prm.friction * lambda_n / norm);
    let u = vt / norm;
    let e = n - u * prm.friction;
    let dphi = e * (dspring * d);
    let dv = e * n.transpose() * (spring * dd / prm.dissipation_velocity)
        - (Matrix3::identity() - n * n.transpose() - u * u.transpose())
            * (spring * prm.friction * d / norm);
    (lambda, dphi, dv)
}

/// Derivatives of one point–SSDF force with respect to its query point `x`, its velocity `v`
/// and the plane body's angular velocity `ω_p` (plane body's frame), from the terms' real
/// parts. With `σ_i = w_i/Z`, `∂w_i/∂x = -(2/ε1) w_i r_i`, `v_i = v + [p_i]× ω_p`:
/// `∂F/∂x = Σ σ_i λ_φ,i n_iᵀ - (2/ε1)(Σ σ_i λ_i r_iᵀ - F r̄ᵀ)` (`r̄ = Σ σ_i r_i`),
/// `∂F/∂v = Σ σ_i ∂λ_i/∂v`, `∂F/∂ω_p = Σ σ_i ∂λ_i/∂v [p_i]×`, and the same for
/// `G = Σ σ_i [p_i]× λ_i` with `[p_i]×` on the left. A half-space (one plane, no softmax) has
/// `σ = 1` and no weight derivative.
#[derive(Clone, Debug)]
struct LocalJacobian {
    prm: ContactParams<f64>,
    softmax: bool,
    z: f64,
    sr: Vector3<f64>,
    lphi_n: Matrix3<f64>,
    lam_r: Matrix3<f64>,
    plphi_n: Matrix3<f64>,
    plam_r: Matrix3<f64>,
    lv: Matrix3<f64>,
    plv: Matrix3<f64>,
    lvp: Matrix3<f64>,
    plvp: Matrix3<f64>,
}

impl ForceSink for LocalJacobian {
    const ON: bool = true;
    fn term(
        &mut self,
        w: f64,
        r: &Vector3<f64>,
        n: &Vector3<f64>,
        p: &Vector3<f64>,
        v: &Vector3<f64>,
    ) {
        let (lambda, lphi, lv) = point_plane_force_jacobian(r, n, v, &self.prm);
        let px = skew(p);
        self.z += w;
        self.sr += r * w;
        self.lphi_n += lphi * n.transpose() * w;
        self.lam_r += lambda * r.transpose() * w;
        self.plphi_n += p.cross(&lphi) * n.transpose() * w;
        self.plam_r += p.cross(&lambda) * r.transpose() * w;
        let plv = px * lv;
        self.lv += lv * w;
        self.plv += plv * w;
        self.lvp += lv * px * w;
        self.plvp += plv * px * w;
    }
}

impl LocalJacobian {
    fn new(prm: &ContactParams<f64>, softmax: bool) -> Self {
        let z = Matrix3::zeros();
        LocalJacobian {
            prm: *prm,
            softmax,
            z: 0.0,
            sr: Vector3::zeros(),
            lphi_n: z,
            lam_r: z,
            plphi_n: z,
            plam_r: z,
            lv: z,
            plv: z,
            lvp: z,
            plvp: z,
        }
    }

    /// `(∂F/∂x, ∂F/∂v, ∂F/∂ω_p, ∂G/∂x, ∂G/∂v, ∂G/∂ω_p)` given the values `F`, `G`.
    fn blocks(&self, f: &Vector3<f64>, g: &Vector3<f64>) -> [Matrix3<f64>; 6] {
        let inv = 1.0 / self.z;
        let (mut fx, mut gx) = (self.lphi_n * inv, self.plphi_n * inv);
        if self.softmax {
            let k = 2.0 / self.prm.eps1;
            let rbar = self.sr * inv;
            fx += (f * rbar.transpose() - self.lam_r * inv) * k;
            gx += (g * rbar.transpose() - self.plam_r * inv) * k;
        }
        [
            fx,
            self.lv * inv,
            self.lvp * inv,
            gx,
            self.plv * inv,
            self.plvp * inv,
        ]
    }
}

/// The pair's outputs in the plane frames (per side `f_q, t_q, f_p, t_p`, see
/// [`PAIR_OUTPUTS`]), the distance last, and their exact Jacobian (row-major,
/// `PAIR_OUTPUTS × 2·SIDE_INPUTS`) with respect to the two [`Relative`] motions (inputs in the
/// order of [`SIDE_INPUTS`]): the value of [`pair_contact_generic`] at `f64`, and the derivative
/// that `Dual64` would carry through it, computed by hand.
///
/// Derivation. Entry `f` of side `s` has query point `a_f` (its body's frame), `arm_f = R a_f`,
/// `x_f = arm_f + t`, `v_f = u + ω_q × arm_f`; its SSDF `Φ_f` depends on `x_f` (gradient
/// [`GradientSink`](crate::geometry::ssdf::GradientSink)); its point force `F_f`, `G_f` on `x_f`, `v_f`, `ω_p` (`LocalJacobian`).
/// `W_f = exp(-Φ_f/ε2)/Σ_g exp(-Φ_g/ε2)`, so `dW_f = -(W_f/ε2)(dΦ_f - dΦ̄)` with
/// `dΦ̄ = Σ_g W_g dΦ_g` over every entry with a weight. For a side's output
/// `S = Σ_f W_f s_f`: `dS = Σ_f W_f (ds_f - s_f dΦ_f/ε2) + S dΦ̄/ε2`, and
/// `dD = Σ_g W_g (1 - (Φ_g - D)/ε2) dΦ_g`. Finally `dx_f = dR a_f + dt`,
/// `dv_f = du - [arm_f]× dω_q + [ω_q]× dR a_f`, `d arm_f = dR a_f`.
pub fn pair_jacobian(
    a: &Collider,
    b: &Collider,
    rels: &[Relative<f64>; 2],
    prm: &ContactParams<f64>,
) -> ([f64; PAIR_OUTPUTS], Vec<f64>) {
    const NI: usize = 2 * SIDE_INPUTS;
    let mut jac = vec![0.0; PAIR_OUTPUTS * NI];
    let mut grads = Vec::new();
    let mut records: Vec<(usize, f64, PointForce<f64>, LocalJacobian)> = Vec::new();
    // The planes of side 0 are b's, of side 1 a's: against a half-space there is no softmax.
    let halfspace = [
        matches!(b, Collider::HalfSpace { .. }),
        matches!(a, Collider::HalfSpace { .. }),
    ];
    let parts = pair_sides(
        a,
        b,
        rels,
        prm,
        &mut Relevant::default(),
        Some(&mut grads),
        || LocalJacobian::new(prm, true),
        |i, w, pf, snk| records.push((i, w, *pf, snk)),
    );
    let mut values = [0.0; PAIR_OUTPUTS];
    values[..12].copy_from_slice(&parts.sums[0].flat());
    values[12..24].copy_from_slice(&parts.sums[1].flat());
    values[24] = parts.dist.distance;
    if !parts.dist.min.is_finite() {
        return (values, jac);
    }
    let (band, dist) = (&parts.band, &parts.dist);
    let e2 = prm.eps2;
    let query = |side: usize| -> &Aopc {
        match if side == 0 { a } else { b } {
            Collider::Aopc(s) => s,
            Collider::HalfSpace { .. } => unreachable!("a band entry is a point of an AOPC"),
        }
    };
    fn add(jac: &mut [f64], row: usize, col: usize, m: &Matrix3<f64>, sign: f64) {
        for i in 0..3 {
            for j in 0..3 {
                jac[(row + i) * NI + col + j] += sign * m[(i, j)];
            }
        }
    }
    // Point forces.
    for (i, w, pf, snk) in &records {
        let e = &band.entries[*i];
        let side = e.side as usize;
        let rel = &rels[side];
        let a_f = query(side).bvh().points[e.k as usize];
        let arm = rel.rotation * a_f;
        let g = grads[*i];
        let mut lj = snk.clone();
        lj.softmax = !halfspace[side];
        let [fx, fv, fw, gx, gv, gw] = lj.blocks(&pf.force, &pf.moment);
        let wf = pf.force * *w;
        let (ax, av, aw) = ((fx - pf.force * g.transpose() / e2) * *w, fv * *w, fw * *w);
        let (bx, bv, bw) = ((gx - pf.moment * g.transpose() / e2) * *w, gv * *w, gw * *w);
        let wq = skew(&rel.angvel);
        let armx = skew(&arm);
        let (ka, kb) = (ax + av * wq, bx + bv * wq);
        let (row, col) = (12 * side, SIDE_INPUTS * side);
        // d(W F) and d(W G) by input block: translation, velocity, ω_q, ω_p.
        let blocks_a = [(9, ax), (12, av), (15, -av * armx), (18, aw)];
        let blocks_b = [(9, bx), (12, bv), (15, -bv * armx), (18, bw)];
        for (off, m) in blocks_a {
            add(&mut jac, row, col + off, &m, 1.0);
            add(&mut jac, row + 6, col + off, &m, -1.0);
            add(&mut jac, row + 3, col + off, &(armx * m), 1.0);
        }
        for (off, m) in blocks_b {
            add(&mut jac, row + 9, col + off, &m, -1.0);
        }
        // The rotation block: ∂/∂R_jk = K[:, j] a_k (and -[W F]×[:, j] a_k for d arm × W F).
        let wfx = skew(&wf);
        for j in 0..3 {
            for k in 0..3 {
                let c0 = col + 3 * j + k;
                let (da, db) = (ka.column(j) * a_f[k], kb.column(j) * a_f[k]);
                let dt = armx * da - wfx.column(j) * a_f[k];
                for m in 0..3 {
                    jac[(row + m) * NI + c0] += da[m];
                    jac[(row + 6 + m) * NI + c0] -= da[m];
                    jac[(row + 3 + m) * NI + c0] += dt[m];
                    jac[(row + 9 + m) * NI + c0] -= db[m];
                }
            }
        }
    }
    // The separation distribution's normaliser (dΦ̄) and the distance.
    let d = dist.distance;
    let mut bar = [[0.0; 12]; 2];
    let mut dd = [[0.0; 12]; 2];
    for (e, g) in band.entries.iter().zip(&grads) {
        let phi = e.phi;
        if phi - dist.min > 746.0 * e2 {
            continue;
        }
        let w = (-(phi - dist.min) / e2).exp() / dist.normaliser;
        let a_f = query(e.side as usize).bvh().points[e.k as usize];
        let cd = w * (1.0 - (phi - d) / e2);
        let (b, dr) = (&mut bar[e.side as usize], &mut dd[e.side as usize]);
        for j in 0..3 {
            for k in 0..3 {
                b[3 * j + k] += w * g[j] * a_f[k];
                dr[3 * j + k] += cd * g[j] * a_f[k];
            }
            b[9 + j] += w * g[j];
            dr[9 + j] += cd * g[j];
        }
    }
    for (side, (b, dr)) in bar.iter().zip(&dd).enumerate() {
        let col = SIDE_INPUTS * side;
        for m in 0..12 {
            for (row, value) in values[..24].iter().enumerate() {
                jac[row * NI + col + m] += value / e2 * b[m];
            }
            jac[24 * NI + col + m] += dr[m];
        }
    }
    (values, jac)
}

/// [`pair_contact`] without any pruning: every point of both bodies, every plane (the
/// reference; O(I1·I2) time, O(I1 + I2) memory).
pub fn pair_contact_naive<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    prm: &ContactParams<T>,
) -> PairContact<T> {
    let field = separation_field_naive(a, fa, b, fb, prm.eps1);
    let dist = SeparationDistribution::new(&field, prm.eps2);
    let (mut on_a, mut on_b) = (Wrench::zero(), Wrench::zero());
    if !dist.min.is_finite() {
        return PairContact {
            on_a,
            on_b,
            distance: dist.distance,
        };
    }
    for (query, qf, planes, pf, phis, q_is_a) in [
        (a, fa, b, fb, &field.of_a, true),
        (b, fb, a, fa, &field.of_b, false),
    ] {
        let Collider::Aopc(s) = query else { continue };
        let rel = qf.relative_to(pf);
        let mut sums = SideSums::zero();
        for (p, &phi) in s.points.iter().zip(phis) {
            let arm = rel.rotation * lift3::<T>(p);
            let x = arm + rel.translation;
            let v = rel.linvel + rel.angvel.cross(&arm);
            let pf = point_force_naive(planes, &x, &v, &rel.angvel_planes, prm);
            sums.add(&arm, &pf, dist.weight(0, phi));
        }
        sums.finish(pf, q_is_a, &mut on_a, &mut on_b);
    }
    PairContact {
        on_a,
        on_b,
        distance: dist.distance,
    }
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
        assert!(
            (p2(-1e-9) - p2(1e-9)).abs() > 0.4,
            "the paper's d is only C1 at 0"
        );
    }

    #[test]
    fn point_plane_force_jacobian_matches_duals_and_central_differences() {
        // The hand-derived ∂λ/∂φ and ∂λ/∂v of `point_plane_force_jacobian` against Dual64
        // through `point_plane_force` (round-off: 1e-12 of the largest entry) and against
        // central differences (h = 1e-7 of the scale: 1e-6 relative), on both sides of the
        // dissipation's kinks (s < 0, 0 < s < 2, s > 2), pressed and separated, sliding and
        // nearly at rest, for both dissipation laws.
        let n = Vector3::new(0.2, -0.3, 0.9).normalize();
        for dissipation in [Dissipation::Paper, Dissipation::Smooth] {
            let prm = ContactParams {
                eps3: 1e-4,
                stiffness: 1e4,
                dissipation_velocity: 0.1,
                stiction_velocity: 0.01,
                friction: 0.5,
                dissipation,
                ..ContactParams::default()
            };
            for (depth, vn, vt) in [
                (1e-3, -0.05, 0.03),
                (2e-4, 0.05, -0.2),
                (-3e-4, 0.15, 1e-3),
                (5e-4, 0.25, 0.1),
                (1e-3, 0.0, 0.0),
            ] {
                let t = n.cross(&Vector3::x()).normalize();
                let (r, v) = (
                    n * -depth + t * 0.01,
                    n * vn + t * vt + n.cross(&t) * 0.2 * vt,
                );
                let (lambda, dphi, dv) = point_plane_force_jacobian(&r, &n, &v, &prm);
                assert!(
                    (lambda - point_plane_force(&r, &n, &v, &prm)).norm() <= 1e-15 * lambda.norm()
                );
                let scale = dphi.amax().max(dv.amax()).max(1e-300);
                // ∂λ/∂φ along r = r0 + s n (φ changes by s).
                let along = |s: f64| point_plane_force(&(r + n * s), &n, &v, &prm);
                let dual: Vector3<f64> = point_plane_force(
                    &(r.map(Dual64::from) + n.map(Dual64::from) * Dual64::new(0.0, 1.0)),
                    &n.map(Dual64::from),
                    &v.map(Dual64::from),
                    &prm.lift(),
                )
                .map(|x| x.eps);
                let fd = (along(1e-9) - along(-1e-9)) / 2e-9;
                assert!(
                    (dphi - dual).amax() <= 1e-12 * scale,
                    "{dissipation:?} {depth} {vn}: dphi {dphi:?} vs dual {dual:?}"
                );
                assert!(
                    (dphi - fd).amax() <= 1e-6 * scale,
                    "{dissipation:?} {depth} {vn}: dphi {dphi:?} vs fd {fd:?}"
                );
                for k in 0..3 {
                    let mut e = Vector3::zeros();
                    e[k] = 1.0;
                    let dual: Vector3<f64> = point_plane_force(
                        &r.map(Dual64::from),
                        &n.map(Dual64::from),
                        &(v.map(Dual64::from) + e.map(|x| Dual64::new(0.0, x))),
                        &prm.lift(),
                    )
                    .map(|x| x.eps);
                    let h = 1e-7 * v.norm().max(0.01);
                    let fd = (point_plane_force(&r, &n, &(v + e * h), &prm)
                        - point_plane_force(&r, &n, &(v - e * h), &prm))
                        / (2.0 * h);
                    assert!(
                        (dv.column(k) - dual).amax() <= 1e-12 * scale,
                        "{dissipation:?} {depth} {vn}: dv[{k}] {:?} vs dual {dual:?}",
                        dv.column(k)
                    );
                    assert!(
                        (dv.column(k) - fd).amax() <= 1e-6 * scale,
                        "{dissipation:?} {depth} {vn}: dv[{k}] {:?} vs fd {fd:?}",
                        dv.column(k)
                    );
                }
            }
        }
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

//! The soft-minimum contact model (paper, Methods B; docs/method.md): the point–plane force, and its
//! soft-minimum averages over an SSDF (point–SSDF) and over a separation distribution
//! (SSDF–SSDF), giving the wrench each body of a pair receives.
//!
//! Naming follows `quantity_shape1_shape2`: [`point_plane_force`] is the force between a point
//! and a plane, [`pair_contact`] the contact between two colliders.

use crate::collision::{
    band_of, pair_relatives, separation_field_naive, terms_budget, BandWork, CandidateMemo,
    Collider, Frame, Relative, Scratch, SeparationBand, SeparationDistribution,
};
use crate::geometry::ssdf::{ssdf_over, NoSink, Relevant, SpringShape};
use crate::geometry::Aopc;
use crate::scalar::{c, lift3, re3, smooth_norm, softplus, Scalar};
use nalgebra::{Matrix3, Vector3};

#[cfg(test)]
mod chain_tests;
#[cfg(test)]
mod distance_tests;
mod jacobian;
mod params;
mod point;
#[cfg(test)]
mod pull_tests;
#[cfg(test)]
mod surface_tests;
mod tape;
#[cfg(test)]
mod tape_tests;
#[cfg(test)]
mod tests;

use jacobian::pair_contact_chained;
pub use jacobian::{pair_jacobian, point_plane_force_jacobian, PAIR_OUTPUTS, SIDE_INPUTS};
pub use params::{eps1_scale, eps1_sides, ContactParams, Dissipation, Param, EPS1_SPACING};
pub(crate) use point::{
    half_space_force, logistic, point_force, point_force_naive, sliding_velocity, ForceSink,
    NoForceSink, PlaneTerm, PointForce, SoftAverage,
};
pub use point::{point_plane_force, point_plane_force_at};
pub use tape::{PairTape, Seeds, TAPE_TERMS_PER_POINT};

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

impl<T: Scalar> PairContact<T> {
    /// The contact of a pair that has nothing to collide (a collider missing, or no points):
    /// no wrenches, the distance infinite.
    pub fn none() -> Self {
        PairContact {
            on_a: Wrench::zero(),
            on_b: Wrench::zero(),
            distance: c(f64::INFINITY),
        }
    }
}

/// Accumulated wrenches of one side of a pair (query points of one body against the planes of
/// the other), in the plane body's frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct SideSums<T: Scalar> {
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

    /// The pair's wrenches `[on_a, on_b]` (world frame) from its two sides' sums: side 0's
    /// (points of `a` in the frame of `b`, `fb`) and side 1's (points of `b`, frame `fa`).
    fn wrenches(sums: [SideSums<T>; 2], fa: &Frame<T>, fb: &Frame<T>) -> [Wrench<T>; 2] {
        let (mut on_a, mut on_b) = (Wrench::zero(), Wrench::zero());
        let [s0, s1] = sums;
        s0.finish(fb, true, &mut on_a, &mut on_b);
        s1.finish(fa, false, &mut on_a, &mut on_b);
        [on_a, on_b]
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
pub(super) fn for_each_force<T: Scalar>(
    a: &Collider,
    b: &Collider,
    rels: &[Relative<T>; 2],
    band: &SeparationBand<T>,
    dist: &SeparationDistribution<T>,
    weights: &[T],
    prm: &ContactParams<T>,
    bounds: &mut Vec<(usize, f64)>,
    mut eval: impl FnMut(usize) -> f64,
) {
    let prm_re = prm.re();
    let cutoff = dist.min + band.margin * dist.eps.re();
    let fric = (1.0 + prm_re.friction * prm_re.friction).sqrt();
    let inv_vd = 1.0 / prm_re.dissipation_velocity.abs();
    let norm = dist.normaliser.re();
    // Per side, real parts: the relative motion and the query AOPC.
    let sides: [Option<(Relative<f64>, &Aopc)>; 2] =
        [(a, &rels[0]), (b, &rels[1])].map(|(q, rel)| {
            let Collider::Aopc(s) = q else { return None };
            Some((rel.re(), s))
        });
    bounds.clear();
    for (i, e) in band.entries.iter().enumerate() {
        let phi = e.phi.re();
        if phi > cutoff {
            continue;
        }
        let Some((rel, s)) = &sides[e.side as usize] else {
            continue;
        };
        let w = weights[i].re() / norm;
        // With adhesion the bound's stiffness and margin (departure 7).
        let spring = prm_re.bound_stiffness() * e.springs;
        if w == 0.0 || spring == 0.0 {
            continue; // zero or subnormal (doc of `pair_contact`)
        }
        let arm = rel.rotation * s.bvh().points[e.k as usize];
        let v_point = rel.linvel + rel.angvel.cross(&arm);
        let speed = sliding_velocity(&(arm + rel.translation), &v_point, &rel.angvel_planes).norm();
        bounds.push((i, w * spring * (1.0 + speed * inv_vd) * fric));
    }
    let Some(first) = (0..bounds.len()).max_by(|&x, &y| bounds[x].1.total_cmp(&bounds[y].1)) else {
        return;
    };
    let tol = crate::collision::pair_tolerance(a, b) / bounds.len() as f64;
    let mut largest = eval(bounds[first].0);
    for (j, &(i, bound)) in bounds.iter().enumerate() {
        if j != first && bound >= tol * largest {
            largest = largest.max(eval(i));
        }
    }
}

/// The SSDF terms at `x` against the planes of `o` (each relevant plane's leaf-order index and
/// softmax weight, in summation order), found again for a band entry whose terms the band did
/// not keep (past its budget): the same relevant set, whichever way it is found, and the same
/// weights as the band's walk found, so the same bits. Used by the live evaluation
/// ([`pair_sides`]) and the tape's replay alike; `again` holds them.
pub(super) fn terms_again<'t, T: Scalar>(
    o: &Aopc,
    x: &Vector3<T>,
    eps1: T,
    scratch: &mut Relevant,
    again: &'t mut Vec<(u32, T)>,
) -> &'t [(u32, T)] {
    scratch.find(o, &re3(x), eps1.re(), usize::MAX);
    again.clear();
    let low = f64::NEG_INFINITY;
    let terms = Some(&mut *again);
    ssdf_over(
        o,
        x,
        eps1,
        SpringShape::NONE,
        low,
        scratch,
        &mut NoSink,
        terms,
    );
    again
}

/// What [`pair_sides`] leaves besides the wrenches: the band, its distribution, and (for
/// derivatives) the entries whose force was evaluated.
pub(super) struct PairParts<T: Scalar> {
    sums: [SideSums<T>; 2],
    band: SeparationBand<T>,
    dist: SeparationDistribution<T>,
}

/// The SSDF–SSDF contact of a pair in the plane frames of both sides (module documentation of
/// [`pair_contact`]), given each body's motion in the other's frame. `on_force(i, W_f, F, s)`
/// is called for every evaluated point force (entry `i` of the band) with the sink that saw its
/// terms (made by `sink()`); `work`: what the band walk works with ([`BandWork`]: its
/// `grads` receive `∇Φ_f` of every band entry, its `memo` is the pair's candidate planes kept
/// across calls, [`CandidateMemo`]; its `keep_terms`, how many SSDF terms the band keeps,
/// [`terms_budget`] but in tests, where the entries past it sum theirs again); its scratch
/// serves the force loop too.
pub(super) fn pair_sides<T: Scalar, S: ForceSink>(
    a: &Collider,
    b: &Collider,
    rels: &[Relative<T>; 2],
    prm: &ContactParams<T>,
    work: BandWork<'_>,
    mut sink: impl FnMut() -> S,
    mut on_force: impl FnMut(usize, T, &PointForce<T>, S),
) -> PairParts<T> {
    let BandWork {
        keep_terms,
        scratch,
        grads,
        memo,
    } = work;
    let band = band_of(
        a,
        b,
        rels,
        prm.eps1_sides(),
        prm.eps2,
        SpringShape {
            eps3: prm.eps3.re(),
            margin: prm.bound_margin(),
        },
        BandWork {
            keep_terms,
            scratch: &mut *scratch,
            grads,
            memo,
        },
    );
    let (dist, weights) = SeparationDistribution::from_band_weights(&band, prm.eps2);
    let mut sums = [SideSums::zero(), SideSums::zero()];
    if !dist.min.is_finite() {
        return PairParts { sums, band, dist };
    }
    let mut bounds = Vec::with_capacity(band.entries.len());
    // The terms of an entry past the band's term budget, summed again (one entry at a time).
    let mut again = Vec::new();
    let eps1 = prm.eps1_sides();
    for_each_force(a, b, rels, &band, &dist, &weights, prm, &mut bounds, |i| {
        let e = &band.entries[i];
        let side = e.side as usize;
        let (query, planes) = if side == 0 { (a, b) } else { (b, a) };
        let Collider::Aopc(s) = query else { return 0.0 };
        let rel = &rels[side];
        let arm = rel.rotation * lift3::<T>(&s.bvh().points[e.k as usize]);
        let x = arm + rel.translation;
        let v = rel.linvel + rel.angvel.cross(&arm);
        // The SSDF's terms, kept by the band for the entries within its cutoff up to its
        // budget; past it, the same relevant set (whichever way it is found) and the same
        // weights, so the same bits.
        let terms = match (e.terms, planes) {
            (Some((from, to)), _) => &band.terms[from as usize..to as usize],
            (None, Collider::HalfSpace { .. }) => &[],
            (None, Collider::Aopc(o)) => {
                terms_again(o, &x, eps1[side], &mut scratch.relevant, &mut again)
            }
        };
        let mut snk = sink();
        let pf = point_force(planes, &x, &v, rel, prm, terms, &mut snk);
        let w = weights[i] / dist.normaliser;
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
/// `W_f G_f` to the torques), where `F_f = Σ_i σ_i λ_i` is its point–SSDF force at the query
/// point `x_f` and `G_f = x_f × F_f`. Each `|λ_i| = c_i d(s_i) |n_i - μ u_i|` with the spring
/// `c_i = k s⁺_ε3(m - φ_i)` (`m` the pair's margin), `d(s) ≤ 1 + max(0, -s) ≤ 1 + V_f/v_d` (`V_f`
/// the speed at which `x_f` slides on the plane body, the same for every plane)
/// and `|n_i - μ u_i| ≤ √(1 + μ²)` (`u_i ⊥ n_i`, `|u_i| < 1`), so
/// `|F_f| ≤ Λ_f := k B_f (1 + V_f/v_d) √(1 + μ²)` and `|G_f| ≤ Λ_f |x_f|`, with
/// `B_f ≥ Σ_i σ_i s⁺_ε3(m - φ_i)` bounded while the SSDF is summed ([`BandEntry::springs`](crate::collision::BandEntry::springs)).
/// An entry is skipped when its separation weight is below the band's cutoff, when `W_f Λ_f`
/// is zero in `f64` (every term's `w_i e^{(m - φ_i)/ε3}` is below e^-745, so its force is zero or
/// subnormal: `B_f < I ε3 e^-745`), or when
/// `W_f Λ_f < (τ/N) M`, `M` the largest summand `W_g |F_g|` evaluated so far (the entry with
/// the largest bound is evaluated first) and `N` the number of entries within the cutoff: each
/// skipped summand is below the relative weight τ/N of the largest, and all of them together
/// change the force by less than `τ M`, the torques by less than `τ M` times the largest lever
/// (`|arm_f|` on the query body, `|x_f|` on the plane body: for a half-space, the contact's
/// distance from its body's origin).
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
    pair_contact_memo(a, fa, b, fb, prm, None, &mut Scratch::default())
}

/// The smooth separation distance `D = Wᵀ Φ` of the pair `a`–`b` alone: the same bits as
/// [`pair_contact`]'s `distance` (the same band, whose entries do not depend on what else the
/// walk bounds or keeps), without the point forces, the springs' bounds or the SSDF terms kept
/// for them. What an output of the distance needs for a pair the proofs left out: on
/// gymnasium's humanoid, the forces were about a third of such an evaluation
/// (docs/fmu.md, "What an output read costs"). The walks work in `scratch`.
pub fn pair_distance<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    prm: &ContactParams<T>,
    scratch: &mut Scratch,
) -> T {
    let rels = pair_relatives(fa, fb, prm.surface.as_ref());
    let band = band_of(
        a,
        b,
        &rels,
        prm.eps1_sides(),
        prm.eps2,
        SpringShape::NONE,
        BandWork::bare(scratch),
    );
    SeparationDistribution::from_band_weights(&band, prm.eps2)
        .0
        .distance
}

/// The sizes of a pair's point forces added up, `Σ_f W_f |F_f|` over both sides (N), in `f64`:
/// with nothing moving, at most the pressing its friction acts on (each plane's spring; the
/// planes of one point may push it different ways), where the net force of [`pair_contact`]
/// can cancel. Of two bodies stacked axis on axis, the points under one's edge
/// weigh its side planes, which push them sideways, in every direction round the edge, and the
/// net force keeps none of it (docs/mjcf.md, "Contact on, against MuJoCo's spread"); where
/// every point force is parallel (a box resting flat) it is the net force's size.
pub fn pair_pressing(
    a: &Collider,
    fa: &Frame<f64>,
    b: &Collider,
    fb: &Frame<f64>,
    prm: &ContactParams<f64>,
) -> f64 {
    let rels = pair_relatives(fa, fb, prm.surface.as_ref());
    let mut pressing = 0.0;
    pair_sides(
        a,
        b,
        &rels,
        prm,
        BandWork {
            keep_terms: terms_budget(a, b),
            scratch: &mut Scratch::default(),
            grads: None,
            memo: None,
        },
        || NoForceSink,
        |_, w, pf, _| pressing += w * pf.force.norm(),
    );
    pressing
}

/// [`pair_contact`] with the pair's candidate planes kept from one call to the next in `kept`
/// ([`CandidateMemo`]): the same contact to the last bit, at less cost while the bodies move
/// little between calls. The chain rule's path (first-order duals) does not use them; it keeps
/// there its hand-derived Jacobian with the real inputs it was taken at, and takes it again
/// only at other inputs (the passes of one Jacobian of dual numbers share it). The hierarchy
/// walks work in `scratch`.
pub fn pair_contact_memo<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    prm: &ContactParams<T>,
    kept: Option<&mut CandidateMemo>,
    scratch: &mut Scratch,
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
    .chain(&prm.pull)
    .all(|x| x.is_constant());
    // The hand-derived Jacobian is the paper's law's: a moving surface's flow (departure 8)
    // takes the path of every other scalar.
    if T::FIRST_ORDER && constant && prm.surface.is_none() {
        let linearized = kept.map(|k| &mut k.linearized);
        pair_contact_chained(a, fa, b, fb, prm, linearized, scratch)
    } else {
        pair_contact_generic_memo(a, fa, b, fb, prm, kept, scratch)
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
    pair_contact_generic_memo(a, fa, b, fb, prm, None, &mut Scratch::default())
}

/// [`pair_contact_generic`] with kept candidate planes ([`pair_contact_memo`]).
fn pair_contact_generic_memo<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    prm: &ContactParams<T>,
    kept: Option<&mut CandidateMemo>,
    scratch: &mut Scratch,
) -> PairContact<T> {
    let rels = pair_relatives(fa, fb, prm.surface.as_ref());
    let parts = pair_sides(
        a,
        b,
        &rels,
        prm,
        BandWork {
            keep_terms: terms_budget(a, b),
            scratch,
            grads: None,
            memo: kept,
        },
        || NoForceSink,
        |_, _, _, _| {},
    );
    let [on_a, on_b] = SideSums::wrenches(parts.sums, fa, fb);
    PairContact {
        on_a,
        on_b,
        distance: parts.dist.distance,
    }
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
    let field = separation_field_naive(a, fa, b, fb, prm.eps1_sides());
    let dist = SeparationDistribution::new(&field, prm.eps2);
    let (mut on_a, mut on_b) = (Wrench::zero(), Wrench::zero());
    if !dist.min.is_finite() {
        return PairContact {
            on_a,
            on_b,
            distance: dist.distance,
        };
    }
    let rels = pair_relatives(fa, fb, prm.surface.as_ref());
    // The ε1 of b's planes (read by a's points) and of a's.
    let [of_b, of_a] = prm.eps1_sides();
    for (query, rel, planes, pf, phis, q_is_a, eps1) in [
        (a, &rels[0], b, fb, &field.of_a, true, of_b),
        (b, &rels[1], a, fa, &field.of_b, false, of_a),
    ] {
        let Collider::Aopc(s) = query else { continue };
        let mut sums = SideSums::zero();
        for (p, &phi) in s.points.iter().zip(phis) {
            let arm = rel.rotation * lift3::<T>(p);
            let x = arm + rel.translation;
            let v = rel.linvel + rel.angvel.cross(&arm);
            let pf = point_force_naive(planes, &x, &v, rel, prm, eps1);
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

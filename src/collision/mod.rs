//! Soft collision detection (paper, Methods A.3; docs/method.md): the separation field of two
//! colliders, the separation distribution over it and the smooth separation distance.
//!
//! Two evaluations, as for the SSDF:
//! - [`separation_field`] + [`SeparationDistribution::new`]: every point of both bodies (the
//!   reference; memory O(I1 + I2), one scalar per point);
//! - [`separation_band`]: only the points whose weight in the separation distribution can
//!   matter, found by walking each body's bounding-volume hierarchy and proving, node by node,
//!   that the other body's SSDF is large over a whole node ([`ssdf_exceeds`]).
//!
//! # The band bound
//! Let `Φ_best` be the smallest field value evaluated so far (so `Φ_min ≤ Φ_best`),
//! `N = I1 + I2` and `M2 = ln(N/τ)` with `τ` = [`PRUNE_TOLERANCE`]. A node of query points is
//! skipped only once it is proven that `Φ_f > Φ_best + M2 ε2` for each of its points, so the
//! weight of each skipped point relative to the largest is below `e^{-M2} = τ/N` (docs/method.md, numerical rules), and
//! all of them together below τ. Each skipped point also has `Φ_f - Φ_min = s ε2` with
//! `s > M2`, so its share of `D = WᵀΦ` is `W_f |Φ_f - D| ≤ e^{-s} (s ε2 + |D - Φ_min|)`, and all
//! of them change `D` by less than `τ (M2 ε2 + 2|D - Φ_min|)`. Because every skipped point lies
//! above `Φ_best + M2 ε2`, the smallest evaluated value is the true `Φ_min`, so the softmax
//! shift is the same as the reference's.
//!
//! Evaluated points that end above the final cutoff `Φ_min + M2 ε2` are left out of the band
//! as skipped points are (the same bound covers them). The band is then the points within the
//! cutoff, in the walk's order, which the poses alone fix: whichever sound proofs skipped the
//! rest, and whatever was kept from earlier steps ([`CandidateMemo`]: a point proven above
//! the cutoff by its kept ball is not evaluated, a node whose proof keeps failing is not tried
//! at every step), the band and every sum over it are the same to the last bit.

use crate::geometry::ssdf::{ssdf_over, GradientSink, NoSink, Relevant, SpringShape};

/// SSDF terms a pair keeps per point of its two clouds, at most: the separation band keeps its
/// entries' terms ([`SeparationBand::terms`]) up to `TERMS_PER_POINT (I1 + I2)`, and an entry
/// past that has its terms summed again when its force is evaluated (the same terms, the same
/// bits). Without the budget the kept terms are the band's points times their relevant planes,
/// which reaches `I1 I2` where `ε1` is wide against the clouds (two 2 cm finger links sampled
/// at 0.2 mm: 7·10⁷ terms); the paper's memory is `O(I1 + I2)`.
pub const TERMS_PER_POINT: usize = 32;

/// The term budget of a pair of colliders ([`TERMS_PER_POINT`]).
pub fn terms_budget(a: &Collider, b: &Collider) -> usize {
    TERMS_PER_POINT * (a.len() + b.len()).max(1)
}
use crate::geometry::{ssdf, ssdf_naive, Aopc};
use crate::scalar::{c, lift3, re, Scalar, PRUNE_TOLERANCE};
use nalgebra::{Matrix3, Vector3};

mod band;
mod bounds;
mod memo;
mod proof;
mod reach;
mod scratch;
mod settle;
mod shapes;
#[cfg(test)]
mod tests;
mod topk;

pub(crate) use band::{band_of, BandWork};
pub use band::{separation_band, BandEntry, SeparationBand};
pub use bounds::{ssdf_exceeds, ssdf_exceeds_over, QueryRegion};
pub use memo::{
    CandidateMemo, Linearized, MemoCounts, PairCarry, CANDIDATES_PER_POINT, PROOF_RETRY,
    UNUSED_WALKS,
};
pub use proof::{
    out_of_reach_proven, reach_distance, reach_proof_holds, ProofSide, ReachProof, FLOOR_ROOM_LIVES,
};
pub use reach::{
    cloud_beyond, out_of_reach, out_of_reach_by, reach_budget, Beyond, ReachParams, ReachQuestion,
    Seed, REACH_BUDGET,
};
pub use scratch::Scratch;
pub use topk::{contact_points, TOPK_TEMPERATURE};

/// What a body collides with: its AOPC, or (for planes) an exact half-space.
#[derive(Clone, Debug, PartialEq)]
pub enum Collider {
    /// A closed surface sampled as an oriented point cloud (body frame).
    Aopc(Aopc),
    /// The half-space below the plane through `point` with outward `normal` (body frame). Its
    /// SSDF is exact: `nᵀ(p - point)`; it contributes no points to the separation field.
    HalfSpace {
        /// A point on the plane (m).
        point: Vector3<f64>,
        /// Outward unit normal.
        normal: Vector3<f64>,
    },
}

/// The pruning tolerance `τ` of a pair's separation band and point forces: the smaller of its
/// clouds' ([`Collider::tolerance`]; a scene gives all its clouds the same), or
/// [`PRUNE_TOLERANCE`] between two half-spaces.
pub fn pair_tolerance(a: &Collider, b: &Collider) -> f64 {
    match (a.tolerance(), b.tolerance()) {
        (Some(x), Some(y)) => x.min(y),
        (Some(x), None) | (None, Some(x)) => x,
        (None, None) => PRUNE_TOLERANCE,
    }
}

impl Collider {
    /// Number of points the collider contributes to a separation field.
    pub fn len(&self) -> usize {
        match self {
            Collider::Aopc(s) => s.len(),
            Collider::HalfSpace { .. } => 0,
        }
    }

    /// The pruning tolerance of its softmax sums and of the contacts its points make
    /// ([`Aopc::tolerance`]); `None` for a half-space, which has none.
    pub fn tolerance(&self) -> Option<f64> {
        match self {
            Collider::Aopc(s) => Some(s.tolerance()),
            Collider::HalfSpace { .. } => None,
        }
    }

    /// Whether it contributes no points (a half-space, or an empty AOPC).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Signed distance (soft for an AOPC, exact for a half-space) of a point in the collider's
    /// frame (pruned SSDF, exact to the bound of [`mod@crate::geometry::ssdf`]).
    pub fn signed_distance<T: Scalar>(&self, p: &Vector3<T>, eps1: T) -> T {
        match self {
            Collider::Aopc(s) => ssdf(s, p, eps1),
            Collider::HalfSpace { point, normal } => {
                (p - point.map(c::<T>)).dot(&normal.map(c::<T>))
            }
        }
    }

    /// A distance `phi` read at `x` (the collider's frame) raised to the floor of the
    /// collider's bounding polytope ([`crate::geometry::polytope`]): the separation field's
    /// entry. A half-space, or a cloud without a polytope, leaves it as it is.
    pub fn raise<T: Scalar>(&self, x: &Vector3<T>, phi: T) -> T {
        match self {
            Collider::Aopc(s) => match &s.bvh().polytope {
                Some(p) => p.floor(x).raise(phi).0,
                None => phi,
            },
            Collider::HalfSpace { .. } => phi,
        }
    }

    /// [`Collider::signed_distance`] summed over every point (the reference).
    pub fn signed_distance_naive<T: Scalar>(&self, p: &Vector3<T>, eps1: T) -> T {
        match self {
            Collider::Aopc(s) => ssdf_naive(s, p, eps1),
            Collider::HalfSpace { .. } => self.signed_distance(p, eps1),
        }
    }
}

/// Pose and velocity of a body, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame<T: Scalar> {
    /// Orientation: world coordinates of the body axes (columns).
    pub rotation: Matrix3<T>,
    /// Position of the body origin (m).
    pub origin: Vector3<T>,
    /// Velocity of the body origin (m/s).
    pub linvel: Vector3<T>,
    /// Angular velocity (rad/s).
    pub angvel: Vector3<T>,
}

/// Motion of a query body seen from a plane body, in the plane body's frame.
#[derive(Clone, Copy, Debug)]
pub struct Relative<T: Scalar> {
    /// Rotation from query-body to plane-body coordinates.
    pub rotation: Matrix3<T>,
    /// Query-body origin in plane-body coordinates.
    pub translation: Vector3<T>,
    /// Velocity of the query-body origin relative to the plane-body origin.
    pub linvel: Vector3<T>,
    /// Angular velocity of the query body.
    pub angvel: Vector3<T>,
    /// Angular velocity of the plane body.
    pub angvel_planes: Vector3<T>,
    /// The moving surfaces' velocity field (MuJoCo's geom `surfacevel`; docs/method.md,
    /// departure 8): the query body's surface material relative to the plane body's, `l + w × x`
    /// at a point `x` (plane body's frame); `None` where neither body's surface moves.
    pub surface: Option<Twist<T>>,
}

/// A velocity field of rigid motion, `lin + ang × x` at a point `x` of the frame it is written
/// in: how a moving surface's material flows (MuJoCo's geom `surfacevel`, in its body's frame),
/// or two such flows' difference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Twist<T> {
    /// The field's value at the frame's origin (m/s).
    pub lin: Vector3<T>,
    /// Its angular velocity (rad/s).
    pub ang: Vector3<T>,
}

impl<T: Scalar> Twist<T> {
    /// The field's value at `x`.
    #[inline]
    pub fn at(&self, x: &Vector3<T>) -> Vector3<T> {
        self.lin + self.ang.cross(x)
    }
}

impl Relative<f64> {
    /// A placeholder for the side of a pair whose query body has no points (a half-space):
    /// identity pose, at rest. Nothing reads it.
    pub fn unread() -> Self {
        Relative {
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
            linvel: Vector3::zeros(),
            angvel: Vector3::zeros(),
            angvel_planes: Vector3::zeros(),
            surface: None,
        }
    }
}

impl<T: Scalar> Relative<T> {
    /// Real parts.
    pub fn re(&self) -> Relative<f64> {
        Relative {
            rotation: self.rotation.map(|x| x.re()),
            translation: crate::scalar::re3(&self.translation),
            linvel: crate::scalar::re3(&self.linvel),
            angvel: crate::scalar::re3(&self.angvel),
            angvel_planes: crate::scalar::re3(&self.angvel_planes),
            surface: self.surface.map(|f| Twist {
                lin: crate::scalar::re3(&f.lin),
                ang: crate::scalar::re3(&f.ang),
            }),
        }
    }

    /// This motion with the surface flows of the query body (`query`, in its frame) and of the
    /// plane body (`planes`, in its frame): the query body's field carried into the plane
    /// body's frame, `R l_q - (R w_q) × t + (R w_q) × x`, less the plane body's,
    /// `l_p + w_p × x`.
    pub fn with_surfaces(mut self, query: &Twist<f64>, planes: &Twist<f64>) -> Self {
        let w = self.rotation * lift3::<T>(&query.ang);
        let lin = self.rotation * lift3::<T>(&query.lin) - w.cross(&self.translation);
        self.surface = Some(Twist {
            lin: lin - lift3::<T>(&planes.lin),
            ang: w - lift3::<T>(&planes.ang),
        });
        self
    }
}

/// The two sides' motions of a pair of bodies with frames `fa` and `fb` (`a`'s points against
/// `b`'s planes, then `b`'s against `a`'s), with the bodies' surface flows `surfaces` (`a`'s,
/// `b`'s, each in its body's frame) where a surface moves.
pub fn pair_relatives<T: Scalar>(
    fa: &Frame<T>,
    fb: &Frame<T>,
    surfaces: Option<&[Twist<f64>; 2]>,
) -> [Relative<T>; 2] {
    let (ra, rb) = (fa.relative_to(fb), fb.relative_to(fa));
    match surfaces {
        None => [ra, rb],
        Some([sa, sb]) => [ra.with_surfaces(sa, sb), rb.with_surfaces(sb, sa)],
    }
}

impl<T: Scalar> Frame<T> {
    /// A body at rest at the world origin (the world itself).
    pub fn identity() -> Self {
        Frame {
            rotation: Matrix3::identity(),
            origin: Vector3::zeros(),
            linvel: Vector3::zeros(),
            angvel: Vector3::zeros(),
        }
    }

    /// Real parts: the frame itself where it is of `f64` (no copy), else [`Frame::re`]. A pair's
    /// proof reads its two bodies' frames at every forward; copying them was a tenth of the
    /// proofs' time on bodies out of reach.
    pub fn real(&self) -> std::borrow::Cow<'_, Frame<f64>> {
        match (self as &dyn std::any::Any).downcast_ref::<Frame<f64>>() {
            Some(f) => std::borrow::Cow::Borrowed(f),
            None => std::borrow::Cow::Owned(self.re()),
        }
    }

    /// Real parts.
    pub fn re(&self) -> Frame<f64> {
        Frame {
            rotation: self.rotation.map(|x| x.re()),
            origin: crate::scalar::re3(&self.origin),
            linvel: crate::scalar::re3(&self.linvel),
            angvel: crate::scalar::re3(&self.angvel),
        }
    }

    /// This body's motion in the world's frame: [`Frame::relative_to`] the world's identity
    /// frame, the same numbers for finite entries (but for a zero's sign) without the products
    /// by the identity
    /// (a pair with the floor: three fifths of `relative_to`'s time on three free bodies were
    /// its matrix products).
    pub fn relative_to_world(&self) -> Relative<T> {
        Relative {
            rotation: self.rotation,
            translation: self.origin,
            linvel: self.linvel,
            angvel: self.angvel,
            angvel_planes: Vector3::zeros(),
            surface: None,
        }
    }

    /// This body's motion in the frame of `planes`. Differences of world positions are taken
    /// once here, so bodies far from the world origin lose no precision in the pair math.
    pub fn relative_to(&self, planes: &Frame<T>) -> Relative<T> {
        let rt = planes.rotation.transpose();
        Relative {
            rotation: rt * self.rotation,
            translation: rt * (self.origin - planes.origin),
            linvel: rt * (self.linvel - planes.linvel),
            angvel: rt * self.angvel,
            angvel_planes: rt * planes.angvel,
            surface: None,
        }
    }
}

/// The separation field `Φ` (paper eq. 14): SSDFs of the points of `a` w.r.t. `b` (`of_a`)
/// followed by those of the points of `b` w.r.t. `a` (`of_b`).
#[derive(Clone, Debug, PartialEq)]
pub struct SeparationField<T> {
    /// `φ̂_b(p_i)` for the points of `a`, in order (m).
    pub of_a: Vec<T>,
    /// `φ̂_a(p'_j)` for the points of `b`, in order (m).
    pub of_b: Vec<T>,
}

impl<T: Scalar> SeparationField<T> {
    /// All entries, `a`'s then `b`'s.
    pub fn iter(&self) -> impl Iterator<Item = &T> + Clone {
        self.of_a.iter().chain(&self.of_b)
    }
}

/// Points of `query` (with frame `fq`) in the frame of the other body `fp`, and their SSDFs
/// with respect to `planes`.
fn field_one_side<T: Scalar>(
    query: &Collider,
    fq: &Frame<T>,
    planes: &Collider,
    fp: &Frame<T>,
    eps1: T,
    naive: bool,
) -> Vec<T> {
    let Collider::Aopc(s) = query else {
        return Vec::new();
    };
    let rel = fq.relative_to(fp);
    s.points
        .iter()
        .map(|p| {
            let x = rel.rotation * p.map(c::<T>) + rel.translation;
            let phi = if naive {
                planes.signed_distance_naive(&x, eps1)
            } else {
                planes.signed_distance(&x, eps1)
            };
            planes.raise(&x, phi)
        })
        .collect()
}

/// Soft collision detection between two colliders: the separation field, every entry (each
/// SSDF pruned to its bound). `eps1` (m²): the ε1 each side reads the other body's planes
/// with (0: `a`'s points against `b`'s planes; [`crate::contact::eps1_sides`]).
pub fn separation_field<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    eps1: [T; 2],
) -> SeparationField<T> {
    SeparationField {
        of_a: field_one_side(a, fa, b, fb, eps1[0], false),
        of_b: field_one_side(b, fb, a, fa, eps1[1], false),
    }
}

/// [`separation_field`] with every SSDF summed over every point (the reference).
pub fn separation_field_naive<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    eps1: [T; 2],
) -> SeparationField<T> {
    SeparationField {
        of_a: field_one_side(a, fa, b, fb, eps1[0], true),
        of_b: field_one_side(b, fb, a, fa, eps1[1], true),
    }
}

/// The separation distribution `W = σ_ε2(-Φ)` (paper eq. 15) without storing it: its
/// normaliser, and the smooth separation distance `D = WᵀΦ`.
#[derive(Clone, Copy, Debug)]
pub struct SeparationDistribution<T: Scalar> {
    /// Smallest entry of the field (real part; the softmax shift).
    pub min: f64,
    /// Temperature ε2 (m).
    pub eps: T,
    /// `Σ exp(-(Φ_f - min)/ε2)`.
    pub normaliser: T,
    /// Smooth separation distance `D` (m).
    pub distance: T,
}

impl<T: Scalar> SeparationDistribution<T> {
    /// Builds the distribution of a field (two streamed passes over it).
    pub fn new(field: &SeparationField<T>, eps2: T) -> Self {
        Self::from_values(field.iter().copied(), eps2)
    }

    /// Builds the distribution of the entries of a [`SeparationBand`].
    pub fn from_band(band: &SeparationBand<T>, eps2: T) -> Self {
        Self::from_values(band.entries.iter().map(|e| e.phi), eps2)
    }

    /// [`SeparationDistribution::from_band`], and each entry's weight before normalisation,
    /// `exp(-(Φ_f - min)/ε2)` (0 where it underflows), computed once for the normaliser and
    /// kept for the forces: `W_f` is that over [`SeparationDistribution::normaliser`].
    pub fn from_band_weights(band: &SeparationBand<T>, eps2: T) -> (Self, Vec<T>) {
        let mut weights = Vec::with_capacity(band.entries.len());
        let dist = Self::build(band.entries.iter().map(|e| e.phi), eps2, |w| {
            weights.push(w)
        });
        weights.resize(band.entries.len(), T::zero());
        (dist, weights)
    }

    /// Builds the distribution of field values (two streamed passes).
    pub fn from_values<I: Iterator<Item = T> + Clone>(values: I, eps2: T) -> Self {
        Self::build(values, eps2, |_| {})
    }

    /// [`SeparationDistribution::from_values`], handing each value's weight before
    /// normalisation to `keep` in order (none when the field is empty).
    fn build<I: Iterator<Item = T> + Clone>(values: I, eps2: T, mut keep: impl FnMut(T)) -> Self {
        let min = values.clone().map(|p| p.re()).fold(f64::INFINITY, f64::min);
        if !min.is_finite() {
            // Empty field, or nothing to collide with: no contact.
            return SeparationDistribution {
                min,
                eps: eps2,
                normaliser: T::one(),
                distance: c(f64::INFINITY),
            };
        }
        let inv = eps2.recip();
        let (mut sum, mut acc) = (T::zero(), T::zero());
        let e2 = eps2.re();
        for phi in values {
            // Past 746 ε2 the weight underflows to exactly 0 (derivatives too): skip exp's slow
            // underflow path; the sums are bit-for-bit the same.
            if phi.re() - min > 746.0 * e2 {
                keep(T::zero());
                continue;
            }
            let w = (-(phi - min) * inv).exp();
            keep(w);
            sum += w;
            acc += w * phi;
        }
        SeparationDistribution {
            min,
            eps: eps2,
            normaliser: sum,
            distance: acc / sum,
        }
    }

    /// `W_f` for entry `f` whose value is `phi`.
    #[inline]
    pub fn weight(&self, _f: usize, phi: T) -> T {
        (-(phi - self.min) / self.eps).exp() / self.normaliser
    }
}

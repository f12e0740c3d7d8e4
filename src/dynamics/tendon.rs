//! Tendons, fixed and spatial (see [`SpatialTendon`] for the latter). Fixed tendons, as MuJoCo
//! defines them: a length `L = Σ cᵢ qᵢ` over slide and hinge joints
//! (`cᵢ` the joint's coefficient), its velocity `L̇ = Σ cᵢ vᵢ`, and a force `F` along the tendon
//! that acts on each joint as `cᵢ F` (the tendon's Jacobian is the coefficient vector, constant).
//!
//! `F` sums, as MuJoCo's passive forces do: a spring `-k x` with `x = L - l_hi` above the spring
//! length's range `[l_lo, l_hi]`, `L - l_lo` below it and zero inside (MuJoCo's deadband; one
//! spring length when `l_lo = l_hi`); a damper `-b L̇`; SCM's smooth dry friction
//! `-F_f L̇ / sqrt(v_s² + L̇²)` (MuJoCo solves a tendon's frictionloss as a constraint, as it
//! does a joint's); and a smooth limit (see [`crate::dynamics::limit`]) on `L`, stiffened by
//! the tendon's effective inertia `1 / (c M⁻¹ cᵀ)` at the reference configuration (MuJoCo's
//! `1 / tendon_invweight0`).

use super::limit::JointLimit;
use super::wrap::{geom_frame, wrap, Wrap, Wrapped};
use crate::collision::Frame;
use crate::contact::Wrench;
use crate::scalar::{c, Scalar};
use nalgebra::Vector3;

/// A fixed tendon.
#[derive(Clone, Debug, PartialEq)]
pub struct FixedTendon {
    /// Name (from the scene, or MuJoCo's `tendonN`).
    pub name: String,
    /// `(position index, velocity index, coefficient)` of each joint.
    pub joints: Vec<(usize, usize, f64)>,
    /// Spring stiffness `k` (N/m or N·m/rad per unit of length).
    pub stiffness: f64,
    /// The spring length's range `[l_lo, l_hi]`: no spring force inside.
    pub spring_length: (f64, f64),
    /// Damping `b`.
    pub damping: f64,
    /// Dry friction `F_f` (smooth, with the contact's stiction velocity).
    pub frictionloss: f64,
    /// Limits on the length, as a joint's are on its coordinate.
    pub limit: Option<JointLimit>,
}

impl FixedTendon {
    /// `L = Σ cᵢ qᵢ`.
    pub fn length<T: Scalar>(&self, q: &[T]) -> T {
        linear_value(&self.joints, q)
    }

    /// `L̇ = Σ cᵢ vᵢ`.
    pub fn velocity<T: Scalar>(&self, v: &[T]) -> T {
        linear_rate(&self.joints, v)
    }

    /// Whether the tendon exerts any force.
    pub fn acts(&self) -> bool {
        self.law().acts()
    }

    /// The force along the tendon at `q`, `v`, with the stiction velocity `v_s`.
    pub fn force<T: Scalar>(&self, q: &[T], v: &[T], stiction_velocity: T) -> T {
        self.law()
            .force(self.length(q), self.velocity(v), stiction_velocity)
    }

    /// The energy stored in the spring and the limit at `q`.
    pub fn energy<T: Scalar>(&self, q: &[T]) -> T {
        self.law().energy(self.length(q))
    }

    /// The force law along the tendon.
    pub fn law(&self) -> TendonLaw {
        TendonLaw {
            stiffness: self.stiffness,
            spring_length: self.spring_length,
            damping: self.damping,
            frictionloss: self.frictionloss,
            limit: self.limit,
        }
    }
}

/// What a tendon does with its length `L` and rate `L̇`, fixed or spatial alike: the force
/// along it (spring with MuJoCo's deadband, damper, smooth dry friction, smooth limit), see the
/// module doc.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TendonLaw {
    /// Spring stiffness `k`.
    pub stiffness: f64,
    /// The spring length's range `[l_lo, l_hi]`: no spring force inside.
    pub spring_length: (f64, f64),
    /// Damping `b`.
    pub damping: f64,
    /// Dry friction `F_f` (smooth, with the contact's stiction velocity).
    pub frictionloss: f64,
    /// Limits on the length.
    pub limit: Option<JointLimit>,
}

impl TendonLaw {
    /// Whether the law gives any force.
    pub fn acts(&self) -> bool {
        self.stiffness != 0.0
            || self.damping != 0.0
            || self.frictionloss != 0.0
            || self.limit.is_some()
    }

    /// The stretch `x` of the spring: past the spring length's range, zero inside.
    fn stretch<T: Scalar>(&self, l: T) -> T {
        let (lo, hi) = self.spring_length;
        if l.re() > hi {
            l - c::<T>(hi)
        } else if l.re() < lo {
            l - c::<T>(lo)
        } else {
            T::zero()
        }
    }

    /// The force along the tendon at length `l` and rate `ldot`, with the stiction velocity.
    pub fn force<T: Scalar>(&self, l: T, ldot: T, stiction_velocity: T) -> T {
        let mut f = -self.stretch(l) * self.stiffness - ldot * self.damping;
        if self.frictionloss > 0.0 {
            f -= ldot * self.frictionloss
                / (stiction_velocity * stiction_velocity + ldot * ldot).sqrt();
        }
        if let Some(limit) = &self.limit {
            f += limit.force(l, ldot);
        }
        f
    }

    /// The energy stored in the spring and the limit at length `l`.
    pub fn energy<T: Scalar>(&self, l: T) -> T {
        let x = self.stretch(l);
        let limit = self.limit.map_or(T::zero(), |lim| lim.energy(l));
        x * x * (0.5 * self.stiffness) + limit
    }
}

/// A spatial tendon as MuJoCo defines it without wrapping: a path through sites whose length is
/// the sum of the straight segments between consecutive sites, each divided by the divisor of
/// the last pulley before it (1 before any). With `u` the unit vector of a segment from point
/// `a` to point `b` and `s` its scale (`1 / divisor`), `∂L/∂b = s u` and `∂L/∂a = -s u`, so the
/// tendon's force `F` (its [`TendonLaw`], with `L̇ = Σ s uᵀ(ḃ - ȧ)`) acts on the two bodies as
/// the point forces `F s u` at `b` and `-F s u` at `a`: the generalized force `Jᵀ F` MuJoCo
/// applies through the tendon's Jacobian. A segment within one body adds to the length but
/// exerts nothing (its forces cancel; MuJoCo leaves it out of the Jacobian). A segment of zero
/// length has no direction: it adds nothing to the rate and exerts nothing (MuJoCo normalizes
/// a zero vector the same way, to no moment).
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialTendon {
    /// Name (from the scene, or MuJoCo's `tendonN`).
    pub name: String,
    /// The straight segments of the path.
    pub segments: Vec<Segment>,
    /// The force law along the tendon.
    pub law: TendonLaw,
}

/// A segment of a spatial tendon between two sites: straight, or wrapped around a sphere or a
/// cylinder ([`Wrap`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// The first site: its body and its point in the body's frame.
    pub from: (usize, Vector3<f64>),
    /// The second site.
    pub to: (usize, Vector3<f64>),
    /// `1 / divisor` of the pulley branch the segment is on.
    pub scale: f64,
    /// The geom the segment wraps around, if any.
    pub wrap: Option<Wrap>,
}

/// A straight piece of a segment: the unit vector from its first point to its second (zero
/// for a piece of zero length), its scaled length and rate, and each end's body and arm from
/// that body's origin.
struct Piece<T: Scalar> {
    unit: Vector3<T>,
    length: T,
    rate: T,
    ends: [(usize, Vector3<T>); 2],
}

/// A point of a body (its index and the point in its frame) in world coordinates: position,
/// velocity and arm from the body's origin.
fn material<T: Scalar>(frames: &[Frame<T>], b: usize, p: &Vector3<T>) -> [Vector3<T>; 3] {
    let f = &frames[b];
    let arm = f.rotation * p;
    [f.origin + arm, f.linvel + f.angvel.cross(&arm), arm]
}

/// The straight piece between two points of bodies `a` and `b` (in their frames), scaled.
fn piece<T: Scalar>(
    frames: &[Frame<T>],
    (a, pa): (usize, Vector3<T>),
    (b, pb): (usize, Vector3<T>),
    scale: f64,
) -> Piece<T> {
    let [xa, va, arm_a] = material(frames, a, &pa);
    let [xb, vb, arm_b] = material(frames, b, &pb);
    let d = xb - xa;
    let n2 = d.dot(&d);
    let ends = [(a, arm_a), (b, arm_b)];
    if n2.re() == 0.0 {
        return Piece {
            unit: Vector3::zeros(),
            length: T::zero(),
            rate: T::zero(),
            ends,
        };
    }
    let n = n2.sqrt();
    let unit = d / n;
    let rate = if a == b {
        T::zero()
    } else {
        unit.dot(&(vb - va)) * scale
    };
    Piece {
        unit,
        length: n * scale,
        rate,
        ends,
    }
}

impl Segment {
    /// The segment's straight pieces (one, or two around a wrapping geom) and the scaled
    /// length along the geom's surface between them (zero for a straight segment).
    fn pieces<T: Scalar>(&self, frames: &[Frame<T>]) -> ([Option<Piece<T>>; 2], T) {
        let lift = |(b, p): (usize, Vector3<f64>)| (b, p.map(c::<T>));
        let (from, to) = (lift(self.from), lift(self.to));
        let straight = || [Some(piece(frames, from, to, self.scale)), None];
        let Some(w) = &self.wrap else {
            return (straight(), T::zero());
        };
        // The sites (and the side site) in the geom's frame.
        let g = &frames[w.body];
        let (rot, origin) = geom_frame(&g.rotation, &g.origin, &w.pose);
        let local =
            |(b, p): (usize, Vector3<T>)| rot.transpose() * (material(frames, b, &p)[0] - origin);
        let side = w.side.map(|s| local(lift(s)));
        match wrap(w.shape, w.radius, &local(from), &local(to), side.as_ref()) {
            None => (straight(), T::zero()),
            Some(Wrapped { points, arc }) => {
                // The tangent points as points of the geom's body.
                let pose = w.pose.to_homogeneous().map(c::<T>);
                let on_body = |t: &Vector3<T>| {
                    let h = pose * t.push(T::one());
                    (w.body, Vector3::new(h.x, h.y, h.z))
                };
                (
                    [
                        Some(piece(frames, from, on_body(&points[0]), self.scale)),
                        Some(piece(frames, on_body(&points[1]), to, self.scale)),
                    ],
                    arc * self.scale,
                )
            }
        }
    }
}

impl SpatialTendon {
    /// The length `L` and its rate `L̇` for the bodies' frames (world frame, with velocities).
    pub fn length_and_rate<T: Scalar>(&self, frames: &[Frame<T>]) -> (T, T) {
        self.segments
            .iter()
            .fold((T::zero(), T::zero()), |(l, r), s| {
                let (pieces, arc) = s.pieces(frames);
                pieces
                    .into_iter()
                    .flatten()
                    .fold((l + arc, r), |(l, r), p| (l + p.length, r + p.rate))
            })
    }

    /// The force along the tendon (positive lengthens it), with the stiction velocity.
    pub fn force<T: Scalar>(&self, frames: &[Frame<T>], stiction_velocity: T) -> T {
        let (l, ldot) = self.length_and_rate(frames);
        self.law.force(l, ldot, stiction_velocity)
    }

    /// Adds the tendon's point forces to the bodies' wrenches (force, and torque about the body
    /// origin, world axes).
    pub fn add_wrenches<T: Scalar>(
        &self,
        frames: &[Frame<T>],
        stiction_velocity: T,
        w: &mut [Wrench<T>],
    ) {
        let f = self.force(frames, stiction_velocity);
        self.add_force_wrenches(frames, f, w);
    }

    /// Adds the point forces of a force `f` along the tendon (positive lengthens it: an
    /// actuator's, or the tendon's own) to the bodies' wrenches.
    pub fn add_force_wrenches<T: Scalar>(&self, frames: &[Frame<T>], f: T, w: &mut [Wrench<T>]) {
        // The segments' pieces again rather than kept: no allocation per step. A piece within
        // one body exerts nothing (its forces cancel).
        for s in &self.segments {
            for p in s.pieces(frames).0.into_iter().flatten() {
                let [(a, arm_a), (b, arm_b)] = p.ends;
                if a == b {
                    continue;
                }
                let force = p.unit * (f * s.scale);
                w[b].force += force;
                w[b].torque += arm_b.cross(&force);
                w[a].force -= force;
                w[a].torque -= arm_a.cross(&force);
            }
        }
    }

    /// The energy stored in the spring and the limit.
    pub fn energy<T: Scalar>(&self, frames: &[Frame<T>]) -> T {
        self.law.energy(self.length_and_rate(frames).0)
    }

    /// The bodies the tendon's length depends on: each segment's two sites' bodies (when they
    /// differ or the segment wraps) and its wrapping geom's and side site's.
    pub fn bodies(&self) -> impl Iterator<Item = usize> + '_ {
        self.segments
            .iter()
            .filter(|s| s.from.0 != s.to.0 || s.wrap.is_some())
            .flat_map(|s| {
                let wrap = s
                    .wrap
                    .iter()
                    .flat_map(|w| std::iter::once(w.body).chain(w.side.map(|(b, _)| b)));
                [s.from.0, s.to.0].into_iter().chain(wrap)
            })
    }
}

/// `Σ cᵢ qᵢ` of a linear coordinate given as `(position index, velocity index, cᵢ)`: a fixed
/// tendon's length, or a joint or tendon equality's coordinate.
pub fn linear_value<T: Scalar>(x: &[(usize, usize, f64)], q: &[T]) -> T {
    x.iter().fold(T::zero(), |s, &(qi, _, c)| s + q[qi] * c)
}

/// `Σ cᵢ vᵢ`: the rate of [`linear_value`].
pub fn linear_rate<T: Scalar>(x: &[(usize, usize, f64)], v: &[T]) -> T {
    x.iter().fold(T::zero(), |s, &(_, vi, c)| s + v[vi] * c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::{first_derivative, Dual64};

    fn tendon() -> FixedTendon {
        FixedTendon {
            name: "t".into(),
            joints: vec![(0, 0, 1.5), (2, 1, -0.5)],
            stiffness: 20.0,
            spring_length: (0.1, 0.3),
            damping: 0.7,
            frictionloss: 0.4,
            limit: Some(JointLimit::from_solref(-0.5, 0.6, [0.02, 1.0], 0.3)),
        }
    }

    #[test]
    fn the_spring_is_the_gradient_of_its_energy() {
        // With zero velocity the force is the spring's and the limit's: -dE/dL along the
        // tendon, checked through q0 (coefficient 1.5) at lengths below, inside and above the
        // deadband and past the upper limit.
        let t = tendon();
        for q0 in [-0.2, 0.1, 0.3, 0.45] {
            let e = |x: Dual64| t.energy(&[x, Dual64::from(0.0), Dual64::from(0.1)]);
            let (_, de) = first_derivative(e, q0);
            let f = t.force(&[q0, 0.0, 0.1], &[0.0, 0.0], 0.01);
            assert!(
                (f * 1.5 + de).abs() < 1e-9 * (1.0 + de.abs()),
                "q0 = {q0}: {f} vs {de}"
            );
        }
    }

    /// Three bodies moving rigidly (a time-dependent translation and rotation each) and a
    /// spatial tendon through them with a pulley and a segment within one body.
    fn strung(t: Dual64) -> (SpatialTendon, Vec<Frame<Dual64>>) {
        let law = TendonLaw {
            stiffness: 30.0,
            spring_length: (0.5, 0.6),
            damping: 0.7,
            frictionloss: 0.2,
            limit: Some(JointLimit::from_solref(0.0, 0.9, [0.02, 1.0], 0.4)),
        };
        let seg = |a: usize, pa: [f64; 3], b: usize, pb: [f64; 3], scale: f64| Segment {
            from: (a, Vector3::from(pa)),
            to: (b, Vector3::from(pb)),
            scale,
            wrap: None,
        };
        let tendon = SpatialTendon {
            name: "s".into(),
            segments: vec![
                seg(0, [0.1, 0.0, 1.0], 1, [0.2, 0.05, 0.0], 1.0),
                seg(1, [-0.1, 0.0, 0.03], 2, [0.0, 0.1, 0.0], 0.5),
                seg(2, [0.0, 0.1, 0.0], 2, [0.05, -0.1, 0.02], 0.5),
            ],
            law,
        };
        let frame = |origin: Vector3<f64>, vel: Vector3<f64>, axis: Vector3<f64>| {
            let scaled = axis.map(|x| Dual64::from(x) * t);
            let rotation = nalgebra::Rotation3::from_scaled_axis(scaled).into_inner();
            let w = axis.map(Dual64::from);
            Frame {
                rotation,
                origin: origin.map(Dual64::from) + vel.map(|x| Dual64::from(x) * t),
                linvel: vel.map(Dual64::from),
                // World angular velocity of a rotation exp(t ω̂) about a fixed axis: ω itself.
                angvel: w,
            }
        };
        let frames = vec![
            frame(Vector3::zeros(), Vector3::zeros(), Vector3::zeros()),
            frame(
                Vector3::new(0.3, 0.0, 0.6),
                Vector3::new(0.4, -0.2, 0.3),
                Vector3::new(0.5, 1.0, -0.3),
            ),
            frame(
                Vector3::new(0.9, 0.1, 0.5),
                Vector3::new(-0.3, 0.5, 0.1),
                Vector3::new(-0.7, 0.2, 0.9),
            ),
        ];
        (tendon, frames)
    }

    #[test]
    fn a_spatial_tendon_pulls_with_its_force_along_its_length() {
        // At a moving pose: the rate is the time derivative of the length (exact, through
        // dual numbers), and the wrenches' power on the bodies' motion is F L̇, the
        // generalized force Jᵀ F seen along any motion; the spring's part is -dE/dL.
        // (Not at t = 0: nalgebra's rotation of a zero angle drops the angle's derivative.)
        for t0 in [0.3, 0.7, 1.1] {
            let (tendon, frames) = strung(Dual64::new(t0, 1.0));
            let (l, ldot) = tendon.length_and_rate(&frames);
            assert!(
                (l.eps - ldot.re).abs() < 1e-12,
                "t = {t0}: {} vs {}",
                l.eps,
                ldot.re
            );
            let f = tendon.force(&frames, Dual64::from(0.01));
            let mut w = vec![Wrench::<Dual64>::zero(); 3];
            tendon.add_wrenches(&frames, Dual64::from(0.01), &mut w);
            let power: f64 = (w.iter().zip(&frames))
                .map(|(w, fr)| (w.force.dot(&fr.linvel) + w.torque.dot(&fr.angvel)).re)
                .sum();
            assert!(
                (power - f.re * ldot.re).abs() < 1e-12 * (1.0 + power.abs()),
                "t = {t0}: power {power} vs F L̇ {}",
                f.re * ldot.re
            );
            assert!(f.re.abs() > 1e-3, "the tendon pulls");
            // The segment within body 2 exerts nothing on it.
            let (mut solo, _) = strung(Dual64::from(t0));
            solo.segments.truncate(2);
            let mut w2 = vec![Wrench::<Dual64>::zero(); 3];
            let fixed = strung(Dual64::from(t0)).1;
            let scale = solo.force(&fixed, Dual64::from(0.01)).re;
            solo.add_wrenches(&fixed, Dual64::from(0.01), &mut w2);
            let full = tendon.force(&fixed, Dual64::from(0.01)).re;
            for b in 0..3 {
                let diff = w[b].force.map(|x| x.re) * (1.0 / f.re)
                    - w2[b].force.map(|x| x.re) * (1.0 / scale);
                assert!(diff.norm() < 1e-9 * (1.0 + full.abs()), "body {b}: {diff}");
            }
        }
        // With no velocity, the spring and limit force is -dE/dL.
        let (tendon, _) = strung(Dual64::from(0.0));
        let law = tendon.law;
        for l in [0.3, 0.55, 0.75, 0.95] {
            let (_, de) = first_derivative(|x: Dual64| law.energy(x), l);
            let f = law.force(l, 0.0, 0.01);
            assert!(
                (f + de).abs() < 1e-9 * (1.0 + de.abs()),
                "L = {l}: {f} vs {de}"
            );
        }
    }

    #[test]
    fn the_damper_and_friction_only_dissipate() {
        let t = FixedTendon {
            stiffness: 0.0,
            limit: None,
            ..tendon()
        };
        for (v0, v1) in [(0.3, -0.2), (-1.0, 0.5), (0.01, 0.0)] {
            let ldot = 1.5 * v0 - 0.5 * v1;
            let f = t.force(&[0.0, 0.0, 0.0], &[v0, v1], 0.01);
            assert!(f * ldot < 0.0, "power {}", f * ldot);
        }
    }
}

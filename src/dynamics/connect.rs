//! MuJoCo's `<equality><connect>` and `<equality><weld>` as springs and dampers between two
//! bodies' points and, for a weld, their orientations (re-exported by
//! [`crate::dynamics::equality`], beside the scalar equalities), with the rows along which
//! MuJoCo's impedance adds its inertia.

use super::equality::Gains;

/// MuJoCo's `<equality><connect>` and `<equality><weld>`: a point of one body held at a point
/// of another (or of the world), as a spring and damper between the two points; a weld also
/// holds the two bodies' relative orientation, by a rotational spring and damper.
///
/// The points are `p₁ = x₁ + R₁ a₁` and `p₂ = x₂ + R₂ a₂`, placed as MuJoCo's compiler places
/// them (for a body connect, `a₂` is where `p₁` is in body 2's frame at `qpos0`; for a body weld,
/// `a₁` is where `p₂` is in body 1's frame), so the error `e = p₁ - p₂` is zero there. The force
/// `F = -(k e + b ė)` acts at `p₁` on body 1 and `-F` at `p₂` on body 2; `k` and `b` come from
/// `solref` and the inertia `1 / (w₁ + w₂)`, with `w` MuJoCo's translational `body_invweight0`.
/// The spring stores `½ k |e|²`.
///
/// The orientation ([`Orientation`], see there) is a spring on the angle between body 1's
/// frame turned by the held relative rotation and body 2's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Connect {
    /// Name (from the scene, or MuJoCo's `equalityN`).
    pub name: String,
    /// Body 1 and the anchor in its frame.
    pub first: (usize, nalgebra::Vector3<f64>),
    /// Body 2 (0: the world) and the anchor in its frame.
    pub second: (usize, nalgebra::Vector3<f64>),
    /// Spring stiffness `k` (N/m), as it acts.
    pub stiffness: f64,
    /// Damping `b` (N·s/m), as it acts.
    pub damping: f64,
    /// The gains the file defines, from which `stiffness` and `damping` act.
    pub gains: Gains,
    /// The inertia added along each of its rows as it acts ([`Gains::added_inertia`]).
    pub impedance: f64,
    /// For a weld, the orientation it holds; `None` for a connect.
    pub orientation: Option<Orientation>,
}

/// The rotational part of a weld: body 1's frame turned by `relative` is held to body 2's.
///
/// With `M = R₁ Q R₂ᵀ` (`Q` the relative rotation; `M = I` when the orientation is held) and
/// `θ` the angle of `M`, the spring stores `E = (κ/2)(3 - tr M) = κ (1 - cos θ)`: a quadratic
/// in MuJoCo's rotational residual, the vector part `r` of the error quaternion, as
/// `|r|² = sin²(θ/2)` makes `E = 2κ |r|²`. Its torque on body 1 is `-(κ/2) vee(M - Mᵀ) =
/// -κ sin θ n` (`n` the axis), and the opposite on body 2. The damper derives from the
/// dissipation function `2β |ṙ|²`, a quadratic in the residual's rate (it takes the power
/// `4β |ṙ|²`): the torque `-(β/4)((3 + tr M) I - M - Mᵀ)(ω₁ - ω₂)` on body 1, `-β (ω₁ - ω₂)`
/// at the held orientation. So for small angles the weld is a torsion spring `κ` and damper
/// `β` on the angle, with `solref`'s time constant whatever MuJoCo's `torquescale` (0 aside);
/// MuJoCo's own stiffness changes with it (see `docs/mjcf.md`).
#[derive(Clone, Debug, PartialEq)]
pub struct Orientation {
    /// The held rotation of body 2's frame seen from body 1's (`R₁ᵀ R₂` when held).
    pub relative: nalgebra::Matrix3<f64>,
    /// Angular stiffness `κ` (N·m/rad), as it acts.
    pub stiffness: f64,
    /// Angular damping `β` (N·m·s/rad), as it acts.
    pub damping: f64,
    /// The gains the file defines, from which `stiffness` and `damping` act.
    pub gains: Gains,
    /// The inertia added along each of its rows as it acts ([`Gains::added_inertia`]).
    pub impedance: f64,
}

impl Orientation {
    /// `M = R₁ Q R₂ᵀ`, world frame.
    fn error<T: crate::scalar::Scalar>(
        &self,
        r1: &nalgebra::Matrix3<T>,
        r2: &nalgebra::Matrix3<T>,
    ) -> nalgebra::Matrix3<T> {
        r1 * self.relative.map(crate::scalar::c::<T>) * r2.transpose()
    }

    /// The torque on body 1 (body 2 takes its opposite), world axes.
    fn torque<T: crate::scalar::Scalar>(
        &self,
        f1: &crate::collision::Frame<T>,
        f2: &crate::collision::Frame<T>,
    ) -> nalgebra::Vector3<T> {
        let m = self.error(&f1.rotation, &f2.rotation);
        let skew = m - m.transpose();
        let vee = nalgebra::Vector3::new(skew[(2, 1)], skew[(0, 2)], skew[(1, 0)]);
        let spring = vee * crate::scalar::c::<T>(-0.5 * self.stiffness);
        if self.damping == 0.0 {
            return spring;
        }
        let w = f1.angvel - f2.angvel;
        let sym = m + m.transpose();
        let scale = w * (m.trace() + 3.0) - sym * w;
        spring + scale * crate::scalar::c::<T>(-0.25 * self.damping)
    }

    /// The spring's energy `(κ/2)(3 - tr M)`.
    fn energy<T: crate::scalar::Scalar>(
        &self,
        r1: &nalgebra::Matrix3<T>,
        r2: &nalgebra::Matrix3<T>,
    ) -> T {
        (crate::scalar::c::<T>(3.0) - self.error(r1, r2).trace()) * (0.5 * self.stiffness)
    }
}

impl Connect {
    /// The two points and their velocities, world frame.
    #[allow(clippy::type_complexity)]
    fn points<T: crate::scalar::Scalar>(
        &self,
        frames: &[crate::collision::Frame<T>],
    ) -> [(
        nalgebra::Vector3<T>,
        nalgebra::Vector3<T>,
        nalgebra::Vector3<T>,
    ); 2] {
        [self.first, self.second].map(|(b, a)| {
            let f = &frames[b];
            let arm = f.rotation * a.map(crate::scalar::c::<T>);
            (f.origin + arm, f.linvel + f.angvel.cross(&arm), arm)
        })
    }

    /// Adds the two point forces, and a weld's torques, to the bodies' wrenches (force, and
    /// torque about the body origin, world axes).
    pub fn add_wrenches<T: crate::scalar::Scalar>(
        &self,
        frames: &[crate::collision::Frame<T>],
        w: &mut [crate::contact::Wrench<T>],
    ) {
        let [(p1, v1, arm1), (p2, v2, arm2)] = self.points(frames);
        let (k, b) = (
            crate::scalar::c::<T>(self.stiffness),
            crate::scalar::c::<T>(self.damping),
        );
        let force = -((p1 - p2) * k + (v1 - v2) * b);
        let (b1, b2) = (self.first.0, self.second.0);
        w[b1].force += force;
        w[b1].torque += arm1.cross(&force);
        w[b2].force -= force;
        w[b2].torque -= arm2.cross(&force);
        if let Some(o) = &self.orientation {
            let torque = o.torque(&frames[b1], &frames[b2]);
            w[b1].torque += torque;
            w[b2].torque -= torque;
        }
    }

    /// Each row of the constraint and the inertia added along it: three for the points' error
    /// `p₁ - p₂` along the world axes, and three more for a weld's rotation (body 1's angular
    /// velocity less body 2's, world axes), as `(row, added inertia)` with `row` `0..6`
    /// ([`Connect::add_row_wrenches`]). Rows without an added inertia are left out.
    pub fn rows(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        let rotation = self.orientation.as_ref().map_or(0.0, |o| o.impedance);
        (0..6)
            .map(move |k| (k, if k < 3 { self.impedance } else { rotation }))
            .filter(|&(k, a)| a > 0.0 && (k < 3 || self.orientation.is_some()))
    }

    /// The rates of its six rows (the points' error along the world axes, then body 1's
    /// angular velocity less body 2's): `Jₖ v` for row `k` of [`Connect::rows`].
    pub fn row_rates<T: crate::scalar::Scalar>(
        &self,
        frames: &[crate::collision::Frame<T>],
    ) -> [T; 6] {
        let [(_, v1, _), (_, v2, _)] = self.points(frames);
        let w = frames[self.first.0].angvel - frames[self.second.0].angvel;
        let d = v1 - v2;
        [d.x, d.y, d.z, w.x, w.y, w.z]
    }

    /// The turning `J̇ₖ v` of its six rows ([`Connect::row_rates`]) given every body's
    /// velocity-product accelerations `bias` ([`crate::dynamics::Tree::bias_accelerations`]):
    /// the points' accelerations at zero joint accelerations, `a + α × r + ω × (ω × r)`, one less
    /// the other, then body 1's angular `α` less body 2's.
    pub fn row_turnings<T: crate::scalar::Scalar>(
        &self,
        frames: &[crate::collision::Frame<T>],
        bias: &[(nalgebra::Vector3<T>, nalgebra::Vector3<T>)],
    ) -> [T; 6] {
        let [(_, _, arm1), (_, _, arm2)] = self.points(frames);
        let point = |b: usize, arm: &nalgebra::Vector3<T>| {
            let (alpha, a) = &bias[b];
            let w = &frames[b].angvel;
            a + alpha.cross(arm) + w.cross(&w.cross(arm))
        };
        let (b1, b2) = (self.first.0, self.second.0);
        let d = point(b1, &arm1) - point(b2, &arm2);
        let alpha = bias[b1].0 - bias[b2].0;
        [d.x, d.y, d.z, alpha.x, alpha.y, alpha.z]
    }

    /// Adds to `w` the wrenches whose generalized force is the transposed row `k` of
    /// [`Connect::rows`]: a unit force along world axis `k` at `p₁` on body 1 and its opposite
    /// at `p₂` on body 2, or (`k ≥ 3`) a unit torque about axis `k - 3` on body 1 and its
    /// opposite on body 2.
    pub fn add_row_wrenches<T: crate::scalar::Scalar>(
        &self,
        frames: &[crate::collision::Frame<T>],
        k: usize,
        w: &mut [crate::contact::Wrench<T>],
    ) {
        let (b1, b2) = (self.first.0, self.second.0);
        let unit = nalgebra::Vector3::from_fn(|i, _| {
            crate::scalar::c::<T>(if i == k % 3 { 1.0 } else { 0.0 })
        });
        if k >= 3 {
            w[b1].torque += unit;
            w[b2].torque -= unit;
            return;
        }
        let [(_, _, arm1), (_, _, arm2)] = self.points(frames);
        w[b1].force += unit;
        w[b1].torque += arm1.cross(&unit);
        w[b2].force -= unit;
        w[b2].torque -= arm2.cross(&unit);
    }

    /// The springs' energy `½ k |e|²`, and a weld's rotational spring's.
    pub fn energy<T: crate::scalar::Scalar>(&self, frames: &[crate::collision::Frame<T>]) -> T {
        let [(p1, _, _), (p2, _, _), ..] = self.points(frames);
        let e = p1 - p2;
        let mut energy = e.dot(&e) * (0.5 * self.stiffness);
        if let Some(o) = &self.orientation {
            energy += o.energy(
                &frames[self.first.0].rotation,
                &frames[self.second.0].rotation,
            );
        }
        energy
    }
}

#[cfg(test)]
mod weld_tests {
    use super::*;
    use crate::collision::Frame;
    use nalgebra::{Rotation3, Vector3};

    fn frame(axis: Vector3<f64>, origin: Vector3<f64>, w: Vector3<f64>) -> Frame<f64> {
        Frame {
            rotation: *Rotation3::new(axis).matrix(),
            origin,
            linvel: Vector3::new(0.1, -0.2, 0.3),
            angvel: w,
        }
    }

    fn weld(damping: f64) -> Connect {
        Connect {
            name: "w".into(),
            first: (1, Vector3::new(0.1, 0.0, -0.2)),
            second: (2, Vector3::new(0.0, 0.3, 0.1)),
            stiffness: 50.0,
            damping,
            gains: Gains::reference(50.0, damping, 1.0),
            impedance: 0.0,
            orientation: Some(Orientation {
                relative: *Rotation3::new(Vector3::new(0.3, -0.5, 0.2)).matrix(),
                stiffness: 7.0,
                damping,
                gains: Gains::reference(7.0, damping, 0.1),
                impedance: 0.0,
            }),
        }
    }

    fn frames() -> Vec<Frame<f64>> {
        vec![
            frame(Vector3::zeros(), Vector3::zeros(), Vector3::zeros()),
            frame(
                Vector3::new(0.4, 0.1, -0.3),
                Vector3::new(0.2, 0.0, 1.0),
                Vector3::new(1.0, -0.5, 0.2),
            ),
            frame(
                Vector3::new(-0.2, 0.9, 0.5),
                Vector3::new(0.5, 0.1, 0.8),
                Vector3::new(-0.3, 0.4, 0.7),
            ),
        ]
    }

    fn wrenches(c: &Connect, f: &[Frame<f64>]) -> Vec<crate::contact::Wrench<f64>> {
        let mut w = vec![crate::contact::Wrench::<f64>::zero(); f.len()];
        c.add_wrenches(f, &mut w);
        w
    }

    #[test]
    fn the_weld_is_the_gradient_of_its_energy() {
        // Turning either body by a small world rotation about each axis, or moving it along
        // each axis, changes the energy by minus the torque (force) times the step: central
        // differences against the analytic wrench, including the far-from-held orientation.
        let c = weld(0.0);
        let f = frames();
        let w = wrenches(&c, &f);
        let h = 1e-6;
        for b in [1, 2] {
            for k in 0..3 {
                let step = |s: f64, turn: bool| {
                    let mut g = f.clone();
                    let d = Vector3::ith(k, s);
                    if turn {
                        g[b].rotation = Rotation3::new(d).matrix() * g[b].rotation;
                    } else {
                        g[b].origin += d;
                    }
                    c.energy(&g)
                };
                let torque = -(step(h, true) - step(-h, true)) / (2.0 * h);
                let force = -(step(h, false) - step(-h, false)) / (2.0 * h);
                assert!(
                    (w[b].torque[k] - torque).abs() < 1e-6,
                    "body {b} torque {k}: {} vs {torque}",
                    w[b].torque[k]
                );
                assert!(
                    (w[b].force[k] - force).abs() < 1e-6,
                    "body {b} force {k}: {} vs {force}",
                    w[b].force[k]
                );
            }
        }
    }

    #[test]
    fn near_the_held_orientation_the_weld_is_a_torsion_spring_and_damper() {
        // Body 2 held where body 1's frame turned by Q puts it, then turned by a small angle θ
        // about n: torque -κ θ n on body 1 to first order, and the damper -β (ω₁ - ω₂).
        let c = weld(3.0);
        let o = c.orientation.as_ref().unwrap();
        let mut f = frames();
        let n = Vector3::new(1.0, 2.0, -2.0) / 3.0;
        let theta = 1e-4;
        f[2].rotation = Rotation3::new(n * theta).matrix() * f[1].rotation * o.relative;
        let m = o.error(&f[1].rotation, &f[2].rotation);
        let spring = o.torque(
            &Frame {
                angvel: Vector3::zeros(),
                ..f[1]
            },
            &Frame {
                angvel: Vector3::zeros(),
                ..f[2]
            },
        );
        assert!(
            (spring - n * (o.stiffness * theta)).norm() < 1e-10 * o.stiffness,
            "{spring} {m}"
        );
        assert!(
            (o.energy(&f[1].rotation, &f[2].rotation) - 0.5 * o.stiffness * theta * theta).abs()
                < 1e-14
        );
        f[2].rotation = f[1].rotation * o.relative;
        let damper = o.torque(&f[1], &f[2]);
        let expected = -(f[1].angvel - f[2].angvel) * o.damping;
        assert!((damper - expected).norm() < 1e-12, "{damper} vs {expected}");
    }

    #[test]
    fn the_weld_damper_only_dissipates() {
        // With the springs off, the power of the wrenches over the bodies' motion is negative,
        // at a held orientation and far from it.
        let mut c = weld(2.0);
        c.stiffness = 0.0;
        c.orientation.as_mut().unwrap().stiffness = 0.0;
        for turn in [0.0, 0.7, 2.5] {
            let mut f = frames();
            let q = c.orientation.as_ref().unwrap().relative;
            f[2].rotation =
                Rotation3::new(Vector3::new(0.0, turn, 0.3 * turn)).matrix() * f[1].rotation * q;
            let w = wrenches(&c, &f);
            let power: f64 = (1..3)
                .map(|b| w[b].force.dot(&f[b].linvel) + w[b].torque.dot(&f[b].angvel))
                .sum();
            assert!(power < 0.0, "turn {turn}: {power}");
        }
    }

    #[test]
    fn a_rows_wrenches_do_the_power_of_its_rate() {
        // The power of row k's wrenches over the bodies' motion is the row times the
        // velocity, the row's rate: the points' error's along axis k, or the relative angular
        // velocity's for a weld's rotation rows.
        let mut c = weld(0.0);
        c.impedance = 2.0;
        c.orientation.as_mut().unwrap().impedance = 0.3;
        let f = frames();
        let rates = c.row_rates(&f);
        let rows: Vec<(usize, f64)> = c.rows().collect();
        assert_eq!(
            rows,
            [(0, 2.0), (1, 2.0), (2, 2.0), (3, 0.3), (4, 0.3), (5, 0.3)]
        );
        for (k, _) in rows {
            let mut w = vec![crate::contact::Wrench::zero(); 3];
            c.add_row_wrenches(&f, k, &mut w);
            let power: f64 = (1..3)
                .map(|b| w[b].force.dot(&f[b].linvel) + w[b].torque.dot(&f[b].angvel))
                .sum();
            let rate = rates[k];
            assert!((power - rate).abs() < 1e-12, "row {k}: {power} vs {rate}");
        }
        // A connect has its three point rows only; rows without inertia are left out.
        c.orientation = None;
        assert_eq!(c.rows().count(), 3);
        c.impedance = 0.0;
        assert_eq!(c.rows().count(), 0);
    }
}

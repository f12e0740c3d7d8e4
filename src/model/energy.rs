//! The mechanical energy of a state ([`Energy`], [`Model::energy`]): what the energy guard
//! balances and the tests of conservation read.

use super::Model;
use crate::dynamics::limit::JointLimit;
use crate::dynamics::{quat_from, quat_log, JointKind, Kinematics};
use crate::scalar::{c, Scalar};

/// Mechanical energy of a state (J).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Energy<T> {
    /// Kinetic energy of the bodies with joints, armature included, and of the inertia
    /// MuJoCo's impedance adds along the equalities' rows (J).
    pub kinetic: T,
    /// Potential energy of gravity, zero at the world origin (J).
    pub gravity: T,
    /// Energy stored in joint springs (J).
    pub springs: T,
}

impl<T: Scalar> Energy<T> {
    /// `kinetic + gravity + springs` (J).
    pub fn total(&self) -> T {
        self.kinetic + self.gravity + self.springs
    }
}

impl Model {
    /// Mechanical energy of a state, computed from the bodies' motion (not from `M`): kinetic
    /// energy `Σ ½ m |v_com|² + ½ ωᵀ I_c ω + Σ ½ armature v²` and the equalities' added inertia's
    /// (`Model::added_kinetic`), gravity `-Σ (1 - gravcomp) m gᵀ
    /// x_com`, springs
    /// `½ k q²` (slide, hinge) and `½ k |θ|²` (ball). Mocap bodies are not counted.
    pub fn energy<T: Scalar>(&self, q: &[T], v: &[T]) -> Energy<T> {
        self.energy_at(&self.tree.kinematics(q, v), q, v)
    }

    /// [`Model::energy`] with the kinematics of `(q, v)` already computed
    /// ([`Tree::kinematics`](crate::dynamics::Tree::kinematics): every mocap body at its scene
    /// pose).
    pub fn energy_at<T: Scalar>(&self, kin: &Kinematics<T>, q: &[T], v: &[T]) -> Energy<T> {
        let g = self.tree.gravity.map(c::<T>);
        let (mut kinetic, mut gravity, mut springs) = (T::zero(), T::zero(), T::zero());
        for (b, body) in self.tree.bodies.iter().enumerate().skip(1) {
            if body.mocap || body.inertia.mass <= 0.0 {
                continue;
            }
            let f = &kin.frames[b];
            let arm = f.rotation * body.inertia.com.map(c::<T>);
            let vcom = f.linvel + f.angvel.cross(&arm);
            let wb = f.rotation.transpose() * f.angvel;
            let m = c::<T>(body.inertia.mass);
            kinetic +=
                m * vcom.dot(&vcom) * 0.5 + wb.dot(&(body.inertia.rot.map(c::<T>) * wb)) * 0.5;
            // Gravity compensation is a conservative force too: it scales the weight.
            gravity -= m * g.dot(&(f.origin + arm)) * (1.0 - body.gravcomp);
        }
        for j in &self.tree.joints {
            for k in 0..j.kind.nv() {
                kinetic += v[j.dadr + k] * v[j.dadr + k] * (0.5 * j.armature);
            }
            match j.kind {
                JointKind::Slide | JointKind::Hinge => {
                    let stretch = q[j.qadr] - c::<T>(j.springref);
                    springs += stretch * stretch * (0.5 * j.stiffness);
                    if let Some(l) = &j.limit {
                        springs += l.energy(q[j.qadr]);
                    }
                }
                JointKind::Ball if j.stiffness != 0.0 => {
                    let th = quat_log(&quat_from(&q[j.qadr..j.qadr + 4]));
                    springs += th.dot(&th) * (0.5 * j.stiffness);
                }
                _ => {}
            }
        }
        kinetic += self.added_kinetic(kin, q, v);
        for t in self.tendons.iter().filter(|t| t.acts()) {
            springs += t.energy(q);
        }
        for e in &self.equalities {
            springs += e.energy(q);
        }
        for c in &self.connects {
            springs += c.energy(&kin.frames);
        }
        for t in self.spatial_tendons.iter().filter(|t| t.law.acts()) {
            springs += t.energy(&kin.frames);
        }
        Energy {
            kinetic,
            gravity,
            springs,
        }
    }

    /// How far the energy count of the limits with an added inertia can still drift at `q`
    /// (J), summed over the joints' and the tendons' limits
    /// ([`JointLimit::load_drift`](crate::dynamics::limit::JointLimit::load_drift)): what the
    /// energy guard counts as stored with the contacts' energy. Zero where no limit has an
    /// added inertia or none is past its onset; the kinematics are computed only for a spatial
    /// tendon's limit that has one.
    pub fn limits_drift(&self, q: &[f64]) -> f64 {
        let drifts = |l: &Option<JointLimit>| l.filter(|l| l.impedance > 0.0);
        let joints: f64 = (self.tree.joints.iter())
            .filter(|j| matches!(j.kind, JointKind::Slide | JointKind::Hinge))
            .filter_map(|j| drifts(&j.limit).map(|l| l.load_drift(q[j.qadr])))
            .sum();
        let fixed: f64 = (self.tendons.iter())
            .filter_map(|t| drifts(&t.limit).map(|l| l.load_drift(t.length(q))))
            .sum();
        let mut frames = None;
        let mut strings = 0.0;
        for t in &self.spatial_tendons {
            let Some(limit) = drifts(&t.law.limit) else {
                continue;
            };
            let frames = frames.get_or_insert_with(|| {
                let v = vec![0.0; self.tree.nv];
                self.tree.kinematics(q, &v).frames
            });
            strings += limit.load_drift(t.length_and_rate(frames).0);
        }
        joints + fixed + strings
    }
}

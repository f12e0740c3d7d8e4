//! The configuration space's Lie-group operations: unit quaternions from slices, their
//! rotation matrices, `exp` and `log`; on a tree's configuration, `q̇` for a velocity, the
//! integration of a velocity over a step, the normalization of its quaternions and the tangent
//! difference of two configurations.

use super::{JointKind, Tree};
use crate::scalar::{c, Scalar};
use nalgebra::{Matrix3, Quaternion, Vector3};

/// Unit quaternion `[w x y z]` of a slice, normalized (so that kinematics stays a rotation for
/// any finite non-zero input, and its derivatives are those of the normalized quaternion).
///
/// A quaternion whose squared norm overflows or underflows (components near 1e200 or 1e-200,
/// which a host may write into a mocap input) is first divided by its largest component, a
/// constant: the unit quaternion and its derivatives are the same, since normalizing undoes
/// any scale. Other quaternions are normalized directly, bit for bit as before.
pub fn quat_from<T: Scalar>(q: &[T]) -> Quaternion<T> {
    let n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    let r = n2.re();
    if !(1e-280..=1e280).contains(&r) {
        let largest = q[..4].iter().fold(0.0f64, |m, x| m.max(x.re().abs()));
        if largest > 0.0 && largest.is_finite() {
            let s: Vec<T> = q[..4].iter().map(|&x| x * (1.0 / largest)).collect();
            let n = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + s[3] * s[3]).sqrt();
            return Quaternion::new(s[0] / n, s[1] / n, s[2] / n, s[3] / n);
        }
    }
    let n = n2.sqrt();
    Quaternion::new(q[0] / n, q[1] / n, q[2] / n, q[3] / n)
}

/// Rotation matrix of a unit quaternion.
pub fn quat_matrix<T: Scalar>(q: &Quaternion<T>) -> Matrix3<T> {
    let (w, x, y, z) = (q.w, q.i, q.j, q.k);
    let two = c::<T>(2.0);
    Matrix3::new(
        T::one() - two * (y * y + z * z),
        two * (x * y - w * z),
        two * (x * z + w * y),
        two * (x * y + w * z),
        T::one() - two * (x * x + z * z),
        two * (y * z - w * x),
        two * (x * z - w * y),
        two * (y * z + w * x),
        T::one() - two * (x * x + y * y),
    )
}

impl Tree {
    /// `q̇` for a velocity `v`: equal to `v` except for quaternions, `q̇ = ½ q ⊗ (0, ω)`, and free
    /// joints' positions, `ṗ = linvel`.
    pub fn qdot<T: Scalar>(&self, q: &[T], v: &[T]) -> Vec<T> {
        let mut out = vec![T::zero(); self.nq];
        for j in &self.joints {
            let (qa, da) = (j.qadr, j.dadr);
            let quat_rate = |out: &mut [T], qi: usize, wi: usize| {
                let qq = Quaternion::new(q[qi], q[qi + 1], q[qi + 2], q[qi + 3]);
                let w = Quaternion::new(T::zero(), v[wi], v[wi + 1], v[wi + 2]);
                let d = qq * w * c::<T>(0.5);
                out[qi..qi + 4].copy_from_slice(&[d.w, d.i, d.j, d.k]);
            };
            match j.kind {
                JointKind::Free => {
                    out[qa..qa + 3].copy_from_slice(&v[da..da + 3]);
                    quat_rate(&mut out, qa + 3, da + 3);
                }
                JointKind::Ball => quat_rate(&mut out, qa, da),
                _ => out[qa] = v[da],
            }
        }
        out
    }

    /// Moves a configuration by a velocity over `h`: on the rotation group for quaternions
    /// (`q ⊗ exp(h ω / 2)`, renormalized), additive otherwise.
    pub fn integrate_q<T: Scalar>(&self, q: &[T], v: &[T], h: T) -> Vec<T> {
        let mut out = q.to_vec();
        for j in &self.joints {
            let (qa, da) = (j.qadr, j.dadr);
            let rotate = |out: &mut [T], qi: usize, wi: usize| {
                let w = Vector3::new(v[wi], v[wi + 1], v[wi + 2]) * h;
                let dq = quat_exp(&w);
                let qq = Quaternion::new(q[qi], q[qi + 1], q[qi + 2], q[qi + 3]) * dq;
                let n = qq.norm();
                out[qi..qi + 4].copy_from_slice(&[qq.w / n, qq.i / n, qq.j / n, qq.k / n]);
            };
            match j.kind {
                JointKind::Free => {
                    for k in 0..3 {
                        out[qa + k] = q[qa + k] + v[da + k] * h;
                    }
                    rotate(&mut out, qa + 3, da + 3);
                }
                JointKind::Ball => rotate(&mut out, qa, da),
                _ => out[qa] = q[qa] + v[da] * h,
            }
        }
        out
    }

    /// Normalizes every quaternion of a configuration in place.
    pub fn normalize_q<T: Scalar>(&self, q: &mut [T]) {
        for j in &self.joints {
            let qi = match j.kind {
                JointKind::Free => j.qadr + 3,
                JointKind::Ball => j.qadr,
                _ => continue,
            };
            let qq = quat_from(&q[qi..qi + 4]);
            q[qi..qi + 4].copy_from_slice(&[qq.w, qq.i, qq.j, qq.k]);
        }
    }
}

/// `exp` of a pure quaternion `(0, θ/2)`: the rotation by the rotation vector `θ`, smooth at
/// `θ = 0` (series for small angles, branching on the real part only).
pub fn quat_exp<T: Scalar>(theta: &Vector3<T>) -> Quaternion<T> {
    let a2 = theta.dot(theta);
    let (cos_half, sinc_half) = if a2.re() < 1e-8 {
        // cos(a/2) and sin(a/2)/a to O(a⁴), exact to 1e-17 here.
        let x = a2 * 0.25;
        (
            T::one() - x * 0.5 + x * x / 24.0,
            (T::one() - x / 6.0 + x * x / 120.0) * 0.5,
        )
    } else {
        let a = a2.sqrt();
        ((a * 0.5).cos(), (a * 0.5).sin() / a)
    };
    Quaternion::new(
        cos_half,
        theta.x * sinc_half,
        theta.y * sinc_half,
        theta.z * sinc_half,
    )
}

/// Rotation vector `θ` of a quaternion (the inverse of [`quat_exp`]): `q = ±exp(θ/2)`, with the
/// sign chosen so that `|θ| ≤ π`. Smooth away from `|θ| = π` (series near `θ = 0`, branching on
/// the real part only). The quaternion need not be normalized.
pub fn quat_log<T: Scalar>(q: &Quaternion<T>) -> Vector3<T> {
    // q and -q are the same rotation: take the one with w ≥ 0 (shortest rotation).
    let q = if q.w.re() < 0.0 { -*q } else { *q };
    let v = Vector3::new(q.i, q.j, q.k);
    let s2 = v.dot(&v);
    let w = q.w;
    // θ = 2 atan2(|v|, w) v/|v|; atan(x)/x = 1 - x²/3 + x⁴/5 - ... for x = |v|/w small.
    let factor = if w.re() > 0.0 && s2.re() < 1e-6 * w.re() * w.re() {
        let x2 = s2 / (w * w);
        (T::one() - x2 / 3.0 + x2 * x2 / 5.0) / w
    } else {
        let s = s2.sqrt();
        s.atan2(w) / s
    };
    v * (factor * 2.0)
}

impl Tree {
    /// Tangent difference `δ = q1 ⊖ q0` (length `nv`), the inverse of
    /// [`integrate_q`](Tree::integrate_q)`(q0, δ, 1)`: differences for scalars and free-joint
    /// positions, body-frame rotation vectors `log(q0⁻¹ ⊗ q1)` for quaternions.
    pub fn difference_q<T: Scalar>(&self, q0: &[T], q1: &[T]) -> Vec<T> {
        let mut out = vec![T::zero(); self.nv];
        for j in &self.joints {
            let (qa, da) = (j.qadr, j.dadr);
            let rot = |out: &mut [T], qi: usize, di: usize| {
                let a = quat_from(&q0[qi..qi + 4]);
                let b = quat_from(&q1[qi..qi + 4]);
                let d = quat_log(&(a.conjugate() * b));
                out[di..di + 3].copy_from_slice(&[d.x, d.y, d.z]);
            };
            match j.kind {
                JointKind::Free => {
                    for k in 0..3 {
                        out[da + k] = q1[qa + k] - q0[qa + k];
                    }
                    rot(&mut out, qa + 3, da + 3);
                }
                JointKind::Ball => rot(&mut out, qa, da),
                _ => out[da] = q1[qa] - q0[qa],
            }
        }
        out
    }
}

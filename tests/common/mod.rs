//! Helpers shared by the integration tests.
#![allow(dead_code)]

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use scm::geometry::Shape;
use std::path::PathBuf;

#[cfg(all(
    any(target_arch = "x86_64", target_arch = "aarch64"),
    target_os = "linux"
))]
pub mod host;

/// Path of a bundled scene.
pub fn scene(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("resources/scenes")
        .join(format!("{name}.xml"))
}

/// Central difference of `f` at `x` along coordinate `k`.
pub fn central_difference(f: impl Fn(&[f64]) -> f64, x: &[f64], k: usize, h: f64) -> f64 {
    let (mut a, mut b) = (x.to_vec(), x.to_vec());
    a[k] += h;
    b[k] -= h;
    (f(&a) - f(&b)) / (2.0 * h)
}

/// A small deterministic generator of uniform numbers in [0, 1) (tests must not depend on
/// the run).
pub struct Lcg(pub u64);

impl Lcg {
    /// Next number in [0, 1).
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64)
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }

    /// A uniformly random unit vector.
    pub fn direction(&mut self) -> nalgebra::Vector3<f64> {
        loop {
            let v = nalgebra::Vector3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let n = v.norm();
            if n > 0.1 && n < 1.0 {
                return v / n;
            }
        }
    }
}

/// Root of an increasing function on `[lo, hi]` by bisection (200 halvings: to the last bit).
pub fn bisect(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The signed distance of a union of posed shapes (the least of theirs) at `x`.
fn union_sdf(geoms: &[(Shape, Isometry3<f64>)], x: &Vector3<f64>) -> f64 {
    geoms
        .iter()
        .map(|(s, p)| s.sdf(&p.inverse_transform_vector(&(x - p.translation.vector))))
        .fold(f64::INFINITY, f64::min)
}

/// How far along `dir` the points `cloud`, turned by `rotation` and moved by `start`, must go to
/// clear the union `geoms` by `gap` (the points' least signed distance, bisected on [0, 1] m).
pub fn offset_to_clear(
    cloud: &[Vector3<f64>],
    rotation: &nalgebra::Matrix3<f64>,
    start: Vector3<f64>,
    dir: Vector3<f64>,
    geoms: &[(Shape, Isometry3<f64>)],
    gap: f64,
) -> f64 {
    let clearance = |d: f64| {
        cloud
            .iter()
            .map(|p| union_sdf(geoms, &(rotation * p + start + dir * d)))
            .fold(f64::INFINITY, f64::min)
    };
    bisect(|d| clearance(d) - gap, 0.0, 1.0)
}

/// Every output of a pair contact (distance, then force and torque on each body) as a flat list.
pub fn pair_outputs<T: scm::scalar::Scalar>(c: &scm::contact::PairContact<T>) -> Vec<T> {
    let mut out = vec![c.distance];
    for w in [&c.on_a, &c.on_b] {
        out.extend(w.force.iter().chain(w.torque.iter()).copied());
    }
    out
}

/// The static balance of the SCM between a plane `z = 0` and an AOPC whose frame origin is at
/// height `z` (m), unrotated, at rest (v = 0, so d = 1 and no friction): the
/// separation-weighted normal force `Σ W_f k s⁺(-Φ_f)`, `Φ_f = z + p_f.z` (N), written out
/// independently of the dynamics code.
pub fn static_lift(
    aopc: &scm::geometry::Aopc,
    prm: &scm::contact::ContactParams<f64>,
    z: f64,
) -> f64 {
    let phis: Vec<f64> = aopc.points.iter().map(|p| z + p.z).collect();
    let min = phis.iter().cloned().fold(f64::INFINITY, f64::min);
    let w: Vec<f64> = phis.iter().map(|f| (-(f - min) / prm.eps2).exp()).collect();
    let sum: f64 = w.iter().sum();
    phis.iter()
        .zip(&w)
        .map(|(f, w)| w / sum * prm.stiffness * scm::scalar::softplus(-f, prm.eps3))
        .sum::<f64>()
}

/// A capsule between two points (body frame), as MuJoCo's `fromto` gives one.
pub fn capsule(a: Vector3<f64>, b: Vector3<f64>, radius: f64) -> (Shape, Isometry3<f64>) {
    let axis = b - a;
    (
        Shape::Capsule {
            radius,
            half_length: axis.norm() / 2.0,
        },
        Isometry3::from_parts(
            Translation3::from((a + b) / 2.0),
            UnitQuaternion::rotation_between(&Vector3::z(), &axis).unwrap(),
        ),
    )
}

/// A sphere at `c` (body frame).
pub fn sphere(c: Vector3<f64>, radius: f64) -> (Shape, Isometry3<f64>) {
    (
        Shape::Sphere { radius },
        Isometry3::translation(c.x, c.y, c.z),
    )
}

/// Gymnasium's humanoid's torso: a capsule, the head's sphere apart from it, and the upper
/// waist's capsule cutting into it.
pub fn humanoid_torso() -> Vec<(Shape, Isometry3<f64>)> {
    let v = Vector3::new;
    vec![
        capsule(v(0.0, -0.07, 0.0), v(0.0, 0.07, 0.0), 0.07),
        sphere(v(0.0, 0.0, 0.19), 0.09),
        capsule(v(-0.01, -0.06, -0.12), v(-0.01, 0.06, -0.12), 0.06),
    ]
}

/// Gymnasium's humanoid's lower arm: a capsule and the hand's sphere, overlapping.
pub fn humanoid_lower_arm() -> Vec<(Shape, Isometry3<f64>)> {
    let v = Vector3::new;
    vec![
        capsule(v(0.01, 0.01, 0.01), v(0.17, 0.17, 0.17), 0.031),
        sphere(v(0.18, 0.18, 0.18), 0.04),
    ]
}

/// The forward dynamics of `model` at rest-or-moving state `(q, v)` under the generalized force
/// `tau` (no mocap bodies, no adhesion), checked against the inverse dynamics:
/// `ID(q, v, FD(q, v, τ)) = τ` to 1e-9 of `1 + max |τ|`. Returns the shares the limits held
/// ([`scm::model::Forward::holds`]).
pub fn forward_then_inverse(
    model: &scm::model::Model,
    q: &[f64],
    v: &[f64],
    tau: &[f64],
) -> Option<Vec<f64>> {
    let prm = model.contact;
    let at = scm::model::EvalPoint {
        q,
        v,
        tau,
        mocap: &[],
        pulls: &[],
    };
    let fd = model.forward_at(at, &prm, Default::default()).unwrap();
    let id = model.inverse(q, v, fd.vdot.as_slice(), &[], &prm, &[]);
    let scale = 1.0 + tau.iter().fold(0.0f64, |m, t| m.max(t.abs()));
    for k in 0..tau.len() {
        assert!(
            (id[k] - tau[k]).abs() <= 1e-9 * scale,
            "dof {k}: ID(FD(τ)) = {} vs τ = {}",
            id[k],
            tau[k]
        );
    }
    fd.holds
}

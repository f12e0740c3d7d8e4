//! Spatial (6D) vector algebra (Featherstone, *Rigid Body Dynamics Algorithms*, ch. 2):
//! motion vectors `[ω; v]` and force vectors `[n; f]`, Plücker transforms and rigid-body
//! inertias, generic over the scalar.

use crate::scalar::{c, Scalar};
use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

/// Skew-symmetric matrix `[a]×` with `[a]× b = a × b`.
#[inline]
pub fn skew<T: Scalar>(a: &Vector3<T>) -> Matrix3<T> {
    Matrix3::new(
        T::zero(),
        -a.z,
        a.y,
        a.z,
        T::zero(),
        -a.x,
        -a.y,
        a.x,
        T::zero(),
    )
}

/// Angular part of a spatial vector.
#[inline]
pub fn ang<T: Scalar>(m: &Vector6<T>) -> Vector3<T> {
    Vector3::new(m[0], m[1], m[2])
}

/// Linear part of a spatial vector.
#[inline]
pub fn lin<T: Scalar>(m: &Vector6<T>) -> Vector3<T> {
    Vector3::new(m[3], m[4], m[5])
}

/// Stacks angular and linear parts.
#[inline]
pub fn spatial<T: Scalar>(a: &Vector3<T>, l: &Vector3<T>) -> Vector6<T> {
    Vector6::new(a.x, a.y, a.z, l.x, l.y, l.z)
}

/// Motion cross product `v ×m m`.
#[inline]
pub fn cross_motion<T: Scalar>(v: &Vector6<T>, m: &Vector6<T>) -> Vector6<T> {
    let (w, vl) = (ang(v), lin(v));
    spatial(&w.cross(&ang(m)), &(w.cross(&lin(m)) + vl.cross(&ang(m))))
}

/// Force cross product `v ×f f`.
#[inline]
pub fn cross_force<T: Scalar>(v: &Vector6<T>, f: &Vector6<T>) -> Vector6<T> {
    let (w, vl) = (ang(v), lin(v));
    spatial(&(w.cross(&ang(f)) + vl.cross(&lin(f))), &w.cross(&lin(f)))
}

/// Plücker transform from a parent frame to a child frame whose axes are `rotation` (columns,
/// in parent coordinates) and whose origin is at `translation` (parent coordinates).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform<T: Scalar> {
    /// Child axes in parent coordinates (child → parent rotation).
    pub rotation: Matrix3<T>,
    /// Child origin in parent coordinates.
    pub translation: Vector3<T>,
}

impl Transform<f64> {
    /// The same transform on `T`.
    #[inline]
    pub fn lift<T: Scalar>(&self) -> Transform<T> {
        Transform {
            rotation: self.rotation.map(c::<T>),
            translation: self.translation.map(c::<T>),
        }
    }
}

impl<T: Scalar> Transform<T> {
    /// The identity transform.
    pub fn identity() -> Self {
        Transform {
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
        }
    }

    /// Composition: `self` (parent → mid) followed by `child` (mid → child).
    pub fn then(&self, child: &Transform<T>) -> Transform<T> {
        Transform {
            rotation: self.rotation * child.rotation,
            translation: self.translation + self.rotation * child.translation,
        }
    }

    /// Motion vector from parent to child coordinates.
    #[inline]
    pub fn motion(&self, m: &Vector6<T>) -> Vector6<T> {
        let et = self.rotation.transpose();
        let w = ang(m);
        spatial(&(et * w), &(et * (lin(m) - self.translation.cross(&w))))
    }

    /// Force vector from child to parent coordinates (`Xᵀ f`).
    #[inline]
    pub fn force_to_parent(&self, f: &Vector6<T>) -> Vector6<T> {
        let fl = self.rotation * lin(f);
        spatial(&(self.rotation * ang(f) + self.translation.cross(&fl)), &fl)
    }

    /// The 6×6 motion transform matrix `X`.
    pub fn matrix(&self) -> Matrix6<T> {
        let et = self.rotation.transpose();
        let mut x = Matrix6::zeros();
        x.fixed_view_mut::<3, 3>(0, 0).copy_from(&et);
        x.fixed_view_mut::<3, 3>(3, 3).copy_from(&et);
        x.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&(-et * skew(&self.translation)));
        x
    }
}

/// Rigid-body inertia about a frame's origin: mass, centre of mass and rotational inertia about
/// the centre of mass, all in that frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inertia {
    /// Mass (kg).
    pub mass: f64,
    /// Centre of mass (m).
    pub com: Vector3<f64>,
    /// Rotational inertia about the centre of mass (kg·m²).
    pub rot: Matrix3<f64>,
}

impl Inertia {
    /// The 6×6 spatial inertia matrix about the frame origin.
    pub fn matrix<T: Scalar>(&self) -> Matrix6<T> {
        let m = self.mass;
        let cx = skew(&self.com);
        let io = self.rot + cx * cx.transpose() * m;
        let mut out = Matrix6::zeros();
        out.fixed_view_mut::<3, 3>(0, 0).copy_from(&io);
        out.fixed_view_mut::<3, 3>(0, 3).copy_from(&(cx * m));
        out.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&(cx.transpose() * m));
        out.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(Matrix3::identity() * m));
        out.map(c::<T>)
    }

    /// The same inertia by its parts about the frame origin ([`BodyInertia`]), on `T`.
    pub fn about_origin<T: Scalar>(&self) -> BodyInertia<T> {
        let m = self.mass;
        let com = self.com;
        let rot = self.rot + (Matrix3::identity() * com.norm_squared() - com * com.transpose()) * m;
        BodyInertia {
            mass: c(m),
            moment: (com * m).map(c::<T>),
            rot: rot.map(c::<T>),
        }
    }

    /// Combined inertia of two bodies expressed in the same frame.
    pub fn add(&self, other: &Inertia) -> Inertia {
        let mass = self.mass + other.mass;
        if mass <= 0.0 {
            return Inertia {
                mass: 0.0,
                com: Vector3::zeros(),
                rot: self.rot + other.rot,
            };
        }
        let com = (self.com * self.mass + other.com * other.mass) / mass;
        let shift = |i: &Inertia| {
            let d = i.com - com;
            i.rot + (Matrix3::identity() * d.norm_squared() - d * d.transpose()) * i.mass
        };
        Inertia {
            mass,
            com,
            rot: shift(self) + shift(other),
        }
    }
}

/// A spatial inertia about a frame's origin kept by its parts, the 6 × 6 matrix
/// `[[rot, [h]×], [[h]×ᵀ, m 1]]` ([`Inertia::matrix`]) without its zeros and repeats: what the
/// composite-rigid-body algorithm and RNEA carry along the tree. Applying it takes 24
/// multiplications where the 6 × 6 product takes 36, and carrying it to a parent frame about
/// 100 where `Xᵀ I X` with `X` as a 6 × 6 matrix takes 432: gymnasium's humanoid's mass
/// matrix over its first 0.3 s took 10.2 M instructions where it took 18.5 M (callgrind).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyInertia<T: Scalar> {
    /// Mass `m`.
    pub mass: T,
    /// First moment of mass about the origin, `h = m c` (`c` the centre of mass).
    pub moment: Vector3<T>,
    /// Rotational inertia about the origin.
    pub rot: Matrix3<T>,
}

impl BodyInertia<f64> {
    /// The same inertia on `T`.
    #[inline]
    pub fn lift<T: Scalar>(&self) -> BodyInertia<T> {
        BodyInertia {
            mass: c(self.mass),
            moment: self.moment.map(c::<T>),
            rot: self.rot.map(c::<T>),
        }
    }
}

impl<T: Scalar> BodyInertia<T> {
    /// No inertia.
    pub fn zero() -> Self {
        BodyInertia {
            mass: T::zero(),
            moment: Vector3::zeros(),
            rot: Matrix3::zeros(),
        }
    }

    /// The force `I m` of a motion `m = [ω; v]`: `[rot ω + h × v; m v - h × ω]`.
    #[inline]
    pub fn apply(&self, m: &Vector6<T>) -> Vector6<T> {
        let (w, v) = (ang(m), lin(m));
        spatial(
            &(self.rot * w + self.moment.cross(&v)),
            &(v * self.mass - self.moment.cross(&w)),
        )
    }

    /// [`BodyInertia::apply`] to the unit motion `e_i` (`i < 3` a rotation about axis `i`,
    /// else a translation along axis `i - 3`), read off the inertia's entries: for finite
    /// entries the same numbers but for the sign of a zero (an infinite one gives `inf` where
    /// `apply`'s products by zero give `NaN`).
    #[inline]
    pub fn apply_unit(&self, i: usize) -> Vector6<T> {
        let h = &self.moment;
        let z = T::zero();
        match i {
            // [rot e_i; e_i × h]
            0 => Vector6::new(
                self.rot[(0, 0)],
                self.rot[(1, 0)],
                self.rot[(2, 0)],
                z,
                -h.z,
                h.y,
            ),
            1 => Vector6::new(
                self.rot[(0, 1)],
                self.rot[(1, 1)],
                self.rot[(2, 1)],
                h.z,
                z,
                -h.x,
            ),
            2 => Vector6::new(
                self.rot[(0, 2)],
                self.rot[(1, 2)],
                self.rot[(2, 2)],
                -h.y,
                h.x,
                z,
            ),
            // [h × e_j; m e_j]
            3 => Vector6::new(z, h.z, -h.y, self.mass, z, z),
            4 => Vector6::new(-h.z, z, h.x, z, self.mass, z),
            _ => Vector6::new(h.y, -h.x, z, z, z, self.mass),
        }
    }

    /// The same body's inertia in the parent frame of `x` (`Xᵀ I X`): rotated by `E`, then
    /// its origin moved by `-r` (`E`, `r` the transform's rotation and translation):
    /// `h' = E h + m r`, `rot' = E rot Eᵀ + 2 (r·Eh) 1 - (Eh) rᵀ - r (Eh)ᵀ + m (|r|² 1 - r rᵀ)`
    /// (docs/method.md, "Dynamics").
    pub fn to_parent(&self, x: &Transform<T>) -> Self {
        let (e, r) = (&x.rotation, &x.translation);
        let eh = e * self.moment;
        let r_eh = r.dot(&eh);
        let rr = r.norm_squared();
        let mut rot = e * self.rot * e.transpose();
        for i in 0..3 {
            for j in 0..3 {
                let diag = if i == j {
                    r_eh + r_eh + self.mass * rr
                } else {
                    T::zero()
                };
                rot[(i, j)] += diag - eh[i] * r[j] - r[i] * eh[j] - self.mass * r[i] * r[j];
            }
        }
        BodyInertia {
            mass: self.mass,
            moment: eh + r * self.mass,
            rot,
        }
    }

    /// The 6 × 6 spatial inertia matrix.
    pub fn matrix(&self) -> Matrix6<T> {
        let hx = skew(&self.moment);
        let mut out = Matrix6::zeros();
        out.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.rot);
        out.fixed_view_mut::<3, 3>(0, 3).copy_from(&hx);
        out.fixed_view_mut::<3, 3>(3, 0).copy_from(&hx.transpose());
        out.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(Matrix3::identity() * self.mass));
        out
    }
}

impl<T: Scalar> std::ops::AddAssign for BodyInertia<T> {
    fn add_assign(&mut self, other: Self) {
        self.mass += other.mass;
        self.moment += other.moment;
        self.rot += other.rot;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    fn body() -> Inertia {
        Inertia {
            mass: 2.5,
            com: Vector3::new(0.1, -0.2, 0.05),
            rot: Matrix3::new(0.3, 0.01, -0.02, 0.01, 0.2, 0.03, -0.02, 0.03, 0.25),
        }
    }

    fn transform() -> Transform<f64> {
        Transform {
            rotation: *Rotation3::from_euler_angles(0.4, -0.7, 1.1).matrix(),
            translation: Vector3::new(0.3, 0.5, -0.2),
        }
    }

    #[test]
    fn parts_apply_as_the_matrix() {
        let i = body();
        let parts = i.about_origin::<f64>();
        assert!((parts.matrix() - i.matrix::<f64>()).norm() < 1e-15);
        let m = Vector6::new(0.3, -1.0, 2.0, 0.5, 0.7, -0.4);
        assert!((parts.apply(&m) - i.matrix::<f64>() * m).norm() < 1e-14);
    }

    #[test]
    fn a_unit_motion_applies_as_the_inertia_entries_it_reads() {
        // `apply_unit(i)` is `apply(e_i)` entry for entry (`==`: a zero's sign aside), on
        // values and on dual numbers.
        let parts = body().about_origin::<f64>();
        let dual = BodyInertia {
            mass: num_dual::Dual64::new(parts.mass, 0.3),
            moment: parts.moment.map(|x| num_dual::Dual64::new(x, -x)),
            rot: parts.rot.map(|x| num_dual::Dual64::new(x, 2.0 * x)),
        };
        for i in 0..6 {
            assert_eq!(
                parts.apply_unit(i),
                parts.apply(&Vector6::ith(i, 1.0)),
                "{i}"
            );
            let (a, b) = (dual.apply_unit(i), dual.apply(&Vector6::ith(i, 1.0.into())));
            for k in 0..6 {
                assert!(a[k].re == b[k].re && a[k].eps == b[k].eps, "{i}, {k}");
            }
        }
    }

    #[test]
    fn carried_to_the_parent_as_x_transposed_i_x() {
        let parts = body().about_origin::<f64>();
        let x = transform();
        let dense = x.matrix().transpose() * parts.matrix() * x.matrix();
        assert!((parts.to_parent(&x).matrix() - dense).norm() < 1e-14);
        // And by the force and motion maps the dynamics uses: X^T I X m = X^T (I (X m)).
        let m = Vector6::new(0.3, -1.0, 2.0, 0.5, 0.7, -0.4);
        let by_maps = x.force_to_parent(&parts.apply(&x.motion(&m)));
        assert!((parts.to_parent(&x).apply(&m) - by_maps).norm() < 1e-14);
    }
}

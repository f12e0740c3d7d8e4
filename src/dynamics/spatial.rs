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

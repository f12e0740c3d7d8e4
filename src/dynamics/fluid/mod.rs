//! Fluid forces on bodies moving through a still medium, as MuJoCo's inertia-box model
//! computes them (its `<option density viscosity>`): each body is replaced by the box that has
//! its mass and principal moments of inertia, and feels, in its principal axes at its centre of
//! mass,
//!
//! - viscous (Stokes) drag of the sphere whose diameter `d` is the box's mean side:
//!   force `-3π β d v`, torque `-π β d³ ω`;
//! - quadratic (pressure) drag of the box's faces: force component `-½ ρ b_j b_k |v_i| v_i`,
//!   torque component `-ρ b_i (b_j⁴ + b_k⁴) |ω_i| ω_i / 64`,
//!
//! with `v`, `ω` the body's linear velocity at its centre of mass and its angular velocity in
//! those axes, `b` the box's sides, `β` the viscosity and `ρ` the density. Every term is C¹ in
//! the velocity (`|x| x` has the derivative `2|x|`), so the dynamics stay differentiable; the
//! forces only dissipate.

use crate::collision::Frame;
use crate::contact::Wrench;
use crate::scalar::{c, Scalar};
use nalgebra::{Matrix3, Vector3};

mod ellipsoid;
pub use ellipsoid::EllipsoidGeom;

/// A body the fluid acts on: its equivalent box, in its principal axes.
#[derive(Clone, Debug, PartialEq)]
pub struct FluidBody {
    /// Body index.
    pub body: usize,
    /// Centre of mass, body coordinates (m).
    pub com: Vector3<f64>,
    /// Principal axes of the body's inertia, as columns, in body coordinates.
    pub axes: Matrix3<f64>,
    /// Sides of the equivalent inertia box along those axes (m).
    pub sides: Vector3<f64>,
}

impl FluidBody {
    /// The body's equivalent inertia box: principal moments `I` (in the order of `axes`) and
    /// mass `m` give sides `b_i = √(6 (I_j + I_k - I_i) / m)` (a difference below 1e-15 counts
    /// as 1e-15, as in MuJoCo, so a rod or a point mass keeps a finite box).
    pub fn new(
        body: usize,
        mass: f64,
        com: Vector3<f64>,
        axes: Matrix3<f64>,
        moments: Vector3<f64>,
    ) -> FluidBody {
        let side = |i: usize, j: usize, k: usize| {
            ((moments[j] + moments[k] - moments[i]).max(1e-15) / mass * 6.0).sqrt()
        };
        FluidBody {
            body,
            com,
            axes,
            sides: Vector3::new(side(0, 1, 2), side(1, 0, 2), side(2, 0, 1)),
        }
    }
}

/// The medium and the bodies it acts on.
#[derive(Clone, Debug, PartialEq)]
pub struct Fluid {
    /// Density ρ (kg/m³).
    pub density: f64,
    /// Dynamic viscosity β (Pa·s).
    pub viscosity: f64,
    /// The bodies with mass that no geom of theirs takes out of the inertia-box model.
    pub bodies: Vec<FluidBody>,
    /// The geoms of MuJoCo's ellipsoid model (`fluidshape="ellipsoid"`); a body with one such
    /// geom feels the fluid only through its ellipsoid geoms.
    pub ellipsoids: Vec<EllipsoidGeom>,
}

/// `|x| x`, branching on the real part only (so a dual number gets the derivative `2|x|`).
fn signed_square<T: Scalar>(x: T) -> T {
    if x.re() < 0.0 {
        -x * x
    } else {
        x * x
    }
}

impl Fluid {
    /// Adds the fluid's wrench on every body to `out` (world frame, torque about the body
    /// origin). `frames`: the bodies' poses and velocities.
    pub fn add_wrenches<T: Scalar>(&self, frames: &[Frame<T>], out: &mut [Wrench<T>]) {
        let (rho, beta) = (self.density, self.viscosity);
        for fb in &self.bodies {
            let f = &frames[fb.body];
            // Principal axes in world coordinates, and the centre of mass's offset.
            let axes = f.rotation * fb.axes.map(c::<T>);
            let arm = f.rotation * fb.com.map(c::<T>);
            let v = axes.transpose() * (f.linvel + f.angvel.cross(&arm));
            let w = axes.transpose() * f.angvel;
            let b = &fb.sides;
            let mut force = Vector3::zeros();
            let mut torque = Vector3::zeros();
            if beta > 0.0 {
                let d = (b.x + b.y + b.z) / 3.0;
                force -= v * c::<T>(3.0 * std::f64::consts::PI * d * beta);
                torque -= w * c::<T>(std::f64::consts::PI * d * d * d * beta);
            }
            if rho > 0.0 {
                for i in 0..3 {
                    let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                    force[i] -= signed_square(v[i]) * (0.5 * rho * b[j] * b[k]);
                    let lever = b[i] * (b[j].powi(4) + b[k].powi(4)) / 64.0;
                    torque[i] -= signed_square(w[i]) * (rho * lever);
                }
            }
            let (force, torque) = (axes * force, axes * torque);
            out[fb.body].torque += torque + arm.cross(&force);
            out[fb.body].force += force;
        }
        for g in &self.ellipsoids {
            g.add_wrench(rho, beta, frames, out);
        }
    }

    /// Power of the fluid forces (W, never positive in a still medium).
    pub fn power<T: Scalar>(&self, frames: &[Frame<T>]) -> T {
        let mut w = vec![Wrench::zero(); frames.len()];
        self.add_wrenches(frames, &mut w);
        w.iter().zip(frames).fold(T::zero(), |p, (w, f)| {
            p + w.force.dot(&f.linvel) + w.torque.dot(&f.angvel)
        })
    }
}

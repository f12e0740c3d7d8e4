//! The fluid forces as MuJoCo's compiler sets them up: the inertia-box model for every moving
//! body with mass, and the ellipsoid model for the geoms that ask for it
//! (`crate::dynamics::fluid`).

use super::*;
use crate::dynamics::fluid::EllipsoidGeom;

/// A geom of MuJoCo's ellipsoid fluid model as read: its index, `fluidcoef`, and for a mesh
/// its inertia frame (in the geom's frame) with the semi-axes there.
pub(super) type FluidEllipsoid = (usize, [f64; 5], Option<(Isometry3<f64>, Vector3<f64>)>);

impl Builder {
    /// MuJoCo's inertia-box fluid model for the moving bodies with mass, when the medium has a
    /// density or a viscosity (and the passive forces are on: MuJoCo skips them all when
    /// springs and dampers are both disabled). Each body's box is taken in its principal axes
    /// as MuJoCo's compiler orients them: an `<inertial diaginertia>`'s frame, the frame of the
    /// body's one massive geom, else the eigenvectors of its inertia (for a body whose moments
    /// are equal in two axes, the quadratic drag then depends on which axes are taken, and
    /// MuJoCo's choice may differ).
    pub(super) fn fluid_model(&self, tree: &Tree) -> Option<Fluid> {
        if self.medium == (0.0, 0.0) || (!self.flags.spring && !self.flags.damper) {
            return None;
        }
        let ellipsoids: Vec<EllipsoidGeom> = (self.fluid_ellipsoids.iter())
            .filter_map(|&(g, coefs, mesh_frame)| {
                let geom = &self.geoms[g];
                let body = &tree.bodies[geom.body];
                if !tree.body_moves(geom.body) || body.inertia.mass < 1e-15 {
                    return None;
                }
                let (pose, semiaxes) = match mesh_frame {
                    Some((frame, semiaxes)) => (geom.pose * frame, semiaxes),
                    None => (geom.pose, fluid_semiaxes(geom.shape.as_ref()?)?),
                };
                let rot = pose.rotation.to_rotation_matrix().into_inner();
                let pos = pose.translation.vector;
                Some(EllipsoidGeom::new(geom.body, pos, rot, semiaxes, coefs))
            })
            .collect();
        let mut bodies = Vec::new();
        for (b, body) in tree.bodies.iter().enumerate().skip(1) {
            let i = &body.inertia;
            if !tree.body_moves(b) || i.mass < 1e-15 || ellipsoids.iter().any(|e| e.body == b) {
                continue;
            }
            let from_geoms = self.inertia_from_geoms(b);
            let one_geom = self.mass_geom_frames.get(&b).filter(|f| f.len() == 1);
            let frame = match (from_geoms, self.inertial_axes.get(&b), one_geom) {
                (false, Some(q), _) => Some(*q),
                (true, _, Some(f)) => Some(f[0]),
                _ => None,
            };
            let axes = match frame {
                Some(q) => q.to_rotation_matrix().into_inner(),
                None => i.rot.symmetric_eigen().eigenvectors,
            };
            let moments = (axes.transpose() * i.rot * axes).diagonal();
            bodies.push(FluidBody::new(b, i.mass, i.com, axes, moments));
        }
        Some(Fluid {
            density: self.medium.0,
            viscosity: self.medium.1,
            bodies,
            ellipsoids,
        })
    }
}

/// The semi-axes MuJoCo's ellipsoid fluid model takes for a geom of shape `shape` (its
/// `mju_geomSemiAxes` on the geom's size): a sphere's radius thrice, a capsule's radius,
/// radius and half-length plus radius, a cylinder's radius, radius and half-length, a box's
/// and an ellipsoid's sizes (a mesh's are taken in its inertia frame where it is read).
fn fluid_semiaxes(shape: &Shape) -> Option<Vector3<f64>> {
    Some(match shape {
        Shape::Sphere { radius } => Vector3::repeat(*radius),
        Shape::Capsule {
            radius,
            half_length,
        } => Vector3::new(*radius, *radius, half_length + radius),
        Shape::Cylinder {
            radius,
            half_length,
        } => Vector3::new(*radius, *radius, *half_length),
        Shape::Box { half } => *half,
        Shape::Ellipsoid { radii } => *radii,
        Shape::Mesh(_) | Shape::Implicit { .. } => return None,
    })
}

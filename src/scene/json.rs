//! The compiled model as JSON, in MuJoCo's conventions (`scm compile`): what the differential
//! tests compare with MuJoCo's `MjModel`, field by field.
//!
//! Bodies: `pos`/`quat` in the parent's frame, `mass`, `ipos` (centre of mass) and `inertia`
//! (the 3×3 rotational inertia about the centre of mass, body axes, row-major). Joints: `pos`
//! and `axis` in the body frame, `ref` (MuJoCo's `qpos0` of slide and hinge joints),
//! `springref`, passive properties and limits in SI units, with the limit spring's stiffness and
//! damping (from `solreflimit` and MuJoCo's `1 / dof_invweight0`, times `1 / (1 - dmax)` of
//! `solimplimit`) and the inertia MuJoCo's impedance adds while it pushes, where the file's
//! integrator takes it so (`limit_added_inertia`). Fixed tendons: joints and coefficients,
//! spring, damper, friction, spring length and limits; spatial tendons (apart): their segments
//! (bodies, points, `1 / divisor`), length at `qpos0` and the same. Equalities, connects and
//! welds: the reference gains, the factor of MuJoCo's statics, the gains that act and the
//! inertia added along each row (`added_inertia`). Geoms: `size` as MuJoCo stores it
//! (a capsule's or cylinder's half-length second, a box's half-extents), `pos`/`quat` in the
//! body frame, with `solref`, `solimp`, `solmix` and `priority`. Pairs: each contact pair's
//! mixed `solref` and `solimp`, effective mass (`1 / (w₁ + w₂)`), the share of its friction
//! cone in the normal force (`cone_share`, 1 but in a pyramid), MuJoCo's resting depth and
//! SCM's stiffness and dissipation velocity from them (docs/mjcf.md).

use super::{Compiled, CompiledPair, Geom};
use crate::dynamics::tendon::TendonLaw;
use crate::dynamics::JointKind;
use crate::geometry::Shape;
use crate::model::{ActivationLaw, ActuatorKind, Transmission};
use nalgebra::{Isometry3, Vector3};
use serde_json::{json, Value};

fn v3(v: &Vector3<f64>) -> Value {
    json!([v.x, v.y, v.z])
}

fn pose(p: &Isometry3<f64>) -> (Value, Value) {
    let q = p.rotation.quaternion();
    (v3(&p.translation.vector), json!([q.w, q.i, q.j, q.k]))
}

/// A tendon's force law: spring, damper, friction, spring length and limit spring.
fn law(law: &TendonLaw) -> Value {
    json!({
        "stiffness": law.stiffness, "damping": law.damping,
        "frictionloss": law.frictionloss,
        "springlength": [law.spring_length.0, law.spring_length.1],
        "limited": law.limit.is_some(),
        "range": law.limit.map(|l| vec![l.lo, l.hi]),
        "limit_stiffness": law.limit.map(|l| l.stiffness),
        "limit_damping": law.limit.map(|l| l.damping),
        "limit_added_inertia": law.limit.map(|l| l.impedance),
    })
}

fn geom(g: &Geom, bodies: &[String]) -> Value {
    let (kind, size) = match &g.shape {
        None => ("plane", json!(null)),
        Some(Shape::Sphere { radius }) => ("sphere", json!([radius, 0.0, 0.0])),
        Some(Shape::Capsule {
            radius,
            half_length,
        }) => ("capsule", json!([radius, half_length, 0.0])),
        Some(Shape::Cylinder {
            radius,
            half_length,
        }) => ("cylinder", json!([radius, half_length, 0.0])),
        Some(Shape::Box { half }) => ("box", v3(half)),
        Some(Shape::Ellipsoid { radii }) => ("ellipsoid", v3(radii)),
        Some(Shape::Mesh(_) | Shape::Implicit { .. }) => ("mesh", json!(null)),
    };
    let (pos, quat) = pose(&g.pose);
    json!({
        "name": g.name, "body": bodies[g.body], "type": kind, "size": size,
        "pos": pos, "quat": quat, "mesh": g.mesh, "fitted_to": g.fitted_to,
        "contype": g.contype, "conaffinity": g.conaffinity,
        "friction": g.friction, "condim": g.condim,
        "solref": g.softness.softness.solref, "solimp": g.softness.softness.solimp,
        "solmix": g.softness.solmix, "priority": g.softness.priority, "margin": g.margin,
        "adhesion": g.adhesion, "gap": g.gap,
        "surfacevel": g.surfacevel.map(|(v, w)| [v.x, v.y, v.z, w.x, w.y, w.z]),
    })
}

impl Compiled {
    /// The model as JSON (see the module documentation).
    pub fn to_json(&self) -> Value {
        let t = &self.tree;
        let names: Vec<String> = t.bodies.iter().map(|b| b.name.clone()).collect();
        let bodies: Vec<Value> = t
            .bodies
            .iter()
            .map(|b| {
                let (pos, quat) = pose(&b.offset);
                let i = &b.inertia;
                json!({
                    "name": b.name,
                    "parent": b.parent.map(|p| names[p].clone()),
                    "pos": pos, "quat": quat, "mass": i.mass, "ipos": v3(&i.com),
                    "inertia": i.rot.transpose().as_slice().to_vec(),
                    "mocap": b.mocap,
                    "gravcomp": b.gravcomp,
                })
            })
            .collect();
        let joints: Vec<Value> = t
            .joints
            .iter()
            .zip(&self.limits)
            .zip(&self.actuator_ranges)
            .map(|((j, limit), actuator_range)| {
                let kind = match j.kind {
                    JointKind::Free => "free",
                    JointKind::Ball => "ball",
                    JointKind::Slide => "slide",
                    JointKind::Hinge => "hinge",
                };
                json!({
                    "name": j.name, "type": kind, "body": names[j.body],
                    "pos": v3(&j.anchor), "axis": v3(&j.axis),
                    "ref": j.reference, "springref": j.springref,
                    "damping": j.damping, "stiffness": j.stiffness,
                    "armature": j.armature, "frictionloss": j.frictionloss,
                    "limited": limit.is_some(),
                    "range": limit.map(|(a, b)| vec![a, b]),
                    "limit_stiffness": j.limit.map(|l| l.stiffness),
                    "limit_damping": j.limit.map(|l| l.damping),
                    "limit_added_inertia": j.limit.map(|l| l.impedance),
                    "actuatorfrcrange": actuator_range.map(|(a, b)| vec![a, b]),
                })
            })
            .collect();
        let actuators: Vec<Value> = self
            .actuators
            .iter()
            .map(|a| {
                let kind = match a.kind {
                    ActuatorKind::Motor => "motor",
                    ActuatorKind::Position { .. } => "position",
                    ActuatorKind::Velocity { .. } => "velocity",
                    ActuatorKind::General { .. } => "general",
                };
                let (gain, bias) = a.kind.gain_bias();
                json!({
                    "name": a.name, "gear": a.gear,
                    "joint": match a.target {
                        Transmission::Joint(j) => Some(t.joints[j].name.clone()),
                        _ => None,
                    },
                    "site": match a.target {
                        Transmission::Site(k) => Some(self.transmissions.sites[k].name.clone()),
                        _ => None,
                    },
                    "site_gear": match a.target {
                        Transmission::Site(k) => Some(self.transmissions.sites[k].gear.to_vec()),
                        _ => None,
                    },
                    "tendon": match a.target {
                        Transmission::Tendon(i) => Some(self.tendons[i].name.clone()),
                        Transmission::Spatial(i) => Some(self.spatial_tendons[i].name.clone()),
                        _ => None,
                    },
                    "body": match a.target {
                        Transmission::Body(b) => Some(t.bodies[b].name.clone()),
                        _ => None,
                    },
                    "slidercrank": match a.target {
                        Transmission::SliderCrank(k) => {
                            let sc = &self.transmissions.slider_cranks[k];
                            Some(json!({"cranksite": sc.crank.0, "slidersite": sc.slider.0, "cranklength": sc.rod}))
                        }
                        _ => None,
                    },
                    "kind": kind, "gainprm": gain, "biasprm": bias,
                    "ctrllimited": a.ctrlrange.is_some(),
                    "ctrlrange": a.ctrlrange.map(|(lo, hi)| vec![lo, hi]),
                    "forcelimited": a.forcerange.is_some(),
                    "forcerange": a.forcerange.map(|(lo, hi)| vec![lo, hi]),
                    "dyntype": match a.activation.map(|d| d.law) {
                        None => "none",
                        Some(ActivationLaw::Integrator) => "integrator",
                        Some(ActivationLaw::Filter { .. }) => "filter",
                        Some(ActivationLaw::FilterExact { .. }) => "filterexact",
                        // MuJoCo's PID plugin keeps its integral as a plugin activation.
                        Some(ActivationLaw::PidIntegral { .. }) => "none",
                    },
                    "timeconst": a.activation.and_then(|d| match d.law {
                        ActivationLaw::Filter { tau } | ActivationLaw::FilterExact { tau } => Some(tau),
                        ActivationLaw::Integrator | ActivationLaw::PidIntegral { .. } => None,
                    }),
                    "actnum": usize::from(a.activation.is_some()),
                    "actlimited": a.activation.is_some_and(|d| d.range.is_some()),
                    "actrange": a.activation.and_then(|d| d.range).map(|(lo, hi)| vec![lo, hi]),
                    "actearly": a.activation.is_some_and(|d| d.early),
                })
            })
            .collect();
        let tendons: Vec<Value> = self
            .tendons
            .iter()
            .map(|tendon| {
                let joints: Vec<Value> = tendon
                    .joints
                    .iter()
                    .map(|&(qi, _, coef)| {
                        let j = t.joints.iter().find(|j| j.qadr == qi);
                        json!([j.map(|j| j.name.clone()), coef])
                    })
                    .collect();
                let mut out = law(&tendon.law());
                out["name"] = json!(tendon.name);
                out["joints"] = json!(joints);
                out
            })
            .collect();
        let at_q0 = t.kinematics(&t.q0(), &vec![0.0; t.nv]);
        let spatial_tendons: Vec<Value> = self
            .spatial_tendons
            .iter()
            .map(|tendon| {
                let segments: Vec<Value> = tendon
                    .segments
                    .iter()
                    .map(|s| {
                        json!([
                            names[s.from.0],
                            v3(&s.from.1),
                            names[s.to.0],
                            v3(&s.to.1),
                            s.scale
                        ])
                    })
                    .collect();
                // Per segment, the geom it wraps around (null for a straight one).
                let wraps: Vec<Value> = (tendon.segments.iter())
                    .map(|s| match &s.wrap {
                        None => Value::Null,
                        Some(w) => json!({
                            "body": names[w.body],
                            "shape": format!("{:?}", w.shape).to_lowercase(),
                            "radius": w.radius,
                            "pos": v3(&w.pose.translation.vector),
                            "sidesite": w.side.map(|(b, p)| json!([names[b], v3(&p)])),
                        }),
                    })
                    .collect();
                let mut out = law(&tendon.law);
                out["name"] = json!(tendon.name);
                out["segments"] = json!(segments);
                out["wraps"] = json!(wraps);
                out["length0"] = json!(tendon.length_and_rate(&at_q0.frames).0);
                out
            })
            .collect();
        let equalities: Vec<Value> = self
            .equalities
            .iter()
            .map(|e| {
                json!({
                    "name": e.name, "poly": e.poly,
                    "reference": [Some(e.first.1), e.second.as_ref().map(|s| s.1)],
                    "stiffness": e.gains.reference.0, "damping": e.gains.reference.1,
                    "statics": e.gains.statics, "acting": [e.stiffness, e.damping],
                    "added_inertia": e.impedance,
                })
            })
            .collect();
        let connects: Vec<Value> = self
            .connects
            .iter()
            .map(|c| {
                // A weld's held orientation as a unit quaternion (w x y z), and its angular
                // spring and damper.
                let orientation = c.orientation.as_ref().map(|o| {
                    let r = nalgebra::Rotation3::from_matrix_unchecked(o.relative);
                    let q = nalgebra::UnitQuaternion::from_rotation_matrix(&r);
                    json!({
                        "relative": [q.w, q.i, q.j, q.k],
                        "stiffness": o.gains.reference.0, "damping": o.gains.reference.1,
                        "statics": o.gains.statics, "acting": [o.stiffness, o.damping],
                        "added_inertia": o.impedance,
                    })
                });
                json!({
                    "name": c.name,
                    "body1": names[c.first.0], "anchor1": v3(&c.first.1),
                    "body2": names[c.second.0], "anchor2": v3(&c.second.1),
                    "stiffness": c.gains.reference.0, "damping": c.gains.reference.1,
                    "statics": c.gains.statics, "acting": [c.stiffness, c.damping],
                    "added_inertia": c.impedance,
                    "orientation": orientation,
                })
            })
            .collect();
        // The fluid's medium and the geoms of MuJoCo's ellipsoid model.
        let fluid = self.fluid.as_ref().map(|f| {
            let ellipsoids: Vec<Value> = (f.ellipsoids.iter())
                .map(|e| {
                    json!({
                        "body": names[e.body], "semiaxes": v3(&e.semiaxes), "coefs": e.coefs,
                        "virtual_mass": v3(&e.virtual_mass),
                        "virtual_inertia": v3(&e.virtual_inertia),
                    })
                })
                .collect();
            json!({"density": f.density, "viscosity": f.viscosity, "ellipsoids": ellipsoids})
        });
        json!({
            "tendons": tendons,
            "spatial_tendons": spatial_tendons,
            "equalities": equalities,
            "connects": connects,
            "fluid": fluid,
            "option": {
                "timestep": self.timestep,
                "gravity": v3(&t.gravity),
                "integrator": self.integrator.name(),
            },
            "bodies": bodies,
            "joints": joints,
            "geoms": self.geoms.iter().map(|g| geom(g, &names)).collect::<Vec<_>>(),
            "actuators": actuators,
            "pairs": self.pair_laws.iter().map(|CompiledPair { body1, body2, margin, adhesion, stiction_floor, hold_separation, law }| json!({
                "body1": body1, "body2": body2, "margin": margin,
                "adhesion": adhesion.0, "gap": adhesion.1,
                "stiction_floor": if stiction_floor.is_nan() { None } else { Some(stiction_floor) },
                "solref": law.softness.solref, "solimp": law.softness.solimp,
                "mass": law.mass, "cone_share": law.cone, "mujoco_depth": law.depth,
                "stiffness": law.stiffness, "dissipation_velocity": law.dissipation_velocity,
                "dissipation_force": law.dissipation_force, "hold_separation": hold_separation,
            })).collect::<Vec<_>>(),
            "refused": self.refused.iter().map(|e| e.to_string()).collect::<Vec<_>>(),
            "unused": self.unused,
            "warnings": self.warnings,
        })
    }
}

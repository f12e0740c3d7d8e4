//! The model's mechanics as MuJoCo's compiler makes them: the tree with its joint limits, the
//! fixed tendons and the equality constraints, each a spring and damper of its `solref`
//! stiffened by the effective inertia MuJoCo computes at the reference configuration.

use super::weights::{body_weights, joint_inertia, mass_at_q0, unit_velocity_kinematics};
use super::*;
use crate::dynamics::equality::{Connect, Gains, Linear, Orientation, ScalarEquality};
use crate::dynamics::limit::{solref_gains, Held, JointLimit, LimitLaw};
use crate::dynamics::tendon::{FixedTendon, Segment, SpatialTendon, TendonLaw};

impl Builder {
    /// A constraint's `solref` as MuJoCo's `refsafe` holds it: a time constant no less than
    /// twice the file's step, where the flag is on (the default). MuJoCo holds every constraint
    /// so, its joint and tendon limits and its equalities as much as its contacts (measured: a
    /// hinge resting on a limit of `solreflimit="0.001 1"` at 2 ms sits 4.5e-5 rad past it; with
    /// `<flag refsafe="disable"/>` MuJoCo finds the run unstable). Direct (negative) values
    /// are not held.
    fn held(&self, solref: [f64; 2]) -> [f64; 2] {
        if self.flags.refsafe && solref[0] > 0.0 {
            let step = self.timestep.unwrap_or(DEFAULT_STEP);
            [solref[0].max(2.0 * step), solref[1]]
        } else {
            solref
        }
    }

    /// A joint's or tendon's limit as MuJoCo's `solreflimit` and `solimplimit` mean it, for a
    /// coordinate of effective inertia `inertia` (docs/mjcf.md, "Joint limits"). MuJoCo's
    /// constraint moves as `r̈ = (1 - d) a - d B ṙ - d² K r` (`a` the acceleration the limit
    /// would have without it): its reference spring and damper carry only `1 - d` of a load, so
    /// statically it is `1 / (1 - d)` times stiffer than the reference (20 times at the default
    /// `dmax` 0.95). The limit's gains are that, MuJoCo's reference gains at `d = dmax`
    /// divided by `1 - dmax`, which hold a load at MuJoCo's static deflection, and `law` says
    /// how it acts ([`LimitLaw`]): with MuJoCo's impedance as an added inertia, which gives it
    /// MuJoCo's dynamics too, or without it where the step takes the limit's damping
    /// implicitly (overdamped, it throws a joint that starts outside its range back in at about
    /// `r₀ / (2τ)` where MuJoCo's critically damped reference lets go at `r₀ / (τ e)`: 11.7
    /// against 9.3 rad/s from 0.5 rad at τ = 0.02 s), or a tendon's with the reference gains
    /// (docs/mjcf.md, "Joint limits").
    fn limit_law(
        &self,
        (lo, hi): (f64, f64),
        softness: &contact::Softness,
        inertia: f64,
        law: LimitLaw,
    ) -> JointLimit {
        JointLimit::from_solref(lo, hi, self.held(softness.solref), inertia)
            .stiffened(1.0 / (1.0 - softness.dmax()))
            .acting(law)
    }

    /// An equality's gains on effective inertia `inertia` (docs/mjcf.md, "Equality
    /// constraints"): MuJoCo's reference gains for its `solref` (as `refsafe` holds it), and
    /// the factor that gives MuJoCo's statics. MuJoCo's soft constraint holds a load `a` (per
    /// unit of effective inertia) at the error `r*` that solves `r d(r)² / (1 - d(r)) = a / K`
    /// (`d` the impedance of `solimp`, `K` its reference stiffness); a spring of the reference
    /// gains deflects `a τ² ζ²` instead, 10 to 20 times more at the default `solimp`. The
    /// factor is the ratio of the two at the constraint's own weight, `a = g` (the impedance
    /// varies with the error, so under another load the ratio is off by at most
    /// `(1 - d0) / (1 - dmax)`, twice at the default), as a contact's stiffness is set at its
    /// weight. The raised gains act with MuJoCo's impedance as an inertia added along the
    /// equality's rows ([`Builder::limits_law`]).
    fn equality_gains(&self, tree: &Tree, softness: &contact::Softness, inertia: f64) -> Gains {
        let solref = self.held(softness.solref);
        let (k, b) = solref_gains(solref, inertia);
        let held = contact::Softness {
            solref,
            solimp: softness.solimp,
        };
        let g = Some(tree.gravity.norm())
            .filter(|&g| g > 0.0)
            .unwrap_or(contact::NOMINAL_GRAVITY);
        let r = held.resting_depth(g, None);
        let (per_inertia, _) = solref_gains(solref, 1.0);
        let statics = g / (r * per_inertia);
        Gains {
            reference: (k, b),
            statics: if statics.is_finite() && statics > 0.0 {
                statics
            } else {
                1.0
            },
            inertia,
        }
    }

    /// How the file's integrator acts a joint's or a tendon's limit or an equality
    /// ([`LimitLaw::under`]).
    fn limits_law(&self, held: Held) -> LimitLaw {
        LimitLaw::under(self.integrator_as_run(), held)
    }

    /// Limited slide and hinge joints get their smooth limit springs, stiffened by their
    /// effective inertia at the reference configuration ([`crate::dynamics::limit`]): the
    /// inverse of the diagonal of `M⁻¹` there, MuJoCo's `1 / dof_invweight0`, i.e. the inertia
    /// the joint's coordinate shows when every other coordinate is free. (The diagonal of `M`
    /// itself would be the inertia with every other joint locked: for a hip of a floating
    /// walker it is 56 times larger, and a limit stiffened by it is too stiff for the file's
    /// step.)
    pub(super) fn set_limits(&self, tree: &mut Tree) {
        let (m, m_inv) = mass_at_q0(tree);
        let law = self.limits_law(Held::Joint);
        for (j, limit) in self.limits.iter().enumerate() {
            if let (Some((lo, hi, _)), JointKind::Slide | JointKind::Hinge) =
                (limit, tree.joints[j].kind)
            {
                let inertia = joint_inertia(tree, j, &m, &m_inv);
                let joint = &mut tree.joints[j];
                joint.limit =
                    Some(self.limit_law((*lo, *hi), &self.limit_softness[j], inertia, law));
            }
        }
    }

    /// The fixed tendons over `tree`'s coordinates, with the option flags applied: the spring
    /// length defaults to the length with every joint at its `springref`, and a limit is stiffened
    /// by the tendon's effective inertia there, `1 / (c M⁻¹ cᵀ)` (MuJoCo's
    /// `1 / tendon_invweight0`; `c` the coefficients over the degrees of freedom).
    fn fixed_tendons(&self, tree: &Tree) -> Result<Vec<FixedTendon>, SceneError> {
        let limited = self.flags.limit && self.tendons.iter().any(|t| t.range.is_some());
        let m_inv = limited.then(|| mass_at_q0(tree).1).flatten();
        self.tendons
            .iter()
            .map(|t| {
                let joints: Vec<(usize, usize, f64)> = t
                    .joints
                    .iter()
                    .map(|&(j, coef)| (tree.joints[j].qadr, tree.joints[j].dadr, coef))
                    .collect();
                // MuJoCo measures the default spring length in the springs' rest configuration
                // (qpos_spring: each joint at its springref), not at qpos0.
                let length0: f64 = t
                    .joints
                    .iter()
                    .map(|&(j, coef)| tree.joints[j].springref * coef)
                    .sum();
                let limit = match (t.range, &m_inv) {
                    (Some((lo, hi)), Some(inv)) => {
                        let inv_weight: f64 = joints
                            .iter()
                            .flat_map(|&(_, a, ca)| {
                                joints.iter().map(move |&(_, b, cb)| ca * cb * inv[(a, b)])
                            })
                            .sum();
                        Some(self.limit_law(
                            (lo, hi),
                            &t.limit_softness,
                            limit_inertia(t, inv_weight)?,
                            self.limits_law(Held::Tendon),
                        ))
                    }
                    _ => None,
                };
                let on = |flag: bool, x: f64| if flag { x } else { 0.0 };
                Ok(FixedTendon {
                    name: t.name.clone(),
                    joints,
                    stiffness: on(self.flags.spring, t.stiffness),
                    spring_length: t.spring_length.unwrap_or((length0, length0)),
                    damping: on(self.flags.damper, t.damping),
                    frictionloss: on(self.flags.frictionloss, t.frictionloss),
                    limit,
                })
            })
            .collect()
    }

    /// The joint and tendon equalities over `tree`'s coordinates, as springs and dampers
    /// ([`crate::dynamics::equality`]): each object's value at `qpos0` is its reference, and
    /// the stiffness and damping come from `solref` and `1 / (w₁ + w₂)`, with `w` MuJoCo's
    /// `dof_invweight0` or `tendon_invweight0` at `qpos0`.
    fn scalar_equalities(&self, tree: &Tree, tendons: &[FixedTendon]) -> Vec<ScalarEquality> {
        if self.equalities.is_empty() {
            return vec![];
        }
        let q0 = tree.q0();
        let Some(inv) = mass_at_q0(tree).1 else {
            return vec![];
        };
        let object = |tendon: bool, i: usize| -> Linear {
            if tendon {
                tendons[i].joints.clone()
            } else {
                let j = &tree.joints[i];
                vec![(j.qadr, j.dadr, 1.0)]
            }
        };
        let inv = &inv;
        let weight = |x: &Linear| -> f64 {
            x.iter()
                .flat_map(|&(_, a, ca)| x.iter().map(move |&(_, b, cb)| ca * cb * inv[(a, b)]))
                .sum()
        };
        let at_q0 = |x: &Linear| -> f64 { x.iter().map(|&(qi, _, c)| q0[qi] * c).sum() };
        self.equalities
            .iter()
            .map(|e| {
                let first = object(e.tendons, e.first);
                let second = e.second.map(|i| object(e.tendons, i));
                let w = weight(&first) + second.as_ref().map_or(0.0, &weight);
                let inertia = if w > 0.0 { 1.0 / w } else { 0.0 };
                let gains = self.equality_gains(tree, &e.softness, inertia);
                let law = self.limits_law(Held::Equality);
                let (stiffness, damping) = gains.acting(law);
                ScalarEquality {
                    name: e.name.clone(),
                    first: (first.clone(), at_q0(&first)),
                    second: second.map(|x| {
                        let r = at_q0(&x);
                        (x, r)
                    }),
                    poly: e.poly,
                    stiffness,
                    damping,
                    gains,
                    impedance: gains.added_inertia(law),
                }
            })
            .collect()
    }

    /// The connect and weld equalities over `tree`, as springs and dampers. Their points and a
    /// weld's held orientation are placed as MuJoCo's compiler places them (body semantics: the
    /// point not written is where the written one is at `qpos0`, a weld's orientation the one
    /// there unless `relpose` gives it; site semantics: the sites). The stiffness and damping
    /// come from `solref` and `1 / (w₁ + w₂)`, `w` MuJoCo's `body_invweight0` ([`body_weights`]):
    /// translational for the points, rotational for a weld's orientation.
    fn connects(&self, tree: &Tree) -> Vec<Connect> {
        if self.connects.is_empty() {
            return vec![];
        }
        let q0 = tree.q0();
        let kin = tree.kinematics(&q0, &vec![0.0; tree.nv]);
        let weights = body_weights(tree);
        let weight = |b: usize| weights[b];
        self.connects
            .iter()
            .map(|c| {
                let (f1, f2) = (&kin.frames[c.body1], &kin.frames[c.body2]);
                let (anchor1, anchor2, relative) = match &c.anchors {
                    Anchors::Bodies { anchor, relpose: _ } if c.weld.is_none() => {
                        let p1 = f1.origin + f1.rotation * anchor;
                        (*anchor, f2.rotation.transpose() * (p1 - f2.origin), None)
                    }
                    Anchors::Bodies {
                        anchor,
                        relpose: None,
                    } => {
                        let p2 = f2.origin + f2.rotation * anchor;
                        let a1 = f1.rotation.transpose() * (p2 - f1.origin);
                        (a1, *anchor, Some(f1.rotation.transpose() * f2.rotation))
                    }
                    Anchors::Bodies {
                        anchor,
                        relpose: Some(pose),
                    } => (
                        pose.translation.vector,
                        *anchor,
                        Some(*pose.rotation.to_rotation_matrix().matrix()),
                    ),
                    Anchors::Sites(s1, s2) => (
                        s1.translation.vector,
                        s2.translation.vector,
                        Some(
                            *(s1.rotation * s2.rotation.inverse())
                                .to_rotation_matrix()
                                .matrix(),
                        ),
                    ),
                };
                let ((t1, r1), (t2, r2)) = (weight(c.body1), weight(c.body2));
                let gains = |w: f64| {
                    let inertia = if w > 0.0 { 1.0 / w } else { 0.0 };
                    self.equality_gains(tree, &c.softness, inertia)
                };
                let law = self.limits_law(Held::Equality);
                let translation = gains(t1 + t2);
                let (stiffness, damping) = translation.acting(law);
                // torquescale 0 frees the rotation; for any other value SCM's spring on the
                // angle keeps solref's time constant (MuJoCo's soft constraint does not: warned
                // where the weld is read).
                let orientation = match (relative, c.weld) {
                    (Some(relative), Some(scale)) if scale != 0.0 => {
                        let rotation = gains(r1 + r2);
                        let (stiffness, damping) = rotation.acting(law);
                        Some(Orientation {
                            relative,
                            stiffness,
                            damping,
                            gains: rotation,
                            impedance: rotation.added_inertia(law),
                        })
                    }
                    _ => None,
                };
                Connect {
                    name: c.name.clone(),
                    first: (c.body1, anchor1),
                    second: (c.body2, anchor2),
                    stiffness,
                    damping,
                    gains: translation,
                    impedance: translation.added_inertia(law),
                    orientation,
                }
            })
            .collect()
    }

    /// The degree of freedom and range of every joint whose total actuator force is limited
    /// (`actuatorfrcrange`), for [`Model::actuator_ranges`].
    pub(super) fn actuator_dof_ranges(&self, tree: &Tree) -> Vec<(usize, f64, f64)> {
        self.actuator_ranges
            .iter()
            .map(|&(j, lo, hi)| (tree.joints[j].dadr, lo, hi))
            .collect()
    }

    /// Sets the stiffness and damping of every joint that gives `springdamper="τ ζ"` as MuJoCo's
    /// compiler does: `k = I/(τ ζ)²`, `b = 2 I/τ` with `I` the joint's inertia at `qpos0`
    /// (`1 / dof_invweight0`, as for its limit), replacing `stiffness` and `damping`. Before the
    /// option flags, which may then switch them off.
    pub(super) fn apply_springdampers(&mut self) -> Result<(), SceneError> {
        if self.springdampers.is_empty() {
            return Ok(());
        }
        let tree = self.tree()?;
        let (m, m_inv) = mass_at_q0(&tree);
        for &(j, tau, zeta) in &self.springdampers {
            let inertia = joint_inertia(&tree, j, &m, &m_inv);
            let (k, b) = solref_gains([tau, zeta], inertia);
            self.joints[j].stiffness = k;
            self.joints[j].damping = b;
        }
        Ok(())
    }

    /// The tree with its joint limits, the tendons, and the equality constraints: the
    /// mechanics of the model, with the option flags applied.
    pub(super) fn mechanics(&self) -> Result<Mechanics, SceneError> {
        let mut tree = self.tree()?;
        self.check_mass_matrix(&tree)?;
        if self.flags.limit {
            self.set_limits(&mut tree);
        }
        let tendons = self.fixed_tendons(&tree)?;
        let equalities = self.scalar_equalities(&tree, &tendons);
        let connects = self.connects(&tree);
        let spatial_tendons = self.spatial_tendons(&tree)?;
        Ok(Mechanics {
            tree,
            tendons,
            spatial_tendons,
            equalities,
            connects,
        })
    }

    /// The spatial tendons over `tree`, with the option flags applied: the spring length
    /// defaults to the length in the springs' rest configuration (each slide and hinge joint
    /// at its `springref`, as MuJoCo's `qpos_spring`), and a limit is stiffened by the
    /// tendon's effective inertia `1 / (J M⁻¹ Jᵀ)` at `qpos0` (MuJoCo's `1 /
    /// tendon_invweight0`), `J = ∂L/∂v` there.
    fn spatial_tendons(&self, tree: &Tree) -> Result<Vec<SpatialTendon>, SceneError> {
        if self.spatial_tendons.is_empty() {
            return Ok(vec![]);
        }
        let q0 = tree.q0();
        let mut q_spring = q0.clone();
        for j in &tree.joints {
            if matches!(j.kind, JointKind::Slide | JointKind::Hinge) {
                q_spring[j.qadr] = j.springref;
            }
        }
        let at_rest = tree.kinematics(&q_spring, &vec![0.0; tree.nv]);
        let inv = self
            .spatial_tendons
            .iter()
            .any(|(t, _)| t.range.is_some() && self.flags.limit)
            .then(|| mass_at_q0(tree).1)
            .flatten();
        // The rate of the length for a unit velocity of each degree of freedom at qpos0: the
        // tendon's Jacobian there.
        let columns = unit_velocity_kinematics(tree, &q0);
        let on = |flag: bool, x: f64| if flag { x } else { 0.0 };
        self.spatial_tendons
            .iter()
            .map(|(t, segments)| {
                let mut tendon = SpatialTendon {
                    law: TendonLaw {
                        stiffness: on(self.flags.spring, t.stiffness),
                        spring_length: (0.0, 0.0),
                        damping: on(self.flags.damper, t.damping),
                        frictionloss: on(self.flags.frictionloss, t.frictionloss),
                        limit: None,
                    },
                    ..spatial_geometry(t, segments)
                };
                let rest = tendon.length_and_rate(&at_rest.frames).0;
                tendon.law.spring_length = t.spring_length.unwrap_or((rest, rest));
                if let (Some((lo, hi)), Some(inv), true) = (t.range, &inv, self.flags.limit) {
                    let jac: Vec<f64> = columns
                        .iter()
                        .map(|k| tendon.length_and_rate(&k.frames).1)
                        .collect();
                    let mut inv_weight = 0.0;
                    for (a, ja) in jac.iter().enumerate() {
                        for (b, jb) in jac.iter().enumerate() {
                            inv_weight += ja * jb * inv[(a, b)];
                        }
                    }
                    tendon.law.limit = Some(self.limit_law(
                        (lo, hi),
                        &t.limit_softness,
                        limit_inertia(t, inv_weight)?,
                        self.limits_law(Held::Tendon),
                    ));
                }
                Ok(tendon)
            })
            .collect()
    }
}

/// The model's mechanics as [`Builder::mechanics`] makes them.
pub(super) struct Mechanics {
    pub tree: Tree,
    pub tendons: Vec<FixedTendon>,
    pub spatial_tendons: Vec<SpatialTendon>,
    pub equalities: Vec<ScalarEquality>,
    pub connects: Vec<Connect>,
}

impl Builder {
    /// Refuses a tree whose mass matrix at `qpos0` is singular: joints of one body that move it
    /// the same way (a hinge beside a ball joint turns it about the hinge's axis twice). MuJoCo
    /// warns that its inertia matrix is too close to singular and runs on with a regularized
    /// factorization; SCM's forward dynamics cannot solve it. Names the body of the first
    /// degree of freedom whose leading block of the matrix is singular.
    fn check_mass_matrix(&self, tree: &Tree) -> Result<(), SceneError> {
        let (m, inv) = mass_at_q0(tree);
        if inv.is_some() || tree.nv == 0 {
            return Ok(());
        }
        let first = (1..=tree.nv)
            .find(|&k| m.view((0, 0), (k, k)).into_owned().cholesky().is_none())
            .unwrap_or(tree.nv)
            - 1;
        let joint = tree
            .joints
            .iter()
            .rev()
            .find(|j| j.dadr <= first)
            .expect("a degree of freedom belongs to a joint");
        let body = &tree.bodies[joint.body].name;
        let at = self.body_places.get(body);
        Err(SceneError {
            file: at.map_or_else(|| self.file.clone(), |p| p.file.to_string()),
            line: at.map_or(0, |p| p.line),
            element: "body".into(),
            message: format!("the mass matrix at the reference configuration is singular at joint '{}' of body '{body}': its joints move it the same way twice (a hinge beside a ball joint, two slides along one axis) or move no mass; MuJoCo warns and regularizes, SCM cannot solve it: remove the redundant joint", joint.name),
        })
    }
}

/// The inertia that stiffens tendon `t`'s limit spring, `1 / (J M⁻¹ Jᵀ)` at `qpos0`; refused
/// where that inverse weight is below MuJoCo's 1e-15 (`mjMINVAL`): the tendon's length does not
/// change with any joint at `qpos0` (a string straight through a hinge's axis, sites on
/// bodies welded together), where MuJoCo holds the limit as a hard constraint and SCM has no
/// inertia to size its spring by.
fn limit_inertia(t: &TendonSpec, inv_weight: f64) -> Result<f64, SceneError> {
    if inv_weight >= 1e-15 {
        return Ok(1.0 / inv_weight);
    }
    Err(SceneError {
        file: t.place.file.to_string(),
        line: t.place.line,
        element: "tendon".into(),
        message: format!("tendon '{}': its length does not change with any joint at the reference configuration (qpos0), so its limit has no effective inertia there (MuJoCo's tendon_invweight0 is {inv_weight:.1e}), which SCM sizes the limit's spring by; MuJoCo holds the limit as a hard constraint: write the bodies in a pose where the tendon's length moves with a joint (qpos0 is the pose as written), or remove the range", t.name),
    })
}

/// A spatial tendon's name and segments as read, with no force law (what measures its length).
pub(super) fn spatial_geometry(spec: &TendonSpec, segments: &[SegmentSpec]) -> SpatialTendon {
    SpatialTendon {
        name: spec.name.clone(),
        segments: segments
            .iter()
            .map(|s| Segment {
                from: s.from,
                to: s.to,
                scale: s.scale,
                wrap: s.wrap,
            })
            .collect(),
        law: TendonLaw {
            stiffness: 0.0,
            spring_length: (0.0, 0.0),
            damping: 0.0,
            frictionloss: 0.0,
            limit: None,
        },
    }
}

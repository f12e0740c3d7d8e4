//! From what was read to the engine's model: inertias as the compiler settings say, option
//! flags applied, the initial state, joint limits, fluid forces and the finished `Model`.

use super::*;
use crate::dynamics::equality::{Connect, Linear, ScalarEquality};
use crate::dynamics::limit::{solref_gains, JointLimit};
use crate::dynamics::tendon::FixedTendon;

impl Builder {
    /// Whether body `b`'s inertia comes from its geoms (`<compiler inertiafromgeom>`, and
    /// whether the body has an `<inertial>`).
    fn inertia_from_geoms(&self, b: usize) -> bool {
        match self.settings.inertia_from_geom {
            InertiaFromGeom::Always => true,
            InertiaFromGeom::Auto => !self.explicit_inertia[b],
            InertiaFromGeom::Never => false,
        }
    }

    /// Body inertias as `<compiler>` says: from the geoms or `<inertial>`, bounded, scaled to
    /// the total mass.
    pub(super) fn compile_inertias(&mut self) {
        let s = self.settings;
        for b in 1..self.bodies.len() {
            if self.inertia_from_geoms(b) {
                self.bodies[b].inertia = self.geom_inertia[b];
            }
            let i = &mut self.bodies[b].inertia;
            i.mass = i.mass.max(s.bound_mass);
            if s.bound_inertia > 0.0 {
                let e = i.rot.symmetric_eigen();
                let d = e.eigenvalues.map(|x| x.max(s.bound_inertia));
                i.rot = e.eigenvectors * Matrix3::from_diagonal(&d) * e.eigenvectors.transpose();
            }
        }
        if s.total_mass > 0.0 {
            let total: f64 = self.bodies.iter().map(|b| b.inertia.mass).sum();
            if total > 0.0 {
                let k = s.total_mass / total;
                for b in self.bodies.iter_mut().skip(1) {
                    b.inertia.mass *= k;
                    b.inertia.rot *= k;
                }
            }
        }
    }

    /// Applies the `<option><flag>` switches; returns what SCM refuses to simulate (features
    /// that change the physics and that SCM does not model), first in file order first.
    pub(super) fn apply_flags(&mut self) -> Vec<SceneError> {
        let mut refused = Vec::new();
        let f = self.flags;
        // MuJoCo's default integrator is its Euler.
        let mujoco = self.option_integrator.unwrap_or(Integrator::DampedEuler);
        if !f.eulerdamp && mujoco == Integrator::DampedEuler {
            self.option_integrator = Some(Integrator::SemiImplicitEuler);
        }
        if !f.gravity {
            self.gravity = Vector3::zeros();
        }
        // MuJoCo (3, 4) computes gravity compensation with the passive forces, which it skips
        // when both springs and dampers are disabled (measured in MuJoCo 4.0).
        if !f.spring && !f.damper {
            for b in &mut self.bodies {
                b.gravcomp = 0.0;
            }
        }
        for j in &mut self.joints {
            if !f.frictionloss {
                j.frictionloss = 0.0;
            }
            if !f.spring {
                j.stiffness = 0.0;
            }
            if !f.damper {
                j.damping = 0.0;
            }
        }
        if let Some(el) = &self.fluid {
            if self.wind != Vector3::zeros() {
                refused.push(self.err(
                    el,
                    "wind is not supported by SCM's fluid forces yet: remove it (the fluid is then still)",
                ));
            }
        }
        if f.limit {
            for (j, (_, _, el)) in self
                .limits
                .iter()
                .enumerate()
                .filter_map(|(j, l)| l.as_ref().map(|l| (j, l)))
            {
                if self.joints[j].kind == JointKind::Ball {
                    refused.push(self.err(el, "ball joint limits are not supported by SCM yet: remove range (or set limited=\"false\"), or switch limits off with <option><flag limit=\"disable\"/></option>"));
                }
            }
        }
        if !f.actuation && !self.actuators.is_empty() {
            refused.push(SceneError {
                file: self.file.clone(),
                line: 0,
                element: "flag".into(),
                message: "actuation=\"disable\" with actuators is not supported by SCM: remove the actuators instead".into(),
            });
        }
        refused.extend(std::mem::take(&mut self.refused));
        refused.sort_by(|a, b| (a.file.as_str(), a.line).cmp(&(b.file.as_str(), b.line)));
        refused
    }

    /// The initial state: the reference configuration at rest with zero controls, or the
    /// `<key>` that `scm_keyframe` names (by `name`, or by its index among the keys), whose
    /// `qpos`, `qvel` and `ctrl` replace those they give. The other keys are noted as unused.
    #[allow(clippy::type_complexity)]
    pub(super) fn initial_state(
        &mut self,
        tree: &Tree,
        keyframe: Option<(String, usize)>,
    ) -> Result<(Vec<f64>, Vec<f64>, Vec<f64>), SceneError> {
        let mut q0 = tree.q0();
        let mut v0 = vec![0.0; tree.nv];
        let mut ctrl0 = vec![0.0; self.actuators.len()];
        let chosen = match &keyframe {
            None => None,
            Some((want, line)) => {
                let by_name = self
                    .keys
                    .iter()
                    .position(|k| k.attr("name") == Some(want.as_str()));
                let by_index = want
                    .trim()
                    .parse::<usize>()
                    .ok()
                    .filter(|&i| i < self.keys.len());
                match by_name.or(by_index) {
                    Some(i) => Some(i),
                    None => {
                        return Err(self.setting_error(
                            *line,
                            "scm_keyframe",
                            format!("no <key> named '{want}' (and no key of that index): the scene has {} key(s)", self.keys.len()),
                        ))
                    }
                }
            }
        };
        for (i, key) in self.keys.clone().iter().enumerate() {
            if Some(i) != chosen {
                self.unused(
                    key,
                    "keyframe not chosen as the initial state (scm_keyframe picks one)",
                );
                continue;
            }
            for (attr, what) in [
                ("act", "actuator activations"),
                ("mpos", "mocap positions"),
                ("mquat", "mocap orientations"),
            ] {
                if key.attr(attr).is_some() {
                    return Err(self.err(key, format!("{attr}: {what} in the initial key are not supported by SCM: set the mocap inputs instead, or remove it")));
                }
            }
            if self.float(key, "time")?.is_some_and(|t| t != 0.0) {
                self.warnings.push(format!(
                    "{}:{}: the key's time is not used: the FMU starts at the host's start time",
                    key.file, key.line
                ));
            }
            for (attr, target) in [("qpos", &mut q0), ("qvel", &mut v0), ("ctrl", &mut ctrl0)] {
                if let Some(s) = key.attr(attr) {
                    let v = parse_floats(s)
                        .filter(|v| v.len() == target.len())
                        .ok_or_else(|| {
                            element_error(
                                key,
                                format!("{attr}: expected {} finite numbers", target.len()),
                            )
                        })?;
                    *target = v;
                }
            }
        }
        Ok((q0, v0, ctrl0))
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
        for (j, limit) in self.limits.iter().enumerate() {
            if let (Some((lo, hi, _)), JointKind::Slide | JointKind::Hinge) =
                (limit, tree.joints[j].kind)
            {
                let d = tree.joints[j].dadr;
                let inertia = match (slider_body_mass(tree, j), &m_inv) {
                    (Some(mass), _) => mass,
                    (None, Some(inv)) if inv[(d, d)] > 0.0 => 1.0 / inv[(d, d)],
                    // A singular mass matrix (a massless chain): the locked-joint inertia.
                    _ => m[(d, d)],
                };
                let joint = &mut tree.joints[j];
                joint.limit = Some(crate::dynamics::limit::JointLimit::from_solref(
                    *lo,
                    *hi,
                    self.solreflimit[j],
                    inertia,
                ));
            }
        }
    }

    /// The fixed tendons over `tree`'s coordinates, with the option flags applied: the spring
    /// length defaults to the length with every joint at its `springref`, and a limit is stiffened
    /// by the tendon's effective inertia there, `1 / (c M⁻¹ cᵀ)` (MuJoCo's
    /// `1 / tendon_invweight0`; `c` the coefficients over the degrees of freedom).
    fn fixed_tendons(&self, tree: &Tree) -> Vec<FixedTendon> {
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
                        (inv_weight > 0.0).then(|| {
                            JointLimit::from_solref(lo, hi, t.solreflimit, 1.0 / inv_weight)
                        })
                    }
                    _ => None,
                };
                let on = |flag: bool, x: f64| if flag { x } else { 0.0 };
                FixedTendon {
                    name: t.name.clone(),
                    joints,
                    stiffness: on(self.flags.spring, t.stiffness),
                    spring_length: t.spring_length.unwrap_or((length0, length0)),
                    damping: on(self.flags.damper, t.damping),
                    frictionloss: on(self.flags.frictionloss, t.frictionloss),
                    limit,
                }
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
                let (stiffness, damping) = solref_gains(e.solref, inertia);
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
                }
            })
            .collect()
    }

    /// The connect equalities over `tree`, as springs and dampers: body 2's anchor is where
    /// body 1's is at `qpos0` (as MuJoCo's compiler puts it), and the stiffness and damping
    /// come from `solref` and `1 / (w₁ + w₂)`, `w` MuJoCo's translational `body_invweight0`
    /// (zero for a body that cannot move, `1 / mass` for a top-level body of sliders, else the
    /// mean of the diagonal of `J M⁻¹ Jᵀ` for the Jacobian `J` of its centre of mass).
    fn connects(&self, tree: &Tree) -> Vec<Connect> {
        if self.connects.is_empty() {
            return vec![];
        }
        let q0 = tree.q0();
        let kin = tree.kinematics(&q0, &vec![0.0; tree.nv]);
        let inv = mass_at_q0(tree).1;
        // Columns of each body's centre-of-mass Jacobian: its velocity for a unit velocity of
        // each degree of freedom.
        let columns: Vec<_> = (0..tree.nv)
            .map(|k| {
                let mut v = vec![0.0; tree.nv];
                v[k] = 1.0;
                tree.kinematics(&q0, &v)
            })
            .collect();
        let weight = |b: usize| -> f64 {
            if b == 0 || !tree.body_moves(b) {
                return 0.0;
            }
            if let Some(mass) = tree.bodies[b]
                .joints
                .first()
                .and_then(|&j| slider_body_mass(tree, j))
            {
                return 1.0 / mass;
            }
            let Some(inv) = &inv else { return 0.0 };
            let com = tree.bodies[b].inertia.com;
            let jac: Vec<nalgebra::Vector3<f64>> = columns
                .iter()
                .map(|k| {
                    let f = &k.frames[b];
                    f.linvel + f.angvel.cross(&(f.rotation * com))
                })
                .collect();
            let mut trace = 0.0;
            for (a, ja) in jac.iter().enumerate() {
                for (c, jc) in jac.iter().enumerate() {
                    trace += ja.dot(jc) * inv[(a, c)];
                }
            }
            trace / 3.0
        };
        self.connects
            .iter()
            .map(|c| {
                let (f1, f2) = (&kin.frames[c.body1], &kin.frames[c.body2]);
                let p1 = f1.origin + f1.rotation * c.anchor;
                let anchor2 = f2.rotation.transpose() * (p1 - f2.origin);
                let w = weight(c.body1) + weight(c.body2);
                let (stiffness, damping) =
                    solref_gains(c.solref, if w > 0.0 { 1.0 / w } else { 0.0 });
                Connect {
                    name: c.name.clone(),
                    first: (c.body1, c.anchor),
                    second: (c.body2, anchor2),
                    stiffness,
                    damping,
                }
            })
            .collect()
    }

    /// The tree with its joint limits, the fixed tendons, and the equality constraints: the
    /// mechanics of the model, with the option flags applied.
    #[allow(clippy::type_complexity)]
    fn mechanics(
        &self,
    ) -> Result<(Tree, Vec<FixedTendon>, Vec<ScalarEquality>, Vec<Connect>), SceneError> {
        let mut tree = self.tree()?;
        if self.flags.limit {
            self.set_limits(&mut tree);
        }
        let tendons = self.fixed_tendons(&tree);
        let equalities = self.scalar_equalities(&tree, &tendons);
        let connects = self.connects(&tree);
        Ok((tree, tendons, equalities, connects))
    }

    /// The compiled model without colliders, and everything SCM would refuse about it.
    pub(super) fn compiled(mut self) -> Result<Compiled, SceneError> {
        self.compile_inertias();
        let refused = self.apply_flags();
        let (tree, tendons, equalities, connects) = self.mechanics()?;
        Ok(Compiled {
            tree,
            tendons,
            equalities,
            connects,
            geoms: self.geoms,
            actuators: self.actuators,
            timestep: self.timestep.unwrap_or(DEFAULT_STEP),
            integrator: self.option_integrator.unwrap_or(Integrator::DampedEuler),
            limits: self
                .limits
                .into_iter()
                .map(|l| l.map(|(lo, hi, _)| (lo, hi)))
                .collect(),
            refused,
            unused: self.unused,
            warnings: self.warnings,
        })
    }

    pub(super) fn tree(&self) -> Result<Tree, SceneError> {
        Tree::new(self.bodies.clone(), self.joints.clone(), self.gravity).map_err(|e| SceneError {
            file: self.file.clone(),
            line: 0,
            element: "body".into(),
            message: e.to_string(),
        })
    }

    pub(super) fn finish(mut self) -> Result<Scene, SceneError> {
        self.compile_inertias();
        if let Some(first) = self.apply_flags().into_iter().next() {
            return Err(first);
        }
        let mut contact = ContactParams::default();
        let mut spacing = DEFAULT_SPACING;
        let mut step = self.timestep.unwrap_or(DEFAULT_STEP);
        let mut integrator = self.option_integrator.unwrap_or(Integrator::DampedEuler);
        let mut tolerance = 1e-6;
        let mut contact_points = 0.0;
        let mut keyframe: Option<(String, usize)> = None;
        for (name, value, line) in self.numeric.clone() {
            let slot = match name.as_str() {
                "scm_eps1" => &mut contact.eps1,
                "scm_eps2" => &mut contact.eps2,
                "scm_eps3" => &mut contact.eps3,
                "scm_stiffness" => &mut contact.stiffness,
                "scm_dissipation_velocity" => &mut contact.dissipation_velocity,
                "scm_stiction_velocity" => &mut contact.stiction_velocity,
                "scm_friction" => &mut contact.friction,
                "scm_spacing" => &mut spacing,
                "scm_step" => &mut step,
                "scm_tolerance" => &mut tolerance,
                "scm_contact_points" => &mut contact_points,
                _ => return Err(self.setting_error(line, &name, "unknown SCM setting".into())),
            };
            if name == "scm_contact_points"
                && !(value.fract() == 0.0 && (0.0..=64.0).contains(&value))
            {
                return Err(self.setting_error(
                    line,
                    &name,
                    format!("{value} must be a whole number of contact points from 0 to 64"),
                ));
            }
            let ok = if name == "scm_friction" || name == "scm_contact_points" {
                value >= 0.0
            } else {
                value > 0.0
            };
            if !ok {
                return Err(self.setting_error(
                    line,
                    &name,
                    format!(
                        "{value} is out of range (must be {})",
                        if name == "scm_friction" {
                            "non-negative"
                        } else {
                            "positive"
                        }
                    ),
                ));
            }
            *slot = value;
        }
        for (name, value, line) in self.text.clone() {
            match name.as_str() {
                "scm_integrator" => {
                    integrator = Integrator::from_name(&value).ok_or_else(|| {
                        self.setting_error(
                            line,
                            &name,
                            format!(
                                "unknown integrator '{value}' (known: {})",
                                Integrator::ALL.map(|i| i.name()).join(", ")
                            ),
                        )
                    })?
                }
                "scm_dissipation" => {
                    contact.dissipation = Dissipation::from_name(&value).ok_or_else(|| {
                        self.setting_error(
                            line,
                            &name,
                            format!("'{value}' must be 'paper' or 'smooth'"),
                        )
                    })?
                }
                "scm_keyframe" => keyframe = Some((value, line)),
                _ => return Err(self.setting_error(line, &name, "unknown SCM setting".into())),
            }
        }
        // With contacts switched off (<flag contact="disable">) no body collides.
        let (pairs, colliders) = if self.flags.contact {
            self.split_static_planes();
            let (pairs, colliding) = self.pairs()?;
            let mut colliders: Vec<Option<Collider>> = vec![None; self.bodies.len()];
            for (b, slot) in colliders.iter_mut().enumerate() {
                *slot = self.collider(b, &colliding, spacing)?;
            }
            let pairs = pairs
                .into_iter()
                .filter(|p| match (&colliders[p.a], &colliders[p.b]) {
                    (Some(Collider::HalfSpace { .. }), Some(Collider::HalfSpace { .. })) => false,
                    (Some(_), Some(_)) => true,
                    _ => false,
                })
                .collect();
            (pairs, colliders)
        } else {
            (vec![], vec![None; self.bodies.len()])
        };
        let (tree, tendons, equalities, connects) = self.mechanics()?;
        let (q0, v0, ctrl0) = self.initial_state(&tree, keyframe)?;
        let fluid = self.fluid_model(&tree);
        let name = Path::new(&self.file)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scene".into());
        let model = Model {
            name,
            tree,
            colliders,
            pairs,
            actuators: std::mem::take(&mut self.actuators),
            contact,
            integrator,
            step,
            tolerance,
            contact_points: contact_points as usize,
            q0,
            v0,
            ctrl0,
            fluid,
            tendons,
            equalities,
            connects,
        };
        Ok(Scene {
            model,
            geoms: self.geoms,
            warnings: self.warnings,
            unused: self.unused,
            meshes: self.meshes,
            meshdir: self.meshdir,
            includes: vec![],
        })
    }

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
        let mut bodies = Vec::new();
        for (b, body) in tree.bodies.iter().enumerate().skip(1) {
            let i = &body.inertia;
            if !tree.body_moves(b) || i.mass < 1e-15 {
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
        })
    }
}

/// The mass MuJoCo takes as the inertia of joint `j` when its body is what MuJoCo's compiler
/// calls a simple body with sliders only (`body_simple = 2`): every joint of the body a slide
/// at the body origin along a coordinate axis, no child body, the parent the world or a
/// jointless child of it, and the inertia's frame the body frame (centre of mass at the
/// origin, diagonal inertia). For such a body MuJoCo's `dof_invweight0` is `1 / mass`: the
/// joints' armature is left out (for other joints it is in). `None` for every other joint.
fn slider_body_mass(tree: &Tree, j: usize) -> Option<f64> {
    let b = tree.joints[j].body;
    let body = &tree.bodies[b];
    let at_origin_on_an_axis = |k: &usize| {
        let joint = &tree.joints[*k];
        joint.kind == JointKind::Slide
            && joint.anchor.norm() == 0.0
            && joint.axis.iter().filter(|a| a.abs() > 1e-14).count() == 1
    };
    let parent_fixed = match body.parent {
        Some(0) => true,
        Some(p) => tree.bodies[p].parent == Some(0) && tree.bodies[p].joints.is_empty(),
        None => false,
    };
    let i = &body.inertia;
    let same_frame =
        i.com.norm() == 0.0 && (0..3).all(|r| (0..3).all(|c| r == c || i.rot[(r, c)] == 0.0));
    let leaf = tree.bodies.iter().all(|o| o.parent != Some(b));
    (body.joints.iter().all(at_origin_on_an_axis) && parent_fixed && same_frame && leaf)
        .then_some(i.mass)
}

/// The mass matrix at the reference configuration `qpos0` and its inverse (`None` when it is
/// singular: a massless chain), for the effective inertias MuJoCo's compiler takes there.
fn mass_at_q0(tree: &Tree) -> (nalgebra::DMatrix<f64>, Option<nalgebra::DMatrix<f64>>) {
    let q0 = tree.q0();
    let kin = tree.kinematics(&q0, &vec![0.0; tree.nv]);
    let m = tree.mass_matrix(&kin);
    let inv = m.clone().cholesky().map(|ch| ch.inverse());
    (m, inv)
}

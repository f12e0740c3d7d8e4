//! From what was read to the engine's model: inertias as the compiler settings say, the
//! initial state, fluid forces and the finished `Model` (its mechanics: `mechanics.rs`; the
//! option flags: `settings.rs`).

use super::mechanics::Mechanics;
use super::*;
use crate::geometry::mesh::MeshSampling;
use crate::geometry::polytope::FloorKind;

/// The initial positions, velocities, controls and activations.
type InitialState = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);

impl Builder {
    /// Whether body `b`'s inertia comes from its geoms (`<compiler inertiafromgeom>`, and
    /// whether the body has an `<inertial>`).
    pub(super) fn inertia_from_geoms(&self, b: usize) -> bool {
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

    /// The initial state: the reference configuration at rest with zero controls, or the
    /// `<key>` that `scm_keyframe` names (by `name`, or by its index among the keys), whose
    /// `qpos`, `qvel`, `ctrl` and `act` replace those they give. The other keys are noted as unused.
    pub(super) fn initial_state(
        &mut self,
        tree: &Tree,
        keyframe: Option<(String, Place)>,
    ) -> Result<InitialState, SceneError> {
        let mut q0 = tree.q0();
        let mut v0 = vec![0.0; tree.nv];
        let mut ctrl0 = vec![0.0; self.actuators.len()];
        let mut act0 = vec![0.0; self.na()];
        let chosen = match &keyframe {
            None => None,
            Some((want, at)) => {
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
                            at,
                            "scm_keyframe",
                            format!("no <key> named '{want}' (and no key of that index): the scene has {} key(s)", self.keys.len()),
                        ))
                    }
                }
            }
        };
        self.check_key_sizes(tree)?;
        for (i, key) in self.keys.clone().iter().enumerate() {
            if Some(i) != chosen {
                self.unused(
                    key,
                    "keyframe not chosen as the initial state (scm_keyframe picks one)",
                );
                continue;
            }
            for (attr, what) in [("mpos", "mocap positions"), ("mquat", "mocap orientations")] {
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
            for (attr, target) in [
                ("qpos", &mut q0),
                ("qvel", &mut v0),
                ("ctrl", &mut ctrl0),
                ("act", &mut act0),
            ] {
                if let Some(s) = key.attr(attr) {
                    // Sizes are checked above; an empty list keeps the default, a short ctrl
                    // sets its first controls (MuJoCo pads it with zeros).
                    let v = parse_floats(s)
                        .filter(|v| v.iter().all(|x| x.is_finite()))
                        .ok_or_else(|| {
                            element_error(key, format!("{attr}: expected finite numbers"))
                        })?;
                    for (t, x) in target.iter_mut().zip(v) {
                        *t = x;
                    }
                }
            }
        }
        Ok((q0, v0, ctrl0, act0))
    }

    /// Number of activation states of the actuators read so far.
    fn na(&self) -> usize {
        (self.actuators.iter())
            .filter(|a| a.activation.is_some())
            .count()
    }

    /// Every key's arrays have MuJoCo's sizes (MuJoCo refuses the file otherwise, whichever
    /// key is used; measured with MuJoCo 4.0.0): qpos nq, qvel nv, act na exactly or empty; ctrl at most nu, mpos and mquat at most 3 and 4
    /// per mocap body (MuJoCo pads them with zeros).
    fn check_key_sizes(&self, tree: &Tree) -> Result<(), SceneError> {
        let nmocap = tree.mocap.len();
        for key in &self.keys {
            for (attr, n) in [
                ("qpos", tree.q0().len()),
                ("qvel", tree.nv),
                ("ctrl", self.actuators.len()),
                ("act", self.na()),
                ("mpos", 3 * nmocap),
                ("mquat", 4 * nmocap),
            ] {
                let Some(text) = key.attr(attr) else { continue };
                let got = parse_floats(text).map(|v| v.len());
                let at_most = matches!(attr, "ctrl" | "mpos" | "mquat");
                let fits = match got {
                    Some(g) => g == n || g == 0 || (at_most && g <= n),
                    None => false,
                };
                if !fits {
                    return Err(element_error(
                    key,
                    format!(
                        "{attr}: expected {n} numbers, got {} (MuJoCo refuses a key of the wrong size, whichever key is used)",
                        got.map_or("an unreadable list".to_string(), |g| g.to_string())
                    ),
                ));
                }
            }
        }
        Ok(())
    }

    /// The compiled model without colliders, and everything SCM would refuse about it.
    pub(super) fn compiled(mut self) -> Result<Compiled, SceneError> {
        self.compile_inertias();
        self.apply_springdampers()?;
        let refused = self.apply_flags();
        let Mechanics {
            tree,
            tendons,
            spatial_tendons,
            equalities,
            connects,
        } = self.mechanics()?;
        self.apply_dampratios(&tree)?;
        self.check_key_sizes(&tree)?;
        let pair_laws = if self.flags.contact {
            let (mut pairs, colliding) = self.pairs()?;
            let eps3 = self
                .numeric
                .iter()
                .rev()
                .find(|(n, _, _)| n == "scm_eps3")
                .map_or(ContactParams::default().eps3, |(_, v, _)| *v);
            let step = self.timestep.unwrap_or(DEFAULT_STEP);
            let integrator = self.integrator_as_run();
            let laws = self.pair_laws(&tree, &mut pairs, &colliding, eps3, step, integrator);
            self.stiction_floors(&tree, &mut pairs, step, integrator);
            let name = |b: usize| self.bodies[b].name.clone();
            pairs
                .iter()
                .zip(laws)
                .filter_map(|(p, law)| {
                    Some(CompiledPair {
                        body1: name(p.a),
                        body2: name(p.b),
                        margin: p.margin,
                        adhesion: (p.adhesion, p.gap),
                        stiction_floor: p.stiction_floor * p.friction.unwrap_or(f64::NAN),
                        hold_separation: p.hold_separation
                            && law.is_some_and(|l| l.dissipation_force.is_finite()),
                        law: law?,
                    })
                })
                .collect()
        } else {
            vec![]
        };
        let fluid = self.fluid_model(&tree);
        Ok(Compiled {
            pair_laws,
            fluid,
            tree,
            tendons,
            spatial_tendons,
            transmissions: self.transmissions,
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
            actuator_ranges: (0..self.joints.len())
                .map(|j| {
                    self.actuator_ranges
                        .iter()
                        .find(|r| r.0 == j)
                        .map(|&(_, lo, hi)| (lo, hi))
                })
                .collect(),
            refused,
            unused: self.unused,
            warnings: self.warnings,
        })
    }

    pub(super) fn tree(&self) -> Result<Tree, SceneError> {
        Tree::new(self.bodies.clone(), self.joints.clone(), self.gravity).map_err(|e| {
            // A body's problem names the body where it is written.
            let at = match &e {
                TreeError::Massless(name) | TreeError::Order(name) => self.body_places.get(name),
                _ => None,
            };
            SceneError {
                file: at.map_or_else(|| self.file.clone(), |p| p.file.to_string()),
                line: at.map_or(0, |p| p.line),
                element: "body".into(),
                message: e.to_string(),
            }
        })
    }

    pub(super) fn finish(mut self) -> Result<Scene, SceneError> {
        self.compile_inertias();
        self.apply_springdampers()?;
        if let Some(first) = self.apply_flags().into_iter().next() {
            return Err(first);
        }
        let mut contact = ContactParams::default();
        let mut spacing = DEFAULT_SPACING;
        let mut resolution = DEFAULT_RESOLUTION;
        let mut spacing_overrides: Vec<(String, f64, Place)> = Vec::new();
        let mut step = self.timestep.unwrap_or(DEFAULT_STEP);
        let mut integrator = self.option_integrator.unwrap_or(Integrator::DampedEuler);
        let mut tolerance = 1e-6;
        let mut prune_tolerance = crate::scalar::PRUNE_TOLERANCE;
        let mut contact_points = 0.0;
        // 0: not set (the machine's default, `PairThreads::default_for_machine`).
        let mut pair_threads = 0.0;
        let mut keyframe: Option<(String, Place)> = None;
        let mut mesh_sampling = MeshSampling::Patches;
        let mut by_hulls = true;
        // Unset: the tight floor on a cloud with a reach (a mesh in patches, whose planes read
        // past its faces' edges), the margin on the others (docs/method.md, "A tight floor").
        let mut floor: Option<FloorKind> = None;
        for (name, value, at) in self.numeric.clone() {
            if let Some(geom) = name.strip_prefix(GEOM_SPACING_PREFIX) {
                if value <= 0.0 {
                    return Err(self.setting_error(
                        &at,
                        &name,
                        format!("{value} is out of range (must be positive)"),
                    ));
                }
                spacing_overrides.push((geom.to_string(), value, at));
                continue;
            }
            if name == "scm_stiction_floor" {
                // Read by `Builder::stiction_floors`.
                if value < 0.0 {
                    return Err(self.setting_error(
                        &at,
                        &name,
                        format!("{value} is out of range (each pair's stiction velocity is at least this times h mu g; 0 for no floor)"),
                    ));
                }
                continue;
            }
            if name == "scm_prune_tolerance" {
                if !crate::scalar::prune_tolerance_ok(value) {
                    return Err(self.setting_error(
                        &at,
                        &name,
                        format!("{value} is out of range (the relative weight below which a softmax term or point force is skipped: from above 0 to {:e}; 1e-15 by default)", crate::scalar::PRUNE_TOLERANCE_MAX),
                    ));
                }
                prune_tolerance = value;
                continue;
            }
            if name == "scm_dissipation_force" {
                // Read by each pair's law (`Builder::pair_laws`).
                if value < 0.0 {
                    return Err(self.setting_error(
                        &at,
                        &name,
                        format!("{value} is out of range (the dissipation force over each pair's resting force, positive; 0 for no bound, the paper's law)"),
                    ));
                }
                continue;
            }
            let slot = match name.as_str() {
                "scm_eps1" => &mut contact.eps1,
                "scm_eps2" => &mut contact.eps2,
                "scm_eps3" => &mut contact.eps3,
                "scm_stiffness" => &mut contact.stiffness,
                "scm_dissipation_velocity" => &mut contact.dissipation_velocity,
                "scm_stiction_velocity" => &mut contact.stiction_velocity,
                "scm_friction" => &mut contact.friction,
                "scm_spacing" => &mut spacing,
                "scm_resolution" => &mut resolution,
                "scm_step" => &mut step,
                "scm_tolerance" => &mut tolerance,
                "scm_contact_points" => &mut contact_points,
                "scm_pair_threads" => &mut pair_threads,
                _ => return Err(self.setting_error(&at, &name, "unknown SCM setting".into())),
            };
            if name == "scm_contact_points"
                && !(value.fract() == 0.0 && (0.0..=64.0).contains(&value))
            {
                return Err(self.setting_error(
                    &at,
                    &name,
                    format!("{value} must be a whole number of contact points from 0 to 64"),
                ));
            }
            if name == "scm_pair_threads"
                && !(value.fract() == 0.0 && (1.0..=64.0).contains(&value))
            {
                return Err(self.setting_error(
                    &at,
                    &name,
                    format!("{value} must be a whole number of threads from 1 (serial) to 64"),
                ));
            }
            let ok = if name == "scm_friction" || name == "scm_contact_points" {
                value >= 0.0
            } else {
                value > 0.0
            };
            if !ok {
                return Err(self.setting_error(
                    &at,
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
        // Each geom's spacing comes from its size ([`AUTO_RESOLUTION`]) only when the scene sets
        // neither (docs/geometry.md, "Spacing per geom").
        let said = |n: &str| self.numeric.iter().any(|(name, _, _)| name == n);
        let resolution_set = (said("scm_spacing") || said("scm_resolution")).then_some(resolution);
        for (name, value, at) in self.text.clone() {
            match name.as_str() {
                "scm_integrator" => {
                    integrator = Integrator::from_name(&value).ok_or_else(|| {
                        self.setting_error(
                            &at,
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
                            &at,
                            &name,
                            format!("'{value}' must be 'paper' or 'smooth'"),
                        )
                    })?
                }
                "scm_keyframe" => keyframe = Some((value, at)),
                "scm_mesh_sampling" => {
                    mesh_sampling = match value.as_str() {
                        "patches" => MeshSampling::Patches,
                        "triangles" => MeshSampling::Triangles,
                        _ => {
                            return Err(self.setting_error(
                                &at,
                                &name,
                                format!("'{value}' must be 'patches' (points as far apart as the spacing, the default) or 'triangles' (triangle by triangle, keeping a mesh's symmetry)"),
                            ))
                        }
                    }
                }
                "scm_mesh_collision" => {
                    by_hulls = match value.as_str() {
                        "hull" => true,
                        "surface" => false,
                        _ => {
                            return Err(self.setting_error(
                                &at,
                                &name,
                                format!("'{value}' must be 'hull' (a mesh collides by its convex hull, as in MuJoCo: the default) or 'surface' (by the mesh itself, concave parts included)"),
                            ))
                        }
                    }
                }
                "scm_floor" => {
                    floor = match value.as_str() {
                        "margin" => Some(FloorKind::Margin),
                        "tight" => Some(FloorKind::Tight),
                        _ => return Err(self.setting_error(&at, &name, format!("'{value}' must be 'margin' (each plane's reading floored one and a half cover radii below what the other body's polytope proves: the default for a primitive's cloud) or 'tight' (at what it proves: the default for a mesh's cloud), for every cloud of the scene"))),
                    }
                }
                _ => return Err(self.setting_error(&at, &name, "unknown SCM setting".into())),
            }
        }
        // File meshes triangle by triangle where the scene asks (height fields always are).
        if mesh_sampling == MeshSampling::Triangles {
            for g in &mut self.geoms {
                if let Some(Shape::Mesh(m)) = &mut g.shape {
                    if m.sampling != mesh_sampling {
                        Arc::make_mut(m).sampling = mesh_sampling;
                    }
                }
            }
        }
        // With contacts switched off (<flag contact="disable">) no body collides.
        let (mut pairs, colliders, colliding) = if self.flags.contact {
            self.split_static_geoms();
            let (pairs, colliding) = self.pairs()?;
            if by_hulls {
                self.collide_by_hulls(&colliding, mesh_sampling);
            }
            self.assign_spacings(spacing, resolution_set, &spacing_overrides, &colliding)?;
            let mut colliders: Vec<Option<Collider>> = vec![None; self.bodies.len()];
            let mut sampled = Vec::new();
            for b in 0..colliders.len() {
                colliders[b] = self.collider(b, &colliding, &mut sampled, &colliders)?;
            }
            // The scene's pruning tolerance and floor, on every cloud (each pair reads its
            // clouds').
            for c in colliders.iter_mut().flatten() {
                if let Collider::Aopc(s) = c {
                    s.set_tolerance(prune_tolerance);
                    let mesh = !s.reach.is_empty();
                    s.set_floor(floor.unwrap_or(if mesh {
                        FloorKind::Tight
                    } else {
                        FloorKind::Margin
                    }));
                }
            }
            let pairs = pairs
                .into_iter()
                .filter(|p| match (&colliders[p.a], &colliders[p.b]) {
                    (Some(Collider::HalfSpace { .. }), Some(Collider::HalfSpace { .. })) => false,
                    (Some(_), Some(_)) => true,
                    _ => false,
                })
                .collect();
            let mut pairs = self.with_surfaces(pairs, &colliding)?;
            self.eps1_scales(&mut pairs, &colliding);
            (pairs, colliders, colliding)
        } else {
            // Nothing is sampled: per-geom spacings are checked and reported unused.
            self.assign_spacings(
                spacing,
                resolution_set,
                &spacing_overrides,
                &vec![false; self.geoms.len()],
            )?;
            (vec![], vec![None; self.bodies.len()], vec![])
        };
        let Mechanics {
            tree,
            tendons,
            spatial_tendons,
            equalities,
            connects,
        } = self.mechanics()?;
        self.apply_dampratios(&tree)?;
        // MuJoCo's refsafe holds the time constants at twice the file's step, whatever SCM's.
        let file_step = self.timestep.unwrap_or(DEFAULT_STEP);
        // A PID's integral reads the file's step (MuJoCo's opt.timestep), whatever SCM's.
        for a in self.actuators.iter_mut() {
            if let Some(Activation {
                law: ActivationLaw::PidIntegral { step, .. },
                ..
            }) = a.activation.as_mut()
            {
                *step = file_step;
            }
        }
        let pair_laws = self.pair_laws(
            &tree,
            &mut pairs,
            &colliding,
            contact.eps3,
            file_step,
            integrator,
        );
        self.stiction_floors(&tree, &mut pairs, file_step, integrator);
        let (q0, v0, ctrl0, act0) = self.initial_state(&tree, keyframe)?;
        let fluid = self.fluid_model(&tree);
        let actuator_ranges = self.actuator_dof_ranges(&tree);
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
            timestep: step,
            tolerance,
            contact_points: contact_points as usize,
            q0,
            v0,
            ctrl0,
            act0,
            fluid,
            tendons,
            equalities,
            connects,
            spatial_tendons,
            site_transmissions: std::mem::take(&mut self.transmissions.sites),
            slider_cranks: std::mem::take(&mut self.transmissions.slider_cranks),
            actuator_ranges,
            pair_threads: if pair_threads > 0.0 {
                crate::model::PairThreads {
                    threads: pair_threads as usize,
                    min_pairs: crate::model::PairThreads::MIN_PAIRS,
                }
            } else {
                crate::model::PairThreads::default_for_machine()
            },
        };
        Ok(Scene {
            model,
            geoms: self.geoms,
            warnings: self.warnings,
            unused: self.unused,
            meshes: self.meshes,
            meshdir: self.meshdir,
            includes: vec![],
            hfields: self.hfields,
            pair_laws,
        })
    }
}

//! Geoms and mesh assets: shapes, their mass and inertia, and what they collide with.

use super::*;

impl Builder {
    pub(super) fn geom(&mut self, el: &Element, body: usize) -> Result<(), SceneError> {
        self.check_attrs(
            el,
            &[
                "name",
                "type",
                "size",
                "pos",
                "quat",
                "fromto",
                "group",
                "shellinertia",
                "mass",
                "density",
                "friction",
                "contype",
                "conaffinity",
                "condim",
                "solref",
                "solimp",
                "solmix",
                "priority",
                "margin",
                "mesh",
                "fluidshape",
                "fluidcoef",
                "fitscale",
                "hfield",
            ],
        )?;
        // MuJoCo's default fluid model is the bodies' inertia boxes (fluidshape="none"), which
        // SCM has; the per-geom ellipsoid model it does not.
        match el.attr("fluidshape") {
            None | Some("none") => {
                if el.attr("fluidcoef").is_some() {
                    self.unused(el, "fluidcoef (read by MuJoCo only with fluidshape=\"ellipsoid\")");
                }
            }
            Some(v) => {
                return Err(self.err(
                    el,
                    format!("fluidshape=\"{v}\": MuJoCo's ellipsoid fluid model is not supported by SCM: remove fluidshape to use the inertia-box model (MuJoCo's default), which SCM has"),
                ))
            }
        }
        if el.attr("shellinertia").is_some_and(|v| v != "false") {
            return Err(self.err(
                el,
                "shellinertia is not supported by SCM: give the body an <inertial>",
            ));
        }
        if matches!(el.attr("condim"), Some("4") | Some("6")) {
            self.unused(
                el,
                "condim 4 and 6 (MuJoCo's torsional and rolling friction)",
            );
        }
        let friction = match el.attr("friction").map(parse_floats) {
            None => 1.0,
            Some(Some(v)) if (1..=3).contains(&v.len()) && v[0] >= 0.0 => {
                if v[1..].iter().any(|&x| x != 0.0) {
                    self.unused(el, "friction's torsional and rolling coefficients (SCM models sliding friction)");
                }
                v[0]
            }
            Some(_) => {
                return Err(self.err(
                    el,
                    format!(
                        "friction=\"{}\": expected 1 to 3 non-negative numbers",
                        el.attr("friction").unwrap_or("")
                    ),
                ))
            }
        };
        let condim: u32 = match el.attr("condim") {
            None => 3,
            Some(c) => c
                .trim()
                .parse()
                .ok()
                .filter(|c| [1, 3, 4, 6].contains(c))
                .ok_or_else(|| self.err(el, format!("condim=\"{c}\": expected 1, 3, 4 or 6")))?,
        };
        let softness = self.geom_softness(el)?;
        let margin = self.float(el, "margin")?.unwrap_or(0.0);
        let size = el.attr("size").and_then(parse_floats).unwrap_or_default();
        let kind = el.attr("type").unwrap_or("sphere");
        let fromto = self.floats(el, "fromto", 6)?;
        // With fromto, the geom runs from one point to the other along its z axis.
        let from_to = match fromto {
            Some(_) if !matches!(kind, "capsule" | "cylinder" | "box" | "ellipsoid") => {
                return Err(self.err(el, format!("fromto does not apply to a {kind}")))
            }
            Some(f) => {
                let (a, b) = (
                    Vector3::new(f[0], f[1], f[2]),
                    Vector3::new(f[3], f[4], f[5]),
                );
                let axis = b - a;
                if axis.norm() < 1e-12 {
                    return Err(self.err(el, "fromto: the two points coincide"));
                }
                // MuJoCo points the geom's z axis from the second point to the first.
                Some((
                    Isometry3::from_parts(
                        Translation3::from((a + b) * 0.5),
                        canonical::z_to(&(a - b)),
                    ),
                    0.5 * axis.norm(),
                ))
            }
            None => None,
        };
        // A primitive with a mesh is fitted to the mesh, as MuJoCo's compiler fits it (its size
        // then comes from the mesh's inertia box or bounding box, whatever size says).
        let fit = match (el.attr("mesh"), matches!(kind, "mesh" | "sdf")) {
            (Some(mesh), false) => {
                if from_to.is_some() {
                    return Err(self.err(el, format!("fromto with mesh=\"{mesh}\": MuJoCo refuses fromto on a geom fitted to a mesh; give pos and quat")));
                }
                Some((mesh.to_string(), self.fit_to_mesh(el, kind, mesh)?))
            }
            _ => None,
        };
        let size = match &fit {
            Some((_, (fitted, _))) => {
                if el.attr("size").is_some() {
                    self.unused(
                        el,
                        "size (MuJoCo sizes a geom fitted to a mesh by the mesh)",
                    );
                }
                fitted.clone()
            }
            None => size,
        };
        let need = |n: usize| -> Result<(), SceneError> {
            if size.len() < n || size[..n].iter().any(|&s| s <= 0.0) {
                return Err(self.err(
                    el,
                    format!(
                        "size needs {n} positive number(s), got \"{}\"",
                        el.attr("size").unwrap_or("")
                    ),
                ));
            }
            Ok(())
        };
        // Half-length along z: from fromto, else the size entry at `k`.
        let half_z = |k: usize| -> Result<f64, SceneError> {
            match from_to {
                Some((_, h)) => Ok(h),
                None => {
                    need(k + 1)?;
                    Ok(size[k])
                }
            }
        };
        let mut mesh_name = None;
        let shape = match kind {
            "sphere" => {
                need(1)?;
                Some(Shape::Sphere { radius: size[0] })
            }
            "box" => {
                need(2)?;
                let hz = half_z(2)?;
                Some(Shape::Box {
                    half: Vector3::new(size[0], size[1], hz),
                })
            }
            "capsule" => {
                need(1)?;
                Some(Shape::Capsule {
                    radius: size[0],
                    half_length: half_z(1)?,
                })
            }
            "cylinder" => {
                need(1)?;
                Some(Shape::Cylinder {
                    radius: size[0],
                    half_length: half_z(1)?,
                })
            }
            "ellipsoid" => {
                need(2)?;
                let hz = half_z(2)?;
                Some(Shape::Ellipsoid {
                    radii: Vector3::new(size[0], size[1], hz),
                })
            }
            "mesh" => {
                let name = el.attr("mesh").ok_or_else(|| {
                    self.err(el, "a mesh geom needs mesh=\"NAME\" naming a <mesh> asset")
                })?;
                let asset = self
                    .meshes
                    .iter_mut()
                    .find(|m| m.name == name)
                    .ok_or_else(|| SceneError {
                        file: self.file.clone(),
                        line: el.line,
                        element: el.name.clone(),
                        message: format!("no mesh asset named '{name}'"),
                    })?;
                match (&asset.mesh, &asset.problem) {
                    (Some(mesh), _) => {
                        asset.used = true;
                        mesh_name = Some(name.to_string());
                        Some(Shape::Mesh(mesh.clone()))
                    }
                    (None, Some(problem)) => {
                        let (problem, inertia) = (problem.clone(), asset.inertia);
                        match self.geom_without_its_mesh(el, body, problem, name, inertia)? {
                            Some(hull) => {
                                let asset = self.meshes.iter_mut().find(|m| m.name == name);
                                asset.expect("found above").used = true;
                                mesh_name = Some(name.to_string());
                                Some(Shape::Mesh(hull))
                            }
                            None => return Ok(()),
                        }
                    }
                    (None, None) => unreachable!("a mesh asset has its mesh or its problem"),
                }
            }
            "plane" => None,
            "hfield" => {
                self.flat_hfield(el)?;
                None
            }
            t @ "sdf" => return Err(self.err(el, format!("geom type {t} is not supported"))),
            t => return Err(self.err(el, format!("type=\"{t}\" is not a geom type"))),
        };
        if el.attr("mesh").is_some() && kind != "mesh" && fit.is_none() {
            return Err(self.err(
                el,
                format!(
                    "mesh=\"{}\" given for a {kind} geom: add type=\"mesh\"",
                    el.attr("mesh").unwrap_or("")
                ),
            ));
        }
        let pose = match (from_to, &fit) {
            (Some((p, _)), _) => p,
            (None, Some((_, (_, frame)))) => self.pose(el)? * frame,
            (None, None) => self.pose(el)?,
        };
        let name = match Self::given_name(el) {
            Some(n) => n,
            None => {
                let base = format!(
                    "{}_geom{}",
                    self.bodies[body].name,
                    self.geoms.iter().filter(|g| g.body == body).count()
                );
                self.names.make("geom", base)
            }
        };
        if let Some(shape) = &shape {
            let group: i64 = match el.attr("group") {
                None => 0,
                Some(g) => g
                    .trim()
                    .parse()
                    .map_err(|_| self.err(el, format!("group=\"{g}\" must be an integer")))?,
            };
            let (lo, hi) = self.settings.inertia_groups;
            if body != 0 && (lo..=hi).contains(&group) {
                // A mesh weighs as MuJoCo weighs it, where its mass is used at all (not under
                // mass="0" or density="0", nor in a body whose <inertial> gives its inertia).
                let weighed = !self.massless(el)? && self.inertia_from_geoms(body);
                let mp = match &mesh_name {
                    Some(mesh) if weighed => self.mesh_mass(el, mesh)?,
                    _ => None,
                }
                .unwrap_or_else(|| shape.mass_properties());
                let mass = match (self.float(el, "mass")?, self.float(el, "density")?) {
                    (Some(m), _) if m < 0.0 => {
                        return Err(self.err(el, format!("mass=\"{m}\" must not be negative")))
                    }
                    (Some(m), _) => m,
                    (None, Some(d)) if d < 0.0 => {
                        return Err(self.err(el, format!("density=\"{d}\" must not be negative")))
                    }
                    (None, d) => d.unwrap_or(1000.0) * mp.volume,
                };
                let gi = geom_inertia(&mp, mass, &pose);
                self.geom_inertia[body] = self.geom_inertia[body].add(&gi);
                self.mass_geom_frames
                    .entry(body)
                    .or_default()
                    .push(pose.rotation);
            }
        } else if self.moves_with_joints(body) {
            return Err(self.err(el, format!("a {kind} can only belong to a body welded to the world (this body or one it hangs from has joints), as MuJoCo requires")));
        }
        let (contype, conaffinity) = (self.bits(el, "contype")?, self.bits(el, "conaffinity")?);
        self.geoms.push(Geom {
            name,
            body,
            shape,
            mesh: mesh_name,
            fitted_to: fit.map(|(mesh, _)| mesh),
            pose,
            contype,
            conaffinity,
            friction,
            condim,
            softness,
            margin,
            file: el.file.to_string(),
            line: el.line,
            spacing: None,
        });
        Ok(())
    }

    /// A geom whose mesh has no closed surface (`problem`), and the convex hull of its
    /// vertices (`hull`, if they span a volume). A geom that collides samples the hull, which
    /// is what MuJoCo collides every mesh by (noted as a warning); its mass, if it gives its
    /// body mass, is what MuJoCo makes of the mesh ([`Builder::mesh_mass`]: by default its
    /// legacy rule, which takes open surfaces), except under `inertia="exact"`, which needs a
    /// closed surface: there the mesh's problem is the error, naming the geom. A geom that neither
    /// collides (`contype` and `conaffinity` both 0) nor gives its body mass (a zero mass or
    /// density, a group outside `inertiagrouprange`, or a body whose inertia does not come from
    /// its geoms) is left out of the model and listed as unused. Returns the shape the geom
    /// takes, `None` when it is left out.
    fn geom_without_its_mesh(
        &mut self,
        el: &Element,
        body: usize,
        problem: SceneError,
        mesh: &str,
        inertia: MeshInertia,
    ) -> Result<Option<Arc<TriMesh>>, SceneError> {
        let collides = self.bits(el, "contype")? != 0 || self.bits(el, "conaffinity")? != 0;
        let group: i64 = el
            .attr("group")
            .and_then(|g| g.trim().parse().ok())
            .unwrap_or(0);
        let (lo, hi) = self.settings.inertia_groups;
        let gives_mass = body != 0
            && (lo..=hi).contains(&group)
            && !self.massless(el)?
            && self.inertia_from_geoms(body);
        let refuse = |why: &str| {
            SceneError {
            message: format!(
                "{} (used by the <geom> at {}:{}, where {why}; a geom that only shows the mesh, with contype=\"0\" conaffinity=\"0\" and no mass, does not need it)",
                problem.message, el.file, el.line
            ),
            ..problem.clone()
        }
        };
        if gives_mass && inertia == MeshInertia::Exact {
            return Err(refuse("it gives its body mass by the mesh's inertia=\"exact\", the solid its surface encloses, and the surface is not closed (MuJoCo's default inertia, without that attribute, or inertia=\"convex\" weigh an open mesh; or give the body an <inertial>)"));
        }
        if collides || gives_mass {
            let (hull, maxhullvert) = match self.hull_of(mesh) {
                Some(h) => h,
                None if collides => {
                    return Err(refuse(
                        &format!("it collides, and SCM samples a closed surface: its convex hull cannot be made ({})", self.hull_problem(mesh)),
                    ))
                }
                None => return Err(refuse(&format!("it gives its body mass by its convex hull, which cannot be made ({})", self.hull_problem(mesh)))),
            };
            if let Some(n) = maxhullvert {
                return Err(refuse(&format!("SCM takes its convex hull, which MuJoCo reduces to {n} vertices (maxhullvert) and SCM does not: remove maxhullvert for the full hull in both")));
            }
            // Its mass is MuJoCo's (`mesh_mass`); its collision surface is the hull.
            if collides {
                self.warnings.push(format!(
                    "{}:{}: <geom> collides by the convex hull of its mesh, as MuJoCo collides every mesh ({})",
                    el.file, el.line, problem.message
                ));
            }
            return Ok(Some(hull));
        }
        self.unused(
            el,
            format!(
                "geom left out: its mesh is not a closed surface ({}), and it neither collides nor carries mass",
                problem.message
            ),
        );
        Ok(None)
    }

    /// MuJoCo's mesh-fitted primitive (docs/mjcf.md): the size of a `kind` geom fitted to mesh
    /// asset `mesh`, and its frame in the geom's written frame (the mesh's inertia frame, moved
    /// to the centre of the bounding box under `fitaabb`). Sizes come from the mesh's
    /// equivalent inertia box (the solid box of the mesh's volume and principal moments, by
    /// the mesh's own `inertia` rule), or from its vertices' bounding box in the inertia frame
    /// (`fitaabb`): a sphere takes the boxes' mean half-size (the largest under `fitaabb`), a
    /// capsule or cylinder the mean of the first two as radius and the third as half-length
    /// (a capsule less half its radius, or under `fitaabb` less its radius), a box or
    /// ellipsoid all three; then all are scaled by `fitscale`.
    fn fit_to_mesh(
        &mut self,
        el: &Element,
        kind: &str,
        mesh: &str,
    ) -> Result<(Vec<f64>, Isometry3<f64>), SceneError> {
        if !matches!(
            kind,
            "sphere" | "capsule" | "cylinder" | "box" | "ellipsoid"
        ) {
            return Err(self.err(el, format!("type=\"{kind}\" with mesh=\"{mesh}\": MuJoCo fits only spheres, capsules, cylinders, boxes and ellipsoids to a mesh")));
        }
        let Some(asset) = self.meshes.iter().find(|m| m.name == mesh) else {
            return Err(self.err(el, format!("no mesh asset named '{mesh}'")));
        };
        let (closed, problem) = (asset.mesh.clone(), asset.problem.clone());
        let weighed = self.mesh_mass(el, mesh).map_err(|mut e| {
            e.message += &format!(
                " (a {kind} fitted to the mesh needs the mesh's inertia, whatever the geom weighs)"
            );
            e
        })?;
        let mp = match (weighed, &closed) {
            (Some(mp), _) => mp,
            (None, Some(m)) => m.mass_properties(),
            (None, None) => {
                let why = problem.map(|p| p.message).unwrap_or_default();
                return Err(self.err(el, format!("the {kind} is fitted to mesh '{mesh}' by its inertia=\"exact\", the solid its surface encloses, and the surface is not closed ({why}): give the mesh MuJoCo's default inertia, or the geom its size without mesh")));
            }
        };
        if mp.volume.is_nan() || mp.volume <= 0.0 {
            return Err(self.err(
                el,
                format!("mesh '{mesh}' has no volume to fit a {kind} to"),
            ));
        }
        let (lambda, axes) = principal_axes(&mp.inertia);
        // MuJoCo refuses a mesh whose inertia no rigid body has (a moment not positive, or one
        // above the sum of the others beyond its tolerances), whatever the fit reads of it.
        let violated = (0..3).any(|i| {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            lambda[j] + lambda[k] < lambda[i] * (1.0 - 1e-6) - 1e-9
        });
        if lambda[2] <= 0.0 || violated {
            return Err(self.err(el, format!("the {kind} is fitted to mesh '{mesh}', whose inertia no rigid body has (principal moments per unit density {:?}, by its inertia rule): MuJoCo refuses the mesh too", lambda.as_slice())));
        }
        let fit_aabb = self.settings.fit_aabb;
        // Half-sizes along the principal axes, and the centre of the fitted shape there.
        let (half, centre) = if fit_aabb {
            // The bounding box of every vertex of the file, also those no face uses (as
            // MuJoCo's): that of their convex hull.
            let vertices = match self.hull_of(mesh) {
                Some((hull, _)) => hull,
                None => return Err(self.err(el, format!("the {kind} is fitted to the bounding box of mesh '{mesh}' (fitaabb), whose vertices span no volume ({})", self.hull_problem(mesh)))),
            };
            let (mut lo, mut hi) = (
                Vector3::repeat(f64::INFINITY),
                Vector3::repeat(-f64::INFINITY),
            );
            for v in &vertices.vertices {
                let p = axes.transpose() * (v - mp.com);
                lo = lo.inf(&p);
                hi = hi.sup(&p);
            }
            let centre = (lo + hi) * 0.5;
            (hi - centre, centre)
        } else {
            let box_half = |i: usize| {
                let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                0.5 * (6.0 * (lambda[j] + lambda[k] - lambda[i]) / mp.volume)
                    .max(0.0)
                    .sqrt()
            };
            (
                Vector3::new(box_half(0), box_half(1), box_half(2)),
                Vector3::zeros(),
            )
        };
        let scale = self.float(el, "fitscale")?.unwrap_or(1.0);
        let mut size = match (kind, fit_aabb) {
            ("sphere", false) => vec![(half.x + half.y + half.z) / 3.0],
            ("sphere", true) => vec![half.max()],
            ("capsule", false) => {
                let r = (half.x + half.y) / 2.0;
                vec![r, (half.z - r / 2.0).max(0.0)]
            }
            ("capsule", true) => {
                let r = half.x.max(half.y);
                vec![r, half.z - r]
            }
            ("cylinder", false) => vec![(half.x + half.y) / 2.0, half.z],
            ("cylinder", true) => vec![half.x.max(half.y), half.z],
            _ => vec![half.x, half.y, half.z],
        };
        for x in size.iter_mut() {
            *x *= scale;
        }
        // Two equal principal moments leave the inertia frame free to turn in their plane: where
        // that turns the fitted shape, MuJoCo's frame is its eigen-solver's choice, which SCM
        // does not reproduce. A mesh already in its inertia frame keeps its own axes in SCM, and
        // in MuJoCo only where its rounding leaves the inertia diagonal, so it is warned about
        // too. Under fitaabb every shape depends on the frame.
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * lambda[0].abs();
        let free = [(0, 1), (1, 2), (0, 2)].map(|(i, j)| close(lambda[i], lambda[j]));
        let turns = match (kind, fit_aabb) {
            (_, true) | ("box", false) => free.iter().any(|&f| f),
            ("capsule" | "cylinder", false) => free[1] || free[2],
            _ => false,
        };
        if size.iter().any(|&x| x.is_nan() || x <= 0.0) {
            let why = if turns {
                " (in SCM's choice of the inertia frame, which two equal principal moments leave free to turn: MuJoCo's may differ)"
            } else {
                ""
            };
            return Err(self.err(el, format!("the {kind} fitted to mesh '{mesh}' has size {size:?} (fitscale {scale}), not all positive{why}: SCM needs a positive size (a capsule shorter than its radius is a sphere: give type=\"sphere\")")));
        }
        if turns {
            self.warnings.push(format!("{}:{}: <geom> the {kind} fitted to mesh '{mesh}' depends on how its inertia frame turns in the plane of two equal principal moments, which MuJoCo's compiler chooses and SCM may choose differently: give the geom its size and quat without mesh to be sure of it", el.file, el.line));
        }
        let rotation =
            UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix_unchecked(axes));
        let frame = Isometry3::from_parts(Translation3::from(mp.com + axes * centre), rotation);
        let asset = self.meshes.iter_mut().find(|m| m.name == mesh);
        asset.expect("found above").used = true;
        Ok((size, frame))
    }

    /// `<hfield>`: a height field, taken only where it is flat when the scene is compiled
    /// (no `file`, no `elevation`: MuJoCo's zeros, which a MuJoCo host may reshape at run
    /// time, e.g. dm_control's quadruped terrain).
    pub(super) fn hfield_asset(&mut self, el: &Element) -> Result<(), SceneError> {
        self.check_attrs(
            el,
            &[
                "name",
                "size",
                "nrow",
                "ncol",
                "file",
                "elevation",
                "content_type",
            ],
        )?;
        if el.attr("file").is_some() || el.attr("elevation").is_some() {
            return Err(self.err(el, "a height field with elevation data (file or elevation) is not supported by SCM: it takes a height field only where it is flat (neither given); use a mesh or primitive geoms"));
        }
        let name = Self::given_name(el)
            .ok_or_else(|| self.err(el, "a height field without a file needs a name"))?;
        let size = match self.floats(el, "size", 4)? {
            Some(v) if v.iter().all(|&x| x > 0.0) => [v[0], v[1], v[2], v[3]],
            _ => {
                return Err(self.err(
                    el,
                    "size needs four positive numbers (x and y half-extents, elevation scale, base depth), as MuJoCo requires",
                ))
            }
        };
        for key in ["nrow", "ncol"] {
            match el.attr(key).map(|v| v.trim().parse::<i64>()) {
                Some(Ok(n)) if n >= 2 => {}
                _ => {
                    return Err(self.err(
                        el,
                        format!(
                        "{key} must be an integer of at least 2 for a height field without a file"
                    ),
                    ))
                }
            }
        }
        if self.hfields.iter().any(|(n, _)| *n == name) {
            return Err(self.err(el, format!("hfield name '{name}' is used twice")));
        }
        self.hfields.push((name, size));
        Ok(())
    }

    /// A geom of type `hfield`: its field is flat at compile time ([`Builder::hfield_asset`]),
    /// so its surface is the plane z = 0 of the geom's frame (MuJoCo's elevation 0), which is
    /// how SCM takes it, with a warning for what differs.
    fn flat_hfield(&mut self, el: &Element) -> Result<(), SceneError> {
        let name = el
            .attr("hfield")
            .ok_or_else(|| self.err(el, "a height field geom needs hfield=\"NAME\""))?;
        let Some((_, size)) = self.hfields.iter().find(|(n, _)| n == name) else {
            return Err(self.err(el, format!("no hfield asset named '{name}'")));
        };
        let (x, y) = (2.0 * size[0], 2.0 * size[1]);
        self.warnings.push(format!("{}:{}: <geom> height field '{name}' is flat when compiled: SCM takes it as the plane of its surface, unbounded, where MuJoCo's is {x} x {y} m over a base {} m deep; a host cannot reshape it at run time", el.file, el.line, size[3]));
        Ok(())
    }

    /// Whether `body` or a body it hangs from has joints (declared so far).
    fn moves_with_joints(&self, mut body: usize) -> bool {
        while body != 0 {
            if !self.bodies[body].joints.is_empty() {
                return true;
            }
            body = self.bodies[body].parent.unwrap_or(0);
        }
        false
    }

    /// Whether geom `el` writes itself massless: `mass="0"`, or `density="0"` without a mass.
    fn massless(&self, el: &Element) -> Result<bool, SceneError> {
        Ok(
            match (self.float(el, "mass")?, self.float(el, "density")?) {
                (Some(m), _) => m == 0.0,
                (None, Some(d)) => d == 0.0,
                (None, None) => false,
            },
        )
    }

    /// The mass properties of mesh asset `mesh` (unit density, mesh frame) as MuJoCo weighs it
    /// for geom `el`: by its legacy rule (the default), its convex hull's (`inertia="convex"`)
    /// or as a thin shell (`inertia="shell"`, density per area); `None` for `inertia="exact"`, the closed surface's own solid (the
    /// shape's exact mass properties). Computed once per mesh. A rule that gives no volume,
    /// and a hull MuJoCo reduces (`maxhullvert`) under `inertia="convex"`, are refused here.
    fn mesh_mass(
        &mut self,
        el: &Element,
        mesh: &str,
    ) -> Result<Option<crate::geometry::MassProperties>, SceneError> {
        let Some(asset) = self.meshes.iter().find(|m| m.name == mesh) else {
            return Ok(None);
        };
        match asset.inertia {
            MeshInertia::Exact => Ok(None),
            MeshInertia::Legacy | MeshInertia::Shell => {
                if let Some(mp) = asset.legacy {
                    return Ok(Some(mp));
                }
                let shell = asset.inertia == MeshInertia::Shell;
                let mp = match (&asset.mesh, shell) {
                    (Some(closed), false) => closed.legacy_mass_properties(),
                    (Some(closed), true) => closed.shell_mass_properties(),
                    (None, false) => TriMesh::load_legacy_mass(&asset.path, &asset.placement).ok(),
                    (None, true) => TriMesh::load_shell_mass(&asset.path, &asset.placement).ok(),
                };
                let mp = mp.ok_or_else(|| {
                    if shell {
                        self.err(el, format!("mesh '{mesh}' has no area to weigh as a shell (inertia=\"shell\"), which MuJoCo refuses too"))
                    } else {
                        self.err(el, format!("mesh '{mesh}' encloses no volume by MuJoCo's default (legacy) rule, which MuJoCo refuses too: give the body an <inertial>, or the geom mass=\"0\""))
                    }
                })?;
                let asset = self.meshes.iter_mut().find(|m| m.name == mesh);
                asset.expect("found above").legacy = Some(mp);
                Ok(Some(mp))
            }
            MeshInertia::Convex => match self.hull_of(mesh) {
                Some((_, Some(n))) => Err(self.err(el, format!("mesh '{mesh}' weighs by its convex hull (inertia=\"convex\"), which MuJoCo reduces to {n} vertices (maxhullvert) and SCM does not: remove maxhullvert for the full hull in both"))),
                Some((hull, None)) => Ok(Some(hull.mass_properties())),
                None => Err(self.err(el, format!("mesh '{mesh}' weighs by its convex hull (inertia=\"convex\"), which cannot be made ({})", self.hull_problem(mesh)))),
            },
        }
    }

    /// Why mesh asset `mesh`'s convex hull could not be made (after [`Builder::hull_of`]).
    fn hull_problem(&self, mesh: &str) -> String {
        (self.meshes.iter().find(|m| m.name == mesh))
            .and_then(|m| m.hull_problem.clone())
            .unwrap_or_else(|| "unknown".into())
    }

    /// The convex hull of mesh asset `mesh`'s vertices and its `maxhullvert`: read once, for
    /// the first geom that collides or weighs by it (a visual mesh never needs it).
    fn hull_of(&mut self, mesh: &str) -> Option<(Arc<TriMesh>, Option<i64>)> {
        let asset = self.meshes.iter_mut().find(|m| m.name == mesh)?;
        if asset.hull.is_none() && asset.hull_problem.is_none() {
            match TriMesh::load_hull(&asset.path, &asset.placement) {
                Ok(h) => asset.hull = Some(Arc::new(h)),
                Err(e) => asset.hull_problem = Some(e.problem.to_string()),
            }
        }
        asset.hull.clone().map(|h| (h, asset.maxhullvert))
    }

    /// `<mesh name file scale>`: loads and checks the file at once (paths relative to the scene
    /// file's folder and the compiler's `meshdir`), so that problems name the asset's line.
    pub(super) fn mesh_asset(&mut self, el: &Element) -> Result<(), SceneError> {
        self.check_attrs(
            el,
            &[
                "name",
                "file",
                "scale",
                "inertia",
                "maxhullvert",
                "refpos",
                "refquat",
                "content_type",
            ],
        )?;
        // A mesh weighs as MuJoCo weighs it: its default rule ("legacy"), the exact solid, or
        // the convex hull (`MeshInertia`).
        let inertia = match el.attr("inertia") {
            None | Some("legacy") => MeshInertia::Legacy,
            Some("exact") => MeshInertia::Exact,
            Some("convex") => MeshInertia::Convex,
            Some("shell") => MeshInertia::Shell,
            Some(v) => {
                return Err(self.err(
                    el,
                    format!("inertia=\"{v}\": expected exact, convex, legacy or shell"),
                ))
            }
        };
        // MuJoCo's hull keeps at most maxhullvert vertices; SCM's hull (used where the surface
        // is not closed) keeps them all, and refuses it there (`geom_without_its_mesh`).
        let maxhullvert = match el.attr("maxhullvert").map(|v| v.trim().parse::<i64>()) {
            None | Some(Ok(-1)) => None,
            Some(Ok(n)) if n > 3 => Some(n),
            Some(_) => {
                return Err(self.err(
                    el,
                    "maxhullvert must be -1 or an integer above 3 (MuJoCo refuses it too)",
                ))
            }
        };
        let file = el
            .attr("file")
            .ok_or_else(|| {
                self.err(
                    el,
                    "a mesh needs file=\"...\" (OBJ or STL); inline vertices are not supported",
                )
            })?
            .to_string();
        // MuJoCo's content_type names the file's format (for files whose extension does not);
        // SCM reads meshes by their extension, so the two must agree.
        if let Some(ct) = el.attr("content_type") {
            let ext = Path::new(&file)
                .extension()
                .map(|e| e.to_string_lossy().to_lowercase())
                .unwrap_or_default();
            let expected = match ct {
                "model/obj" => "obj",
                "model/stl" => "stl",
                "model/vnd.mujoco.msh" => "msh",
                _ => return Err(self.err(el, format!("content_type=\"{ct}\": SCM reads model/obj, model/stl and model/vnd.mujoco.msh meshes"))),
            };
            if ext != expected {
                return Err(self.err(el, format!("content_type=\"{ct}\" but the file's extension is '.{ext}': SCM reads a mesh by its extension, name the file .{expected}")));
            }
        }
        let name = Self::given_name(el).unwrap_or_else(|| {
            Path::new(&file)
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default()
        });
        if self.meshes.iter().any(|m| m.name == name) {
            return Err(self.err(el, format!("mesh name '{name}' is used twice")));
        }
        let scale = self
            .vec3(el, "scale")?
            .unwrap_or_else(|| Vector3::repeat(1.0));
        if scale.iter().any(|&x| x == 0.0) {
            return Err(self.err(el, "scale has a zero component"));
        }
        // The file's coordinates relative to the reference frame `refpos`, `refquat`, as MuJoCo
        // places them, then scaled.
        let refpos = self.vec3(el, "refpos")?.unwrap_or_else(Vector3::zeros);
        let refquat = match self.floats(el, "refquat", 4)? {
            None => UnitQuaternion::identity(),
            Some(q) => {
                let q = nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]);
                if q.norm() < 1e-10 {
                    return Err(self.err(el, "refquat is zero: it names no orientation"));
                }
                UnitQuaternion::from_quaternion(q)
            }
        };
        let placement = Placement {
            refpos,
            refquat,
            scale,
        };
        let path = mesh_path(Path::new(&self.file), self.meshdir.as_deref(), &file);
        // A file that cannot be read is an error at once (MuJoCo's too); a surface that is
        // not closed is one only where a geom needs it (`MeshAsset::problem`).
        // MuJoCo refuses a mesh whose triangles, as written, enclose a negative volume when it
        // is weighed as the exact solid (SCM would turn them outward).
        if inertia == MeshInertia::Exact {
            if let Ok(v) = TriMesh::load_signed_volume(&path, &placement) {
                if v < 0.0 {
                    return Err(self.err(el, format!("mesh '{file}' faces inward (its triangles enclose the volume {v:.3e} m³ as written), which MuJoCo refuses under inertia=\"exact\" (\"mesh volume is negative\"): turn its triangles outward, or weigh it by MuJoCo's default rule")));
                }
            }
        }
        let (mesh, problem) = match TriMesh::load(&path, &placement) {
            Ok((mesh, warnings)) => {
                for w in warnings {
                    self.warnings.push(format!("{}:{}: {w}", el.file, el.line));
                }
                (Some(Arc::new(mesh)), None)
            }
            Err(e) if e.problem.is_of_the_surface() => {
                for w in &e.notes {
                    self.warnings.push(format!("{}:{}: {w}", el.file, el.line));
                }
                (None, Some(self.err(el, e.to_string())))
            }
            Err(e) => return Err(self.err(el, e.to_string())),
        };
        if maxhullvert.is_some() && problem.is_none() {
            self.unused(
                el,
                "maxhullvert (the size of the hull MuJoCo collides by; SCM samples the closed surface itself)",
            );
        }
        self.meshes.push(MeshAsset {
            name,
            file,
            path,
            mesh,
            problem,
            hull: None,
            hull_problem: None,
            placement,
            inertia,
            legacy: None,
            maxhullvert,
            used: false,
        });
        Ok(())
    }
}

/// The principal moments of a symmetric inertia `inertia`, largest first, and the principal
/// axes as the columns of a rotation. An inertia already diagonal (off-diagonal entries below
/// 1e-12 of its trace) keeps the frame's own axes, permuted into that order. Moments within
/// 1e-7 of the trace of each other keep their order: MuJoCo 4.0.0 keeps a mesh's own axes for
/// moments that close (measured on boxes a hair from square, at sizes from 1 cm to 10 m).
/// The axes are the exact eigenvectors; MuJoCo's iterative solver stops within about 1e-6 rad
/// of them (docs/mjcf.md).
fn principal_axes(inertia: &Matrix3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
    let tiny = 1e-12 * inertia.trace().abs();
    let equal = 1e-7 * inertia.trace().abs();
    let off = inertia[(0, 1)]
        .abs()
        .max(inertia[(0, 2)].abs())
        .max(inertia[(1, 2)].abs());
    let diagonal = off <= tiny;
    let (values, vectors) = if diagonal {
        (inertia.diagonal(), Matrix3::identity())
    } else {
        let e = inertia.symmetric_eigen();
        (e.eigenvalues, e.eigenvectors)
    };
    // Largest first; near-equal moments keep their order (three passes of a bubble sort).
    let mut order = [0usize, 1, 2];
    for i in [0, 1, 0] {
        if values[order[i]] + equal < values[order[i + 1]] {
            order.swap(i, i + 1);
        }
    }
    let lambda = Vector3::new(values[order[0]], values[order[1]], values[order[2]]);
    let (e0, e1) = (
        vectors.column(order[0]).normalize(),
        vectors.column(order[1]).normalize(),
    );
    let axes = Matrix3::from_columns(&[e0, e1, e0.cross(&e1)]);
    (lambda, axes)
}

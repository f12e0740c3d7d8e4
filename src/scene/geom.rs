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
                "adhesion",
                "mesh",
                "fluidshape",
                "fluidcoef",
                "fitscale",
                "hfield",
                "surfacevel",
            ],
        )?;
        // MuJoCo's default fluid model is the bodies' inertia boxes (fluidshape="none"), which
        // SCM has; the per-geom ellipsoid model it does not.
        let ellipsoid_fluid = match el.attr("fluidshape") {
            None | Some("none") => {
                if el.attr("fluidcoef").is_some() {
                    self.unused(
                        el,
                        "fluidcoef (read by MuJoCo only with fluidshape=\"ellipsoid\")",
                    );
                }
                None
            }
            // MuJoCo's per-geom ellipsoid model (`crate::dynamics::fluid::EllipsoidGeom`).
            Some("ellipsoid") => Some(match self.floats(el, "fluidcoef", 5)? {
                Some(v) => [v[0], v[1], v[2], v[3], v[4]],
                None => [0.5, 0.25, 1.5, 1.0, 1.0],
            }),
            Some(v) => {
                return Err(self.err(
                    el,
                    format!("fluidshape=\"{v}\": expected none or ellipsoid"),
                ))
            }
        };
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
        let friction = match self.friction_list(el, "friction", 3)? {
            None => 1.0,
            Some(v) => {
                if v[1..].iter().any(|&x| x != 0.0) {
                    self.unused(el, "friction's torsional and rolling coefficients (SCM models sliding friction)");
                }
                v[0]
            }
        };
        let condim = self.condim(el)?;
        let softness = self.geom_softness(el)?;
        let margin = self.float(el, "margin")?.unwrap_or(0.0);
        let adhesion = self.float(el, "adhesion")?.unwrap_or(0.0);
        if adhesion < 0.0 {
            return Err(self.err(el, format!("adhesion=\"{adhesion}\" is negative: it is the pull a contact can hold (N), 0 or more")));
        }
        // Read only where a pair is adhesive (the attribute stays in the list of those noted
        // unused otherwise).
        let gap = match el.attr("gap") {
            Some(g) => parse_floats(g)
                .filter(|v| v.len() == 1 && v[0] >= 0.0)
                .map(|v| v[0])
                .ok_or_else(|| {
                    self.err(el, format!("gap=\"{g}\": expected one number, 0 or more"))
                })?,
            None => 0.0,
        };
        // MuJoCo's moving surface, `v + ω × (x - p)` in the geom's frame (docs/method.md,
        // departure 8); all zeros is none.
        let surfacevel = self
            .floats(el, "surfacevel", 6)?
            .filter(|v| v.iter().any(|&x| x != 0.0))
            .map(|v| {
                (
                    Vector3::new(v[0], v[1], v[2]),
                    Vector3::new(v[3], v[4], v[5]),
                )
            });
        let size = el.attr("size").and_then(parse_floats).unwrap_or_default();
        // MuJoCo's `sdf` geom collides by its plugin's distance field; SCM by the closed
        // surface of its mesh (`sdf.rs`), as a mesh geom, never by its hull.
        let sdf = el.attr("type") == Some("sdf");
        let kind = match el.attr("type").unwrap_or("sphere") {
            "sdf" => "mesh",
            k => k,
        };
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
        let (mut mesh_name, mut by_hull) = (None, false);
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
                        Some(match asset.implicit {
                            Some(shape) => Shape::Implicit {
                                shape,
                                mesh: mesh.clone(),
                            },
                            None => Shape::Mesh(mesh.clone()),
                        })
                    }
                    (None, Some(problem)) => {
                        let (problem, inertia) = (problem.clone(), asset.inertia);
                        match self.geom_without_its_mesh(el, body, problem, name, inertia)? {
                            Some(hull) => {
                                let asset = self.meshes.iter_mut().find(|m| m.name == name);
                                asset.expect("found above").used = true;
                                (mesh_name, by_hull) = (Some(name.to_string()), true);
                                Some(Shape::Mesh(hull))
                            }
                            None => return Ok(()),
                        }
                    }
                    (None, None) => unreachable!("a mesh asset has its mesh or its problem"),
                }
            }
            "plane" => None,
            "hfield" => self.hfield_geom(el, body)?,
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
                // MuJoCo's compiler moves a mesh to its principal frame, and its geom's frame
                // with it: the axes of the fluid's inertia box where the geom is its body's
                // only mass (a primitive's own frame is principal already).
                let frame = match &mesh_name {
                    Some(_) => {
                        let axes = super::mesh_weight::principal_axes(&mp.inertia).1;
                        let r = nalgebra::Rotation3::from_matrix_unchecked(axes);
                        pose.rotation * UnitQuaternion::from_rotation_matrix(&r)
                    }
                    None => pose.rotation,
                };
                self.mass_geom_frames.entry(body).or_default().push(frame);
            }
        } else if self.moves_with_joints(body) {
            return Err(self.err(el, format!("a {kind} can only belong to a body welded to the world (this body or one it hangs from has joints), as MuJoCo requires")));
        }
        let (contype, conaffinity) = (self.bits(el, "contype")?, self.bits(el, "conaffinity")?);
        if let Some(coefs) = ellipsoid_fluid {
            // On a mesh MuJoCo takes the ellipsoid in the mesh's inertia frame, its semi-axes
            // the vertices' farthest reach along each axis (its size of a mesh geom).
            let mesh_frame = match &mesh_name {
                Some(mesh) => {
                    let what = format!("the ellipsoid fluid model on mesh '{mesh}'");
                    let (mp, _, axes) = self.mesh_inertia_frame(el, mesh, &what)?;
                    let (lo, hi) = self.mesh_extents(el, mesh, &what, &mp.com, &axes)?;
                    let rotation = nalgebra::Rotation3::from_matrix_unchecked(axes);
                    let frame = Isometry3::from_parts(
                        nalgebra::Translation3::from(mp.com),
                        UnitQuaternion::from_rotation_matrix(&rotation),
                    );
                    Some((frame, lo.abs().sup(&hi.abs())))
                }
                None => None,
            };
            self.fluid_ellipsoids
                .push((self.geoms.len(), coefs, mesh_frame));
        }
        if sdf {
            self.sdf_geoms.push(self.geoms.len());
        }
        self.geoms.push(Geom {
            name,
            body,
            shape,
            mesh: mesh_name,
            by_hull,
            fitted_to: fit.map(|(mesh, _)| mesh),
            pose,
            contype,
            conaffinity,
            friction,
            condim,
            softness,
            margin,
            adhesion,
            gap,
            surfacevel,
            file: el.file.to_string(),
            line: el.line,
            spacing: None,
            spacing_reason: String::new(),
            points: None,
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
            // A hull MuJoCo reduces (`maxhullvert`) is taken whole, listed with the asset.
            let (hull, _) = match self.hull_of(mesh) {
                Some(h) => h,
                None if collides => {
                    return Err(refuse(
                        &format!("it collides, and SCM samples a closed surface: its convex hull cannot be made ({})", self.hull_problem(mesh)),
                    ))
                }
                None => return Err(refuse(&format!("it gives its body mass by its convex hull, which cannot be made ({})", self.hull_problem(mesh)))),
            };
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
}

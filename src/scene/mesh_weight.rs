//! How a mesh weighs, as MuJoCo weighs it: by its inertia rule (legacy, exact, convex, shell),
//! its principal frame, its extent in that frame, its convex hull read on demand, and the
//! hulls colliding meshes collide by.

use super::assets::MeshInertia;
use super::*;

impl Builder {
    /// Mesh asset `mesh`'s mass properties (unit density) by its own inertia rule and its
    /// principal moments and axes (largest first, right-handed): MuJoCo's mesh frame, for
    /// `what` on geom `el` (a fitted primitive, the ellipsoid fluid model), which needs them.
    /// Refused where the mesh has no volume or an inertia no rigid body has, as MuJoCo refuses it.
    pub(super) fn mesh_inertia_frame(
        &mut self,
        el: &Element,
        mesh: &str,
        what: &str,
    ) -> Result<(crate::geometry::MassProperties, Vector3<f64>, Matrix3<f64>), SceneError> {
        let Some(asset) = self.meshes.iter().find(|m| m.name == mesh) else {
            return Err(self.err(el, format!("no mesh asset named '{mesh}'")));
        };
        let (closed, problem) = (asset.mesh.clone(), asset.problem.clone());
        let weighed = self.mesh_mass(el, mesh).map_err(|mut e| {
            e.message += &format!(" ({what} needs the mesh's inertia, whatever the geom weighs)");
            e
        })?;
        let mp = match (weighed, &closed) {
            (Some(mp), _) => mp,
            (None, Some(m)) => m.mass_properties(),
            (None, None) => {
                let why = problem.map(|p| p.message).unwrap_or_default();
                return Err(self.err(el, format!("{what} needs the mesh's inertia by its inertia=\"exact\", the solid its surface encloses, and the surface is not closed ({why}): give the mesh MuJoCo's default inertia")));
            }
        };
        if mp.volume.is_nan() || mp.volume <= 0.0 {
            return Err(self.err(
                el,
                format!("mesh '{mesh}' has no volume, which {what} needs"),
            ));
        }
        let (lambda, axes) = principal_axes(&mp.inertia);
        // MuJoCo refuses a mesh whose inertia no rigid body has (a moment not positive, or one
        // above the sum of the others beyond its tolerances), whatever reads it.
        let violated = (0..3).any(|i| {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            lambda[j] + lambda[k] < lambda[i] * (1.0 - 1e-6) - 1e-9
        });
        if lambda[2] <= 0.0 || violated {
            return Err(self.err(el, format!("{what} needs the inertia of mesh '{mesh}', which no rigid body has (principal moments per unit density {:?}, by its inertia rule): MuJoCo refuses the mesh too", lambda.as_slice())));
        }
        Ok((mp, lambda, axes))
    }

    /// The bounding box `(lo, hi)` of every vertex of mesh asset `mesh` (also those no face
    /// uses, as MuJoCo's: that of their convex hull), in the frame at `com` with axes `axes`,
    /// for `what` on geom `el`.
    pub(super) fn mesh_extents(
        &mut self,
        el: &Element,
        mesh: &str,
        what: &str,
        com: &Vector3<f64>,
        axes: &Matrix3<f64>,
    ) -> Result<(Vector3<f64>, Vector3<f64>), SceneError> {
        let vertices = match self.hull_of(mesh) {
            Some((hull, _)) => hull,
            None => {
                return Err(self.err(
                    el,
                    format!(
                    "{what} reads the bounding box of the mesh, whose vertices span no volume ({})",
                    self.hull_problem(mesh)
                ),
                ))
            }
        };
        let (mut lo, mut hi) = (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(-f64::INFINITY),
        );
        for v in &vertices.vertices {
            let p = axes.transpose() * (v - com);
            lo = lo.inf(&p);
            hi = hi.sup(&p);
        }
        Ok((lo, hi))
    }

    /// The mass properties of mesh asset `mesh` (unit density, mesh frame) as MuJoCo weighs it
    /// for geom `el`: by its legacy rule (the default), its convex hull's (`inertia="convex"`)
    /// or as a thin shell (`inertia="shell"`, density per area); `None` for `inertia="exact"`, the closed surface's own solid (the
    /// shape's exact mass properties). Computed once per mesh. A rule that gives no volume,
    /// and a hull MuJoCo reduces (`maxhullvert`) under `inertia="convex"`, are refused here.
    pub(super) fn mesh_mass(
        &mut self,
        el: &Element,
        mesh: &str,
    ) -> Result<Option<crate::geometry::MassProperties>, SceneError> {
        let Some(asset) = self.meshes.iter().find(|m| m.name == mesh) else {
            return Ok(None);
        };
        // A mesh an SDF plugin made keeps its vertices where the distance function puts them
        // (MuJoCo moves no such mesh into its inertial frame), yet MuJoCo 4.0.0 weighs it as
        // if it were there: its centre of mass at the mesh's origin and its principal moments,
        // largest first, along the mesh's own axes (measured: a bowl whose centre of mass is
        // 12 cm below its origin, a torus about z, both with iquat identity).
        if asset.inline.as_ref().is_some_and(|m| m.plugin) {
            let closed = asset.mesh.clone();
            let mp = match self.mesh_rule_mass(el, mesh)? {
                Some(mp) => mp,
                None => match closed {
                    Some(m) => m.mass_properties(),
                    None => return Ok(None),
                },
            };
            let (moments, _) = principal_axes(&mp.inertia);
            return Ok(Some(crate::geometry::MassProperties {
                volume: mp.volume,
                com: Vector3::zeros(),
                inertia: Matrix3::from_diagonal(&moments),
            }));
        }
        self.mesh_rule_mass(el, mesh)
    }

    /// [`Builder::mesh_mass`] by the mesh's inertia rule alone.
    fn mesh_rule_mass(
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
                    (None, _) => asset.source_mass(shell),
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
    pub(super) fn hull_problem(&self, mesh: &str) -> String {
        (self.meshes.iter().find(|m| m.name == mesh))
            .and_then(|m| m.hull_problem.clone())
            .unwrap_or_else(|| "unknown".into())
    }

    /// Every colliding geom (`colliding`, by geom) of a closed file or inline mesh collides by
    /// that mesh's convex hull, as MuJoCo collides every mesh (docs/mjcf.md, "Meshes"): a body
    /// tucked into a mesh's concave side is apart from it in MuJoCo, and would be inside the
    /// surface's points' reach in SCM. Left as they are: a scene's `scm_mesh_collision` =
    /// `surface`, a geom written `type="sdf"` (MuJoCo collides it by its mesh's distance field,
    /// sdflib's of a file's surface), an SDF plugin's shape, a mesh that is not closed (its
    /// hull already), height fields, and geoms that do not collide (their mass was weighed
    /// before, by the mesh's own rule). The hull is sampled as `sampling` asks.
    pub(super) fn collide_by_hulls(
        &mut self,
        colliding: &[bool],
        sampling: crate::geometry::mesh::MeshSampling,
    ) {
        for i in 0..self.geoms.len() {
            let g = &self.geoms[i];
            let (Some(name), Some(Shape::Mesh(_)), true) =
                (g.mesh.clone(), &g.shape, colliding.get(i) == Some(&true))
            else {
                continue;
            };
            let Some(asset) = self.meshes.iter().find(|m| m.name == name) else {
                continue;
            };
            if asset.mesh.is_none() || asset.implicit.is_some() || self.sdf_geoms.contains(&i) {
                continue;
            }
            // A closed surface whose hull SCM cannot make (its vertices span a volume, so
            // MuJoCo's can be made) keeps colliding by the surface, said in a warning.
            let Some((mut hull, _)) = self.hull_of(&name) else {
                let g = &self.geoms[i];
                let warning = format!("{}:{}: <geom> '{}' collides by the surface of mesh '{name}', not by its convex hull as in MuJoCo: SCM cannot make the hull ({})", g.file, g.line, g.name, self.hull_problem(&name));
                self.warnings.push(warning);
                continue;
            };
            if hull.sampling != sampling {
                // Once per mesh: its other geoms then share this hull.
                Arc::make_mut(&mut hull).sampling = sampling;
                let asset = self.meshes.iter_mut().find(|m| m.name == name);
                asset.expect("found above").hull = Some(hull.clone());
            }
            self.geoms[i].shape = Some(Shape::Mesh(hull));
            self.geoms[i].by_hull = true;
        }
    }

    /// The convex hull of mesh asset `mesh`'s vertices and its `maxhullvert`: read once, for
    /// the first geom that collides or weighs by it (a visual mesh never needs it).
    pub(super) fn hull_of(&mut self, mesh: &str) -> Option<(Arc<TriMesh>, Option<i64>)> {
        let asset = self.meshes.iter_mut().find(|m| m.name == mesh)?;
        if asset.hull.is_none() && asset.hull_problem.is_none() {
            match asset.source_hull() {
                Ok(h) => asset.hull = Some(Arc::new(h)),
                Err(e) => asset.hull_problem = Some(e),
            }
        }
        asset.hull.clone().map(|h| (h, asset.maxhullvert))
    }
}

/// The principal moments of a symmetric inertia `inertia`, largest first, and the principal
/// axes as the columns of a rotation. An inertia already diagonal (off-diagonal entries below
/// 1e-12 of its trace) keeps the frame's own axes, permuted into that order. Moments within
/// 1e-7 of the trace of each other keep their order: MuJoCo 4.0.0 keeps a mesh's own axes for
/// moments that close (measured on boxes a hair from square, at sizes from 1 cm to 10 m).
/// The axes are the exact eigenvectors; MuJoCo's iterative solver stops within about 1e-6 rad
/// of them (docs/mjcf.md).
pub(super) fn principal_axes(inertia: &Matrix3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
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

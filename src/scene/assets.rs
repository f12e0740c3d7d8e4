//! Mesh and height-field assets: reading them, their convex hulls, how MuJoCo weighs a mesh,
//! and a primitive geom fitted to a mesh.

use super::*;
use crate::geometry::mesh::{MeshError, MeshProblem};

/// A mesh asset of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAsset {
    /// Asset name (`name`, else the file name without extension).
    pub name: String,
    /// The `file` attribute as written.
    pub file: String,
    /// The file, resolved against the scene's folder and `meshdir`.
    pub path: PathBuf,
    /// The checked mesh (scaled), shared by every geom that uses it; `None` when the file's
    /// surface is not a closed manifold ([`MeshAsset::problem`]).
    pub mesh: Option<Arc<TriMesh>>,
    /// What is wrong with the surface (open, not manifold, degenerate triangles, ...), with
    /// the asset's file and line. MuJoCo takes such meshes; SCM needs the closed surface only
    /// where a geom collides or gives its body mass, and refuses the mesh there (a geom that
    /// does neither is left out and listed as unused).
    pub problem: Option<SceneError>,
    /// The convex hull of the vertices of a mesh with a `problem` (what MuJoCo collides it
    /// by), where they span a volume: what a colliding geom samples instead of the surface.
    /// Computed when the first geom needs it (a visual mesh never does).
    pub hull: Option<Arc<TriMesh>>,
    /// Why its convex hull could not be made, once tried.
    pub hull_problem: Option<String>,
    /// How the file's vertices are placed (`refpos`, `refquat`, `scale`): for the hull and
    /// the mass rules that read the file again.
    pub placement: Placement,
    /// How MuJoCo weighs it (`inertia`).
    pub inertia: MeshInertia,
    /// Its mass properties by MuJoCo's default rule (`inertia="legacy"`) or as a shell
    /// (`inertia="shell"`), computed when the first geom that weighs by it needs them.
    pub legacy: Option<crate::geometry::MassProperties>,
    /// `maxhullvert`, when it limits MuJoCo's hull (not -1).
    pub maxhullvert: Option<i64>,
    /// Whether a geom uses it.
    pub used: bool,
    /// The vertices and faces of a mesh given inline (`vertex`, `face`; its `file` and `path`
    /// are then empty).
    pub inline: Option<super::inline_mesh::InlineMesh>,
}

/// How MuJoCo weighs a mesh: `<mesh inertia>` (`shell` is refused).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshInertia {
    /// MuJoCo's default: pyramids from the faces, each counted positive
    /// ([`crate::geometry::mesh::legacy_mass_properties`]).
    Legacy,
    /// The exact solid of the closed surface.
    Exact,
    /// The solid of the convex hull of the vertices.
    Convex,
    /// The surface as a thin shell ([`crate::geometry::mesh::shell_mass_properties`]).
    Shell,
}

impl Builder {
    /// MuJoCo's mesh-fitted primitive (docs/mjcf.md): the size of a `kind` geom fitted to mesh
    /// asset `mesh`, and its frame in the geom's written frame (the mesh's inertia frame, moved
    /// to the centre of the bounding box under `fitaabb`). Sizes come from the mesh's
    /// equivalent inertia box (the solid box of the mesh's volume and principal moments, by
    /// the mesh's own `inertia` rule), or from its vertices' bounding box in the inertia frame
    /// (`fitaabb`): a sphere takes the boxes' mean half-size (the largest under `fitaabb`), a
    /// capsule or cylinder the mean of the first two as radius and the third as half-length
    /// (a capsule less half its radius, or under `fitaabb` less its radius), a box or
    /// ellipsoid all three; then all are scaled by `fitscale`.
    pub(super) fn fit_to_mesh(
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
        let what = format!("a {kind} fitted to mesh '{mesh}'");
        let (mp, lambda, axes) = self.mesh_inertia_frame(el, mesh, &what)?;
        let fit_aabb = self.settings.fit_aabb;
        // Half-sizes along the principal axes, and the centre of the fitted shape there.
        let (half, centre) = if fit_aabb {
            let (lo, hi) = self.mesh_extents(el, mesh, &what, &mp.com, &axes)?;
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
    pub(super) fn flat_hfield(&mut self, el: &Element) -> Result<(), SceneError> {
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
                "vertex",
                "face",
                "normal",
                "texcoord",
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
        if el.attr("vertex").is_some() || el.attr("face").is_some() {
            let placement = self.mesh_placement(el)?;
            return self.inline_mesh(el, placement, inertia, maxhullvert);
        }
        for key in ["normal", "texcoord"] {
            if el.attr(key).is_some() {
                return Err(self.err(el, format!("{key}=\"...\" belongs to a mesh given inline (vertex=\"...\"); a file's mesh takes its own")));
            }
        }
        let plugin = el.children.iter().find(|c| c.name == "plugin");
        let file = match (el.attr("file"), plugin) {
            (Some(f), p) => {
                // A plugin on a mesh file (MuJoCo's sdflib) gives MuJoCo a distance field of
                // that surface; SCM's SSDF takes the surface itself.
                if let Some(p) = p {
                    self.unused(p, "a distance-field plugin on a mesh file (SCM collides by the surface itself)");
                }
                f.to_string()
            }
            // MuJoCo's SDF plugins (mujoco.sdf.torus, bowl, …) make the mesh at load time.
            (None, Some(p)) => return self.sdf_mesh(el, p, (inertia, maxhullvert)),
            (None, None) => return Err(self.err(el, "a mesh needs file=\"...\" (OBJ or STL)")),
        };
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
        let placement = self.mesh_placement(el)?;
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
        let read = match TriMesh::load(&path, &placement) {
            // A file of vertices without faces is, as MuJoCo makes it, their convex hull.
            Err(e) if matches!(e.problem, MeshProblem::Empty) => {
                TriMesh::load_hull(&path, &placement).map(|hull| (hull, Vec::new()))
            }
            read => read,
        };
        let (mesh, problem) = self.surface_of(el, read)?;
        self.add_mesh(
            el,
            MeshAsset {
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
                inline: None,
            },
        );
        Ok(())
    }

    /// A mesh's surface as read (its warnings recorded), or, where it is not a closed surface,
    /// the problem kept for the geoms that would need it (`MeshAsset::problem`); any other
    /// error is the scene's at once.
    pub(super) fn surface_of(
        &mut self,
        el: &Element,
        read: Result<(TriMesh, Vec<String>), MeshError>,
    ) -> Result<(Option<Arc<TriMesh>>, Option<SceneError>), SceneError> {
        match read {
            Ok((mesh, warnings)) => {
                for w in warnings {
                    self.warnings.push(format!("{}:{}: {w}", el.file, el.line));
                }
                Ok((Some(Arc::new(mesh)), None))
            }
            Err(e) if e.problem.is_of_the_surface() => {
                for w in &e.notes {
                    self.warnings.push(format!("{}:{}: {w}", el.file, el.line));
                }
                Ok((None, Some(self.err(el, e.to_string()))))
            }
            Err(e) => Err(self.err(el, e.to_string())),
        }
    }

    /// Records a mesh asset, noting an unused `maxhullvert` where its surface is closed.
    pub(super) fn add_mesh(&mut self, el: &Element, asset: MeshAsset) {
        if asset.maxhullvert.is_some() && asset.problem.is_none() {
            self.unused(
                el,
                "maxhullvert (the size of the hull MuJoCo collides by; SCM samples the closed surface itself)",
            );
        }
        self.meshes.push(asset);
    }

    /// How a mesh's vertices are placed (`refpos`, `refquat`, `scale`), for a file's and an
    /// inline mesh alike.
    pub(super) fn mesh_placement(&self, el: &Element) -> Result<Placement, SceneError> {
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
        Ok(placement)
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

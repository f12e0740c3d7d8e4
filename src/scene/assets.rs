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
    /// The convex hull of the mesh's vertices (what MuJoCo collides a mesh by), where they
    /// span a volume: what a colliding geom samples (`Builder::collide_by_hulls`; a mesh with
    /// a `problem` always). Computed when the first geom needs it (a visual mesh never does).
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
    /// The distance function of a mesh made by an SDF plugin, whose geoms collide by it
    /// ([`crate::geometry::Shape::Implicit`]).
    pub implicit: Option<crate::geometry::implicit::ImplicitShape>,
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
                "builtin",
                "params",
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
        // MuJoCo's hull keeps at most maxhullvert vertices; SCM's hull keeps them all (listed
        // as unused by `add_mesh`; refused where a mass weighs by the hull, `mesh_rule_mass`).
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
        match el.attr("builtin").map(str::trim) {
            None | Some("none") => {
                if el.attr("params").is_some() {
                    self.unused(el, "params (read only by a built-in mesh: builtin=\"...\")");
                }
            }
            Some(kind) => {
                let (kind, placement) = (kind.to_string(), self.mesh_placement(el)?);
                return self.builtin_mesh(el, &kind, placement, (inertia, maxhullvert));
            }
        }
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
                // that surface, which a `type="sdf"` geom collides by; SCM's SSDF takes the
                // surface itself there (`Builder::collide_by_hulls`).
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
                file,
                path,
                ..MeshAsset::read(name, placement, (inertia, maxhullvert), (mesh, problem))
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

    /// Records a mesh asset, noting that SCM does not reduce its hull (`maxhullvert`).
    pub(super) fn add_mesh(&mut self, el: &Element, asset: MeshAsset) {
        if asset.maxhullvert.is_some() {
            self.unused(
                el,
                "maxhullvert (MuJoCo collides a mesh geom by its hull reduced to that many vertices; SCM by the full hull, which holds MuJoCo's and may touch where it does not, unless the scene sets scm_mesh_collision to 'surface'; refused where a mass weighs by the hull: inertia=\"convex\")",
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

impl MeshAsset {
    /// A mesh asset of `name`, placed by `placement`, weighed by `inertia` (with its
    /// `maxhullvert`), its surface as read (or its problem); no file, hull or inline data yet.
    pub(super) fn read(
        name: String,
        placement: Placement,
        (inertia, maxhullvert): (MeshInertia, Option<i64>),
        (mesh, problem): (Option<Arc<TriMesh>>, Option<SceneError>),
    ) -> MeshAsset {
        MeshAsset {
            name,
            file: String::new(),
            path: PathBuf::new(),
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
            implicit: None,
        }
    }
}

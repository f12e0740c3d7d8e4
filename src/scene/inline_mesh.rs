//! Meshes given inline: `<mesh name vertex face>`, read as MuJoCo's compiler reads them. The
//! vertices (placed by `refpos`, `refquat`, `scale` as a file's are) with the faces as given
//! form the surface; given without faces, the mesh is the convex hull of its vertices (every
//! vertex counts, also those inside it). `normal` and `texcoord` only render in MuJoCo.

use super::assets::MeshInertia;
use super::*;
use crate::geometry::mesh::{signed_volume, Placement};
use crate::geometry::MassProperties;

/// The vertices (placed) and faces of a mesh given inline; `faces` `None` where the file gave
/// none (the mesh is then its vertices' convex hull).
#[derive(Clone, Debug, PartialEq)]
pub struct InlineMesh {
    /// The vertices, placed by the mesh's `refpos`, `refquat` and `scale`.
    pub vertices: Vec<Vector3<f64>>,
    /// The faces as written (vertex indices), if any.
    pub faces: Option<Vec<[u32; 3]>>,
    /// Where it comes from, for people: "given inline", or the plugin that made it.
    pub origin: String,
    /// Whether an SDF plugin made it: MuJoCo then weighs it in its own frame (see
    /// the scene loader's `mesh_mass`).
    pub plugin: bool,
}

/// A mesh the scene file makes rather than reads from a mesh file: given inline or built in.
pub(super) struct MadeMesh {
    /// The asset's name.
    pub(super) name: String,
    /// Its vertices, before `refpos`, `refquat` and `scale` place them.
    pub(super) vertices: Vec<Vector3<f64>>,
    /// Its faces (`None`: the vertices' convex hull).
    pub(super) faces: Option<Vec<[u32; 3]>>,
    /// Where it comes from, for people ([`InlineMesh::origin`]).
    pub(super) origin: String,
}

impl MeshAsset {
    /// Where the mesh comes from, for messages and `scm check`: its file, or "given inline".
    pub fn source(&self) -> String {
        match &self.inline {
            Some(m) => m.origin.clone(),
            None => self.path.display().to_string(),
        }
    }

    /// The mass properties of this mesh's own triangles as MuJoCo weighs an open or closed
    /// surface, by its default rule or as a shell (`shell`), read from its file or its inline
    /// faces; `None` where that rule gives nothing to weigh.
    pub(super) fn source_mass(&self, shell: bool) -> Option<MassProperties> {
        match &self.inline {
            Some(InlineMesh {
                vertices,
                faces: Some(faces),
                ..
            }) => match shell {
                false => crate::geometry::mesh::legacy_mass_properties(vertices, faces),
                true => crate::geometry::mesh::shell_mass_properties(vertices, faces),
            },
            // Without faces the mesh is its hull, closed: weighed as such before this is asked.
            Some(InlineMesh { faces: None, .. }) => None,
            None if shell => TriMesh::load_shell_mass(&self.path, &self.placement).ok(),
            None => TriMesh::load_legacy_mass(&self.path, &self.placement).ok(),
        }
    }

    /// The convex hull of every vertex of this mesh (file or inline): what MuJoCo collides it by.
    pub(super) fn source_hull(&self) -> Result<TriMesh, String> {
        match &self.inline {
            Some(m) => TriMesh::convex_hull(&self.source_name(), &m.vertices),
            None => TriMesh::load_hull(&self.path, &self.placement),
        }
        .map_err(|e| e.problem.to_string())
    }

    /// How meshes are named in messages about their surface.
    fn source_name(&self) -> String {
        match &self.inline {
            Some(m) => format!("'{}' ({})", self.name, m.origin),
            None => self.path.display().to_string(),
        }
    }
}

impl Builder {
    /// `<mesh name vertex face>` (after [`Builder::mesh_asset`] read the attributes every mesh
    /// has): checked as MuJoCo checks it (a name, numbers in threes, at least four vertices,
    /// faces naming vertices that exist, no `file` besides), the surface closed or its problem
    /// kept for the geoms that need it, as for a file.
    pub(super) fn inline_mesh(
        &mut self,
        el: &Element,
        placement: Placement,
        inertia: MeshInertia,
        maxhullvert: Option<i64>,
    ) -> Result<(), SceneError> {
        if el.attr("file").is_some() {
            return Err(self.err(
                el,
                "a mesh is given by file=\"...\" or inline (vertex=\"...\"), not both: remove one",
            ));
        }
        let name = Self::given_name(el).ok_or_else(|| {
            self.err(el, "a mesh given inline needs a name (there is no file to name it after; MuJoCo refuses it too)")
        })?;
        if self.meshes.iter().any(|m| m.name == name) {
            return Err(self.err(el, format!("mesh name '{name}' is used twice")));
        }
        let Some(text) = el.attr("vertex") else {
            return Err(self.err(
                el,
                "face=\"...\" indexes vertices: give them with vertex=\"x y z ...\"",
            ));
        };
        let numbers = parse_floats(text)
            .ok_or_else(|| self.err(el, "vertex=\"...\": expected finite numbers"))?;
        if numbers.len() % 3 != 0 {
            return Err(self.err(el, format!("vertex has {} numbers, not a multiple of 3 (x y z for each vertex); MuJoCo refuses it too", numbers.len())));
        }
        if numbers.len() < 12 {
            return Err(self.err(
                el,
                format!(
                    "vertex gives {} vertices: a mesh needs at least 4 (MuJoCo refuses it too)",
                    numbers.len() / 3
                ),
            ));
        }
        let vertices: Vec<Vector3<f64>> = numbers
            .chunks(3)
            .map(|v| Vector3::new(v[0], v[1], v[2]))
            .collect();
        let faces = match el.attr("face") {
            None => None,
            Some(text) => Some(self.inline_faces(el, text, vertices.len())?),
        };
        for key in ["normal", "texcoord"] {
            if el.attr(key).is_some() {
                self.unused(el, format!("{key} (MuJoCo renders with it; SCM's contact reads the surface's own normals)"));
            }
        }
        let made = MadeMesh {
            name,
            vertices,
            faces,
            origin: "given inline".into(),
        };
        self.add_made_mesh(el, made, placement, (inertia, maxhullvert))
    }

    /// A mesh whose vertices (before `placement`) and faces (`None`: their convex hull) the
    /// file gives inline or a built-in generator makes (`origin` says which): placed, checked,
    /// its surface closed or its problem kept, as a file's.
    pub(super) fn add_made_mesh(
        &mut self,
        el: &Element,
        MadeMesh {
            name,
            vertices,
            faces,
            origin,
        }: MadeMesh,
        placement: Placement,
        (inertia, maxhullvert): (MeshInertia, Option<i64>),
    ) -> Result<(), SceneError> {
        let vertices: Vec<Vector3<f64>> = vertices.iter().map(|v| placement.apply(v)).collect();
        let label = format!("'{name}' ({origin})");
        let (mesh, problem, hull) = match &faces {
            // Without faces MuJoCo's mesh is the convex hull of the vertices.
            None => match TriMesh::convex_hull(&label, &vertices) {
                Ok(h) => {
                    let h = Arc::new(h);
                    (Some(h.clone()), None, Some(h))
                }
                Err(e) => return Err(self.err(el, format!("{e}: MuJoCo takes the convex hull of vertices given without faces, and refuses these too"))),
            },
            Some(faces) => {
                if inertia == MeshInertia::Exact && signed_volume(&vertices, faces, &placement) < 0.0 {
                    return Err(self.err(el, format!("{label} faces inward (its triangles enclose a negative volume as written), which MuJoCo refuses under inertia=\"exact\": turn its triangles outward, or weigh it by MuJoCo's default rule")));
                }
                let (mesh, problem) =
                    self.surface_of(el, TriMesh::new(&label, vertices.clone(), faces.clone()))?;
                (mesh, problem, None)
            }
        };
        self.add_mesh(
            el,
            MeshAsset {
                hull,
                inline: Some(InlineMesh {
                    vertices,
                    faces,
                    origin,
                    plugin: false,
                }),
                ..MeshAsset::read(name, placement, (inertia, maxhullvert), (mesh, problem))
            },
        );
        Ok(())
    }

    /// The `face` list of an inline mesh: vertex indices in threes, each naming one of its
    /// `n` vertices.
    fn inline_faces(
        &self,
        el: &Element,
        text: &str,
        n: usize,
    ) -> Result<Vec<[u32; 3]>, SceneError> {
        let indices = text
            .split_whitespace()
            .map(|t| t.parse::<u32>().ok().filter(|&i| (i as usize) < n).ok_or(t))
            .collect::<Result<Vec<u32>, &str>>()
            .map_err(|t| {
                self.err(
                    el,
                    format!(
                        "face names vertex '{t}', which is not one of the {n} vertices (0 to {})",
                        n - 1
                    ),
                )
            })?;
        if indices.len() % 3 != 0 || indices.is_empty() {
            return Err(self.err(el, format!("face has {} indices, not a positive multiple of 3 (three vertices for each triangle)", indices.len())));
        }
        Ok(indices.chunks(3).map(|t| [t[0], t[1], t[2]]).collect())
    }
}

impl Builder {
    /// `<mesh name builtin params>`: one of MuJoCo's built-in procedural meshes
    /// (`builtin_mesh.rs`), placed by `scale`, `refpos` and `refquat` as a file's; a tactile
    /// sensor's grid (`wedge`, `plate`) is kept without a surface, so a geom that collides or
    /// weighs by it is refused there and a visual one is left out.
    pub(super) fn builtin_mesh(
        &mut self,
        el: &Element,
        kind: &str,
        placement: Placement,
        weighing: (MeshInertia, Option<i64>),
    ) -> Result<(), SceneError> {
        if el.attr("file").is_some() {
            return Err(self.err(el, "a mesh is built in (builtin=\"...\") or read from file=\"...\", not both (MuJoCo refuses it too): remove one"));
        }
        for key in ["vertex", "face"] {
            if el.attr(key).is_some() {
                return Err(self.err(
                    el,
                    format!(
                        "a built-in mesh makes its own vertices and faces: remove {key}=\"...\""
                    ),
                ));
            }
        }
        let name = Self::given_name(el)
            .ok_or_else(|| self.err(el, "a built-in mesh needs a name (MuJoCo refuses it too)"))?;
        if self.meshes.iter().any(|m| m.name == name) {
            return Err(self.err(el, format!("mesh name '{name}' is used twice")));
        }
        let params = match el.attr("params") {
            None => Vec::new(),
            Some(text) => parse_floats(text)
                .ok_or_else(|| self.err(el, "params=\"...\": expected finite numbers"))?,
        };
        let origin = format!("MuJoCo's built-in {kind}");
        match super::builtin_mesh::builtin(kind, &params).map_err(|e| self.err(el, e))? {
            super::builtin_mesh::Builtin::Surface(vertices, faces) => {
                let made = MadeMesh {
                    name,
                    vertices,
                    faces,
                    origin,
                };
                self.add_made_mesh(el, made, placement, weighing)
            }
            super::builtin_mesh::Builtin::SensorGrid => {
                let problem = self.err(el, format!("{origin} is the point grid of a tactile sensor, without a closed surface (SCM reads no tactile sensor)"));
                self.add_mesh(
                    el,
                    MeshAsset {
                        hull_problem: Some("a tactile sensor's point grid".into()),
                        ..MeshAsset::read(name, placement, weighing, (None, Some(problem)))
                    },
                );
                Ok(())
            }
        }
    }
}

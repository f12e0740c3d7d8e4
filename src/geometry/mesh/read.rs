//! Reading a mesh file: OBJ through tobj, STL through stl_io, each parser guarded so that a
//! panic on untrusted bytes becomes an error; then the checks of [`TriMesh::new`].

use super::*;

impl TriMesh {
    /// Loads an OBJ or STL file, scales it, checks it and orients it outward. Returns the mesh
    /// and warnings (e.g. an inward orientation that was fixed).
    pub fn load(path: &Path, placement: &Placement) -> Result<(TriMesh, Vec<String>), MeshError> {
        let (file, vertices, triangles, notes) = read(path, placement)?;
        let (mut mesh, mut warnings) =
            TriMesh::new(&file, vertices, triangles).map_err(|e| MeshError {
                notes: notes.clone(),
                ..e
            })?;
        warnings.extend(notes);
        let scale = placement.scale;
        if scale.x * scale.y * scale.z < 0.0 {
            // A mirroring scale turns the surface inside out; `new` has already flipped it back.
            warnings.retain(|w| !w.contains("inward"));
        }
        mesh.file = file;
        Ok((mesh, warnings))
    }

    /// The mass properties MuJoCo gives an OBJ or STL file (placed: [`Placement`]) by default, its
    /// `inertia="legacy"` ([`legacy_mass_properties`]), whatever its surface: read from the
    /// file's own triangles, so also for an open mesh. Fails where the file cannot be read or
    /// its triangles enclose no volume by that rule.
    pub fn load_legacy_mass(
        path: &Path,
        placement: &Placement,
    ) -> Result<MassProperties, MeshError> {
        let (file, vertices, triangles, _) = read(path, placement)?;
        legacy_mass_properties(&vertices, &triangles).ok_or(MeshError {
            file,
            problem: MeshProblem::ZeroVolume(0.0),
            notes: Vec::new(),
        })
    }

    /// MuJoCo's shell inertia of an OBJ or STL file (placed: [`Placement`]), `inertia="shell"`
    /// ([`shell_mass_properties`]), from the file's own triangles, open or closed. Fails where
    /// the file cannot be read or its area is zero.
    pub fn load_shell_mass(
        path: &Path,
        placement: &Placement,
    ) -> Result<MassProperties, MeshError> {
        let (file, vertices, triangles, _) = read(path, placement)?;
        shell_mass_properties(&vertices, &triangles).ok_or(MeshError {
            file,
            problem: MeshProblem::ZeroVolume(0.0),
            notes: Vec::new(),
        })
    }

    /// The convex hull of an OBJ or STL file's vertices (placed: [`Placement`]), whatever its surface: what
    /// MuJoCo collides a mesh by. Every vertex counts, as in MuJoCo, also an OBJ's vertices
    /// that no face uses. Fails where the file cannot be read or its vertices span no volume
    /// (all in one plane).
    pub fn load_hull(path: &Path, placement: &Placement) -> Result<TriMesh, MeshError> {
        let (file, mut vertices, _, _) = read(path, placement)?;
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("obj"))
        {
            let bytes = std::fs::read(path).map_err(|e| MeshError {
                file: file.clone(),
                problem: MeshProblem::Missing(e.to_string()),
                notes: Vec::new(),
            })?;
            vertices = obj_positions(&bytes)
                .into_iter()
                .map(|v| placement.apply(&v))
                .collect();
        }
        TriMesh::convex_hull(&file, &vertices)
    }
}

/// A file's name, its vertices (placed: [`Placement`]) and triangles.
type Read = (String, Vec<Vector3<f64>>, Vec<[u32; 3]>, Vec<String>);

/// The file's name, its vertices (placed: [`Placement`]) and triangles.
fn read(path: &Path, placement: &Placement) -> Result<Read, MeshError> {
    let file = path.display().to_string();
    let err = |problem| MeshError {
        file: file.clone(),
        problem,
        notes: Vec::new(),
    };
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    if !matches!(ext.as_str(), "obj" | "stl" | "msh") {
        return Err(err(MeshProblem::Format(ext)));
    }
    let bytes = std::fs::read(path).map_err(|e| err(MeshProblem::Missing(e.to_string())))?;
    // The parsers are third-party code reading untrusted bytes: a panic inside them becomes
    // a parse error, never a crash of the host.
    let parsed = std::panic::catch_unwind(|| match ext.as_str() {
        "obj" => parse_obj(&bytes),
        "msh" => parse_msh(&bytes),
        _ => parse_stl(&bytes),
    })
    .unwrap_or_else(|_| Err("the parser failed on this file".into()));
    let (vertices, triangles, notes) = parsed.map_err(|e| err(MeshProblem::Parse(e)))?;
    let notes = notes.iter().map(|n| format!("mesh {file}: {n}")).collect();
    let vertices = vertices.iter().map(|v| placement.apply(v)).collect();
    Ok((file, vertices, triangles, notes))
}

/// Vertices and triangles of a parsed file and notes on it, or what is wrong with it.
type Parsed = Result<(Vec<Vector3<f64>>, Vec<[u32; 3]>, Vec<String>), String>;

/// Every vertex position (`v x y z`) of an OBJ file, whether a face uses it or not (the parser
/// keeps only those faces use), read in single precision as the parser reads them. Lines that
/// do not parse are skipped: the file has been parsed whole before.
fn obj_positions(bytes: &[u8]) -> Vec<Vector3<f64>> {
    String::from_utf8_lossy(bytes)
        .lines()
        .filter_map(|line| {
            let mut words = line.split_whitespace();
            if words.next() != Some("v") {
                return None;
            }
            let mut xyz = words.take(3).map(|w| w.parse::<f32>().ok().map(f64::from));
            Some(Vector3::new(xyz.next()??, xyz.next()??, xyz.next()??))
        })
        .collect()
}

/// Vertices and triangles of a file in MuJoCo's own binary mesh format (`.msh`, written by
/// older MuJoCo tools): little-endian `i32` counts of vertices, normals, texture coordinates
/// and faces, then as many `f32` triples, triples and pairs, then the faces' `i32` vertex
/// triples (from 0). Read here by hand: the format is MuJoCo's alone, with no library for it.
/// The sizes are checked as MuJoCo checks them (at least 4 vertices; normals and texture
/// coordinates none or one per vertex; the file exactly as long as they say); normals and
/// texture coordinates are not used. A file without faces (MuJoCo takes the convex hull of
/// its vertices) is refused with the mesh problems' "no triangles".
fn parse_msh(bytes: &[u8]) -> Parsed {
    let int = |at: usize| -> i32 {
        i32::from_le_bytes(bytes[at..at + 4].try_into().expect("four bytes"))
    };
    if bytes.len() < 16 {
        return Err("the MSH header (four counts) is missing".into());
    }
    let [nv, nn, nt, nf] = [0, 4, 8, 12].map(int);
    if nv < 4 || nf < 0 || nn < 0 || nt < 0 || (nn > 0 && nn != nv) || (nt > 0 && nt != nv) {
        return Err(format!(
            "invalid sizes in the MSH header: {nv} vertices, {nn} normals, {nt} texture coordinates, {nf} faces"
        ));
    }
    let [nv, nn, nt, nf] = [nv, nn, nt, nf].map(|n| n as usize);
    let expected = 16 + 4 * (3 * nv + 3 * nn + 2 * nt + 3 * nf);
    if bytes.len() != expected {
        return Err(format!(
            "the MSH file has {} bytes where its header says {expected}",
            bytes.len()
        ));
    }
    let float = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().expect("four bytes"));
    let vertices = (0..nv)
        .map(|i| {
            let at = 16 + 12 * i;
            Vector3::new(float(at), float(at + 4), float(at + 8)).map(f64::from)
        })
        .collect::<Vec<_>>();
    let faces_at = 16 + 4 * (3 * nv + 3 * nn + 2 * nt);
    let mut triangles = Vec::with_capacity(nf);
    for f in 0..nf {
        let t = [0, 1, 2].map(|k| int(faces_at + 12 * f + 4 * k));
        if t.iter().any(|&i| i < 0 || i as usize >= nv) {
            return Err(format!("face {f} refers to a vertex that does not exist"));
        }
        triangles.push(t.map(|i| i as u32));
    }
    Ok((vertices, triangles, Vec::new()))
}

/// Vertices and triangles of an OBJ file (all its objects), with a note where a polygon of
/// more than three corners is not planar or not convex: SCM splits every polygon into a fan
/// from its first corner, and MuJoCo 4.0.0 splits polygons otherwise (a quad along its other
/// diagonal, larger polygons by clipping ears), so such a polygon's triangles enclose a
/// slightly different volume in the two (docs/mjcf.md, MuJoCo Menagerie).
fn parse_obj(bytes: &[u8]) -> Parsed {
    let opts = tobj::LoadOptions {
        triangulate: false,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = std::io::BufReader::new(bytes);
    let (models, _) = tobj::load_obj_buf(&mut reader, &opts, |_| Ok(Default::default()))
        .map_err(|e| e.to_string())?;
    let (mut verts, mut tris) = (Vec::new(), Vec::new());
    let (mut uneven, mut first) = (0usize, None);
    // MuJoCo 4.0.0 reads the faces of the file's first object only (an `o` or `g` line after
    // faces starts another; measured: a file of two tetrahedra weighs one): the faces after
    // it are left out here too.
    let (kept, total) = first_object_faces(bytes);
    let mut face = 0usize;
    for m in &models {
        let base = verts.len() as u32;
        let p = &m.mesh.positions;
        verts.extend(
            p.chunks_exact(3)
                .map(|c| Vector3::new(c[0] as f64, c[1] as f64, c[2] as f64)),
        );
        let idx = &m.mesh.indices;
        // Without arities every face is a triangle.
        let arities: Vec<u32> = if m.mesh.face_arities.is_empty() {
            vec![3; idx.len() / 3]
        } else {
            m.mesh.face_arities.clone()
        };
        let mut at = 0usize;
        for &n in arities.iter().take(kept.saturating_sub(face)) {
            let corners = idx
                .get(at..at + n as usize)
                .ok_or("a face runs past the file's indices")?;
            at += n as usize;
            for k in 1..corners.len().saturating_sub(1) {
                tris.push([corners[0] + base, corners[k] + base, corners[k + 1] + base]);
            }
            if n > 3 && !flat_and_convex(&verts, base, corners) {
                uneven += 1;
                first.get_or_insert(face);
            }
            face += 1;
        }
    }
    let mut notes = Vec::new();
    if let Some(face) = first {
        notes.push(format!("{uneven} of its polygons of more than three corners (the first is face {face}) are not planar or not convex: SCM splits each into a fan from its first corner, MuJoCo otherwise, so the mesh's volume and mass may differ slightly from MuJoCo's"));
    }
    if total > kept {
        notes.push(format!("the file holds more than one object (an 'o' or 'g' line after faces): MuJoCo 4.0.0 reads the faces of the first only, and so does SCM ({} of its {total} faces left out; their vertices still count for the convex hull)", total - kept));
    }
    Ok((verts, tris, notes))
}

/// The number of faces (`f` lines) of an OBJ file's first object, and of the whole file: the
/// first object ends at the first `o` or `g` line that follows a face.
fn first_object_faces(bytes: &[u8]) -> (usize, usize) {
    let (mut faces, mut first) = (0usize, None);
    for line in String::from_utf8_lossy(bytes).lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("f") => faces += 1,
            Some("o" | "g") if faces > 0 && first.is_none() => first = Some(faces),
            _ => {}
        }
    }
    (first.unwrap_or(faces), faces)
}

/// Whether the polygon `corners` (indices into `verts` from `base`) lies in one plane and
/// turns one way: its fan then covers it exactly, as any other split does. Tolerances are
/// those of single-precision coordinates (1e-6 of the polygon's size).
fn flat_and_convex(verts: &[Vector3<f64>], base: u32, corners: &[u32]) -> bool {
    let at = |i: usize| verts.get((corners[i % corners.len()] + base) as usize);
    let Some(points) = (0..corners.len()).map(at).collect::<Option<Vec<_>>>() else {
        return true; // a bad index is the mesh checks' to report
    };
    let n = points.len();
    // Newell's normal of the polygon, and its size.
    let mut normal = Vector3::zeros();
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        normal += Vector3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    let size = (0..n)
        .map(|i| (points[i] - points[0]).norm())
        .fold(0.0, f64::max);
    if normal.norm() <= 0.0 || size <= 0.0 {
        return true; // degenerate: the mesh checks report it
    }
    let unit = normal.normalize();
    let tol = 1e-6 * size;
    let planar = points
        .iter()
        .all(|&p| (p - points[0]).dot(&unit).abs() <= tol);
    let convex = (0..n).all(|i| {
        let (a, b, c) = (points[i], points[(i + 1) % n], points[(i + 2) % n]);
        (b - a).cross(&(c - b)).dot(&unit) >= -tol * size
    });
    planar && convex
}

/// Vertices and triangles of an STL file (binary or ASCII). Stored normals are ignored: the
/// winding decides the orientation.
fn parse_stl(bytes: &[u8]) -> Parsed {
    let mut cursor = std::io::Cursor::new(bytes);
    let mesh = stl_io::read_stl(&mut cursor).map_err(|e| e.to_string())?;
    let verts = mesh
        .vertices
        .iter()
        .map(|v| Vector3::new(v[0] as f64, v[1] as f64, v[2] as f64))
        .collect();
    let tris = mesh
        .faces
        .iter()
        .map(|f| f.vertices.map(|i| i as u32))
        .collect();
    Ok((verts, tris, Vec::new()))
}

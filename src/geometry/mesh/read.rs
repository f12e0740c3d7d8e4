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

    /// The signed volume the file's triangles enclose as written (m³, placed: negative where
    /// they face inward; a mirroring scale counted as the mirror it is, not as a turn inside
    /// out). MuJoCo refuses a mesh weighed by `inertia="exact"` whose volume is negative.
    pub fn load_signed_volume(path: &Path, placement: &Placement) -> Result<f64, MeshError> {
        let (_, vertices, triangles, _) = read(path, placement)?;
        Ok(signed_volume(&vertices, &triangles, placement))
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

/// The signed volume `triangles` over `vertices` (placed by `placement`) enclose as written
/// (m³: negative where they face inward; a mirroring scale counted as the mirror it is, not as
/// a turn inside out). A triangle naming a vertex that does not exist counts nothing.
pub fn signed_volume(
    vertices: &[Vector3<f64>],
    triangles: &[[u32; 3]],
    placement: &Placement,
) -> f64 {
    let s = placement.scale;
    let mirror = if s.x * s.y * s.z < 0.0 { -1.0 } else { 1.0 };
    let volume: f64 = triangles
        .iter()
        .filter_map(|t| {
            let [a, b, c] = t.map(|i| vertices.get(i as usize));
            Some(a?.dot(&b?.cross(c?)) / 6.0)
        })
        .sum();
    mirror * volume
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

/// Vertices and triangles of an OBJ file (the faces of its first object, as MuJoCo 4.0.0
/// reads them; every object's vertices), with notes. Polygons of more than three corners are
/// split as MuJoCo splits them where that is known ([`split_polygon`]), else into a fan from
/// the first corner with a note (the enclosed volume may then differ from MuJoCo's).
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
            if !split_polygon(&verts, base, corners, &mut tris) {
                uneven += 1;
                first.get_or_insert(face + 1);
            }
            face += 1;
        }
    }
    let mut notes = Vec::new();
    if let Some(face) = first {
        notes.push(format!("{uneven} of its polygons of more than four corners (the first is face {face}, counting from 1) do not lie in one plane or cross themselves: SCM splits each into a fan from its first corner and MuJoCo by clipping ears, so the mesh's volume and mass may differ slightly from MuJoCo's"));
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
            // A face of one or two corners is a point or a line, which the parser drops.
            Some("f") if words.clone().count() >= 3 => faces += 1,
            Some("o" | "g") if faces > 0 && first.is_none() => first = Some(faces),
            _ => {}
        }
    }
    (first.unwrap_or(faces), faces)
}

/// Splits the polygon `corners` (indices into `verts` from `base`) into triangles pushed on
/// `tris`, keeping its winding. A triangle is itself. A quad is split along its shorter
/// diagonal, the second one on a tie, as MuJoCo 4.0.0 splits it (measured: the enclosed
/// volume of a pyramid on a bent quad matches MuJoCo's either way round). A larger polygon in
/// one plane (to 1e-6 of its size: single-precision coordinates) is split by clipping ears,
/// which covers it exactly, as any valid split and so MuJoCo's; otherwise (not planar, or no
/// ear found: self-intersecting) it is split into a fan from its first corner and `false` is
/// returned.
fn split_polygon(
    verts: &[Vector3<f64>],
    base: u32,
    corners: &[u32],
    tris: &mut Vec<[u32; 3]>,
) -> bool {
    let n = corners.len();
    let id = |i: usize| corners[i] + base;
    let at = |i: usize| verts.get(id(i) as usize).copied();
    let fan = |tris: &mut Vec<[u32; 3]>| {
        for k in 1..n.saturating_sub(1) {
            tris.push([id(0), id(k), id(k + 1)]);
        }
    };
    if n <= 3 {
        fan(tris);
        return true;
    }
    let Some(points) = (0..n).map(at).collect::<Option<Vec<_>>>() else {
        fan(tris); // a bad index is the mesh checks' to report
        return true;
    };
    if n == 4 {
        let d02 = (points[2] - points[0]).norm_squared();
        let d13 = (points[3] - points[1]).norm_squared();
        if d02 < d13 {
            tris.extend([[id(0), id(1), id(2)], [id(0), id(2), id(3)]]);
        } else {
            tris.extend([[id(0), id(1), id(3)], [id(1), id(2), id(3)]]);
        }
        return true;
    }
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
        fan(tris); // degenerate: the mesh checks report it
        return true;
    }
    let unit = normal.normalize();
    let tol = 1e-6 * size;
    if points
        .iter()
        .any(|&p| (p - points[0]).dot(&unit).abs() > tol)
    {
        fan(tris);
        return false;
    }
    match clip_ears(&points, &unit) {
        Some(ears) => {
            tris.extend(ears.iter().map(|t| t.map(id)));
            true
        }
        None => {
            fan(tris);
            false
        }
    }
}

/// Ear clipping of a planar polygon with normal `unit` (its winding's): triangles of corner
/// positions `0..points.len()`, in the polygon's winding, or `None` where no ear is found (a
/// self-intersecting outline). Written here: O(n²) for the few polygons meshes have.
fn clip_ears(points: &[Vector3<f64>], unit: &Vector3<f64>) -> Option<Vec<[usize; 3]>> {
    let turn = |a: usize, b: usize, c: usize| {
        (points[b] - points[a])
            .cross(&(points[c] - points[b]))
            .dot(unit)
    };
    // Whether p lies in the triangle a, b, c (counter-clockwise about `unit`), edges included.
    let inside = |p: usize, a: usize, b: usize, c: usize| {
        let side = |u: usize, v: usize| {
            (points[v] - points[u])
                .cross(&(points[p] - points[u]))
                .dot(unit)
        };
        side(a, b) >= 0.0 && side(b, c) >= 0.0 && side(c, a) >= 0.0
    };
    let mut left: Vec<usize> = (0..points.len()).collect();
    let mut out = Vec::with_capacity(points.len() - 2);
    while left.len() > 3 {
        let m = left.len();
        let ear = (0..m).find(|&i| {
            let (a, b, c) = (left[(i + m - 1) % m], left[i], left[(i + 1) % m]);
            turn(a, b, c) > 0.0
                && left
                    .iter()
                    .all(|&p| p == a || p == b || p == c || !inside(p, a, b, c))
        })?;
        out.push([left[(ear + m - 1) % m], left[ear], left[(ear + 1) % m]]);
        left.remove(ear);
    }
    out.push([left[0], left[1], left[2]]);
    Some(out)
}

/// Vertices and triangles of an STL file (binary or ASCII). Stored normals are ignored: the
/// winding decides the orientation.
///
/// A file is binary, as MuJoCo decides, when its size is `84 + 50 n` with `n` the triangle
/// count at bytes 80..84, whatever its 80-byte header says: exporters often begin that header
/// with "solid", which stl_io would read as ASCII. Such a file is read with the header blanked.
fn parse_stl(bytes: &[u8]) -> Parsed {
    let blanked;
    let bytes = match binary_stl_size(bytes) {
        true if bytes.starts_with(b"solid") => {
            let mut b = bytes.to_vec();
            b[..80].fill(b' ');
            blanked = b;
            &blanked[..]
        }
        _ => bytes,
    };
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

/// Whether `bytes` has the size of a binary STL file: an 80-byte header, a little-endian
/// triangle count `n` and 50 bytes per triangle.
fn binary_stl_size(bytes: &[u8]) -> bool {
    bytes.len() >= 84 && {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
        bytes.len() as u64 == 84 + 50 * n
    }
}

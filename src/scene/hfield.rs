//! Height fields (`<hfield>`, `<geom type="hfield">`) as MuJoCo compiles them. A field whose
//! elevation is given (`elevation`, or a file: a grey PNG or MuJoCo's own binary format)
//! becomes the closed solid MuJoCo collides with: over the grid of `nrow × ncol` points
//! spanning `±size[0] × ±size[1]`, the elevations scaled to `[0, 1]` (as MuJoCo scales them)
//! times `size[2]`, each cell cut along the diagonal MuJoCo's prisms use, down to a flat base
//! at `-size[3]`; its cloud is then sampled as a mesh's. A field without elevation data is
//! flat when compiled: the plane of its surface.

use super::*;
use crate::geometry::{Shape, TriMesh};
use std::path::PathBuf;

/// The most grid points SCM takes in a height field (a 4096 × 4096 image).
const MAX_POINTS: usize = 1 << 24;

/// A `<hfield>` asset.
#[derive(Clone, Debug)]
pub struct HeightField {
    /// Its name (`name`, else its file's name without extension).
    pub name: String,
    /// `size`: half-extents along x and y, elevation scale, base depth (m).
    pub size: [f64; 4],
    /// The elevation grid, scaled to `[0, 1]`, if the file gives one.
    grid: Option<Grid>,
    /// The `file` attribute as written and the resolved path, if any (`scm pack` carries it).
    pub file: Option<(String, PathBuf)>,
}

/// Elevations row by row (`nrow` rows along y, `ncol` columns along x), in `[0, 1]`.
#[derive(Clone, Debug)]
struct Grid {
    nrow: usize,
    ncol: usize,
    data: Vec<f32>,
}

impl Builder {
    /// `<hfield name size nrow ncol elevation file content_type>`, checked as MuJoCo checks it.
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
        let file = el.attr("file").map(str::to_string);
        let name = match (Self::given_name(el), &file) {
            (Some(n), _) => n,
            (None, Some(f)) => Path::new(f)
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            (None, None) => return Err(self.err(el, "a height field without a file needs a name")),
        };
        let size = match self.floats(el, "size", 4)? {
            Some(v) if v.iter().all(|&x| x > 0.0) => [v[0], v[1], v[2], v[3]],
            _ => return Err(self.err(el, "size needs four positive numbers (x and y half-extents, elevation scale, base depth), as MuJoCo requires")),
        };
        let count = |key: &str| -> Result<Option<usize>, SceneError> {
            match el.attr(key).map(|v| v.trim().parse::<i64>()) {
                None => Ok(None),
                Some(Ok(n)) if (0..=i64::from(i32::MAX)).contains(&n) => Ok(Some(n as usize)),
                Some(_) => Err(self.err(
                    el,
                    format!("{key} must be a non-negative integer (MuJoCo's int)"),
                )),
            }
        };
        let (nrow, ncol) = (count("nrow")?, count("ncol")?);
        let (grid, file) = match (file, el.attr("elevation")) {
            (Some(_), Some(_)) => {
                return Err(self.err(el, "a height field takes its elevation from file=\"...\" or from elevation=\"...\", not both (MuJoCo refuses it too)"))
            }
            (Some(f), None) => {
                if nrow.unwrap_or(0) != 0 || ncol.unwrap_or(0) != 0 {
                    return Err(self.err(el, "nrow and ncol come from the height field's file: remove them (MuJoCo refuses both)"));
                }
                let path = paths::mesh_path(Path::new(&self.file), self.meshdir.as_deref(), &f);
                let png = match el.attr("content_type") {
                    Some("image/png") => true,
                    Some("image/vnd.mujoco.hfield") => false,
                    Some(t) => return Err(self.err(el, format!("content_type=\"{t}\": a height field's file is image/png or image/vnd.mujoco.hfield"))),
                    None => f.to_ascii_lowercase().ends_with(".png"),
                };
                let read = if png { read_png(&path) } else { read_custom(&path) };
                let (nrow, ncol, data) =
                    read.map_err(|why| self.err(el, format!("{}: {why}", path.display())))?;
                if nrow * ncol > MAX_POINTS {
                    return Err(self.err(el, format!("a height field of {nrow} x {ncol} points: SCM takes at most {MAX_POINTS}")));
                }
                (Some(Grid { nrow, ncol, data }), Some((f, path)))
            }
            (None, Some(text)) => {
                let (Some(nrow), Some(ncol)) = (nrow, ncol) else {
                    return Err(self.err(el, "elevation=\"...\" needs nrow and ncol"));
                };
                let cells = nrow.checked_mul(ncol).filter(|&n| n <= MAX_POINTS).ok_or_else(|| {
                    self.err(el, format!("a height field of {nrow} x {ncol} points: SCM takes at most {MAX_POINTS}"))
                })?;
                let written: Vec<f32> = parse_floats(text)
                    .ok_or_else(|| self.err(el, "elevation: expected finite numbers"))?
                    .iter()
                    .map(|&x| x as f32)
                    .collect();
                if written.len() != cells {
                    return Err(self.err(el, format!("elevation has {} numbers where nrow × ncol is {cells} (MuJoCo refuses it too)", written.len())));
                }
                // Written top to bottom, as MuJoCo reads it: the first row at +y.
                let data = written.chunks(ncol).rev().flatten().copied().collect();
                (Some(Grid { nrow, ncol, data }), None)
            }
            (None, None) => {
                for (key, n) in [("nrow", nrow), ("ncol", ncol)] {
                    if n.unwrap_or(0) < 2 {
                        return Err(self.err(el, format!("{key} must be an integer of at least 2 for a height field without a file")));
                    }
                }
                (None, None)
            }
        };
        let grid = match grid {
            Some(g) if g.nrow < 2 || g.ncol < 2 => {
                return Err(self.err(
                    el,
                    format!(
                        "a height field of {} x {} points has no cell: SCM needs at least 2 x 2",
                        g.nrow, g.ncol
                    ),
                ))
            }
            Some(mut g) => {
                scale_to_unit(&mut g.data);
                Some(g)
            }
            None => None,
        };
        if self.hfields.iter().any(|h| h.name == name) {
            return Err(self.err(el, format!("hfield name '{name}' is used twice")));
        }
        self.hfields.push(HeightField {
            name,
            size,
            grid,
            file,
        });
        Ok(())
    }

    /// A geom of type `hfield` on body `body`: the closed solid of its field's elevation
    /// (module documentation), or, for a field flat when compiled, `None`: the plane z = 0 of
    /// the geom's frame (MuJoCo's elevation 0), with a warning for what differs.
    pub(super) fn hfield_geom(
        &mut self,
        el: &Element,
        body: usize,
    ) -> Result<Option<Shape>, SceneError> {
        let name = el
            .attr("hfield")
            .ok_or_else(|| self.err(el, "a height field geom needs hfield=\"NAME\""))?;
        let Some(field) = self.hfields.iter().find(|h| h.name == name).cloned() else {
            return Err(self.err(el, format!("no hfield asset named '{name}'")));
        };
        let size = field.size;
        let Some(grid) = &field.grid else {
            let (x, y) = (2.0 * size[0], 2.0 * size[1]);
            self.warnings.push(format!("{}:{}: <geom> height field '{name}' is flat when compiled: SCM takes it as the plane of its surface, unbounded, where MuJoCo's is {x} x {y} m over a base {} m deep; a host cannot reshape it at run time", el.file, el.line, size[3]));
            return Ok(None);
        };
        if body != 0 {
            return Err(self.err(el, "a height field with elevation data outside the worldbody is not supported by SCM: put its geom in the worldbody"));
        }
        let (vertices, triangles) = grid.solid(&size);
        let label = format!("height field '{name}'");
        let (mut mesh, warnings) = TriMesh::new(&label, vertices, triangles)
            .map_err(|e| self.err(el, format!("{label}: {}", e.problem)))?;
        // A regular grid of the data's cells: sampled cell by cell, as even as it is.
        mesh.sampling = crate::geometry::mesh::MeshSampling::Triangles;
        for w in warnings {
            self.warnings
                .push(format!("{}:{}: <geom> {w}", el.file, el.line));
        }
        Ok(Some(Shape::Mesh(Arc::new(mesh))))
    }
}

impl Grid {
    /// The closed solid under the field (module documentation): the grid's points on top,
    /// each cell cut along the diagonal from its point (r, c) to (r + 1, c + 1) as MuJoCo's
    /// prisms cut it, the walls down the border, and the base as a fan about its centre.
    fn solid(&self, size: &[f64; 4]) -> (Vec<Vector3<f64>>, Vec<[u32; 3]>) {
        let (nrow, ncol) = (self.nrow, self.ncol);
        let (dx, dy) = (
            2.0 * size[0] / (ncol - 1) as f64,
            2.0 * size[1] / (nrow - 1) as f64,
        );
        let mut v = Vec::with_capacity(nrow * ncol + 2 * (nrow + ncol));
        for r in 0..nrow {
            for c in 0..ncol {
                let z = f64::from(self.data[r * ncol + c]) * size[2];
                v.push(Vector3::new(
                    dx * c as f64 - size[0],
                    dy * r as f64 - size[1],
                    z,
                ));
            }
        }
        let at = |r: usize, c: usize| (r * ncol + c) as u32;
        let mut t = Vec::with_capacity(2 * nrow * ncol + 6 * (nrow + ncol));
        for r in 0..nrow - 1 {
            for c in 0..ncol - 1 {
                let (a, b, cc, d) = (at(r, c), at(r, c + 1), at(r + 1, c), at(r + 1, c + 1));
                t.extend([[a, b, d], [a, d, cc]]);
            }
        }
        // The border, counter-clockwise seen from above, and a base point under each.
        let border: Vec<u32> = (0..ncol)
            .map(|c| at(0, c))
            .chain((1..nrow).map(|r| at(r, ncol - 1)))
            .chain((0..ncol - 1).rev().map(|c| at(nrow - 1, c)))
            .chain((1..nrow - 1).rev().map(|r| at(r, 0)))
            .collect();
        let base = v.len() as u32;
        for &k in &border {
            let p = v[k as usize];
            v.push(Vector3::new(p.x, p.y, -size[3]));
        }
        let centre = v.len() as u32;
        v.push(Vector3::new(0.0, 0.0, -size[3]));
        let n = border.len();
        for k in 0..n {
            let next = (k + 1) % n;
            let (top, top_next) = (border[k], border[next]);
            let (low, low_next) = (base + k as u32, base + next as u32);
            t.extend([
                [top, low, low_next],
                [top, low_next, top_next],
                [centre, low_next, low],
            ]);
        }
        (v, t)
    }
}

/// MuJoCo's scaling of a field's elevations to `[0, 1]`, in single precision: less the
/// lowest, over the span where the span is above `1e-14`.
fn scale_to_unit(data: &mut [f32]) {
    let lo = data.iter().copied().fold(f32::INFINITY, f32::min);
    let hi = data.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    for x in data.iter_mut() {
        *x -= lo;
        if f64::from(hi - lo) > 1e-14 {
            *x /= hi - lo;
        }
    }
}

/// A grey PNG's pixels as elevations, its last image row first (MuJoCo's order: the image's
/// top row at +y).
fn read_png(path: &Path) -> Result<(usize, usize, Vec<f32>), String> {
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
    let mut pixels = vec![0; reader.output_buffer_size()];
    let frame = reader.next_frame(&mut pixels).map_err(|e| e.to_string())?;
    if frame.color_type != png::ColorType::Grayscale || frame.bit_depth != png::BitDepth::Eight {
        return Err(format!("a {:?} image: SCM reads a height field from a grey PNG (one 8-bit channel); convert it to greyscale", frame.color_type));
    }
    let (ncol, nrow) = (frame.width as usize, frame.height as usize);
    let data = (0..nrow)
        .flat_map(|r| (0..ncol).map(move |c| (r, c)))
        .map(|(r, c)| f32::from(pixels[c + (nrow - 1 - r) * frame.line_size]))
        .collect();
    Ok((nrow, ncol, data))
}

/// MuJoCo's own height field file: two 32-bit integers (rows, columns), then the elevations
/// as 32-bit floats, little-endian.
fn read_custom(path: &Path) -> Result<(usize, usize, Vec<f32>), String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let word = |k: usize| -> Option<[u8; 4]> { bytes.get(4 * k..4 * k + 4)?.try_into().ok() };
    let (Some(r), Some(c)) = (word(0), word(1)) else {
        return Err("no header (rows and columns)".into());
    };
    let (nrow, ncol) = (i32::from_le_bytes(r), i32::from_le_bytes(c));
    if nrow < 1 || ncol < 1 {
        return Err(format!("{nrow} x {ncol}: the dimensions must be positive"));
    }
    let (nrow, ncol) = (nrow as usize, ncol as usize);
    if bytes.len() != 8 + 4 * nrow * ncol {
        return Err(format!(
            "{} bytes where {nrow} x {ncol} elevations take {}",
            bytes.len(),
            8 + 4 * nrow * ncol
        ));
    }
    let data = (0..nrow * ncol)
        .map(|k| f32::from_le_bytes(word(2 + k).expect("length checked")))
        .collect();
    Ok((nrow, ncol, data))
}

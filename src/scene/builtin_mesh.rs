//! MuJoCo's built-in procedural meshes (`<mesh builtin="..." params="...">`), made as MuJoCo's
//! compiler makes them, vertex for vertex in single precision as it stores them, so that they
//! weigh as MuJoCo weighs them (docs/mjcf.md): `sphere` (an icosahedron subdivided, each new
//! vertex an edge's midpoint pushed onto the unit sphere), `hemisphere` (rows of points from the
//! pole to the equator, closed by a fan about the centre), `supersphere` and `supertorus`
//! (parametric grids with signed powers of the cosine and sine), `cone` (its vertices only:
//! MuJoCo's mesh is their convex hull). `wedge` and `plate` are the point grids of MuJoCo's
//! tactile sensors, without a closed surface: kept as a mesh no geom can collide or weigh by.

use nalgebra::Vector3;
use std::collections::HashMap;
use std::f64::consts::PI;

/// The finest grid side SCM makes a supersphere or supertorus of (MuJoCo's gallery uses 64).
const MAX_RESOLUTION: i64 = 4096;

/// A built-in mesh's vertices (unit size, before `scale`) and faces (`None`: the convex hull of
/// the vertices), or why it has no surface.
pub(super) enum Builtin {
    /// A surface: vertices and, where MuJoCo gives them, faces.
    Surface(Vec<Vector3<f64>>, Option<Vec<[u32; 3]>>),
    /// A tactile sensor's point grid (`wedge`, `plate`).
    SensorGrid,
}

/// The built-in mesh `kind` with its `params`, checked as MuJoCo checks them.
pub(super) fn builtin(kind: &str, params: &[f64]) -> Result<Builtin, String> {
    let want = |n: usize| {
        if params.len() == n {
            Ok(())
        } else {
            Err(format!(
                "builtin=\"{kind}\" takes {n} parameter(s) in params=\"...\", {} given (MuJoCo refuses it too)",
                params.len()
            ))
        }
    };
    let int = |x: f64| x as i64;
    // MuJoCo's resolutions are C ints; SCM makes at most MAX_RESOLUTION along a side.
    let too_fine = |n: i64| {
        Err(format!(
            "a builtin {kind} of resolution {n}: SCM makes at most {MAX_RESOLUTION} along a side"
        ))
    };
    match kind {
        "sphere" => {
            want(1)?;
            match int(params[0]) {
                s @ 0..=4 => Ok(icosphere(s as usize)),
                _ => Err("a builtin sphere's subdivision is 0 to 4 (MuJoCo refuses others)".into()),
            }
        }
        "hemisphere" => {
            want(1)?;
            match int(params[0]) {
                r @ 0..=10 => Ok(hemisphere(r as usize)),
                _ => Err("a builtin hemisphere's resolution is 0 to 10 (MuJoCo refuses others)".into()),
            }
        }
        "supersphere" => {
            want(3)?;
            let (res, e, n) = (int(params[0]), params[1], params[2]);
            if res > MAX_RESOLUTION {
                return too_fine(res);
            }
            if res < 3 || e < 0.0 || n < 0.0 {
                return Err("a supersphere needs a resolution of 3 or more and exponents e, n not negative (MuJoCo refuses others)".into());
            }
            Ok(supersphere(res as usize, e, n))
        }
        "supertorus" => {
            want(4)?;
            let (res, radius, s, t) = (int(params[0]), params[1], params[2], params[3]);
            if res > MAX_RESOLUTION {
                return too_fine(res);
            }
            if res < 3 || radius <= 0.0 || radius > 1.0 || s <= 0.0 || t <= 0.0 {
                return Err("a supertorus needs a resolution of 3 or more, a radius in (0, 1] and positive exponents s, t (MuJoCo refuses others)".into());
            }
            Ok(supertorus(res as usize, radius, s, t))
        }
        "cone" => {
            want(2)?;
            let edges = int(params[0]);
            if edges > MAX_RESOLUTION * MAX_RESOLUTION {
                return too_fine(edges);
            }
            if edges < 3 {
                return Err("a builtin cone needs 3 or more edges".into());
            }
            Ok(cone(edges as usize, params[1]))
        }
        "wedge" => {
            want(5)?;
            let p = params;
            if p[0] < 1.0 || p[1] < 1.0 || !(p[2] > 0.0 && p[2] <= 180.0) || !(p[3] > 0.0 && p[3] <= 90.0) || !(0.0..=1.0).contains(&p[4]) {
                return Err("a builtin wedge needs positive resolutions, fields of view in (0, 180] and (0, 90] degrees and gamma in [0, 1] (MuJoCo refuses others)".into());
            }
            Ok(Builtin::SensorGrid)
        }
        "plate" => {
            want(2)?;
            if params[0] < 1.0 || params[1] < 1.0 {
                return Err("a builtin plate needs positive resolutions (MuJoCo refuses others)".into());
            }
            Ok(Builtin::SensorGrid)
        }
        _ => Err(format!(
            "builtin=\"{kind}\": expected none, sphere, hemisphere, cone, supersphere, supertorus, wedge or plate"
        )),
    }
}

/// A vertex as MuJoCo stores it: each coordinate rounded to single precision.
fn stored(x: f64, y: f64, z: f64) -> Vector3<f64> {
    Vector3::new(x as f32 as f64, y as f32 as f64, z as f32 as f64)
}

/// `sign(cos ω) |cos ω|^m` and `sign(sin ω) |sin ω|^m`: the signed powers of the superquadrics.
fn signed_cos(w: f64, m: f64) -> f64 {
    w.cos().abs().powf(m).copysign(w.cos())
}
fn signed_sin(w: f64, m: f64) -> f64 {
    w.sin().abs().powf(m).copysign(w.sin())
}

/// The unit icosahedron subdivided `levels` times, in single precision as MuJoCo computes it
/// (the midpoint of an edge, normalised, in `f32`).
fn icosphere(levels: usize) -> Builtin {
    let phi = ((1.0 + 5f64.sqrt()) / 2.0) as f32;
    let norm = (1.0 + f64::from(phi) * f64::from(phi)).sqrt();
    // The twelve corners: cyclic permutations of (±1, ±φ, 0).
    let mut v: Vec<[f32; 3]> = Vec::new();
    for k in 0..3 {
        for (a, b) in [(-1.0, 1.0), (1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
            let mut c = [0.0f32; 3];
            c[k] = a;
            c[(k + 1) % 3] = b * phi;
            v.push(c.map(|x| (f64::from(x) / norm) as f32));
        }
    }
    // Its twenty faces: the triples of mutually neighbouring corners (edge 2/norm), outward.
    let near = |i: usize, j: usize| {
        let d: f32 = (0..3).map(|k| (v[i][k] - v[j][k]).powi(2)).sum();
        (d - (4.0 / (norm * norm)) as f32).abs() < 1e-4
    };
    let mut faces = Vec::new();
    for i in 0..12 {
        for j in i + 1..12 {
            for k in j + 1..12 {
                if near(i, j) && near(j, k) && near(i, k) {
                    faces.push(outward(&v, [i as u32, j as u32, k as u32]));
                }
            }
        }
    }
    for _ in 0..levels {
        let mut middle: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, v: &mut Vec<[f32; 3]>| {
            *middle.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let m = [0, 1, 2].map(|k| (v[a as usize][k] + v[b as usize][k]) / 2.0);
                let n = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
                v.push(m.map(|x| x / n));
                (v.len() - 1) as u32
            })
        };
        let mut finer = Vec::with_capacity(4 * faces.len());
        for [a, b, c] in faces {
            let (ab, bc, ca) = (mid(a, b, &mut v), mid(b, c, &mut v), mid(c, a, &mut v));
            finer.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = finer;
    }
    let vertices = v
        .iter()
        .map(|c| Vector3::new(c[0].into(), c[1].into(), c[2].into()))
        .collect();
    Builtin::Surface(vertices, Some(faces))
}

/// Triangle `t` of vertices `v` (about the origin) turned to face away from it.
fn outward(v: &[[f32; 3]], t: [u32; 3]) -> [u32; 3] {
    let p = t.map(|i| {
        let c = v[i as usize];
        Vector3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]))
    });
    if (p[1] - p[0]).cross(&(p[2] - p[0])).dot(&p[0]) < 0.0 {
        [t[0], t[2], t[1]]
    } else {
        t
    }
}

/// The unit hemisphere above z = 0 in `res + 1` rows: row `r` has `4 (r + 1)` points, each
/// side of the square from the pole to the equator's four points cut into `r + 1` steps and
/// pushed onto the sphere; the rows are joined by triangles and the equator is closed by a fan
/// about the centre.
fn hemisphere(res: usize) -> Builtin {
    const EQUATOR: [[f64; 3]; 4] = [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
    ];
    let pole = Vector3::z();
    let mut v = vec![stored(0.0, 0.0, 1.0)];
    for row in 0..=res {
        let f = (row + 1) as f64 / (res + 1) as f64;
        for side in 0..4 {
            let start = pole + (Vector3::from(EQUATOR[side]) - pole) * f;
            let end = pole + (Vector3::from(EQUATOR[(side + 1) % 4]) - pole) * f;
            let step = (end - start) / (row + 1) as f64;
            for i in 0..=row {
                let p = start + step * i as f64;
                let p = p / p.norm();
                v.push(stored(p.x, p.y, p.z));
            }
        }
    }
    let centre = v.len() as u32;
    v.push(Vector3::zeros());
    let mut faces: Vec<[u32; 3]> = vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]];
    let first = |row: usize| (2 * row * (row + 1) + 1) as u32; // row's first vertex
    for row in 0..res {
        let (here, next) = (first(row), first(row + 1));
        let (n_here, n_next) = (4 * (row + 1) as u32, 4 * (row + 2) as u32);
        for side in 0..4u32 {
            for i in 0..(row + 2) as u32 {
                let a = i + (row as u32 + 1) * side;
                let b = i + (row as u32 + 2) * side;
                faces.push([
                    here + a % n_here,
                    next + b % n_next,
                    next + (b + 1) % n_next,
                ]);
                if i < row as u32 + 1 {
                    faces.push([
                        here + a % n_here,
                        next + (b + 1) % n_next,
                        here + (a + 1) % n_here,
                    ]);
                }
            }
        }
    }
    let (rim, n_rim) = (first(res), 4 * (res + 1) as u32);
    faces.extend((0..n_rim).map(|i| [rim + i, centre, rim + (i + 1) % n_rim]));
    Builtin::Surface(v, Some(faces))
}

/// The superellipsoid `|x|^(2/e) …` as MuJoCo grids it: `res - 1` rings of `res` points
/// between the poles, latitude `v` and longitude `u` through the signed powers `n` and `e`.
fn supersphere(res: usize, e: f64, n: f64) -> Builtin {
    let mut v = vec![stored(0.0, 0.0, -1.0)];
    for i in 1..res {
        let lat = -PI / 2.0 + i as f64 * PI / res as f64;
        for j in 0..res {
            let lon = -PI + j as f64 * 2.0 * PI / res as f64;
            v.push(stored(
                signed_cos(lat, n) * signed_cos(lon, e),
                signed_cos(lat, n) * signed_sin(lon, e),
                signed_sin(lat, n),
            ));
        }
    }
    let north = v.len() as u32;
    v.push(stored(0.0, 0.0, 1.0));
    let r = res as u32;
    let at = |ring: u32, j: u32| 1 + ring * r + j % r;
    let mut faces = Vec::new();
    faces.extend((0..r).map(|j| [0, at(0, j + 1), at(0, j)]));
    for ring in 0..r - 2 {
        for j in 0..r {
            let (a, b, c, d) = (
                at(ring, j),
                at(ring, j + 1),
                at(ring + 1, j + 1),
                at(ring + 1, j),
            );
            faces.extend([[a, b, d], [b, c, d]]);
        }
    }
    faces.extend((0..r).map(|j| [at(r - 2, j), at(r - 2, j + 1), north]));
    Builtin::Surface(v, Some(faces))
}

/// The supertoroid of tube `radius` (about a unit circle) with exponents `s` (the tube) and
/// `t` (round the axis), on a `res × res` grid.
fn supertorus(res: usize, radius: f64, s: f64, t: f64) -> Builtin {
    let mut v = Vec::with_capacity(res * res);
    for i in 0..res {
        let u = 2.0 * PI * i as f64 / res as f64;
        for j in 0..res {
            let w = 2.0 * PI * j as f64 / res as f64;
            let ring = 1.0 + radius * signed_cos(w, s);
            v.push(stored(
                ring * signed_cos(u, t),
                ring * signed_sin(u, t),
                radius * signed_sin(w, s),
            ));
        }
    }
    let r = res as u32;
    let at = |i: u32, j: u32| (i % r) * r + j % r;
    let mut faces = Vec::with_capacity(2 * res * res);
    for i in 0..r {
        for j in 0..r {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            faces.extend([[a, b, d], [b, c, d]]);
        }
    }
    Builtin::Surface(v, Some(faces))
}

/// A cone's vertices: `edges` points round the unit circle at z = -1, and as many round a
/// circle of `radius` at z = 1 (a single apex there when the radius is not positive).
fn cone(edges: usize, radius: f64) -> Builtin {
    let round = |i: usize, r: f64, z: f64| {
        let a = 2.0 * i as f64 * PI / edges as f64;
        stored(r * a.cos(), r * a.sin(), z)
    };
    let mut v: Vec<Vector3<f64>> = (0..edges).map(|i| round(i, 1.0, -1.0)).collect();
    if radius > 0.0 {
        v.extend((edges..2 * edges).map(|i| round(i, radius, 1.0)));
    } else {
        v.push(stored(0.0, 0.0, 1.0));
    }
    Builtin::Surface(v, None)
}

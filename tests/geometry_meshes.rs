//! Mesh files: every kind of bad mesh gives an error naming the file and the problem (never a
//! panic); an inward orientation is fixed with a warning; the bundled scenes with meshes load,
//! and the horseshoe's separation distribution has two modes with no sideways bias.

use crate::common::scene;
use nalgebra::Vector3;
use scm::collision::{separation_band, Collider, SeparationDistribution};
use scm::geometry::mesh::MeshProblem;
use scm::geometry::{Placement, TriMesh};
use std::path::{Path, PathBuf};

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("scm-mesh-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// OBJ text of a unit cube (12 triangles, outward), with triangle `drop` left out and triangles
/// in `flip` reversed.
fn cube_obj(drop: Option<usize>, flip: &[usize]) -> String {
    let mut s = String::new();
    for i in 0..8 {
        s += &format!("v {} {} {}\n", i & 1, (i >> 1) & 1, (i >> 2) & 1);
    }
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let tris: Vec<[usize; 3]> = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    for (k, t) in tris.iter().enumerate() {
        if Some(k) == drop {
            continue;
        }
        let t = if flip.contains(&k) {
            [t[0], t[2], t[1]]
        } else {
            *t
        };
        s += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

fn load(name: &str, text: &[u8]) -> Result<(TriMesh, Vec<String>), scm::geometry::MeshError> {
    let p = tmp(name);
    std::fs::write(&p, text).unwrap();
    TriMesh::load(&p, &Placement::scaled(Vector3::repeat(1.0)))
}

#[test]
fn each_bad_mesh_gives_its_error_naming_the_file() {
    type Case = (&'static str, Vec<u8>, fn(&MeshProblem) -> bool);
    let cases: Vec<Case> = vec![
        ("open.obj", cube_obj(Some(3), &[]).into_bytes(), |p| {
            matches!(p, MeshProblem::Open { count: 3, .. })
        }),
        ("inconsistent.obj", cube_obj(None, &[5]).into_bytes(), |p| {
            matches!(p, MeshProblem::Inconsistent { .. })
        }),
        (
            "degenerate.obj",
            (cube_obj(None, &[]) + "v 0 0 0\nf 1 9 2\n").into_bytes(),
            |p| {
                matches!(
                    p,
                    MeshProblem::Degenerate {
                        count: 1,
                        first: 12
                    }
                )
            },
        ),
        (
            "flat.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 2\n".to_vec(),
            |p| matches!(p, MeshProblem::ZeroVolume(_)),
        ),
        ("empty.obj", b"# nothing\n".to_vec(), |p| {
            matches!(p, MeshProblem::Empty)
        }),
        ("garbage.stl", vec![0xde, 0xad, 0xbe, 0xef, 1, 2, 3], |p| {
            matches!(p, MeshProblem::Parse(_))
        }),
        (
            "truncated.stl",
            {
                let mut b = vec![b' '; 80];
                b.extend(1000u32.to_le_bytes());
                b.extend([0u8; 30]);
                b
            },
            |p| matches!(p, MeshProblem::Parse(_)),
        ),
        ("bad.obj", b"v 0 0 0\nf 1 2 3\n".to_vec(), |p| {
            matches!(p, MeshProblem::Parse(_))
        }),
        ("mesh.ply", b"ply\n".to_vec(), |p| {
            matches!(p, MeshProblem::Format(_))
        }),
    ];
    for (name, bytes, expected) in cases {
        let e = load(name, &bytes)
            .err()
            .unwrap_or_else(|| panic!("{name}: accepted"));
        assert!(expected(&e.problem), "{name}: {e}");
        assert!(
            e.to_string().contains(name),
            "{name}: the message does not name the file: {e}"
        );
        println!("{e}");
    }
    let e = TriMesh::load(
        Path::new("/nonexistent/dir/missing.stl"),
        &Placement::scaled(Vector3::repeat(1.0)),
    )
    .unwrap_err();
    assert!(
        matches!(e.problem, MeshProblem::Missing(_)) && e.to_string().contains("missing.stl"),
        "{e}"
    );
}

#[test]
fn an_inward_mesh_is_flipped_with_a_warning() {
    let all: Vec<usize> = (0..12).collect();
    let (m, warnings) = load("inward.obj", cube_obj(None, &all).as_bytes()).unwrap();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("inward.obj") && warnings[0].contains("flipped"),
        "{warnings:?}"
    );
    assert!((m.mass_properties().volume - 1.0).abs() < 1e-12);
    // A mirroring scale turns it inside out too: fixed silently (the file is fine).
    let p = tmp("cube.obj");
    std::fs::write(&p, cube_obj(None, &[])).unwrap();
    let (m, w) = TriMesh::load(&p, &Placement::scaled(Vector3::new(-2.0, 1.0, 1.0))).unwrap();
    assert!(
        w.is_empty() && (m.mass_properties().volume - 2.0).abs() < 1e-12,
        "{w:?}"
    );
}

#[test]
fn a_scene_names_the_mesh_problem_and_its_line() {
    let dir = tmp("scene");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("open.obj"), cube_obj(Some(0), &[])).unwrap();
    // Weighed by the solid it encloses (inertia="exact"), an open surface is refused.
    let xml = r#"<mujoco>
  <asset>
    <mesh name="m" file="open.obj" inertia="exact"/>
  </asset>
  <worldbody><body><freejoint/><geom type="mesh" mesh="m"/></body></worldbody>
</mujoco>"#;
    let e = scm::scene::load_str(xml, &dir.join("s.xml")).unwrap_err();
    assert_eq!((e.line, e.element.as_str()), (3, "mesh"), "{e}");
    assert!(
        e.message.contains("open.obj") && e.message.contains("not watertight"),
        "{e}"
    );
    let e =
        scm::scene::load_str(&xml.replace("open.obj", "none.obj"), &dir.join("s.xml")).unwrap_err();
    assert!(
        e.message.contains("none.obj") && e.message.contains("cannot read"),
        "{e}"
    );
}

#[test]
fn horseshoe_rests_on_two_separated_modes_without_sideways_bias() {
    let sc = scm::scene::load(&scene("horseshoe")).unwrap();
    let m = &sc.model;
    let (bar, ring) = (
        m.tree.bodies.iter().position(|b| b.name == "bar").unwrap(),
        m.tree.bodies.iter().position(|b| b.name == "ring").unwrap(),
    );
    // The ring lowered until it presses on the bar (bar top at z = 0.02; the tube's lowest
    // facet is r cos 18° = 14.27 mm below the ring's centre), 0.3 mm deep.
    let mut q = m.tree.q0();
    q[2] = 0.02 + 0.015 * (18f64).to_radians().cos() - 0.0003;
    let kin = m.tree.kinematics(&q, &vec![0.0; m.tree.nv]);
    let (ca, cb) = (
        m.colliders[bar].as_ref().unwrap(),
        m.colliders[ring].as_ref().unwrap(),
    );
    let (fa, fb) = (&kin.frames[bar], &kin.frames[ring]);
    // The ε1 each side reads with: the pair's own (its clouds' scales).
    let pair = m.pairs.iter().find(|p| p.a == bar && p.b == ring).unwrap();
    let eps1 = pair.eps1_sides(m.contact.eps1);
    let band = separation_band(ca, fa, cb, fb, eps1, m.contact.eps2);
    let dist = SeparationDistribution::from_band(&band, m.contact.eps2);
    // Weight of the field by the side of x the point is on (world frame).
    let (mut left, mut right, mut middle) = (0.0, 0.0, 0.0);
    for e in &band.entries {
        let (c, f) = if e.side == 0 { (ca, fa) } else { (cb, fb) };
        let Collider::Aopc(s) = c else { unreachable!() };
        let x = (f.rotation * s.bvh().points[e.k as usize] + f.origin).x;
        let w = dist.weight(0, e.phi);
        if x < -0.03 {
            left += w
        } else if x > 0.03 {
            right += w
        } else {
            middle += w
        }
    }
    println!("weight at x < -3 cm: {left}, x > 3 cm: {right}, between: {middle}");
    // Two modes, one at each place the ring crosses the bar (x = ±6 cm), nothing between.
    assert!(
        left > 0.45 && right > 0.45 && middle < 1e-6,
        "{left} {right} {middle}"
    );
    let c = scm::contact::pair_contact(ca, fa, cb, fb, &m.contact);
    // Symmetric contact: the force on the ring is vertical, and at rest it is close to the
    // weight (0.3 kg): the height above was chosen near the resting height.
    let f = c.on_b.force;
    assert!(
        f.z > 0.0 && f.x.abs() < 1e-9 * f.z && f.y.abs() < 1e-9 * f.z,
        "{f:?}"
    );
}

/// MuJoCo's default mesh inertia (`legacy_mass_properties`): for a closed convex mesh, the
/// exact solid's volume, centre and inertia (a box, shifted and turned); independent of how the
/// triangles wind (each pyramid counts positive); for the same box without a face, the five
/// pyramids of the faces it has, from their centroid.
#[test]
fn mujocos_default_mesh_inertia_is_exact_for_a_convex_mesh_and_weighs_open_ones() {
    use scm::geometry::mesh::legacy_mass_properties;
    let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.5);
    let (m, _) = load("legacy.obj", cube_obj(None, &[]).as_bytes()).unwrap();
    let v: Vec<Vector3<f64>> = m
        .vertices
        .iter()
        .map(|p| r * p.component_mul(&Vector3::new(0.3, 0.2, 0.1)) + Vector3::new(1.0, 2.0, 3.0))
        .collect();
    let exact = TriMesh::new("box", v.clone(), m.triangles.clone())
        .unwrap()
        .0
        .mass_properties();
    let legacy = legacy_mass_properties(&v, &m.triangles).unwrap();
    assert!((legacy.volume - exact.volume).abs() < 1e-15, "{legacy:?}");
    assert!((legacy.com - exact.com).norm() < 1e-14);
    assert!((legacy.inertia - exact.inertia).amax() < 1e-16);
    let flipped: Vec<[u32; 3]> = m.triangles.iter().map(|t| [t[0], t[2], t[1]]).collect();
    let turned = legacy_mass_properties(&v, &flipped).unwrap();
    assert!((turned.volume - legacy.volume).abs() < 1e-15);
    assert!((turned.com - legacy.com).norm() < 1e-14);
    assert!((turned.inertia - legacy.inertia).amax() < 1e-16);
    // The unit cube without its face at x = 1 (the last two triangles): the other five faces'
    // centroid is (0.4, 0.5, 0.5); pyramids from it of 0.4/3 (the face at x = 0) and 4 × 0.5/3
    // put the centre of mass at x = (0.4/3 · 0.1 + 4 · 0.5/3 · 0.475) / 0.8 = 0.4125, and the
    // pyramids from there weigh (0.4125 + 4 × 0.5) / 3.
    let (unit, _) = load("unit.obj", cube_obj(None, &[]).as_bytes()).unwrap();
    let open = legacy_mass_properties(&unit.vertices, &unit.triangles[..10]).unwrap();
    assert!((open.volume - 2.4125 / 3.0).abs() < 1e-14, "{open:?}");
    assert!(
        (open.com - Vector3::new(0.4125, 0.5, 0.5)).norm() < 1e-14,
        "{open:?}"
    );
}

/// MuJoCo's binary `.msh` format: a tetrahedron written as MuJoCo writes it (counts, vertices,
/// normals, faces) reads as the same closed mesh; a file whose header or length is wrong, or
/// whose face names a missing vertex, is refused saying so.
#[test]
fn mujocos_msh_format_reads_and_its_errors_are_named() {
    fn msh(counts: [i32; 4], floats: &[f32], faces: &[i32]) -> Vec<u8> {
        let mut b: Vec<u8> = counts.iter().flat_map(|c| c.to_le_bytes()).collect();
        b.extend(floats.iter().flat_map(|f| f.to_le_bytes()));
        b.extend(faces.iter().flat_map(|f| f.to_le_bytes()));
        b
    }
    let vertices = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    let normals = [0.0f32; 12];
    let faces = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3];
    let floats: Vec<f32> = vertices.iter().chain(&normals).copied().collect();
    let (m, _) = load("tet.msh", &msh([4, 4, 0, 4], &floats, &faces)).unwrap();
    assert_eq!((m.vertices.len(), m.triangles.len()), (4, 4));
    assert!((m.mass_properties().volume - 1.0 / 6.0).abs() < 1e-12);
    for (bytes, says) in [
        (vec![1, 2, 3], "header"),
        (msh([4, 3, 0, 4], &floats, &faces), "invalid sizes"),
        (
            msh([4, 4, 0, 4], &floats, &faces[..9]),
            "bytes where its header says",
        ),
        (
            msh([4, 4, 0, 4], &floats, &[0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 9]),
            "face 3",
        ),
    ] {
        let e = load("bad.msh", &bytes).unwrap_err().to_string();
        assert!(e.contains(says), "{says}: {e}");
    }
}

/// An OBJ's polygons of more than three corners are split as MuJoCo splits them where that is
/// known: a quad along its shorter diagonal (here, on a bent quad, the one that is not the fan
/// from the first corner: the enclosed volume tells which), a flat polygon by clipping ears
/// (an L-shaped cap, whose fan from its first corner would reach outside the L: the prism's
/// volume is the L's exactly). A polygon of more corners that is not flat is split into a fan
/// with a note naming the file and the face (counting from 1); a mesh that is refused as open
/// still carries the note (the scene reports it where it weighs the file anyway).
#[test]
fn polygons_are_split_as_mujoco_splits_them_or_noted() {
    // A pyramid whose base is one quad with its third corner raised 0.2: the quad's diagonal
    // from its second corner is the shorter one.
    let pyramid = "v 0 0 0\nv 1 0 0\nv 1 1 0.2\nv 0 1 0\nv 0.5 0.5 1\nf 1 4 3 2\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n";
    let (m, w) = load("quad_bent.obj", pyramid.as_bytes()).unwrap();
    assert!(w.iter().all(|w| !w.contains("polygons")), "{w:?}");
    // Split along corners 1-3 (written 4 and 2): the base's two triangles (0,0,0),(0,1,0),
    // (1,0,0) and (0,1,0),(1,1,0.2),(1,0,0); the solid is the two tetrahedra on them with the
    // apex.
    let tet = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| {
        let (a, b, c, d) = (
            Vector3::from(a),
            Vector3::from(b),
            Vector3::from(c),
            Vector3::new(0.5, 0.5, 1.0),
        );
        ((b - a).cross(&(c - a)).dot(&(d - a)) / 6.0).abs()
    };
    let expected = tet([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
        + tet([0.0, 1.0, 0.0], [1.0, 1.0, 0.2], [1.0, 0.0, 0.0]);
    let volume = m.mass_properties().volume;
    assert!((volume - expected).abs() < 1e-7, "{volume} vs {expected}");
    // An L-shaped prism whose caps are single six-corner polygons, the bottom one written from
    // a corner whose fan would leave the L.
    let l = "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 3 0\nv 0 3 0\nv 0 0 0.5\nv 2 0 0.5\nv 2 1 0.5\nv 1 1 0.5\nv 1 3 0.5\nv 0 3 0.5\nf 3 2 1 6 5 4\nf 7 8 9 10 11 12\nf 1 2 8\nf 1 8 7\nf 2 3 9\nf 2 9 8\nf 3 4 10\nf 3 10 9\nf 4 5 11\nf 4 11 10\nf 5 6 12\nf 5 12 11\nf 6 1 7\nf 6 7 12\n";
    let (m, w) = load("l_caps.obj", l.as_bytes()).unwrap();
    assert!(w.iter().all(|w| !w.contains("polygons")), "{w:?}");
    let volume = m.mass_properties().volume;
    assert!((volume - 2.0).abs() < 1e-12, "{volume}");
    // A pentagonal prism whose top is bent: its top pentagon is noted; open (no bottom), the
    // error carries the note.
    let mut prism = String::new();
    for (k, z) in [(0, 0.0), (1, 1.0)] {
        for i in 0..5 {
            let a = std::f64::consts::TAU * i as f64 / 5.0;
            let bend = if k == 1 && i == 2 { 0.3 } else { 0.0 };
            prism += &format!("v {} {} {}\n", a.cos(), a.sin(), z + bend);
        }
    }
    let sides: String = (0..5)
        .map(|i| {
            let j = (i + 1) % 5;
            format!(
                "f {} {} {}\nf {} {} {}\n",
                i + 1,
                j + 1,
                j + 6,
                i + 1,
                j + 6,
                i + 6
            )
        })
        .collect();
    let closed = format!("{prism}f 5 4 3 2 1\nf 6 7 8 9 10\n{sides}");
    let (_, w) = load("bent_pentagon.obj", closed.as_bytes()).unwrap();
    let note = w.iter().find(|w| w.contains("polygons")).expect("noted");
    assert!(
        note.contains("bent_pentagon.obj") && note.contains("face 2") && note.contains("MuJoCo"),
        "{note}"
    );
    let open = format!("{prism}f 6 7 8 9 10\n{sides}");
    let e = load("bent_pentagon_open.obj", open.as_bytes()).unwrap_err();
    assert!(
        e.notes.iter().any(|n| n.contains("polygons")),
        "{e}: {:?}",
        e.notes
    );
}

/// MuJoCo 4.0.0 reads the faces of an OBJ file's first object only (an `o` or `g` line after
/// faces starts another; a material change does not): of two tetrahedra in two objects, the
/// mesh is the first, with a note naming how many faces were left out; under two materials
/// in one object it is both.
#[test]
fn only_the_first_object_of_an_obj_file_is_read_as_in_mujoco() {
    let tetra = |o: f64| format!("v {o} 0 0\nv {} 0 0\nv {o} 1 0\nv {o} 0 1\n", o + 1.0);
    let faces = |b: usize| {
        [[1, 3, 2], [1, 2, 4], [2, 3, 4], [3, 1, 4]]
            .iter()
            .map(|f| format!("f {} {} {}\n", f[0] + b, f[1] + b, f[2] + b))
            .collect::<String>()
    };
    for (split, kept) in [("o", 4), ("g", 4), ("usemtl", 8)] {
        let text = format!(
            "{split} first\n{}{}{split} second\n{}{}",
            tetra(0.0),
            faces(0),
            tetra(2.0),
            faces(4)
        );
        let name = format!("two_{split}.obj");
        let (mesh, warnings) = load(&name, text.as_bytes()).unwrap();
        assert_eq!(mesh.triangles.len(), kept, "{split}");
        let noted = warnings
            .iter()
            .any(|w| w.contains("more than one object") && w.contains("4 of its 8 faces"));
        assert_eq!(noted, kept == 4, "{split}: {warnings:?}");
    }
}

/// A binary STL of the unit cube of [`cube_obj`] with the given 80-byte header (padded).
fn cube_binary_stl(header: &[u8]) -> Vec<u8> {
    let text = cube_obj(None, &[]);
    let verts: Vec<[f32; 3]> = text
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let c: Vec<f32> = l.split(' ').map(|x| x.parse().unwrap()).collect();
            [c[0], c[1], c[2]]
        })
        .collect();
    let tris: Vec<[usize; 3]> = text
        .lines()
        .filter_map(|l| l.strip_prefix("f "))
        .map(|l| {
            let i: Vec<usize> = l.split(' ').map(|x| x.parse().unwrap()).collect();
            [i[0] - 1, i[1] - 1, i[2] - 1]
        })
        .collect();
    let mut b = header.to_vec();
    b.resize(80, b' ');
    b.extend((tris.len() as u32).to_le_bytes());
    for t in &tris {
        b.extend([0u8; 12]); // the stored normal, which the reader ignores
        for &v in t {
            for c in verts[v] {
                b.extend(c.to_le_bytes());
            }
        }
        b.extend([0u8; 2]);
    }
    b
}

#[test]
fn a_binary_stl_whose_header_begins_with_solid_is_read_as_binary() {
    // Exporters write "solid NAME" into a binary file's header (robosuite's jaco shoulder.stl
    // is one); MuJoCo decides by the size, 84 + 50 n bytes, and so does the reader: the same
    // cube as with a blank header.
    let (plain, _) = load("plain.stl", &cube_binary_stl(b"")).expect("a plain binary STL");
    let header = b"solid cube, exported as binary STL\n";
    let bytes = cube_binary_stl(header);
    assert_eq!(bytes.len(), 84 + 50 * 12);
    let (solid, _) = load("solid.stl", &bytes).expect("a binary STL whose header says solid");
    assert_eq!(solid.vertices, plain.vertices);
    assert_eq!(solid.triangles, plain.triangles);
    assert_eq!(solid.triangles.len(), 12);
    // One byte more and the file is no binary STL: read as ASCII, it is refused with the file.
    let mut longer = bytes.clone();
    longer.push(b'\n');
    let e = load("longer.stl", &longer).expect_err("neither binary nor ASCII");
    assert!(matches!(e.problem, MeshProblem::Parse(_)), "{e}");
}

/// An icosphere of radius `r` (m) whose icosahedron is subdivided `n` times (20·4ⁿ triangles,
/// every vertex on the sphere).
fn icosphere(r: f64, n: u32) -> TriMesh {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<Vector3<f64>> = [
        (-1.0, g, 0.0),
        (1.0, g, 0.0),
        (-1.0, -g, 0.0),
        (1.0, -g, 0.0),
        (0.0, -1.0, g),
        (0.0, 1.0, g),
        (0.0, -1.0, -g),
        (0.0, 1.0, -g),
        (g, 0.0, -1.0),
        (g, 0.0, 1.0),
        (-g, 0.0, -1.0),
        (-g, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vector3::new(x, y, z).normalize() * r)
    .collect();
    let mut t: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..n {
        let mut mid = std::collections::HashMap::new();
        let mut at = |a: u32, b: u32, v: &mut Vec<Vector3<f64>>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push((v[a as usize] + v[b as usize]).normalize() * r);
                v.len() as u32 - 1
            })
        };
        t = t
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (at(a, b, &mut v), at(b, c, &mut v), at(c, a, &mut v));
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    TriMesh::new("icosphere", v, t).expect("a closed sphere").0
}

#[test]
fn a_mesh_finer_than_the_scene_asks_is_sampled_at_the_scenes_spacing() {
    // A 3 cm sphere tessellated at about 1 mm (20,480 triangles), sampled at 1 cm: simplified
    // within 0.05 × 1 cm first (or a halved tolerance, to keep its volume), its triangles now
    // finer than the spacing give one point each: about two thousand points instead of the
    // twenty thousand of its own triangles (sixty thousand when each triangle gave three), and
    // its SSDF near the surface departs from the sphere's signed distance by no more than the
    // sphere primitive sampled at the same spacing does, plus the tolerance: what the scene's
    // spacing costs anyway. Measured (printed): the largest error over 600 points from 2 mm
    // inside to 5 mm outside, at a sharp ε1.
    let r = 0.03;
    let fine = icosphere(r, 5);
    assert_eq!(fine.triangles.len(), 20_480);
    let spacing = 0.01;
    let s = fine.simplified(spacing).expect("a fine sphere simplifies");
    assert!(s.tolerance <= scm::geometry::mesh::SIMPLIFY_TOLERANCE * spacing);
    assert!(
        s.error <= s.tolerance * 1.001,
        "{} > {}",
        s.error,
        s.tolerance
    );
    // The volume guard halves the tolerance until the enclosed volume is kept to 1 %
    // (measured: 0.125 mm, 2,032 triangles left).
    let volume = |m: &TriMesh| m.mass_properties().volume;
    assert!(
        (volume(&s.mesh) / volume(&fine) - 1.0).abs() <= scm::geometry::mesh::SIMPLIFY_VOLUME,
        "volume {} against {}",
        volume(&s.mesh),
        volume(&fine)
    );
    assert!(
        s.mesh.triangles.len() * 8 < fine.triangles.len(),
        "{} triangles left",
        s.mesh.triangles.len()
    );
    // No vertex moved: the simplified mesh's vertices are the file's.
    for v in &s.mesh.vertices {
        assert!((v.norm() - r).abs() < 1e-15, "a vertex off the sphere");
    }
    let (coarse, own) = (fine.sample(spacing), fine.sample_as_is(spacing));
    assert!(
        coarse.len() * 8 < own.len(),
        "{} points against {}",
        coarse.len(),
        own.len()
    );
    // One point per triangle: the surface stays closed and its volume is the mesh's.
    for (cloud, mesh) in [(&coarse, &s.mesh), (&own, &fine)] {
        assert!(cloud.closure_defect().norm() < 1e-15);
        assert!((cloud.enclosed_volume() / volume(mesh) - 1.0).abs() < 1e-12);
    }
    // The same sphere as SCM's primitive, sampled at the same spacing: what the spacing costs.
    let primitive = scm::geometry::Shape::Sphere { radius: r }.sample(spacing);
    let eps1 = 1e-8;
    let mut state = 5u64;
    let mut worst = [0.0f64; 3];
    for _ in 0..600 {
        let mut u = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let dir = Vector3::new(u(), u(), u()).normalize();
        let depth = -0.002 + 0.0035 * (u() + 1.0);
        let p = dir * (r + depth);
        for (k, cloud) in [&coarse, &own, &primitive].into_iter().enumerate() {
            let e = (scm::geometry::ssdf(cloud, &p, eps1) - depth).abs();
            worst[k] = worst[k].max(e);
        }
    }
    println!(
        "SSDF error: simplified {:.3} mm ({} points), own triangles {:.3} mm ({} points), \
         primitive sphere {:.3} mm ({} points)",
        worst[0] * 1e3,
        coarse.len(),
        worst[1] * 1e3,
        own.len(),
        worst[2] * 1e3,
        primitive.len()
    );
    assert!(
        worst[0] <= worst[2] + s.tolerance,
        "simplified {} against the primitive's {} + {}",
        worst[0],
        worst[2],
        s.tolerance
    );
}

#[test]
fn a_thin_plate_simplifies_to_a_closed_surface_or_not_at_all() {
    // A 4 cm × 4 cm plate 1 mm thick, each face tessellated at 1 mm: a collapse could bring
    // its two faces together. What `simplified` gives is a closed, outward surface (the checks
    // of `TriMesh::new`), within its tolerance of the plate's volume, or nothing.
    let (n, half, t) = (40usize, 0.02, 0.0005);
    let mut v = Vec::new();
    let mut tris: Vec<[u32; 3]> = Vec::new();
    // The six faces of a box as grids of n × n, n × 1 quads, welded by coordinates.
    let mut index = std::collections::HashMap::new();
    let mut id = |p: Vector3<f64>, v: &mut Vec<Vector3<f64>>| -> u32 {
        let key = [p.x, p.y, p.z].map(|x| (x * 1e9).round() as i64);
        *index.entry(key).or_insert_with(|| {
            v.push(p);
            v.len() as u32 - 1
        })
    };
    let size = Vector3::new(half, half, t);
    let cells = [n, n, 1];
    for axis in 0..3 {
        let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
        for sign in [-1.0, 1.0] {
            for i in 0..cells[u] {
                for j in 0..cells[w] {
                    let corner = |a: usize, b: usize| {
                        let mut p = Vector3::zeros();
                        p[axis] = sign * size[axis];
                        p[u] = -size[u] + 2.0 * size[u] * a as f64 / cells[u] as f64;
                        p[w] = -size[w] + 2.0 * size[w] * b as f64 / cells[w] as f64;
                        p
                    };
                    let q = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
                        .map(|(a, b)| id(corner(a, b), &mut v));
                    let (q0, q1, q2, q3) = if sign > 0.0 {
                        (q[0], q[1], q[2], q[3])
                    } else {
                        (q[0], q[3], q[2], q[1])
                    };
                    tris.push([q0, q1, q2]);
                    tris.push([q0, q2, q3]);
                }
            }
        }
    }
    let (plate, _) = TriMesh::new("plate", v, tris).expect("a closed plate");
    let volume = plate.mass_properties().volume;
    assert!((volume - 8.0 * half * half * t).abs() < 1e-12);
    for spacing in [0.002, 0.01, 0.03] {
        if let Some(s) = plate.simplified(spacing) {
            let area = 2.0 * (4.0 * half * half + 8.0 * half * t);
            let moved = (s.mesh.mass_properties().volume - volume).abs();
            assert!(
                moved <= area * s.tolerance,
                "spacing {spacing}: the volume moved by {moved}"
            );
            assert!(s.mesh.triangles.len() < plate.triangles.len());
        }
        let cloud = plate.sample(spacing);
        let closure: Vector3<f64> = cloud
            .normals
            .iter()
            .zip(&cloud.areas)
            .map(|(n, a)| n * *a)
            .sum();
        assert!(closure.norm() < 1e-12, "spacing {spacing}: {closure}");
    }
}

/// A CAD-style cylinder: each side segment two slivers the cylinder's length long, each cap a
/// fan of thin triangles from its centre (`segments` around).
fn sliver_cylinder(r: f64, half: f64, segments: u32) -> TriMesh {
    let mut v = vec![Vector3::new(0.0, 0.0, -half), Vector3::new(0.0, 0.0, half)];
    for k in 0..segments {
        let a = std::f64::consts::TAU * k as f64 / segments as f64;
        v.push(Vector3::new(r * a.cos(), r * a.sin(), -half));
        v.push(Vector3::new(r * a.cos(), r * a.sin(), half));
    }
    let mut t = Vec::new();
    for k in 0..segments {
        let (b0, t0) = (2 + 2 * k, 3 + 2 * k);
        let (b1, t1) = (2 + 2 * ((k + 1) % segments), 3 + 2 * ((k + 1) % segments));
        t.push([b0, b1, t1]);
        t.push([b0, t1, t0]);
        t.push([0, b1, b0]);
        t.push([1, t0, t1]);
    }
    TriMesh::new("cylinder", v, t).expect("a closed cylinder").0
}

#[test]
fn a_mesh_of_slivers_is_sampled_in_patches_as_far_apart_as_the_spacing() {
    // A 3 cm cylinder 10 cm long as CAD exports it: 48 slivers 10 cm long and 4 mm wide per
    // side, caps as fans. One point per triangle no longer than the spacing and three quads
    // per longer one put about nine times the points the spacing asks on it (robosuite's
    // Franka links: 2 to 4 times); patches of about the spacing put as many as the spacing
    // asks, never straddle the caps' sharp edges, keep the surface closed, and read distances
    // near the surface as well as SCM's cylinder primitive at the same spacing does.
    let (r, half, spacing) = (0.03, 0.05, 0.01);
    let mesh = sliver_cylinder(r, half, 48);
    let area: f64 = mesh.sample_as_is(spacing).areas.iter().sum();
    let asked = area / (spacing * spacing);
    let (triangles, patches) = (mesh.sample_as_is(spacing), mesh.sample_patches(spacing));
    let primitive = scm::geometry::Shape::Cylinder {
        radius: r,
        half_length: half,
    }
    .sample(spacing);
    println!(
        "area / spacing² {asked:.0}: per triangle {} points, in patches {}, primitive {}",
        triangles.len(),
        patches.len(),
        primitive.len()
    );
    assert!(triangles.len() as f64 > 2.0 * asked);
    assert!(
        (0.75 * asked..=1.25 * asked).contains(&(patches.len() as f64)),
        "{} patches where the spacing asks {asked:.0}",
        patches.len()
    );
    // Closed. The enclosed volume `⅓ Σ p·A` falls short where patches are curved: a patch
    // spanning ±φ of the side counts `sin²φ / φ²` of its pieces' share, `1 - φ²/3`; a patch
    // takes in pieces within 26° of its first, so at most 6.9 % short.
    assert!(patches.closure_defect().norm() < 1e-15);
    let volume = mesh.mass_properties().volume;
    let short = 1.0 - patches.enclosed_volume() / volume;
    println!("enclosed volume {:.2} % short", short * 100.0);
    let phi = scm::geometry::mesh::PATCH_ANGLE_COSINE.acos();
    assert!((0.0..phi * phi / 3.0).contains(&short), "{short}");
    // A patch is on a cap or on the side, never across their edge (whose normals would mix
    // a cap's and the side's, |z| near 0.5; the simplification tilts side triangles by up to
    // a few thousandths, measured 0.0024).
    for n in &patches.normals {
        assert!(
            n.z.abs() > 0.99 || n.z.abs() < 0.01,
            "a patch across an edge: {:?}",
            n.as_slice()
        );
    }
    // The SSDF at a sharp ε1 near the surface (2 mm inside to 5 mm outside, over the side, the
    // caps and their edges) against the mesh's signed distance.
    let mut state = 11u64;
    let mut u = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut worst = [0.0f64; 3];
    for _ in 0..600 {
        let a = std::f64::consts::TAU * u();
        let (rho, z) = if u() < 0.5 {
            (r - 0.002 + 0.007 * u(), half * (2.0 * u() - 1.0))
        } else {
            (r * u().sqrt(), half - 0.002 + 0.007 * u())
        };
        let p = Vector3::new(rho * a.cos(), rho * a.sin(), if u() < 0.5 { z } else { -z });
        let exact = mesh.sdf(&p);
        for (k, cloud) in [&triangles, &patches, &primitive].into_iter().enumerate() {
            let e = (scm::geometry::ssdf(cloud, &p, 1e-8) - exact).abs();
            worst[k] = worst[k].max(e);
        }
    }
    println!(
        "SSDF error (mm): per triangle {:.3}, patches {:.3}, primitive {:.3}",
        worst[0] * 1e3,
        worst[1] * 1e3,
        worst[2] * 1e3
    );
    assert!(
        worst[1] <= worst[2],
        "patches {} against the primitive's {}",
        worst[1],
        worst[2]
    );
}

#[test]
fn a_scene_chooses_patches_or_triangles_for_its_meshes() {
    // A file's mesh in patches by default; `scm_mesh_sampling` = `triangles` samples it
    // triangle by triangle (the horseshoe's ring, to keep its symmetry); another word is
    // refused with its line.
    let dir = tmp("sampling");
    std::fs::create_dir_all(&dir).unwrap();
    let mut obj = String::new();
    let cyl = sliver_cylinder(0.03, 0.05, 48);
    for v in &cyl.vertices {
        obj += &format!("v {} {} {}\n", v.x, v.y, v.z);
    }
    for t in &cyl.triangles {
        obj += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(dir.join("cyl.obj"), obj).unwrap();
    let xml = |setting: &str| {
        format!(
            r#"<mujoco>
  <custom>{setting}</custom>
  <asset><mesh name="m" file="cyl.obj"/></asset>
  <worldbody><geom type="plane" size="1 1 0.1"/>
    <body pos="0 0 0.2"><freejoint/><geom type="mesh" mesh="m"/></body></worldbody>
</mujoco>"#
        )
    };
    let points = |setting: &str| {
        let sc = scm::scene::load_str(&xml(setting), &dir.join("s.xml")).unwrap();
        sc.model
            .colliders
            .iter()
            .flatten()
            .find_map(|c| match c {
                Collider::Aopc(s) => Some(s.len()),
                _ => None,
            })
            .expect("a sampled body")
    };
    let patches = points("");
    let triangles = points(r#"<text name="scm_mesh_sampling" data="triangles"/>"#);
    assert_eq!(
        patches,
        points(r#"<text name="scm_mesh_sampling" data="patches"/>"#)
    );
    assert!(triangles > 2 * patches, "{triangles} against {patches}");
    let e = scm::scene::load_str(
        &xml(r#"<text name="scm_mesh_sampling" data="quads"/>"#),
        &dir.join("s.xml"),
    )
    .unwrap_err();
    assert_eq!(e.line, 2, "{e}");
    assert!(e.message.contains("'quads' must be 'patches'"), "{e}");
}

/// A thin mesh gets at least five points across its thinnest extent when the file sets no
/// spacing (docs/geometry.md, "Thin meshes"): its inertia box's smallest side over
/// `MESH_POINTS_ACROSS`, floored to 0.1 mm; a thick one keeps 1 cm, and a file's own spacing
/// wins. The inertia box is a box's own half-sizes, and a cylinder's `√3/2 r` across.
#[test]
fn a_thin_mesh_is_sampled_with_points_across_it_by_default() {
    use scm::geometry::shapes::MESH_POINTS_ACROSS;
    // A 2 × 4 × 6 cm box's inertia, turned: its half-sizes back, smallest first.
    let (a, b, c) = (0.03, 0.01, 0.02);
    let volume = 8.0 * a * b * c;
    let turn = nalgebra::Rotation3::from_euler_angles(0.3, -0.7, 1.1);
    let diag = nalgebra::Matrix3::from_diagonal(&Vector3::new(
        volume * (b * b + c * c) / 3.0,
        volume * (a * a + c * c) / 3.0,
        volume * (a * a + b * b) / 3.0,
    ));
    let props = scm::geometry::shapes::MassProperties {
        volume,
        com: Vector3::zeros(),
        inertia: turn * diag * turn.transpose(),
    };
    let half = props.inertia_box().unwrap();
    assert!((half - Vector3::new(b, c, a)).amax() < 1e-12, "{half}");
    let dir = tmp("thin");
    std::fs::create_dir_all(&dir).unwrap();
    // The arm 6 cm long and 5.2 cm across: thicker than five spacings of 1 cm.
    for (name, r, half) in [("finger", 0.007, 0.02), ("arm", 0.03, 0.03)] {
        let mut obj = String::new();
        let cyl = sliver_cylinder(r, half, 48);
        for v in &cyl.vertices {
            obj += &format!("v {} {} {}\n", v.x, v.y, v.z);
        }
        for t in &cyl.triangles {
            obj += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
        }
        std::fs::write(dir.join(format!("{name}.obj")), obj).unwrap();
    }
    let scene = |setting: &str| {
        let xml = format!(
            r#"<mujoco>
  <custom>{setting}</custom>
  <asset><mesh name="finger" file="finger.obj"/><mesh name="arm" file="arm.obj"/></asset>
  <worldbody><geom type="plane" size="1 1 0.1"/>
    <body pos="0 0 0.2"><freejoint/><geom name="finger" type="mesh" mesh="finger"/></body>
    <body pos="0.5 0 0.2"><freejoint/><geom name="arm" type="mesh" mesh="arm"/></body></worldbody>
</mujoco>"#
        );
        scm::scene::load_str(&xml, &dir.join("s.xml")).unwrap()
    };
    let spacing = |s: &scm::scene::Scene, name: &str| {
        let g = s.geoms.iter().find(|g| g.name == name).unwrap();
        (g.spacing.unwrap().fine, g.spacing_reason.clone())
    };
    let auto = scene("");
    // The 48-gon's inertia box: 2 × 0.866 × 7 mm across, 12.1 mm: 2.4 mm at five across.
    let (finger, why) = spacing(&auto, "finger");
    assert_eq!(MESH_POINTS_ACROSS, 5.0);
    assert_eq!(finger, 0.0024, "{why}");
    assert!(
        why.contains("thin mesh: 5 points across its 0.0121 m"),
        "{why}"
    );
    let (arm, why) = spacing(&auto, "arm");
    assert_eq!(arm, 0.01, "{why}");
    assert!(why.contains("does not tell"), "{why}");
    let set = scene(r#"<numeric name="scm_spacing" data="0.01"/>"#);
    assert_eq!(spacing(&set, "finger").0, 0.01);
    // A pad on the thin link's body is sampled as finely, so that the body's planes are read
    // with one ε1 (docs/method.md, "ε1 follows the spacing"); a geom with its own spacing keeps
    // it, and a body without a thin mesh keeps 1 cm.
    let xml = r#"<mujoco>
  <custom><numeric name="scm_spacing:own" data="0.008"/></custom>
  <asset><mesh name="finger" file="finger.obj"/><mesh name="arm" file="arm.obj"/></asset>
  <worldbody><geom type="plane" size="1 1 0.1"/>
    <body name="link" pos="0 0 0.2"><freejoint/><geom name="finger" type="mesh" mesh="finger"/>
      <geom name="pad" type="box" size="0.01 0.01 0.003" pos="0 0 0.025"/>
      <geom name="own" type="box" size="0.01 0.01 0.003" pos="0 0 -0.025"/></body>
    <body name="upper" pos="0.5 0 0.2"><freejoint/><geom name="arm" type="mesh" mesh="arm"/>
      <geom name="cap" type="box" size="0.01 0.01 0.003" pos="0 0 0.025"/></body>
    <body name="tray" pos="0 0.8 0.2"><freejoint/><geom name="rim" type="mesh" mesh="finger"/>
      <geom name="slab" type="box" size="0.3 0.3 0.004" pos="0 0 0.03"/></body></worldbody>
</mujoco>"#;
    let s = scm::scene::load_str(xml, &dir.join("pad.xml")).unwrap();
    let (pad, why) = spacing(&s, "pad");
    assert_eq!(pad, 0.0024, "{why}");
    assert!(why.contains("its body's thin mesh 'finger'"), "{why}");
    assert_eq!(spacing(&s, "own").0, 0.008);
    assert_eq!(spacing(&s, "cap").0, 0.01);
    // The link's planes are read with ε1 at its cloud's longest quad (the own box's 8 mm),
    // the upper arm's at the default.
    let eps1 = |body: &str| {
        let b = s
            .model
            .tree
            .bodies
            .iter()
            .position(|x| x.name == body)
            .unwrap();
        let p = s.model.pairs.iter().find(|p| p.a == b || p.b == b).unwrap();
        p.eps1_scale[usize::from(p.b == b)]
    };
    assert!((eps1("link") - 0.64).abs() < 1e-12, "{}", eps1("link"));
    assert_eq!(eps1("upper"), 1.0);
    // A large geom beside a thin mesh keeps its graded grid (at 2.4 mm the 60 cm slab would
    // be 1.3e5 points), and its body's pairs the default ε1.
    let slab = s.geoms.iter().find(|g| g.name == "slab").unwrap();
    let grid = slab.spacing.unwrap();
    assert_eq!(grid.fine, 0.01, "{}", slab.spacing_reason);
    assert!(grid.coarse.max() > 0.01, "{:?}", grid.coarse);
    assert_eq!(eps1("tray"), 1.0);
}

/// The shortcuts of a mesh's signed distance: outside the vertices' bounding box its sign is
/// read without the solid angles, and the distance to that box is a floor of the distance to
/// the mesh (the union sampling skips a geom's triangles where that floor passes its
/// tolerance). On the bundled bracket (concave, 3 mm holes) at points around and inside it:
/// the sign is the winding number's everywhere, and the floor is never above the distance.
#[test]
fn a_meshs_bounding_box_gives_its_sign_outside_and_a_floor_of_its_distance() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("resources/meshes/bracket.stl");
    let (m, _) = TriMesh::load(&path, &Placement::scaled(Vector3::repeat(1.0))).unwrap();
    let (lo, hi) = m.bounds();
    let (centre, extent) = ((lo + hi) / 2.0, hi - lo);
    let mut rng = crate::common::Lcg(12345);
    let (mut outside_box, mut inside_mesh) = (0, 0);
    for _ in 0..600 {
        // Points over a box twice the bounding box's size: a third outside it or so.
        let p = centre + Vector3::from_fn(|k, _| rng.range(-1.0, 1.0) * extent[k]);
        let d = m.sdf(&p);
        let inside = m.winding_number(&p) > 0.5;
        assert_eq!(d < 0.0, inside, "sign at {p:?}: {d}");
        let floor = m.distance_floor(&p);
        assert!(
            floor <= d.abs() * (1.0 + 1e-12),
            "floor {floor} above {d} at {p:?}"
        );
        let out = (0..3).any(|k| p[k] < lo[k] || p[k] > hi[k]);
        assert_eq!(floor > 0.0, out, "floor {floor} at {p:?}");
        outside_box += usize::from(out);
        inside_mesh += usize::from(inside);
    }
    assert!(
        outside_box > 100 && inside_mesh > 10,
        "{outside_box} outside, {inside_mesh} inside"
    );
}

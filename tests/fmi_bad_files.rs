//! Bad files through `fmi2Instantiate` and `fmi2DeSerializeFMUstate`: malformed XML,
//! unsupported or unknown MJCF, out-of-range settings, missing and corrupt meshes, an absent
//! resources folder or scene, a resource URI that is not `file:`, a scene too large to sample;
//! and every truncation and every single-byte corruption of a real serialized state.
//!
//! `fmi2Instantiate` returns NULL with the reason logged (`fmi2Error`, category
//! `logStatusError`, format `"%s"`); `fmi2DeSerializeFMUstate` refuses with the reason and the
//! instance keeps its state. A proptest mutates the bundled scenes at random (deleted, doubled
//! or swapped text, numbers replaced by extreme values): each mutant is refused with a message
//! or loads and steps, never a panic or an abort.

use crate::common::host::{self, Capture};
use proptest::prelude::*;
use scm::fmi::ffi::*;
use scm::*;
use std::ffi::CString;
use std::ptr::null_mut;

/// Instantiates the scene text (with meshes) and returns the instance or the logged error.
fn instantiate_text(tag: &str, text: &str, meshes: &[(String, Vec<u8>)]) -> Result<(), String> {
    let res = host::resources_of(tag, text, meshes);
    let capture = Capture::default();
    let cb = host::callbacks(&capture);
    unsafe {
        let c = host::instantiate(&res, fmi2CoSimulation, &cb);
        if c.is_null() {
            let last = capture.last();
            assert_eq!(last.status, fmi2Error, "{last:?}");
            assert_eq!(last.format, "%s");
            assert_eq!(last.category, "logStatusError");
            assert!(last.message.starts_with("fmi2Instantiate"), "{last:?}");
            return Err(last.message);
        }
        fmi2FreeInstance(c);
    }
    Ok(())
}

fn sphere_drop() -> String {
    std::fs::read_to_string(crate::common::scene("sphere_drop")).unwrap()
}

fn mesh_drop() -> (String, Vec<(String, Vec<u8>)>) {
    let d = scm::pack::describe(&crate::common::scene("mesh_drop")).unwrap();
    (d.scene_text, d.resources)
}

#[test]
fn broken_scenes_are_refused_by_instantiate_with_the_reason() {
    let good = sphere_drop();
    assert_eq!(instantiate_text("good", &good, &[]), Ok(()));
    let cases: Vec<(&str, String, &str)> = vec![
        ("truncated", good[..good.len() / 2].to_string(), "scene.xml"),
        ("not-xml", "this is not XML".into(), "scene.xml"),
        ("empty", String::new(), "scene.xml"),
        (
            "mismatched",
            good.replace("</body>", "</bodyx>"),
            "scene.xml:22",
        ),
        (
            "unknown-element",
            good.replace("<freejoint/>", "<freejoint/><tendon/>"),
            "tendon",
        ),
        (
            "unsupported-geom",
            good.replace("type=\"sphere\"", "type=\"hfield\""),
            "hfield",
        ),
        (
            "unsupported-joint",
            good.replace("<freejoint/>", "<joint type=\"universal\"/>"),
            "universal",
        ),
        (
            "negative-mass",
            good.replace("mass=\"1\"", "mass=\"-1\""),
            "mass",
        ),
        (
            "zero-mass",
            good.replace("mass=\"1\"", "mass=\"0\""),
            "mass",
        ),
        (
            "nan-mass",
            good.replace("mass=\"1\"", "mass=\"nan\""),
            "mass",
        ),
        (
            "negative-radius",
            good.replace("size=\"0.05\"", "size=\"-0.05\""),
            "size",
        ),
        (
            "nan-position",
            good.replace("pos=\"0 0 0.3\"", "pos=\"0 nan 0.3\""),
            "pos",
        ),
        (
            "inf-position",
            good.replace("pos=\"0 0 0.3\"", "pos=\"0 inf 0.3\""),
            "pos",
        ),
        (
            "text-number",
            good.replace("pos=\"0 0 0.3\"", "pos=\"0 zero 0.3\""),
            "pos",
        ),
        (
            "zero-stiffness",
            good.replace("data=\"10000\"", "data=\"0\""),
            "scm_stiffness",
        ),
        (
            "negative-eps1",
            good.replace(
                "name=\"scm_eps1\" data=\"1e-5\"",
                "name=\"scm_eps1\" data=\"-1e-5\"",
            ),
            "scm_eps1",
        ),
        (
            "nan-eps2",
            good.replace(
                "name=\"scm_eps2\" data=\"2e-4\"",
                "name=\"scm_eps2\" data=\"nan\"",
            ),
            "scm_eps2",
        ),
        (
            "zero-timestep",
            good.replace("timestep=\"0.001\"", "timestep=\"0\""),
            "timestep",
        ),
        (
            "negative-timestep",
            good.replace("timestep=\"0.001\"", "timestep=\"-0.001\""),
            "timestep",
        ),
        (
            "unknown-integrator",
            good.replace("data=\"semi_implicit_euler\"", "data=\"leapfrog\""),
            "leapfrog",
        ),
        (
            "unknown-setting",
            good.replace("scm_friction", "scm_fiction"),
            "scm_fiction",
        ),
        // Sampling this would need ~3e13 points (terabytes): refused before any allocation.
        (
            "tiny-spacing",
            good.replace(
                "name=\"scm_spacing\" data=\"0.01\"",
                "name=\"scm_spacing\" data=\"1e-9\"",
            ),
            "AOPC points",
        ),
        (
            "huge-geom",
            good.replace("size=\"0.05\"", "size=\"1000\""),
            "AOPC points",
        ),
    ];
    for (tag, text, expect) in &cases {
        assert_ne!(text, &good, "{tag}: the replacement did not apply");
        let err = instantiate_text(tag, text, &[]).expect_err(tag);
        assert!(
            err.to_lowercase().contains(&expect.to_lowercase()),
            "{tag}: {err:?} should mention {expect:?}"
        );
    }
}

#[test]
fn missing_and_corrupt_meshes_are_refused() {
    let (text, meshes) = mesh_drop();
    assert_eq!(instantiate_text("mesh-good", &text, &meshes), Ok(()));
    let name = meshes[0].0.clone();
    let err = instantiate_text("mesh-missing", &text, &[]).unwrap_err();
    assert!(err.contains("bracket.stl"), "{err}");
    let corrupt: Vec<(String, Vec<u8>)> = vec![
        (name.clone(), b"solid nothing\nendsolid\n".to_vec()),
        (name.clone(), vec![0u8; 84]),
        (name.clone(), meshes[0].1[..meshes[0].1.len() / 2].to_vec()),
        (name.clone(), {
            // A binary STL of one triangle: an open surface.
            let mut b = vec![0u8; 80];
            b.extend(1u32.to_le_bytes());
            for v in [
                [0.0f32, 0.0, 0.0],
                [0.0, 0.0, 1.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
            ] {
                for x in v {
                    b.extend(x.to_le_bytes());
                }
            }
            b.extend([0u8; 2]);
            b
        }),
    ];
    for (k, m) in corrupt.iter().enumerate() {
        let err = instantiate_text(&format!("mesh-corrupt-{k}"), &text, std::slice::from_ref(m))
            .unwrap_err();
        assert!(err.contains("bracket.stl"), "case {k}: {err}");
    }
    // An unknown mesh format.
    let obj = text.replace("bracket.stl", "bracket.ply");
    let err = instantiate_text(
        "mesh-format",
        &obj,
        &[(name.replace(".stl", ".ply"), meshes[0].1.clone())],
    )
    .unwrap_err();
    assert!(err.contains("bracket.ply"), "{err}");
}

#[test]
fn bad_resource_locations_are_refused() {
    let res = host::resources("sphere_drop");
    let capture = Capture::default();
    let cb = host::callbacks(&capture);
    let missing = CString::new(format!("file://{}/nowhere/resources", res.dir.display())).unwrap();
    let uris: Vec<(CString, &str)> = vec![
        (missing, "nowhere"),
        (c"http://example.com/resources".into(), "http"),
        (c"ftp:///tmp/resources".into(), "ftp"),
        (c"resources".into(), "resources"),
        (c"".into(), "not a file: URI"),
        (c"file://remote-host/tmp/resources".into(), "remote-host"),
        (c"file:///tmp/%zz".into(), "%zz"),
    ];
    for (uri, expect) in &uris {
        unsafe {
            let c = scm::fmi2Instantiate(
                c"t".as_ptr(),
                fmi2CoSimulation,
                res.guid.as_ptr(),
                uri.as_ptr(),
                &cb,
                0,
                0,
            );
            assert!(c.is_null(), "{uri:?} accepted");
        }
        let last = capture.last();
        assert_eq!(last.status, fmi2Error);
        assert!(last.message.contains(expect), "{uri:?}: {last:?}");
    }
    // A folder without the scene.
    let empty = std::env::temp_dir()
        .join(format!("scm-empty-{}", std::process::id()))
        .join("resources");
    std::fs::create_dir_all(&empty).unwrap();
    let uri = CString::new(format!("file://{}", empty.display())).unwrap();
    unsafe {
        assert!(scm::fmi2Instantiate(
            c"t".as_ptr(),
            fmi2CoSimulation,
            res.guid.as_ptr(),
            uri.as_ptr(),
            &cb,
            0,
            0
        )
        .is_null());
    }
    assert!(
        capture.last().message.contains("scene.xml"),
        "{:?}",
        capture.last()
    );
    // The GUID of another scene.
    let other = host::resources("sphere_pair");
    unsafe {
        assert!(scm::fmi2Instantiate(
            c"t".as_ptr(),
            fmi2CoSimulation,
            other.guid.as_ptr(),
            res.uri.as_ptr(),
            &cb,
            0,
            0
        )
        .is_null());
    }
    assert!(
        capture
            .last()
            .message
            .contains(other.guid.to_str().unwrap()),
        "{:?}",
        capture.last()
    );
    let _ = std::fs::remove_dir_all(empty.parent().unwrap());
}

/// Every prefix of a serialized state, and every byte XORed with 0x01, 0x80 or 0xff,
/// is refused with a message, and the instance keeps its state.
#[test]
fn every_truncation_and_corruption_of_a_serialized_state_is_refused() {
    for scene in ["sphere_drop", "arm_push"] {
        let res = host::resources(scene);
        let capture = Capture::default();
        let cb = host::callbacks(&capture);
        unsafe {
            let c = host::instantiate(&res, fmi2CoSimulation, &cb);
            assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
            assert_eq!(fmi2ExitInitializationMode(c), fmi2OK);
            for k in 0..3 {
                assert_eq!(fmi2DoStep(c, k as f64 * 0.002, 0.002, 1), fmi2OK);
            }
            let bytes = host::serialize_current(c);
            let size = bytes.len();
            assert_eq!(fmi2DoStep(c, 0.006, 0.002, 1), fmi2OK);
            let nvars = scm::sim::Simulation::from_file(&crate::common::scene(scene))
                .unwrap()
                .rows()
                .len() as u32;
            let read = |c| -> Vec<u64> {
                (0..nvars)
                    .map(|vr| {
                        let mut v = 0.0;
                        fmi2GetReal(c, &vr, 1, &mut v);
                        v.to_bits()
                    })
                    .collect()
            };
            let before = read(c);
            let refuse = |b: &[u8], what: &str| {
                let mut back = null_mut();
                let n = capture.len();
                assert_eq!(
                    fmi2DeSerializeFMUstate(c, b.as_ptr().cast(), b.len(), &mut back),
                    fmi2Error,
                    "{scene}: {what} accepted"
                );
                assert!(back.is_null());
                let said = capture.since(n);
                assert!(
                    said.iter().any(|l| l.status == fmi2Error
                        && l.message.contains("fmi2DeSerializeFMUstate")
                        && l.message.len() > 30),
                    "{what}: {said:?}"
                );
            };
            for len in 0..size {
                refuse(&bytes[..len], &format!("truncation to {len} bytes"));
            }
            for i in 0..size {
                for mask in [0x01u8, 0x80, 0xff] {
                    let mut b = bytes.clone();
                    b[i] ^= mask;
                    refuse(&b, &format!("byte {i} ^ {mask:#x}"));
                }
            }
            let mut longer = bytes.clone();
            longer.push(0);
            refuse(&longer, "an extra byte");
            assert_eq!(
                read(c),
                before,
                "{scene}: a refused state changed the instance"
            );
            // The intact bytes restore the saved state.
            let mut back = null_mut();
            assert_eq!(
                fmi2DeSerializeFMUstate(c, bytes.as_ptr().cast(), size, &mut back),
                fmi2OK
            );
            assert_eq!(fmi2SetFMUstate(c, back), fmi2OK);
            let mut t = 0.0;
            assert_eq!(fmi2GetReal(c, &0, 1, &mut t), fmi2OK);
            assert_eq!(t, 0.006);
            fmi2FreeInstance(c);
        }
    }
}

/// A mutation of a scene's text.
#[derive(Clone, Debug)]
enum Mutation {
    /// Deletes `len` bytes at `at` (both modulo the length).
    Delete { at: usize, len: usize },
    /// Doubles the line at `line`.
    DoubleLine { line: usize },
    /// Swaps two lines.
    SwapLines { a: usize, b: usize },
    /// Replaces the `k`-th number in the text by `value`.
    Number { k: usize, value: &'static str },
    /// Replaces the `k`-th attribute value or tag name by `word`.
    Word { k: usize, word: &'static str },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 1usize..40).prop_map(|(at, len)| Mutation::Delete { at, len }),
        any::<usize>().prop_map(|line| Mutation::DoubleLine { line }),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapLines { a, b }),
        (
            any::<usize>(),
            prop::sample::select(vec![
                "0",
                "-0",
                "-1",
                "1e300",
                "-1e300",
                "1e-300",
                "nan",
                "inf",
                "-inf",
                "1e9",
                "1e-9",
                "100000",
                "2",
                "0.5",
                "",
                "x",
                "1 2",
                "1e5 1e5 1e5"
            ])
        )
            .prop_map(|(k, value)| Mutation::Number { k, value }),
        (
            any::<usize>(),
            prop::sample::select(vec![
                "", "body", "geom", "joint", "mesh", "tendon", "free", "ball", "hinge", "slide",
                "box", "plane", "sphere", "capsule", "world", "true", "x y z", "\"", "<", "&amp;",
                "&bogus;"
            ])
        )
            .prop_map(|(k, word)| Mutation::Word { k, word }),
    ]
}

/// Spans of numbers (digits with sign, dot, exponent) in `text`.
fn numbers(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_digit() {
            let mut s = i;
            if s > 0 && (b[s - 1] == b'-' || b[s - 1] == b'.') {
                s -= 1;
            }
            let mut e = i;
            while e < b.len()
                && (b[e].is_ascii_digit()
                    || b[e] == b'.'
                    || b[e] == b'e'
                    || ((b[e] == b'-' || b[e] == b'+') && b[e - 1] == b'e'))
            {
                e += 1;
            }
            out.push((s, e));
            i = e;
        } else {
            i += 1;
        }
    }
    out
}

/// Spans of words that are attribute values or tag names.
fn words(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    for (i, &c) in b.iter().enumerate() {
        if c == b'"' || c == b'<' {
            let s = i + 1;
            let e = (s..b.len())
                .find(|&j| !(b[j].is_ascii_alphanumeric() || b[j] == b'_'))
                .unwrap_or(b.len());
            if e > s {
                out.push((s, e));
            }
        }
    }
    out
}

fn apply(text: &str, m: &Mutation) -> String {
    let lines: Vec<&str> = text.lines().collect();
    match *m {
        Mutation::Delete { at, len } => {
            let at = at % text.len();
            let end = (at + len).min(text.len());
            let (at, end) = (
                (0..=at).rev().find(|&i| text.is_char_boundary(i)).unwrap(),
                (end..=text.len())
                    .find(|&i| text.is_char_boundary(i))
                    .unwrap(),
            );
            format!("{}{}", &text[..at], &text[end..])
        }
        Mutation::DoubleLine { line } => {
            let l = line % lines.len();
            let mut v = lines.clone();
            v.insert(l, lines[l]);
            v.join("\n")
        }
        Mutation::SwapLines { a, b } => {
            let mut v = lines.clone();
            v.swap(a % lines.len(), b % lines.len());
            v.join("\n")
        }
        Mutation::Number { k, value } => {
            let spans = numbers(text);
            let (s, e) = spans[k % spans.len()];
            format!("{}{}{}", &text[..s], value, &text[e..])
        }
        Mutation::Word { k, word } => {
            let spans = words(text);
            let (s, e) = spans[k % spans.len()];
            format!("{}{}{}", &text[..s], word, &text[e..])
        }
    }
}

/// The scenes the mutation fuzz uses, with their meshes (`scm pack` layout).
type SceneFiles = (String, Vec<(String, Vec<u8>)>);

fn mutable_scenes() -> &'static [SceneFiles] {
    static S: std::sync::OnceLock<Vec<SceneFiles>> = std::sync::OnceLock::new();
    S.get_or_init(|| {
        [
            "sphere_drop",
            "sphere_pair",
            "box_stack",
            "arm_push",
            "mocap_push",
            "mesh_drop",
        ]
        .iter()
        .map(|n| {
            let d = scm::pack::describe(&crate::common::scene(n)).unwrap();
            (d.scene_text, d.resources)
        })
        .collect()
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 3000, max_shrink_iters: 500, failure_persistence: None, ..ProptestConfig::default() })]

    /// A mutated scene is refused by `fmi2Instantiate` with a logged reason, or it loads, and
    /// then initialization and a few steps return a status (never a panic: `fmi2Fatal`).
    #[test]
    fn mutated_scenes_are_refused_or_run(scene in 0usize..6, mutations in proptest::collection::vec(mutation(), 1..4)) {
        let (text, meshes) = &mutable_scenes()[scene];
        let mut t = text.clone();
        for m in &mutations {
            if !t.is_empty() {
                t = apply(&t, m);
            }
        }
        let dir = std::env::temp_dir().join(format!("scm-mutant-{}-{:?}", std::process::id(), std::thread::current().id())).join("resources");
        let _ = std::fs::remove_dir_all(&dir);
        for (file, bytes) in meshes {
            let path = dir.join(file);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(path, bytes).unwrap();
        }
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(scm::sim::SCENE_FILE), &t).unwrap();
        let uri = CString::new(format!("file://{}", dir.display())).unwrap();
        let guid = CString::new(scm::sim::guid(&t)).unwrap();
        let capture = Capture::default();
        let cb = host::callbacks(&capture);
        unsafe {
            let c = scm::fmi2Instantiate(c"mutant".as_ptr(), fmi2CoSimulation, guid.as_ptr(), uri.as_ptr(), &cb, 0, 0);
            if c.is_null() {
                let last = capture.last();
                prop_assert_eq!(last.status, fmi2Error);
                prop_assert!(last.message.len() > 20, "{:?}", last);
                return Ok(());
            }
            let mut statuses = vec![fmi2EnterInitializationMode(c), fmi2ExitInitializationMode(c)];
            if statuses[1] == fmi2OK {
                for k in 0..3 {
                    statuses.push(fmi2DoStep(c, k as f64 * 0.002, 0.002, 1));
                }
            }
            let mut v = 0.0;
            statuses.push(fmi2GetReal(c, &0, 1, &mut v));
            prop_assert!(!statuses.contains(&fmi2Fatal), "{:?}: {:?}", statuses, capture.last());
            for s in &statuses {
                if *s == fmi2Error || *s == fmi2Discard {
                    prop_assert!(capture.all().iter().any(|l| l.status == *s && !l.message.is_empty()));
                }
            }
            fmi2FreeInstance(c);
        }
    }
}

//! The generated `modelDescription.xml` of every bundled scene equals the golden copy checked in
//! under `modelDescription/`, so any change of an FMU's interface shows in review.
//!
//! After a deliberate change, regenerate the goldens with
//! `SCM_BLESS=1 cargo test --release golden_model_description` and commit them.

use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn every_bundled_scene_matches_its_golden_model_description() {
    let bless = std::env::var_os("SCM_BLESS").is_some();
    let golden_dir = root().join("modelDescription");
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(root().join("resources/scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "xml"))
        .collect();
    scenes.sort();
    assert!(!scenes.is_empty());
    let mut stale = Vec::new();
    for scene in &scenes {
        let name = scene.file_stem().unwrap().to_string_lossy().into_owned();
        let generated = scm::pack::describe(scene)
            .unwrap_or_else(|e| panic!("{}: {e}", scene.display()))
            .model_description;
        let golden = golden_dir.join(format!("{name}.xml"));
        if bless {
            std::fs::create_dir_all(&golden_dir).unwrap();
            std::fs::write(&golden, &generated).unwrap();
            continue;
        }
        match std::fs::read_to_string(&golden) {
            Ok(g) if g == generated => {}
            Ok(g) => {
                let line = g
                    .lines()
                    .zip(generated.lines())
                    .position(|(a, b)| a != b)
                    .map_or(g.lines().count().min(generated.lines().count()), |i| i)
                    + 1;
                stale.push(format!(
                    "{name}: differs from {} from line {line}",
                    golden.display()
                ));
            }
            Err(_) => stale.push(format!("{name}: no golden file {}", golden.display())),
        }
    }
    // Goldens of scenes that no longer exist are stale too.
    if let Ok(entries) = std::fs::read_dir(&golden_dir) {
        for e in entries {
            let p = e.unwrap().path();
            let stem = p.file_stem().unwrap().to_string_lossy().into_owned();
            if !scenes
                .iter()
                .any(|s| s.file_stem().unwrap().to_string_lossy() == stem)
            {
                stale.push(format!(
                    "{}: no scene resources/scenes/{stem}.xml",
                    p.display()
                ));
            }
        }
    }
    assert!(stale.is_empty(), "modelDescription.xml changed:\n  {}\nIf the change is deliberate: SCM_BLESS=1 cargo test --release golden_model_description", stale.join("\n  "));
}

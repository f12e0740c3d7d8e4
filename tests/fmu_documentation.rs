//! `documentation/index.html` of every bundled scene's FMU: well-formed (parsed as XML), and it
//! lists the scene's bodies, joints, actuators, every variable with its unit, the parameters
//! with their meaning, and the integrator.

use quick_xml::events::Event;
use quick_xml::Reader;
use scm::fmi::contract::VarType;
use std::io::Read;

/// The text content of an (X)HTML page, failing on malformed markup.
fn text_of(html: &str) -> String {
    let mut reader = Reader::from_str(html);
    let mut text = String::new();
    let mut depth = 0i32;
    loop {
        match reader.read_event() {
            Ok(Event::Start(_)) => depth += 1,
            Ok(Event::End(_)) => depth -= 1,
            Ok(Event::Text(t)) => {
                let raw: &str = t.as_ref();
                text.push_str(raw);
                text.push(' ');
            }
            Ok(Event::GeneralRef(r)) => text.push_str(match AsRef::<str>::as_ref(&r) {
                "lt" => "<",
                "gt" => ">",
                "amp" => "&",
                "quot" => "\"",
                _ => "'",
            }),
            Ok(Event::Eof) => break,
            Ok(_) => {}
            Err(e) => panic!(
                "malformed documentation at byte {}: {e}",
                reader.buffer_position()
            ),
        }
    }
    assert_eq!(depth, 0, "unbalanced elements");
    text
}

#[test]
fn every_fmu_documents_its_scene() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("resources/scenes");
    let mut scenes: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    scenes.sort();
    for path in scenes {
        let d = scm::pack::describe(&path).unwrap();
        let text = text_of(&d.documentation);
        let scene = scm::scene::load(&path).unwrap();
        let sim = scm::sim::Simulation::from_file(&path).unwrap();
        let name = path.display();
        for b in &scene.model.tree.bodies {
            assert!(text.contains(&b.name), "{name}: body {}", b.name);
        }
        for j in &scene.model.tree.joints {
            assert!(text.contains(&j.name), "{name}: joint {}", j.name);
        }
        for a in &scene.model.actuators {
            assert!(
                text.contains(&format!("{}.ctrl", a.name)),
                "{name}: actuator {}",
                a.name
            );
        }
        for (v, _) in sim.rows() {
            assert!(text.contains(&v.name), "{name}: variable {}", v.name);
            if let VarType::Real { unit: Some(u), .. } = v.var_type {
                assert!(
                    text.contains(&format!("{} {} ", v.name, v.value_reference))
                        && text.contains(u),
                    "{name}: {} with its unit {u}",
                    v.name
                );
            }
        }
        for p in scm::sim::Param::ALL {
            let (pname, _, meaning) = p.describe();
            assert!(
                text.contains(&format!("scm.{pname}")) && text.contains(meaning),
                "{name}: parameter {pname} and its meaning"
            );
        }
        assert!(
            text.contains(scene.model.integrator.name()),
            "{name}: integrator"
        );
    }
}

#[test]
fn the_fmu_carries_its_documentation() {
    let dir = std::env::temp_dir().join(format!("scm-doc-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let lib = dir.join("lib.so");
    std::fs::write(&lib, b"not loaded").unwrap();
    let scene = crate::common::scene("t_push");
    let fmu = dir.join("t_push.fmu");
    scm::pack::pack(&scene, &lib, &fmu).unwrap();
    let mut archive = zip::ZipArchive::new(std::fs::File::open(&fmu).unwrap()).unwrap();
    let mut html = String::new();
    archive
        .by_name("documentation/index.html")
        .unwrap()
        .read_to_string(&mut html)
        .unwrap();
    assert_eq!(html, scm::pack::describe(&scene).unwrap().documentation);
    let _ = std::fs::remove_dir_all(&dir);
}

//! The crate's layers, checked on its source: the engine (geometry, collision, contact,
//! dynamics, model, integration, derivatives) imports nothing from scene loading, the
//! simulation's variable table, FMI or packing; scene loading imports only the engine; and the
//! modules' imports form no cycle. A `crate::module` path in code (comments aside) is an import.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The engine: the paper's pipeline and its derivatives.
const ENGINE: &[&str] = &[
    "scalar",
    "autodiff",
    "linalg",
    "geometry",
    "collision",
    "contact",
    "dynamics",
    "model",
    "integrator",
    "integrate",
    "derivatives",
];

/// What each layer above the engine may import (besides the engine and itself).
const ABOVE: &[(&str, &[&str])] = &[
    ("scene", &[]),
    ("fmi", &[]),
    ("sim", &["scene", "fmi"]),
    ("pack", &["scene", "fmi", "sim"]),
];

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// Module → the other top-level modules it names in code.
fn imports() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in files {
        let rel = f.strip_prefix(&src).unwrap();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        // The crate root and the command line sit on top of everything.
        if first == "lib.rs" || first == "bin" {
            continue;
        }
        let module = first.trim_end_matches(".rs").to_string();
        let text = std::fs::read_to_string(&f).unwrap();
        let entry = graph.entry(module.clone()).or_default();
        for line in text.lines() {
            let code = line.split("//").next().unwrap();
            for (i, _) in code.match_indices("crate::") {
                let name: String = code[i + 7..]
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                // `$crate::` in the FMI export macro names the macro's own crate items.
                let macro_path = code[..i].ends_with('$');
                if !name.is_empty() && name != module && !macro_path {
                    entry.insert(name);
                }
            }
        }
    }
    graph
}

#[test]
fn engine_imports_only_the_engine() {
    let graph = imports();
    for m in ENGINE {
        let deps = graph
            .get(*m)
            .unwrap_or_else(|| panic!("engine module {m} not found in src/"));
        let outside: Vec<&String> = deps
            .iter()
            .filter(|d| !ENGINE.contains(&d.as_str()))
            .collect();
        assert!(outside.is_empty(), "engine module {m} imports {outside:?}");
    }
}

#[test]
fn layers_above_the_engine_import_downwards() {
    let graph = imports();
    for (m, allowed) in ABOVE {
        let deps = &graph[*m];
        let wrong: Vec<&String> = deps
            .iter()
            .filter(|d| !ENGINE.contains(&d.as_str()) && !allowed.contains(&d.as_str()))
            .collect();
        assert!(wrong.is_empty(), "{m} imports {wrong:?}, above its layer");
    }
    // Every module is placed in a layer, so a new one cannot slip past these checks.
    for m in graph.keys() {
        assert!(
            ENGINE.contains(&m.as_str()) || ABOVE.iter().any(|(a, _)| a == m),
            "module {m} is in no layer: add it to tests/layers.rs"
        );
    }
}

#[test]
fn no_import_cycle() {
    let graph = imports();
    // Depth-first search with colours; a grey node reached again closes a cycle.
    fn visit<'a>(
        m: &'a str,
        graph: &'a BTreeMap<String, BTreeSet<String>>,
        colour: &mut BTreeMap<&'a str, u8>,
        path: &mut Vec<&'a str>,
    ) {
        match colour.get(m) {
            Some(2) => return,
            Some(1) => {
                let start = path.iter().position(|p| *p == m).unwrap();
                panic!("import cycle: {} -> {m}", path[start..].join(" -> "));
            }
            _ => {}
        }
        colour.insert(m, 1);
        path.push(m);
        for d in graph.get(m).into_iter().flatten() {
            visit(d, graph, colour, path);
        }
        path.pop();
        colour.insert(m, 2);
    }
    let mut colour = BTreeMap::new();
    for m in graph.keys() {
        visit(m, &graph, &mut colour, &mut Vec::new());
    }
}

/// docs/layout.md names every source file, folder by folder: under a heading `` ### `src/x/` ``
/// a table whose rows begin with each file's path within that folder (`` | `shapes.rs` | ``,
/// `` | `mesh/read.rs` | ``), a file under the deepest folder that has a heading. A file added
/// without a word on what it holds fails here, and so does a row of a file that is gone.
#[test]
fn the_layout_doc_names_every_source_file() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = std::fs::read_to_string(root.join("docs/layout.md")).unwrap();
    // The listed files, by full path: each section's folder joined with its rows' first cells.
    let mut listed = BTreeSet::new();
    let mut folder: Option<String> = None;
    for line in doc.lines() {
        if let Some(heading) = line.strip_prefix("### `") {
            folder = heading
                .split('`')
                .next()
                .filter(|f| f.starts_with("src/"))
                .map(str::to_string);
        } else if line.starts_with("## ") {
            folder = None;
        } else if let (Some(f), Some(row)) = (&folder, line.strip_prefix("| `")) {
            let file = row.split('`').next().unwrap();
            if file.ends_with(".rs") {
                listed.insert(format!("{f}{file}"));
            }
        }
    }
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    let present: BTreeSet<String> = files
        .iter()
        .map(|f| {
            let rel = f.strip_prefix(root).unwrap().to_string_lossy();
            rel.replace('\\', "/")
        })
        .collect();
    let unnamed: Vec<&String> = present.difference(&listed).collect();
    let gone: Vec<&String> = listed.difference(&present).collect();
    assert!(
        unnamed.is_empty() && gone.is_empty(),
        "docs/layout.md does not name {unnamed:?}, and names {gone:?} that are not in src/"
    );
}

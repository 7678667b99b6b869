//! docs/DESIGN.md names every module of the three crates: each source
//! file's module (a `mod.rs` by its folder), as a backticked name or path
//! component, so the layout it describes is the code's.

use std::collections::BTreeSet;
use std::path::Path;

/// The `.rs` files under `dir`, test modules (`tests.rs`, `tests/`) left out.
fn sources(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if p.is_dir() && name != "tests" {
            sources(&p, out);
        } else if name.ends_with(".rs") && name != "tests.rs" {
            out.push(p);
        }
    }
}

#[test]
fn the_design_doc_names_every_module() {
    let design = std::fs::read_to_string("docs/DESIGN.md").unwrap();
    // every path component of every backticked span: `train/`, `colmap_io/`, `mod.rs`, `nerf_train::run::Run`
    let named: BTreeSet<&str> = design
        .split('`')
        .skip(1)
        .step_by(2)
        .flat_map(|span| span.split(['/', ':', ' ', '(', ')', ',']))
        .map(|c| c.strip_suffix(".rs").unwrap_or(c))
        .collect();
    let mut files = Vec::new();
    for root in ["nerf-train/src", "nerf-infer/src", "src"] {
        sources(Path::new(root), &mut files);
    }
    assert!(files.len() > 100, "{} source files", files.len());
    let missing: Vec<String> = files
        .iter()
        .filter_map(|f| {
            let stem = f.file_stem().unwrap().to_string_lossy();
            let module = match &*stem {
                "lib" | "main" => return None,
                "mod" => f.parent().unwrap().file_name().unwrap().to_string_lossy(),
                _ => stem,
            };
            (!named.contains(&*module)).then(|| f.display().to_string())
        })
        .collect();
    assert!(missing.is_empty(), "docs/DESIGN.md does not name these modules: {missing:?}");
}

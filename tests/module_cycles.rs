//! No import cycle between modules, in `nerf-infer` and `nerf-train`: among
//! the modules of one parent (the crate's top-level stages, or the files of
//! one folder), if module A uses something in module B (directly or in a
//! module inside B), nothing in B uses A, nor through a chain of siblings.
//! A child using its parent (or an ancestor) is not a cycle, nor a parent
//! using its child. Test modules are left out.
//!
//! References are the `crate::`, `super::` and `self::` paths in the code
//! (comments and string literals skipped), resolved to the longest module
//! path they start with.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

type Module = Vec<String>;

/// `text` without comments, string literals and `#[cfg(test)]` items to
/// the end of the file (the crates keep their test modules last).
fn code(text: &str) -> String {
    let text = match text.find("#[cfg(test)]") {
        Some(i) => &text[..i],
        None => text,
    };
    let (mut out, b) = (String::new(), text.as_bytes());
    let mut i = 0;
    while i < b.len() {
        if text[i..].starts_with("//") {
            i += text[i..].find('\n').unwrap_or(text.len() - i);
        } else if b[i] == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if text[i..].starts_with("'\"'") {
            i += 3;
        } else {
            let c = text[i..].chars().next().unwrap();
            out.push(c);
            i += c.len_utf8();
        }
    }
    out
}

/// Every module file of the crate at `src`, by module path, with its code.
fn modules(src: &Path) -> BTreeMap<Module, String> {
    let mut out = BTreeMap::new();
    let mut todo = vec![src.to_path_buf()];
    while let Some(dir) = todo.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
                continue;
            }
            if p.extension().is_none_or(|x| x != "rs") {
                continue;
            }
            let rel = p.strip_prefix(src).unwrap().with_extension("");
            let mut m: Module = rel.iter().map(|s| s.to_string_lossy().into_owned()).collect();
            if matches!(m.last().map(String::as_str), Some("mod" | "lib" | "main")) {
                m.pop();
            }
            if m.iter().any(|s| s == "tests") {
                continue;
            }
            out.insert(m, code(&std::fs::read_to_string(&p).unwrap()));
        }
    }
    out
}

fn ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The module paths `code` of module `m` refers to (`crate::a::b::Item`,
/// `super::x`, `self::y`, and the items of a `{...}` group), resolved
/// against `m` but not yet to a module.
fn references(m: &Module, code: &str) -> Vec<Module> {
    let mut out = Vec::new();
    for key in ["crate::", "super::", "self::"] {
        for (i, _) in code.match_indices(key) {
            // (the second `super` of `super::super::` is part of the first's path)
            if code[..i].ends_with(|c: char| ident(c) || c == ':') {
                continue;
            }
            let mut base = match key {
                "crate::" => Vec::new(),
                "self::" => m.clone(),
                _ => m[..m.len().saturating_sub(1)].to_vec(),
            };
            path(&code[i + key.len()..], &mut base, &mut out);
        }
    }
    out
}

/// Follows the path segments at the start of `rest` from `base` and adds
/// the module path they name to `out` (each item of a `{...}` group too).
fn path(rest: &str, base: &mut Module, out: &mut Vec<Module>) {
    let mut rest = rest;
    loop {
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for item in group[..end].split(',') {
                path(item.trim(), &mut base.clone(), out);
            }
            return;
        }
        let seg: String = rest.chars().take_while(|&c| ident(c)).collect();
        if seg.is_empty() {
            break;
        }
        if seg == "super" {
            base.pop();
        } else {
            base.push(seg.clone());
        }
        match rest[seg.len()..].strip_prefix("::") {
            Some(r) => rest = r,
            None => break,
        }
    }
    out.push(base.clone());
}

/// Cycles among siblings, each as the module paths around it.
fn cycles(src: &Path) -> Vec<String> {
    let mods = modules(src);
    // parent -> sibling -> siblings it uses
    let mut graph: BTreeMap<Module, BTreeMap<String, BTreeSet<String>>> = BTreeMap::new();
    for (m, text) in &mods {
        for r in references(m, text) {
            // the longest module path `r` starts with
            let Some(target) = (0..=r.len()).rev().map(|n| r[..n].to_vec()).find(|p| mods.contains_key(p)) else {
                continue;
            };
            let common = m.iter().zip(&target).take_while(|(a, b)| a == b).count();
            if common < m.len() && common < target.len() {
                let parent = m[..common].to_vec();
                let e = graph.entry(parent).or_default().entry(m[common].clone()).or_default();
                e.insert(target[common].clone());
            }
        }
    }
    let mut found = Vec::new();
    for (parent, g) in &graph {
        // depth-first search for a back edge
        fn visit(
            n: &str,
            g: &BTreeMap<String, BTreeSet<String>>,
            stack: &mut Vec<String>,
            done: &mut BTreeSet<String>,
            found: &mut Vec<Vec<String>>,
        ) {
            if let Some(k) = stack.iter().position(|s| s == n) {
                let mut c = stack[k..].to_vec();
                c.push(n.to_string());
                found.push(c);
                return;
            }
            if !done.insert(n.to_string()) {
                return;
            }
            stack.push(n.to_string());
            for next in g.get(n).into_iter().flatten() {
                visit(next, g, stack, done, found);
            }
            stack.pop();
        }
        let mut raw = Vec::new();
        let mut done = BTreeSet::new();
        for n in g.keys() {
            visit(n, g, &mut Vec::new(), &mut done, &mut raw);
        }
        let prefix = if parent.is_empty() { String::new() } else { format!("{}::", parent.join("::")) };
        for c in raw {
            found.push(c.iter().map(|s| format!("{prefix}{s}")).collect::<Vec<_>>().join(" -> "));
        }
    }
    found
}

#[test]
fn no_import_cycles_between_modules() {
    let mut all = Vec::new();
    for krate in ["nerf-infer", "nerf-train"] {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join(krate).join("src");
        assert!(modules(&src).len() > 10, "{krate}: modules found");
        all.extend(cycles(&src).into_iter().map(|c| format!("{krate}: {c}")));
    }
    assert!(all.is_empty(), "import cycles:\n{}", all.join("\n"));
}

/// The checker finds a cycle where there is one.
#[test]
fn the_checker_finds_a_planted_cycle() {
    let dir = std::env::temp_dir().join(format!("nerf-test-cycles-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("b")).unwrap();
    std::fs::write(dir.join("lib.rs"), "pub mod a;\npub mod b;\n").unwrap();
    std::fs::write(dir.join("a.rs"), "use crate::b::inner::X; // crate::a in a comment\n").unwrap();
    std::fs::write(dir.join("b/mod.rs"), "pub mod inner;\n").unwrap();
    std::fs::write(dir.join("b/inner.rs"), "fn f() { super::super::a::g(); let s = \"crate::a\"; }\n").unwrap();
    // b::inner uses a through super::super: a cycle a -> b -> a among the crate's modules
    let found = cycles(&dir);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(found, ["a -> b -> a"]);
}

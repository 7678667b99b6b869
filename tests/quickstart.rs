//! nerf-infer's README quick start is the program CI builds and runs
//! (`examples/quickstart`): its `src/main.rs` word for word, and the
//! dependency and profile lines of its `Cargo.toml`.

use std::fs;

/// The body of the first fenced block of `lang` after `heading`.
fn block<'a>(text: &'a str, heading: &str, lang: &str) -> &'a str {
    let after = &text[text.find(heading).unwrap_or_else(|| panic!("no {heading:?}"))..];
    let open = format!("```{lang}\n");
    let start = after.find(&open).unwrap_or_else(|| panic!("no {lang} block after {heading:?}")) + open.len();
    let len = after[start..].find("```\n").expect("closed block");
    &after[start..start + len]
}

#[test]
fn the_readme_quick_start_is_the_quickstart_example() {
    let readme = fs::read_to_string("nerf-infer/README.md").unwrap();
    let main = fs::read_to_string("examples/quickstart/src/main.rs").unwrap();
    assert_eq!(block(&readme, "## Quick start", "rust"), main);
    let manifest = fs::read_to_string("examples/quickstart/Cargo.toml").unwrap();
    let toml = block(&readme, "## Quick start", "toml");
    for line in toml.lines().filter(|l| !l.starts_with("nerf-infer = ")) {
        assert!(manifest.lines().any(|m| m == line), "Cargo.toml lacks the README's line {line:?}");
    }
    // the dependency line differs only by the path
    let dep = |t: &str| {
        t.lines().find(|l| l.starts_with("nerf-infer = ")).map(|l| l.split("features").nth(1).map(str::to_owned))
    };
    assert_eq!(dep(toml), dep(&manifest));
}

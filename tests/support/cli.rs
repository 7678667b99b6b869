//! Running the `nerf` binary from the end-to-end tests.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `nerf` binary under test.
pub const BIN: &str = env!("CARGO_BIN_EXE_nerf");

/// Runs `nerf args` to completion.
pub fn nerf(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().expect("run nerf")
}

/// Runs `nerf args`, expects success; returns stdout.
pub fn ok(args: &[&str]) -> String {
    let o = nerf(args);
    assert!(o.status.success(), "nerf {args:?} failed: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout).unwrap()
}

/// Runs `nerf args`, expects failure with exactly one line on stderr;
/// returns it.
pub fn fails(args: &[&str]) -> String {
    let o = nerf(args);
    let e = String::from_utf8(o.stderr).unwrap();
    assert!(!o.status.success(), "nerf {args:?} should fail; stderr: {e}");
    assert_eq!(e.trim_end().lines().count(), 1, "nerf {args:?}: not one line: {e}");
    e
}

/// A fresh, empty directory under the system temp dir for test `name`,
/// removed when the test passes ([`super::TestDir`]).
pub fn tmp(name: &str) -> super::TestDir {
    super::TestDir::new(name)
}

/// Generates the built-in scene under `dir/scene` (`size`² pixels,
/// `train` training views); returns its Blender-layout dataset directory.
pub fn blender_scene(dir: &Path, size: u32, train: u32) -> PathBuf {
    let scene = dir.join("scene");
    ok(&["scene", "--out", s(&scene), "--size", &size.to_string(), "--train", &train.to_string()]);
    scene.join("blender")
}

/// `p` as a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A suite of two scenes of the built-in scene at 16×16 under `dir/suite`
/// for `nerf bench`: `lego` (Blender layout, so the paper's lego figure
/// stands beside it) and `object` (a COLMAP capture); returns the suite
/// folder and a tiny configuration (`dir/tiny.json`).
pub fn bench_suite(dir: &Path) -> (PathBuf, PathBuf) {
    let scene = dir.join("scene");
    ok(&["scene", "--out", s(&scene), "--size", "16", "--train", "6"]);
    let suite = dir.join("suite");
    std::fs::create_dir_all(&suite).unwrap();
    std::fs::rename(scene.join("blender"), suite.join("lego")).unwrap();
    std::fs::rename(scene.join("colmap"), suite.join("object")).unwrap();
    let cfg = dir.join("tiny.json");
    std::fs::write(&cfg, r#"{"depth": 2, "width": 16, "view_width": 8, "pos_freqs": 4, "batch_rays": 64}"#).unwrap();
    (suite, cfg)
}

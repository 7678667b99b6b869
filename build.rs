//! Builds the browser viewer's WebAssembly module (`nerf-web` for
//! `wasm32-unknown-unknown`, release, stripped) so that `nerf web` can
//! write it next to the page. Without that target installed, the `nerf`
//! binary is built without the viewer and `nerf web` says how to add it;
//! adding the target reruns this script at the next build.

use std::path::PathBuf;
use std::process::Command;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(web_viewer)");
    for p in ["nerf-web/src", "nerf-web/Cargo.toml", "nerf-infer/src", "nerf-infer/Cargo.toml", "nerf-infer/build.rs"] {
        println!("cargo::rerun-if-changed={p}");
    }
    commit();
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let cargo = std::env::var_os("CARGO").expect("cargo sets CARGO");
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let sysroot = Command::new(&rustc).args(["--print", "sysroot"]).output().ok();
    let rustlib = sysroot.map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()).join("lib/rustlib"));
    if let Some(lib) = &rustlib {
        // a target added later (rustup's list of installed components, or
        // the folder of targets without rustup) reruns this script: the
        // next build has the viewer
        let components = lib.join("components");
        let watched = if components.is_file() { components } else { lib.clone() };
        println!("cargo::rerun-if-changed={}", watched.display());
    }
    let installed = rustlib.is_some_and(|lib| lib.join("wasm32-unknown-unknown").is_dir());
    if !installed {
        println!(
            "cargo::warning=the wasm32-unknown-unknown target is not installed: `nerf web` is left out \
             (`rustup target add wasm32-unknown-unknown`, then `cargo build --release` again adds it)"
        );
        return;
    }
    let target_dir = out.join("web");
    let mut cmd = Command::new(cargo);
    cmd.args(["build", "--release", "--quiet", "-p", "nerf-web", "--target", "wasm32-unknown-unknown"])
        .arg("--target-dir")
        .arg(&target_dir)
        .env("CARGO_PROFILE_RELEASE_DEBUG", "false")
        .env("CARGO_PROFILE_RELEASE_STRIP", "true")
        .env("CARGO_PROFILE_RELEASE_CODEGEN_UNITS", "1");
    // the host build's flags (target-cpu=native, a linter as rustc wrapper) are not the module's
    for v in ["RUSTFLAGS", "RUSTC_WORKSPACE_WRAPPER", "CARGO_TARGET_DIR", "CARGO_BUILD_TARGET"] {
        cmd.env_remove(v);
    }
    // 128-bit SIMD (every current browser has it): the portable integer
    // loops vectorise, with the same results as scalar code
    cmd.env("CARGO_ENCODED_RUSTFLAGS", "-Ctarget-feature=+simd128");
    let status = cmd.status().expect("run cargo for the WebAssembly module");
    assert!(status.success(), "building nerf-web for wasm32-unknown-unknown failed");
    let wasm = target_dir.join("wasm32-unknown-unknown/release/nerf_web.wasm");
    std::fs::copy(&wasm, out.join("nerf_web.wasm")).expect("copy the WebAssembly module");
    println!("cargo::rustc-cfg=web_viewer");
}

/// Sets `NERF_COMMIT` to the commit this checkout is at (`git rev-parse
/// --short HEAD`, with `-dirty` when tracked files differ from it;
/// `unknown` outside a git checkout), which `nerf bench` stamps on its
/// rows; rerun when HEAD or the branch it names moves, or a source changes.
fn commit() {
    let git = |args: &[&str]| {
        Command::new("git")
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
    };
    let branch = git(&["symbolic-ref", "-q", "HEAD"]);
    // --git-path: the files as this worktree sees them (a linked worktree keeps its refs in the common folder)
    let mut watched: Vec<String> =
        ["HEAD", "packed-refs"].iter().filter_map(|f| git(&["rev-parse", "--git-path", f])).collect();
    watched.extend(branch.and_then(|b| git(&["rev-parse", "--git-path", &b])));
    // only files that exist: a missing one would rerun this script at every build
    for f in watched.iter().filter(|f| std::path::Path::new(f).is_file()) {
        println!("cargo::rerun-if-changed={f}");
    }
    // edited sources make the build dirty (nerf-infer's are watched above)
    for p in ["src", "nerf-train/src", "Cargo.toml", "nerf-train/Cargo.toml"] {
        println!("cargo::rerun-if-changed={p}");
    }
    let hash = git(&["rev-parse", "--short", "HEAD"]).unwrap_or_else(|| "unknown".into());
    let dirty = git(&["status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| !s.is_empty());
    println!("cargo::rustc-env=NERF_COMMIT={hash}{}", if dirty { "-dirty" } else { "" });
}

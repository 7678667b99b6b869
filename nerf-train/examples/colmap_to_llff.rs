//! Writes a COLMAP capture in LLFF's layout, as LLFF's `imgs2poses` does:
//! `OUT/poses_bounds.npy` from the sparse model and `OUT/images/`, a
//! symbolic link to each registered photo (the photos are not copied).
//!
//! ```sh
//! cargo run --release -p nerf-train --example colmap_to_llff -- ../shared/data/bird /tmp/bird_llff
//! nerf train --data /tmp/bird_llff --downscale 8 --minutes 5
//! ```
//!
//! `OUT` must not exist. Unix only (symbolic links).

use nerf_train::dataset::colmap::colmap_views;
use nerf_train::dataset::reconstructions::choose_model;
use nerf_train::dataset::write_poses_bounds;
use std::path::PathBuf;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [src, out] = args.as_slice() else {
        eprintln!("usage: colmap_to_llff COLMAP_DIR OUT_DIR");
        std::process::exit(2);
    };
    if let Err(e) = run(src.into(), out.into()) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run(src: PathBuf, out: PathBuf) -> Result<(), String> {
    if out.exists() {
        return Err(format!("{}: already exists; name a new folder", out.display()));
    }
    let (model_dir, note) = choose_model(&src, None).map_err(|e| e.to_string())?;
    if let Some(note) = note {
        eprintln!("note: {note}");
    }
    let (views, points) = colmap_views(&src, &model_dir).map_err(|e| e.to_string())?;
    let images = out.join("images");
    std::fs::create_dir_all(&images).map_err(|e| format!("{}: {e}", images.display()))?;
    for v in &views {
        let name = v.image.file_name().ok_or_else(|| format!("{}: no file name", v.image.display()))?;
        let target = std::fs::canonicalize(&v.image).map_err(|e| format!("{}: {e}", v.image.display()))?;
        link(&target, &images.join(name))?;
    }
    write_poses_bounds(&out, &views, &points).map_err(|e| e.to_string())?;
    eprintln!(
        "wrote {} ({} cameras from {}, {} sparse points)",
        out.join("poses_bounds.npy").display(),
        views.len(),
        model_dir.display(),
        points.len()
    );
    Ok(())
}

#[cfg(unix)]
fn link(target: &std::path::Path, at: &std::path::Path) -> Result<(), String> {
    std::os::unix::fs::symlink(target, at).map_err(|e| format!("{}: {e}", at.display()))
}

#[cfg(not(unix))]
fn link(_: &std::path::Path, at: &std::path::Path) -> Result<(), String> {
    Err(format!("{}: symbolic links need a Unix system", at.display()))
}

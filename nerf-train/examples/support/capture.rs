//! A COLMAP capture read for the examples that write it in another layout
//! without copying its photos: its cameras and points, and the photos
//! linked into the new folder.

use nerf_train::dataset::capture::CaptureView;
use nerf_train::dataset::colmap::colmap_views;
use nerf_train::dataset::reconstructions::choose_model;
use std::error::Error;
use std::path::Path;

/// The cameras and sparse points of the COLMAP capture `src` (its model
/// with the most registered photos), each photo linked into `out/images/`
/// (`out`, which must not exist, is made; removed again if a link
/// fails); returns the model's folder too.
#[allow(clippy::type_complexity)]
pub fn read_and_link(src: &Path, out: &Path) -> Result<(Vec<CaptureView>, Vec<glam::DVec3>, String), Box<dyn Error>> {
    if out.exists() {
        return Err(format!("{}: already exists; name a new folder", out.display()).into());
    }
    let (model_dir, note) = choose_model(src, None)?;
    if let Some(note) = note {
        eprintln!("note: {note}");
    }
    let (views, points) = colmap_views(src, &model_dir)?;
    let images = out.join("images");
    std::fs::create_dir_all(&images).map_err(|e| format!("{}: {e}", images.display()))?;
    let linked = views.iter().try_for_each(|v| {
        let name = v.image.file_name().ok_or_else(|| format!("{}: no file name", v.image.display()))?;
        let target = std::fs::canonicalize(&v.image).map_err(|e| format!("{}: {e}", v.image.display()))?;
        link(&target, &images.join(name))
    });
    or_remove(out, linked)?;
    Ok((views, points, model_dir.display().to_string()))
}

/// `written`, having removed `out` (made by [`read_and_link`]) if it
/// failed, so that a rerun finds no half-written folder.
pub fn or_remove<E>(out: &Path, written: Result<(), E>) -> Result<(), E> {
    if written.is_err() {
        let _ = std::fs::remove_dir_all(out);
    }
    written
}

/// Links `at` to `target` (Unix only; elsewhere an error naming `at`).
#[cfg(unix)]
fn link(target: &Path, at: &Path) -> Result<(), Box<dyn Error>> {
    std::os::unix::fs::symlink(target, at).map_err(|e| format!("{}: {e}", at.display()).into())
}

/// Links `at` to `target` (Unix only; elsewhere an error naming `at`).
#[cfg(not(unix))]
fn link(_: &Path, at: &Path) -> Result<(), Box<dyn Error>> {
    Err(format!("{}: symbolic links need a Unix system", at.display()).into())
}

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

use nerf_train::dataset::write_poses_bounds;
use std::path::PathBuf;

#[path = "support/capture.rs"]
mod support;
use support::{or_remove, read_and_link};

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

fn run(src: PathBuf, out: PathBuf) -> Result<(), Box<dyn std::error::Error>> {
    let (views, points, model_dir) = read_and_link(&src, &out)?;
    or_remove(&out, write_poses_bounds(&out, &views, &points))?;
    eprintln!(
        "wrote {} ({} cameras from {}, {} sparse points)",
        out.join("poses_bounds.npy").display(),
        views.len(),
        model_dir,
        points.len()
    );
    Ok(())
}

//! Writes a COLMAP capture in nerfstudio's layout, as `ns-process-data`
//! leaves it: `OUT/transforms.json` (each frame's camera-to-world matrix
//! in OpenGL axes and its intrinsics and lens), with `--points` the sparse
//! points as `OUT/sparse_pc.ply` named by `ply_file_path`, and
//! `OUT/images/`, a symbolic link to each registered photo (the photos are
//! not copied). Without `--points` the file is what instant-ngp's
//! `colmap2nerf` writes: cameras only.
//!
//! ```sh
//! cargo run --release -p nerf-train --example colmap_to_transforms -- ../shared/data/bird /tmp/bird_ns --points
//! nerf train --data /tmp/bird_ns --downscale 8 --minutes 5
//! ```
//!
//! `OUT` must not exist. Unix only (symbolic links). A lens nerfstudio's
//! `OPENCV` and `OPENCV_FISHEYE` cannot express (COLMAP's `FULL_OPENCV`
//! with `k4..k6`, `THIN_PRISM_FISHEYE`) is refused.

use nerf_train::dataset::write_transforms;
use std::path::PathBuf;

#[path = "support/capture.rs"]
mod support;
use support::{or_remove, read_and_link};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (points, rest): (Vec<&String>, Vec<&String>) = args.iter().partition(|a| *a == "--points");
    let [src, out] = rest.as_slice() else {
        eprintln!("usage: colmap_to_transforms COLMAP_DIR OUT_DIR [--points]");
        std::process::exit(2);
    };
    if let Err(e) = run(src.into(), out.into(), !points.is_empty()) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run(src: PathBuf, out: PathBuf, with_points: bool) -> Result<(), Box<dyn std::error::Error>> {
    let (views, points, model_dir) = read_and_link(&src, &out)?;
    or_remove(&out, write_transforms(&out, &views, with_points.then_some(&points[..])))?;
    eprintln!(
        "wrote {} ({} cameras from {}{})",
        out.join("transforms.json").display(),
        views.len(),
        model_dir,
        if with_points { format!(", {} sparse points", points.len()) } else { String::new() }
    );
    Ok(())
}

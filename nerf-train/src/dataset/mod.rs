//! Posed image datasets: Blender synthetic, LLFF forward-facing, the
//! instant-ngp / nerfstudio `transforms.json` variant and COLMAP sparse
//! models, loaded into one [`Dataset`] type. Every failure is a
//! [`DataError`] naming the file.

mod blender;
pub mod capture;
pub mod colmap;
pub mod colmap_io;
pub mod exposure;
pub mod fit;
mod forward;
mod image_io;
pub mod lens;
mod llff;
mod nerfstudio;
mod npy;
mod ply;
pub mod reconstructions;
pub mod synthetic;
mod types;

pub use blender::{load_blender, load_ngp};
pub use fit::SceneKind;
pub use image_io::{load_alpha, load_rgb, load_rgba, save_png_rgb};
pub use lens::Lens;
pub use llff::{load_llff, write_poses_bounds};
pub use nerfstudio::write_transforms;
pub use npy::{parse_npy_f64, read_npy_f64, write_npy_f64};

pub use types::{capture_record, rigid_pose, stem, DataError, Dataset, Format, LoadOptions, Split, View};

use std::path::Path;

/// Detects the layout of `dir`: `transforms_train.json` is a Blender
/// synthetic split, or an instant-ngp / nerfstudio capture split into files
/// when the Blender loader would lose its lens or intrinsics; then `poses_bounds.npy` (LLFF),
/// `transforms.json` (instant-ngp / nerfstudio), a COLMAP sparse model.
pub fn detect(dir: &Path) -> Result<Format, DataError> {
    if dir.join("transforms_train.json").is_file() {
        Ok(if blender::is_ngp_split(dir) { Format::Ngp } else { Format::Blender })
    } else if dir.join("poses_bounds.npy").is_file() {
        Ok(Format::Llff)
    } else if dir.join("transforms.json").is_file() {
        Ok(Format::Ngp)
    } else if reconstructions::find_model_dir(dir).is_some() {
        Ok(Format::Colmap)
    } else if !dir.is_dir() {
        Err(DataError::new(dir, "no such directory"))
    } else {
        Err(DataError::new(dir, "no transforms_train.json, transforms.json, poses_bounds.npy or COLMAP sparse/0 found"))
    }
}

/// Loads one split of the dataset in `dir`.
pub fn load(dir: &Path, split: Split, opts: LoadOptions) -> Result<Dataset, DataError> {
    if opts.downscale == 0 {
        return Err(DataError::new(dir, "downscale must be at least 1"));
    }
    let format = match opts.format {
        Format::Auto => detect(dir)?,
        f => f,
    };
    if let (Some(n), false) = (opts.sparse_model, format == Format::Colmap) {
        let format = match format {
            Format::Blender => "a Blender capture",
            Format::Llff => "an LLFF capture (poses_bounds.npy)",
            _ => "an instant-ngp capture (transforms.json)",
        };
        return Err(DataError::new(
            dir,
            format!(
                "--sparse-model {n}: only a COLMAP capture has numbered reconstructions (sparse/N); this one is read \
                 as {format}: leave --sparse-model out"
            ),
        ));
    }
    match format {
        Format::Blender => load_blender(dir, split, opts.downscale),
        Format::Ngp => load_ngp(dir, split, opts),
        Format::Colmap => colmap::load_colmap(dir, split, opts),
        Format::Llff => load_llff(dir, split, opts),
        Format::Auto => unreachable!("resolved above"),
    }
}

/// For tests: `n` grey 8×8 photos of the unit scene (bounds ±1, near 2,
/// far 6) from cameras on a circle of radius 4 around it.
#[cfg(test)]
pub(crate) fn grey_views(n: usize) -> Dataset {
    let views = (0..n)
        .map(|i| {
            let a = i as f32 / n as f32 * std::f32::consts::TAU;
            let c2w = synthetic::look_at(glam::Vec3::new(4.0 * a.cos(), 4.0 * a.sin(), 0.5));
            View {
                name: format!("grey{i}"),
                file: Default::default(),
                camera: nerf_infer::camera::Camera::new(8, 8, 8.0, 8.0, 4.0, 4.0, c2w).unwrap(),
                rgb: vec![[0.5; 3]; 64],
                alpha: Vec::new(),
                lens: Lens::Pinhole,
                mask: Vec::new(),
            }
        })
        .collect();
    let scene = nerf_infer::format::Scene::blender(1.0, 2.0, 6.0);
    Dataset { scene, views, downscale: 1, notes: Vec::new(), capture: None }
}

//! Posed image datasets: Blender synthetic, LLFF forward-facing, and the
//! instant-ngp / nerfstudio `transforms.json` variant, loaded into one
//! [`Dataset`] type. Every failure is a [`DataError`] naming the file.

mod blender;
mod image_io;
mod llff;
mod npy;
pub mod synthetic;

pub use blender::{load_blender, load_ngp};
pub use image_io::{load_rgb, save_png_rgb};
pub use llff::load_llff;
pub use npy::{read_npy_f64, write_npy_f64};

use nerf_infer::camera::Camera;
use nerf_infer::format::Scene;
use std::path::{Path, PathBuf};

/// A loading error: the file and what is wrong with it.
#[derive(Debug, thiserror::Error)]
#[error("{}: {msg}", path.display())]
pub struct DataError {
    /// The file (or directory) at fault.
    pub path: PathBuf,
    /// What is wrong, one line.
    pub msg: String,
}

impl DataError {
    /// An error about `path`.
    pub fn new(path: impl AsRef<Path>, msg: impl Into<String>) -> Self {
        Self { path: path.as_ref().to_path_buf(), msg: msg.into() }
    }
}

/// Which part of a dataset to load.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// Training views.
    Train,
    /// Validation views.
    Val,
    /// Test views.
    Test,
}

impl Split {
    /// The split's name as used in file names (`train`, `val`, `test`).
    pub fn name(self) -> &'static str {
        match self {
            Split::Train => "train",
            Split::Val => "val",
            Split::Test => "test",
        }
    }
}

/// Dataset layout on disk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Detect from the files present.
    Auto,
    /// `transforms_{train,val,test}.json` with `camera_angle_x`.
    Blender,
    /// `poses_bounds.npy` + `images/`.
    Llff,
    /// instant-ngp / nerfstudio `transforms.json` with `fl_x`, `cx`, ….
    Ngp,
}

/// One posed image, linear in stored sRGB values, `[0, 1]`.
#[derive(Clone, Debug)]
pub struct View {
    /// Image file stem, for reports.
    pub name: String,
    /// Camera at the loaded (downscaled) resolution.
    pub camera: Camera,
    /// Pixels row-major, `camera.width × camera.height`.
    pub rgb: Vec<[f32; 3]>,
}

/// The views of one split and the scene they show.
#[derive(Clone, Debug)]
pub struct Dataset {
    /// Bounds, near/far, background, NDC parameters.
    pub scene: Scene,
    /// The views.
    pub views: Vec<View>,
    /// Downscale factor applied when loading.
    pub downscale: u32,
}

impl Dataset {
    /// Number of pixels over all views.
    pub fn pixel_count(&self) -> usize {
        self.views.iter().map(|v| v.rgb.len()).sum()
    }
}

/// Options of [`load`].
#[derive(Clone, Copy, Debug)]
pub struct LoadOptions {
    /// Layout (or auto-detect).
    pub format: Format,
    /// Integer downscale by area averaging (≥ 1).
    pub downscale: u32,
    /// LLFF / ngp hold-out: every `holdout`-th image is a test (and val) view.
    pub holdout: usize,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self { format: Format::Auto, downscale: 1, holdout: 8 }
    }
}

/// Detects the layout of `dir`.
pub fn detect(dir: &Path) -> Result<Format, DataError> {
    if dir.join("transforms_train.json").is_file() {
        Ok(Format::Blender)
    } else if dir.join("poses_bounds.npy").is_file() {
        Ok(Format::Llff)
    } else if dir.join("transforms.json").is_file() {
        Ok(Format::Ngp)
    } else if !dir.is_dir() {
        Err(DataError::new(dir, "no such directory"))
    } else {
        Err(DataError::new(dir, "no transforms_train.json, transforms.json or poses_bounds.npy found"))
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
    match format {
        Format::Blender => load_blender(dir, split, opts.downscale),
        Format::Ngp => load_ngp(dir, split, opts.downscale, opts.holdout),
        Format::Llff => load_llff(dir, split, opts.downscale, opts.holdout),
        Format::Auto => unreachable!("resolved above"),
    }
}

/// Checks that a row-major 4×4 (or 3×4) pose is finite and rigid and turns
/// it into a 3×4 camera-to-world matrix.
pub fn rigid_pose(path: &Path, what: &str, m: &[Vec<f64>]) -> Result<[[f32; 4]; 3], DataError> {
    if m.len() < 3 || m.iter().take(3).any(|r| r.len() != 4) {
        return Err(DataError::new(path, format!("{what}: transform_matrix must be 4x4")));
    }
    let mut out = [[0f32; 4]; 3];
    for r in 0..3 {
        for c in 0..4 {
            let v = m[r][c];
            if !v.is_finite() {
                return Err(DataError::new(path, format!("{what}: transform_matrix has a non-finite value")));
            }
            out[r][c] = v as f32;
        }
    }
    let rot = glam::Mat3::from_cols(
        glam::Vec3::new(out[0][0], out[1][0], out[2][0]),
        glam::Vec3::new(out[0][1], out[1][1], out[2][1]),
        glam::Vec3::new(out[0][2], out[1][2], out[2][2]),
    );
    if !nerf_infer::camera::is_rotation(&rot) {
        return Err(DataError::new(path, format!("{what}: pose is not a rigid transform (rotation not orthonormal)")));
    }
    Ok(out)
}

//! COLMAP sparse models on disk: `cameras`, `images` and `points3D` in
//! COLMAP's binary (`.bin`, little-endian) and text (`.txt`) formats, read
//! and written (the layouts of COLMAP's `read_write_model.py`).
//!
//! Every count in a file is checked against the bytes left before anything
//! is allocated from it, every value must be finite, and every failure is a
//! [`ParseError`] naming the file and the record: a damaged or hostile file
//! gives an error, never a panic or a huge allocation.

pub use crate::error::ParseError;
use std::collections::HashSet;

use std::io::Write;
use std::path::Path;

mod binary;
mod text;
pub use binary::*;
pub use text::*;

fn err(path: &Path, msg: impl Into<String>) -> ParseError {
    ParseError { path: path.to_path_buf(), msg: msg.into() }
}

/// COLMAP's camera models (id, name and parameter count as COLMAP defines them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraModel {
    /// 0: `f, cx, cy`.
    SimplePinhole,
    /// 1: `fx, fy, cx, cy`.
    Pinhole,
    /// 2: `f, cx, cy, k`.
    SimpleRadial,
    /// 3: `f, cx, cy, k1, k2`.
    Radial,
    /// 4: `fx, fy, cx, cy, k1, k2, p1, p2`.
    Opencv,
    /// 5: `fx, fy, cx, cy, k1, k2, k3, k4`.
    OpencvFisheye,
    /// 6: `fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6`.
    FullOpencv,
    /// 7: `fx, fy, cx, cy, omega`.
    Fov,
    /// 8: `f, cx, cy, k`.
    SimpleRadialFisheye,
    /// 9: `f, cx, cy, k1, k2`.
    RadialFisheye,
    /// 10: `fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, sx1, sy1`.
    ThinPrismFisheye,
    /// 11: 16 parameters.
    RadTanThinPrismFisheye,
    /// 12: `f, cx, cy, k`.
    SimpleDivision,
    /// 13: `fx, fy, cx, cy, k`.
    Division,
    /// 14: `f, cx, cy` (equidistant fisheye).
    SimpleFisheye,
    /// 15: `fx, fy, cx, cy` (equidistant fisheye).
    Fisheye,
    /// 16: `fx, fy, cx, cy, alpha, beta`.
    Eucm,
    /// 17: `w, h` (a spherical panorama).
    Equirectangular,
}

const MODELS: [(CameraModel, &str, usize); 18] = [
    (CameraModel::SimplePinhole, "SIMPLE_PINHOLE", 3),
    (CameraModel::Pinhole, "PINHOLE", 4),
    (CameraModel::SimpleRadial, "SIMPLE_RADIAL", 4),
    (CameraModel::Radial, "RADIAL", 5),
    (CameraModel::Opencv, "OPENCV", 8),
    (CameraModel::OpencvFisheye, "OPENCV_FISHEYE", 8),
    (CameraModel::FullOpencv, "FULL_OPENCV", 12),
    (CameraModel::Fov, "FOV", 5),
    (CameraModel::SimpleRadialFisheye, "SIMPLE_RADIAL_FISHEYE", 4),
    (CameraModel::RadialFisheye, "RADIAL_FISHEYE", 5),
    (CameraModel::ThinPrismFisheye, "THIN_PRISM_FISHEYE", 12),
    (CameraModel::RadTanThinPrismFisheye, "RAD_TAN_THIN_PRISM_FISHEYE", 16),
    (CameraModel::SimpleDivision, "SIMPLE_DIVISION", 4),
    (CameraModel::Division, "DIVISION", 5),
    (CameraModel::SimpleFisheye, "SIMPLE_FISHEYE", 3),
    (CameraModel::Fisheye, "FISHEYE", 4),
    (CameraModel::Eucm, "EUCM", 6),
    (CameraModel::Equirectangular, "EQUIRECTANGULAR", 2),
];

impl CameraModel {
    /// The model with COLMAP's numeric id.
    pub fn from_id(id: i32) -> Option<Self> {
        usize::try_from(id).ok().and_then(|i| MODELS.get(i)).map(|m| m.0)
    }

    /// COLMAP's numeric id.
    pub fn id(self) -> i32 {
        MODELS.iter().position(|m| m.0 == self).map_or(-1, |i| i as i32)
    }

    /// The model with COLMAP's name (`PINHOLE`, …).
    pub fn from_name(name: &str) -> Option<Self> {
        MODELS.iter().find(|m| m.1 == name).map(|m| m.0)
    }

    /// COLMAP's name.
    pub fn name(self) -> &'static str {
        MODELS.iter().find(|m| m.0 == self).map_or("?", |m| m.1)
    }

    /// Number of parameters.
    pub fn num_params(self) -> usize {
        MODELS.iter().find(|m| m.0 == self).map_or(0, |m| m.2)
    }
}

/// One camera: model, image size in pixels and parameters (pixels, and
/// distortion coefficients on normalised coordinates).
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapCamera {
    /// Camera id.
    pub id: u32,
    /// Camera model.
    pub model: CameraModel,
    /// Image width, pixels.
    pub width: u64,
    /// Image height, pixels.
    pub height: u64,
    /// The model's parameters, `model.num_params()` of them.
    pub params: Vec<f64>,
}

/// One registered image: its world-to-camera pose (OpenCV axes), camera
/// and file name under `images/`. Its 2-D points are read and skipped.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapImage {
    /// Image id.
    pub id: u32,
    /// World-to-camera rotation as a quaternion `(w, x, y, z)`.
    pub qvec: [f64; 4],
    /// World-to-camera translation, world units.
    pub tvec: [f64; 3],
    /// The camera it was taken with.
    pub camera_id: u32,
    /// File name relative to `images/`.
    pub name: String,
}

/// One sparse point: position (world units), colour, reprojection error
/// (pixels) and the number of images that see it.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapPoint {
    /// Position, world units.
    pub xyz: [f64; 3],
    /// Colour, 8-bit RGB.
    pub rgb: [u8; 3],
    /// Mean reprojection error, pixels.
    pub error: f64,
    /// Number of observations.
    pub track_len: u64,
}

/// A sparse model.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Reconstruction {
    /// Cameras.
    pub cameras: Vec<ColmapCamera>,
    /// Registered images.
    pub images: Vec<ColmapImage>,
    /// Sparse points.
    pub points: Vec<ColmapPoint>,
}

/// Reads the model in `model_dir`, each part from `.bin` if present, else
/// `.txt`. Cameras and images are required; points are optional.
pub fn read_model(model_dir: &Path) -> Result<Reconstruction, ParseError> {
    let pick = |stem: &str| {
        let bin = model_dir.join(format!("{stem}.bin"));
        let txt = model_dir.join(format!("{stem}.txt"));
        if bin.is_file() {
            Some((bin, true))
        } else if txt.is_file() {
            Some((txt, false))
        } else {
            None
        }
    };
    let missing = |stem: &str| err(&model_dir.join(format!("{stem}.bin")), format!("no {stem}.bin or {stem}.txt"));
    let (cp, cb) = pick("cameras").ok_or_else(|| missing("cameras"))?;
    let cameras = if cb { read_cameras_bin(&cp)? } else { read_cameras_txt(&cp)? };
    let (ip, ib) = pick("images").ok_or_else(|| missing("images"))?;
    let images = if ib { read_images_bin(&ip)? } else { read_images_txt(&ip)? };
    // one photo with two poses contradicts itself: which one is right cannot be told
    let mut names: std::collections::HashMap<&str, u32> = Default::default();
    for im in &images {
        if let Some(first) = names.insert(im.name.as_str(), im.id) {
            return Err(err(
                &ip,
                format!("images {first} and {} both name {}: one photo with two poses; remove one", im.id, im.name),
            ));
        }
    }
    let ids: HashSet<u32> = cameras.iter().map(|c| c.id).collect();
    if let Some(im) = images.iter().find(|im| !ids.contains(&im.camera_id)) {
        return Err(err(
            &ip,
            format!("image {} ({}): camera {} is not in the cameras file", im.id, im.name, im.camera_id),
        ));
    }
    let points = match pick("points3D") {
        Some((p, true)) => read_points_bin(&p)?,
        Some((p, false)) => read_points_txt(&p)?,
        None => Vec::new(),
    };
    Ok(Reconstruction { cameras, images, points })
}

/// Largest model file read (2 GiB).
const MAX_FILE: u64 = 2 << 30;

fn read_file(path: &Path) -> Result<Vec<u8>, ParseError> {
    crate::util::userfile::read_checked(path, MAX_FILE).map_err(|e| err(path, e.to_string()))
}

fn check_camera(path: &Path, c: &ColmapCamera, seen: &mut HashSet<u32>) -> Result<(), ParseError> {
    let what = format!("camera {}", c.id);
    if !seen.insert(c.id) {
        return Err(err(path, format!("{what}: id appears twice")));
    }
    if c.width == 0 || c.height == 0 || c.width > 1 << 20 || c.height > 1 << 20 {
        return Err(err(path, format!("{what}: image size {}x{} out of range", c.width, c.height)));
    }
    if c.params.iter().any(|p| !p.is_finite()) {
        return Err(err(path, format!("{what}: non-finite parameter")));
    }
    Ok(())
}

fn check_image(path: &Path, im: &ColmapImage, seen: &mut HashSet<u32>) -> Result<(), ParseError> {
    if !seen.insert(im.id) {
        return Err(err(path, format!("image {} ({}): id appears twice", im.id, im.name)));
    }
    if im.name.is_empty() {
        return Err(err(path, format!("image {}: empty name", im.id)));
    }
    Ok(())
}

#[cfg(test)]
mod tests;

//! LLFF forward-facing captures: `poses_bounds.npy` (N × 17: a 3×5 pose
//! `[R | t | (h, w, focal)]` in LLFF's `[down, right, back]` axes, then
//! near and far depth bounds) and `images/` (sorted by name).
//!
//! As nerf-pytorch: axes converted to OpenGL `[right, up, back]`; scale so
//! the nearest bound is 1/0.75; poses recentred on their average; rays in
//! NDC (near plane 1), so `t ∈ [0, 1]` and the bounds are `[−1, 1]³`;
//! every `holdout`-th image is a test/val view.

use super::image_io::load_rgb;
use super::lens::Lens;
use super::npy::read_npy_f64;
use super::types::{capture_record, stem, DataError, Dataset, Split, View};
use glam::{DMat3, DVec3};
use nerf_infer::camera::Camera;
use nerf_infer::format::{CameraConvention, Framing, Ndc, Scene};
use std::path::Path;

fn pose_matrix(p: &[f64]) -> (DMat3, DVec3) {
    // rows of the 3×5 block: p[r*5 + c]; LLFF columns [down, right, back, t, hwf]
    let col = |c: usize| DVec3::new(p[c], p[5 + c], p[10 + c]);
    let (down, right, back, t) = (col(0), col(1), col(2), col(3));
    (DMat3::from_cols(right, -down, back), t)
}

/// Loads an LLFF capture's split.
pub fn load_llff(dir: &Path, split: Split, downscale: u32, holdout: usize) -> Result<Dataset, DataError> {
    let npy = dir.join("poses_bounds.npy");
    let (rows, cols, vals) = read_npy_f64(&npy)?;
    if cols != 17 || rows == 0 {
        return Err(DataError::new(&npy, format!("expected shape (N, 17), found ({rows}, {cols})")));
    }
    if vals.iter().any(|v| !v.is_finite()) {
        return Err(DataError::new(&npy, "non-finite values"));
    }
    let img_dir = dir.join("images");
    let mut files: Vec<_> = std::fs::read_dir(&img_dir)
        .map_err(|e| DataError::new(&img_dir, format!("cannot list images: {e}")))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            matches!(
                p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref(),
                Some("png" | "jpg" | "jpeg")
            )
        })
        .collect();
    files.sort();
    if files.len() != rows {
        return Err(DataError::new(&img_dir, format!("{} images but {rows} poses in poses_bounds.npy", files.len())));
    }
    let mut poses: Vec<(DMat3, DVec3)> = Vec::with_capacity(rows);
    let mut min_near = f64::INFINITY;
    for i in 0..rows {
        let r = &vals[i * 17..(i + 1) * 17];
        let (m, t) = pose_matrix(r);
        let err = (m * m.transpose() - DMat3::IDENTITY).to_cols_array().iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if err > 1e-3 || (m.determinant() - 1.0).abs() > 1e-3 {
            return Err(DataError::new(&npy, format!("pose {i} is not a rigid transform")));
        }
        if r[15] <= 0.0 || r[16] <= r[15] {
            return Err(DataError::new(&npy, format!("pose {i}: bounds must satisfy 0 < near < far")));
        }
        min_near = min_near.min(r[15]);
        poses.push((m, t));
    }
    let (h_full, w_full, focal_full) = (vals[4], vals[9], vals[14]);
    let frame = ForwardFrame::new(&poses, min_near);
    let holdout = holdout.max(1);
    let mut views: Vec<View> = Vec::new();
    for (i, file) in files.iter().enumerate() {
        if (i % holdout == 0) == (split == Split::Train) {
            continue;
        }
        let (w, h, rgb) = load_rgb(file, downscale, false)?;
        if let Some(v0) = views.first() {
            if (w, h) != (v0.camera.width, v0.camera.height) {
                return Err(DataError::new(
                    file,
                    format!("image size {w}x{h} differs from {}x{}", v0.camera.width, v0.camera.height),
                ));
            }
        }
        let f = (focal_full * w as f64 / w_full) as f32;
        let fy = (focal_full * h as f64 / h_full) as f32;
        let camera = Camera::new(w, h, f, fy, w as f32 / 2.0, h as f32 / 2.0, frame.apply(&poses[i]))
            .map_err(|_| DataError::new(&npy, format!("pose {i}: invalid camera")))?;
        views.push(View { name: stem(file), file: file.clone(), camera, rgb, alpha: Vec::new(), lens: Lens::Pinhole });
    }
    if views.is_empty() {
        return Err(DataError::new(dir, format!("no images in the {} split", split.name())));
    }
    let scene = ndc_scene(&views[0].camera);
    let names: Vec<String> = files.iter().map(|f| stem(f)).collect();
    let capture = Some(capture_record(holdout, &names, Framing::Forward, true));
    Ok(Dataset { scene, views, downscale, notes: Vec::new(), capture })
}

/// The NDC scene of a forward-facing capture whose first view is `v0`:
/// bounds `[−1, 1]³`, `t ∈ [0, 1]`, black background.
pub(super) fn ndc_scene(v0: &Camera) -> Scene {
    Scene {
        bounds_min: [-1.0; 3],
        bounds_max: [1.0; 3],
        near: 0.0,
        far: 1.0,
        white_background: false,
        convention: CameraConvention::OpenGl,
        ndc: Some(Ndc { focal: v0.fx, width: v0.width as f32, height: v0.height as f32 }),
        unbounded: None,
    }
}

/// nerf-pytorch's normalisation of a forward-facing capture: scale so the
/// nearest depth bound is 1/0.75, then recentre on the average pose.
pub(super) struct ForwardFrame {
    inv: DMat3,
    centre: DVec3,
    sc: f64,
}

impl ForwardFrame {
    /// The frame of `poses` (OpenGL axes: right, up, back; centres) whose
    /// nearest scene depth is `min_near` (capture units, > 0).
    pub(super) fn new(poses: &[(DMat3, DVec3)], min_near: f64) -> Self {
        let n = poses.len().max(1) as f64;
        let sc = 1.0 / (min_near * 0.75);
        // average pose: mean centre, z = mean back axis, y from mean up.
        let centre = poses.iter().map(|p| p.1 * sc).sum::<DVec3>() / n;
        let z = poses.iter().map(|p| p.0.z_axis).sum::<DVec3>().normalize();
        let up = poses.iter().map(|p| p.0.y_axis).sum::<DVec3>();
        let x = up.cross(z).normalize();
        let y = z.cross(x);
        Self { inv: DMat3::from_cols(x, y, z).transpose(), centre, sc }
    }

    /// `pose` in the normalised frame, row-major 3×4 camera-to-world.
    pub(super) fn apply(&self, pose: &(DMat3, DVec3)) -> [[f32; 4]; 3] {
        super::fit::pose_rows(&(self.inv * pose.0, self.inv * (pose.1 * self.sc - self.centre)))
    }
}

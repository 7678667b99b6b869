//! Blender synthetic (`transforms_{split}.json` with `camera_angle_x`) and
//! instant-ngp / nerfstudio (`transforms.json` with `fl_x`, `fl_y`, `cx`,
//! `cy`, `w`, `h`, global or per frame) loaders.
//!
//! Scene defaults: Blender uses the paper's near 2, far 6, bounds ±1.5 and
//! a white background. ngp captures take bounds ±r, near 0.05·r, far 2·r
//! where r is the largest camera distance from the origin, and black. Both
//! honour optional keys `near`, `far`, `aabb` ([[min], [max]]) and
//! `white_background`.

use super::{image_io::load_rgb, rigid_pose, DataError, Dataset, Split, View};
use nerf_infer::camera::Camera;
use nerf_infer::format::{CameraConvention, Scene};
use serde::Deserialize;
use std::path::Path;

#[derive(Deserialize)]
struct Intrinsics {
    fl_x: Option<f64>,
    fl_y: Option<f64>,
    cx: Option<f64>,
    cy: Option<f64>,
    w: Option<f64>,
    h: Option<f64>,
}

#[derive(Deserialize)]
struct Frame {
    file_path: String,
    transform_matrix: Vec<Vec<f64>>,
    #[serde(flatten)]
    intr: Intrinsics,
}

#[derive(Deserialize)]
struct Transforms {
    camera_angle_x: Option<f64>,
    #[serde(flatten)]
    intr: Intrinsics,
    frames: Vec<Frame>,
    near: Option<f64>,
    far: Option<f64>,
    aabb: Option<[[f64; 3]; 2]>,
    white_background: Option<bool>,
}

fn read_transforms(path: &Path) -> Result<Transforms, DataError> {
    let text = std::fs::read_to_string(path).map_err(|e| DataError::new(path, format!("cannot read: {e}")))?;
    let t: Transforms =
        serde_json::from_str(&text).map_err(|e| DataError::new(path, format!("malformed JSON: {e}")))?;
    if t.frames.is_empty() {
        return Err(DataError::new(path, "no frames"));
    }
    Ok(t)
}

fn image_path(dir: &Path, file: &str) -> std::path::PathBuf {
    let p = dir.join(file);
    if p.extension().is_some() && p.is_file() {
        p
    } else {
        let mut s = p.into_os_string();
        s.push(".png");
        s.into()
    }
}

struct SceneDefaults {
    near: f64,
    far: f64,
    half: f64,
    white: bool,
}

fn scene_from(path: &Path, t: &Transforms, d: SceneDefaults) -> Result<Scene, DataError> {
    let (lo, hi) = match t.aabb {
        Some([a, b]) => (a.map(|v| v as f32), b.map(|v| v as f32)),
        None => ([-d.half as f32; 3], [d.half as f32; 3]),
    };
    let s = Scene {
        bounds_min: lo,
        bounds_max: hi,
        near: t.near.unwrap_or(d.near) as f32,
        far: t.far.unwrap_or(d.far) as f32,
        white_background: t.white_background.unwrap_or(d.white),
        convention: CameraConvention::OpenGl,
        ndc: None,
    };
    let ok =
        s.near.is_finite() && s.far.is_finite() && s.near >= 0.0 && s.near < s.far && (0..3).all(|i| lo[i] < hi[i]);
    if !ok {
        return Err(DataError::new(path, "invalid near/far or aabb"));
    }
    Ok(s)
}

#[allow(clippy::too_many_arguments)]
fn load_frames(
    path: &Path,
    dir: &Path,
    t: &Transforms,
    frames: &[&Frame],
    downscale: u32,
    white: bool,
) -> Result<Vec<View>, DataError> {
    let mut views: Vec<View> = Vec::with_capacity(frames.len());
    for (i, f) in frames.iter().enumerate() {
        let what = format!("frame {i} ({})", f.file_path);
        let pose = rigid_pose(path, &what, &f.transform_matrix)?;
        let img = image_path(dir, &f.file_path);
        let (w, h, rgb) = load_rgb(&img, downscale, white)?;
        if let Some(v0) = views.first() {
            if (w, h) != (v0.camera.width, v0.camera.height) {
                return Err(DataError::new(
                    &img,
                    format!(
                        "image size {w}x{h} differs from the first image's {}x{}",
                        v0.camera.width, v0.camera.height
                    ),
                ));
            }
        }
        let s = downscale as f64;
        let pick = |a: Option<f64>, b: Option<f64>| a.or(b);
        let camera = if let Some(fx) = pick(f.intr.fl_x, t.intr.fl_x) {
            // ngp intrinsics are given at the full resolution `w × h`.
            let full_w = pick(f.intr.w, t.intr.w).unwrap_or(w as f64 * s);
            let full_h = pick(f.intr.h, t.intr.h).unwrap_or(h as f64 * s);
            let sx = full_w / w as f64;
            let sy = full_h / h as f64;
            let fy = pick(f.intr.fl_y, t.intr.fl_y).unwrap_or(fx);
            let cx = pick(f.intr.cx, t.intr.cx).unwrap_or(full_w / 2.0);
            let cy = pick(f.intr.cy, t.intr.cy).unwrap_or(full_h / 2.0);
            Camera::new(w, h, (fx / sx) as f32, (fy / sy) as f32, (cx / sx) as f32, (cy / sy) as f32, pose)
        } else if let Some(fov) = t.camera_angle_x {
            Camera::from_fov(w, h, fov as f32, pose)
        } else {
            return Err(DataError::new(path, "neither camera_angle_x nor fl_x given"));
        }
        .map_err(|_| DataError::new(path, format!("{what}: invalid intrinsics")))?;
        let name = img.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        views.push(View { name, camera, rgb });
    }
    Ok(views)
}

/// Loads a Blender synthetic split from `dir/transforms_{split}.json`.
pub fn load_blender(dir: &Path, split: Split, downscale: u32) -> Result<Dataset, DataError> {
    let path = dir.join(format!("transforms_{}.json", split.name()));
    let t = read_transforms(&path)?;
    let scene = scene_from(&path, &t, SceneDefaults { near: 2.0, far: 6.0, half: 1.5, white: true })?;
    let frames: Vec<&Frame> = t.frames.iter().collect();
    let views = load_frames(&path, dir, &t, &frames, downscale, scene.white_background)?;
    Ok(Dataset { scene, views, downscale })
}

/// Loads an instant-ngp / nerfstudio capture: `transforms_{split}.json` if
/// present, otherwise `transforms.json` with every `holdout`-th frame as
/// the val/test views.
pub fn load_ngp(dir: &Path, split: Split, downscale: u32, holdout: usize) -> Result<Dataset, DataError> {
    let own = dir.join(format!("transforms_{}.json", split.name()));
    let (path, select_all) = if own.is_file() { (own, true) } else { (dir.join("transforms.json"), false) };
    let t = read_transforms(&path)?;
    let r = t
        .frames
        .iter()
        .filter_map(|f| {
            f.transform_matrix
                .get(..3)
                .map(|m| m.iter().map(|row| row.get(3).copied().unwrap_or(0.0).powi(2)).sum::<f64>().sqrt())
        })
        .fold(0.0f64, f64::max)
        .max(1e-3);
    let scene = scene_from(&path, &t, SceneDefaults { near: 0.05 * r, far: 2.0 * r, half: r, white: false })?;
    let holdout = holdout.max(1);
    let frames: Vec<&Frame> = t
        .frames
        .iter()
        .enumerate()
        .filter(|(i, _)| select_all || ((i % holdout == 0) != (split == Split::Train)))
        .map(|(_, f)| f)
        .collect();
    if frames.is_empty() {
        return Err(DataError::new(&path, format!("no frames in the {} split", split.name())));
    }
    let views = load_frames(&path, dir, &t, &frames, downscale, scene.white_background)?;
    Ok(Dataset { scene, views, downscale })
}

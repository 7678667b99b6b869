//! LLFF captures: `poses_bounds.npy` (N × 17: a 3×5 pose
//! `[R | t | (h, w, focal)]` in LLFF's `[down, right, back]` axes, then
//! near and far depth bounds) and `images/` (sorted by name).
//!
//! The cameras go through the same scene fit as a COLMAP capture's
//! ([`super::capture::build`], [`super::fit`]): a capture whose cameras
//! look one way is forward-facing and keeps nerf-pytorch's treatment (axes
//! converted to OpenGL `[right, up, back]`; scale so the nearest bound is
//! 1/0.75; poses recentred on their average; rays in NDC, near plane 1, so
//! `t ∈ [0, 1]` and the bounds are `[−1, 1]³`); one whose cameras look
//! inward (mip-NeRF 360's scenes ship in this layout) is unbounded, and
//! `--scene` chooses otherwise. The file has no sparse points: each
//! camera's near bound stands for the nearest thing it sees, as the point
//! at that depth on its optical axis. Every `holdout`-th image is a
//! test/val view. At a downscale `N`, the `images_N/` copies LLFF and
//! mip-NeRF 360 ship are read if present ([`image_folder`]).
//!
//! [`write_poses_bounds`] writes the file from posed cameras and sparse
//! points as LLFF's `imgs2poses` does from a COLMAP model.

use super::capture::{build, CaptureOptions, CaptureView, Intrinsics, Selection};
use super::lens::Lens;
use super::npy::{read_npy_f64, write_npy_f64};
use super::types::{DataError, Dataset, LoadOptions};
use glam::{DMat3, DVec3};
use std::path::{Path, PathBuf};

fn pose_matrix(p: &[f64]) -> (DMat3, DVec3) {
    // rows of the 3×5 block: p[r*5 + c]; LLFF columns [down, right, back, t, hwf]
    let col = |c: usize| DVec3::new(p[c], p[5 + c], p[10 + c]);
    let (down, right, back, t) = (col(0), col(1), col(2), col(3));
    (DMat3::from_cols(right, -down, back), t)
}

/// The image files of an LLFF capture's `images/`, sorted by name.
fn image_files(img_dir: &Path) -> Result<Vec<PathBuf>, DataError> {
    let mut files: Vec<_> = std::fs::read_dir(img_dir)
        .map_err(|e| DataError::new(img_dir, format!("cannot list images: {e}")))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            matches!(
                p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref(),
                Some("png" | "jpg" | "jpeg")
            )
        })
        .collect();
    files.sort();
    Ok(files)
}

/// The downscales of the `images_N/` copies of `images/` that an LLFF
/// capture may ship.
const COPIES: [u32; 4] = [2, 4, 8, 16];

/// The folder of photos an LLFF capture is read from at `downscale`, and
/// the downscale left to apply to them: `images_N` as it is for `N` the
/// downscale (the copies LLFF and mip-NeRF 360 ship, `images_4`, `images_8`,
/// made from `images/` by resizing), else `images/` downscaled, else
/// `images_K` for a `K` dividing the downscale, downscaled the rest of the
/// way. A folder counts if it holds one photo per pose, and a copy only
/// if its photos bear the names of `images/`'s (the views' names, which a
/// model records; nerf_llff_data's copies are renamed `image000.png`, …,
/// and are passed over) or `images/` holds no photo per pose; `images/` is
/// named otherwise (the error then counts its photos). The cameras keep
/// the full size the file gives: [`build`] scales them to the photos.
fn image_folder(dir: &Path, downscale: u32, poses: usize) -> (PathBuf, u32) {
    let stems = |p: &Path| {
        image_files(p)
            .ok()
            .filter(|f| f.len() == poses)
            .map(|f| f.iter().map(|x| super::types::stem(x)).collect::<Vec<_>>())
    };
    let full = stems(&dir.join("images"));
    let holds = |p: &Path| stems(p).is_some_and(|s| full.as_ref().is_none_or(|f| *f == s));
    let mut tries = Vec::new();
    if downscale > 1 {
        tries.push((dir.join(format!("images_{downscale}")), 1));
    }
    tries.push((dir.join("images"), downscale));
    for k in COPIES {
        if k < downscale && downscale.is_multiple_of(k) {
            tries.push((dir.join(format!("images_{k}")), downscale / k));
        }
    }
    tries.into_iter().find(|(p, _)| holds(p)).unwrap_or((dir.join("images"), downscale))
}

/// Loads an LLFF capture's split (see the module doc).
pub fn load_llff(dir: &Path, split: super::types::Split, opts: LoadOptions) -> Result<Dataset, DataError> {
    let npy = dir.join("poses_bounds.npy");
    let (rows, cols, vals) = read_npy_f64(&npy)?;
    if cols != 17 || rows == 0 {
        return Err(DataError::new(&npy, format!("expected shape (N, 17), found ({rows}, {cols})")));
    }
    if vals.iter().any(|v| !v.is_finite()) {
        return Err(DataError::new(&npy, "non-finite values"));
    }
    let (img_dir, downscale) = image_folder(dir, opts.downscale, rows);
    // the shipped copies that hold a photo per pose, for the error's hint
    let copies: Vec<String> = COPIES
        .iter()
        .filter(|k| image_files(&dir.join(format!("images_{k}"))).is_ok_and(|f| f.len() == rows))
        .map(|k| format!("images_{k}/ (--downscale {k})"))
        .collect();
    let hint = if copies.is_empty() { String::new() } else { format!("; {} can be read instead", copies.join(", ")) };
    let files = image_files(&img_dir).map_err(|e| DataError::new(&img_dir, format!("{}{hint}", e.msg)))?;
    if files.len() != rows {
        return Err(DataError::new(
            &img_dir,
            format!("{} images but {rows} poses in poses_bounds.npy{hint}", files.len()),
        ));
    }
    let mut views = Vec::with_capacity(rows);
    let mut near_points = Vec::with_capacity(rows);
    let mut min_near = f64::INFINITY;
    for (i, file) in files.iter().enumerate() {
        let r = &vals[i * 17..(i + 1) * 17];
        let (m, t) = pose_matrix(r);
        let err = (m * m.transpose() - DMat3::IDENTITY).to_cols_array().iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if err > 1e-3 || (m.determinant() - 1.0).abs() > 1e-3 {
            return Err(DataError::new(&npy, format!("pose {i} ({}) is not a rigid transform", file.display())));
        }
        if r[15] <= 0.0 || r[16] <= r[15] {
            return Err(DataError::new(&npy, format!("pose {i}: bounds must satisfy 0 < near < far")));
        }
        let (h, w, f) = (r[4], r[9], r[14]);
        if !(h >= 1.0 && w >= 1.0 && f > 0.0) {
            return Err(DataError::new(
                &npy,
                format!("pose {i}: height {h}, width {w} and focal {f} must be positive (pixels)"),
            ));
        }
        min_near = min_near.min(r[15]);
        near_points.push(t - r[15] * m.z_axis);
        let intrinsics = Intrinsics { size: [w, h], focal: [f, f], centre: [w / 2.0, h / 2.0] };
        views.push(CaptureView { image: file.clone(), pose: (m, t), intrinsics, lens: Lens::Pinhole, mask: None });
    }
    let copts = CaptureOptions {
        split,
        select: Selection::Holdout(opts.holdout),
        downscale,
        kind: opts.scene,
        lens: false,
        undistort: false,
        white_background: false,
        nearest: Some(min_near),
        upright: false,
        measure_exposure: false,
    };
    let mut data = build(&npy, &views, &near_points, None, copts)?;
    if data.scene.ndc.is_none() && split == super::types::Split::Train {
        data.notes.push(format!(
            "{}: no sparse points in this layout: each camera's near bound stands for the nearest thing it sees, \
             the point at that depth on its optical axis (the near plane is fitted to those, and the object box \
             when at least {} of them lie inside the camera ring; else {})",
            npy.display(),
            super::fit::MIN_POINTS,
            super::fit::without_points()
        ));
    }
    Ok(data)
}

/// Writes `poses_bounds.npy` into `dir` for `views` (in the order of their
/// images' names, as LLFF lists `images/`), as LLFF's `imgs2poses` does:
/// each pose in LLFF's axes with its full image height, width and focal
/// length (pixels; the mean of fx and fy), then the 0.1st and 99.9th
/// percentiles of the depths of the sparse `points` the camera sees (in
/// front of it and inside its image); a camera that sees fewer than two
/// points takes the bounds of all cameras together.
pub fn write_poses_bounds(dir: &Path, views: &[CaptureView], points: &[DVec3]) -> Result<(), DataError> {
    let path = dir.join("poses_bounds.npy");
    if views.is_empty() {
        return Err(DataError::new(&path, "no cameras to write"));
    }
    let percentile = |v: &mut Vec<f64>, q: f64| {
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * q).round() as usize]
    };
    let mut bounds: Vec<Option<(f64, f64)>> = Vec::with_capacity(views.len());
    for v in views {
        let (r, eye) = v.pose;
        let k = &v.intrinsics;
        let mut depths: Vec<f64> = points
            .iter()
            .filter_map(|&q| {
                let d = q - eye;
                let z = -d.dot(r.z_axis);
                let (x, y) = (d.dot(r.x_axis) / z, -d.dot(r.y_axis) / z);
                let (u, w) = (k.centre[0] + k.focal[0] * x, k.centre[1] + k.focal[1] * y);
                (z > 0.0 && (0.0..k.size[0]).contains(&u) && (0.0..k.size[1]).contains(&w)).then_some(z)
            })
            .collect();
        bounds.push((depths.len() >= 2).then(|| (percentile(&mut depths, 0.001), percentile(&mut depths, 0.999))));
    }
    let known: Vec<(f64, f64)> = bounds.iter().flatten().copied().collect();
    let all = if known.is_empty() {
        (0.1, 100.0)
    } else {
        (known.iter().map(|b| b.0).fold(f64::INFINITY, f64::min), known.iter().map(|b| b.1).fold(0.0, f64::max))
    };
    let mut rows = Vec::with_capacity(views.len() * 17);
    for (v, b) in views.iter().zip(&bounds) {
        let (r, t) = v.pose;
        let (right, up, back) = (r.x_axis, r.y_axis, r.z_axis);
        let k = &v.intrinsics;
        let hwf = [k.size[1], k.size[0], 0.5 * (k.focal[0] + k.focal[1])];
        for a in 0..3 {
            rows.extend_from_slice(&[-up[a], right[a], back[a], t[a], hwf[a]]);
        }
        let (near, far) = b.unwrap_or(all);
        let near = near.max(1e-6);
        rows.extend_from_slice(&[near, far.max(near * 1.001)]);
    }
    write_npy_f64(&path, views.len(), 17, &rows).map_err(|e| DataError::new(&path, format!("cannot write: {e}")))
}

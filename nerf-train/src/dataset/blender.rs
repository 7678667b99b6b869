//! Blender synthetic (`transforms_{split}.json` with `camera_angle_x`) and
//! instant-ngp / nerfstudio (`transforms.json` with `fl_x`, `fl_y`, `cx`,
//! `cy`, `w`, `h`, global or per frame) loaders.
//!
//! Scene defaults: Blender uses the paper's near 2, far 6, bounds ±1.5 and
//! a white background. An ngp capture that gives `aabb` (`[[min], [max]]`)
//! or `near`/`far` keeps its frame and those values (near 0.05·r, far 2·r,
//! bounds ±r for the ones it omits, r the largest camera distance from the
//! origin); one that gives neither gets a scene fitted to its cameras
//! ([`super::fit`]). Both honour `white_background`.
//!
//! ngp lens keys, global or per frame: `k1 k2 k3 k4 p1 p2` and
//! `camera_model` (`OPENCV` or absent: `k1 k2 p1 p2` with `k3` in the
//! numerator; `OPENCV_FISHEYE` or ngp's `is_fisheye`: `k1..k4`). Frames
//! whose image file is missing are skipped and counted in the dataset's notes.
//! A frame's `mask_path` (nerfstudio) leaves the pixels its mask zeroes out
//! of training and scoring ([`View::mask`]).

use super::capture::{build, CaptureOptions, CaptureView, Intrinsics as CaptureIntrinsics, Selection};
use super::image_io::load_rgba;
use super::lens::Lens;
use super::types::{rigid_pose, DataError, Dataset, LoadOptions, Split, View};
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
    k1: Option<f64>,
    k2: Option<f64>,
    k3: Option<f64>,
    k4: Option<f64>,
    p1: Option<f64>,
    p2: Option<f64>,
    camera_model: Option<String>,
    is_fisheye: Option<bool>,
}

#[derive(Deserialize)]
struct Frame {
    file_path: String,
    transform_matrix: Vec<Vec<f64>>,
    /// nerfstudio's mask of the pixels to leave out of training and
    /// scoring (0 in its first channel), relative to the file's folder.
    mask_path: Option<String>,
    #[serde(flatten)]
    intr: Intrinsics,
}

#[derive(Deserialize)]
struct Transforms {
    camera_angle_x: Option<f64>,
    camera_angle_y: Option<f64>,
    #[serde(flatten)]
    intr: Intrinsics,
    frames: Vec<Frame>,
    near: Option<f64>,
    far: Option<f64>,
    aabb: Option<[[f64; 3]; 2]>,
    white_background: Option<bool>,
    /// nerfstudio's sparse points (a PLY file beside this one, in the
    /// frames' coordinates).
    ply_file_path: Option<String>,
}

fn read_transforms(path: &Path) -> Result<Transforms, DataError> {
    let bytes = crate::util::userfile::read_checked(path, crate::util::userfile::MAX_JSON)
        .map_err(|e| DataError::new(path, e.to_string()))?;
    let text = String::from_utf8(bytes).map_err(|_| DataError::new(path, "not UTF-8 text"))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let t: Transforms = serde_json::from_str(text).map_err(|e| DataError::new(path, format!("malformed JSON: {e}")))?;
    if t.frames.is_empty() {
        return Err(DataError::new(path, "no frames"));
    }
    Ok(t)
}

/// The file a path in a transforms file names, relative to the file's
/// folder `dir` (Windows separators read as `/`).
fn beside(dir: &Path, name: &str) -> std::path::PathBuf {
    dir.join(name.replace('\\', "/"))
}

/// The image a frame's `file_path` names ([`beside`]), a name that is not
/// a file tried with the extensions instant-ngp tries (Blender's frames
/// name `r_0` for `r_0.png`). A frame whose image is found under none of them gets the name with
/// `.png` added if it had no extension, as given otherwise.
fn image_path(dir: &Path, file: &str) -> std::path::PathBuf {
    let p = beside(dir, file);
    if p.is_file() {
        return p;
    }
    let with = |ext: &str| {
        let mut s = p.clone().into_os_string();
        s.push(ext);
        std::path::PathBuf::from(s)
    };
    const EXTENSIONS: [&str; 14] = [
        ".png", ".jpg", ".jpeg", ".PNG", ".JPG", ".JPEG", ".bmp", ".tga", ".tif", ".tiff", ".TIF", ".TIFF", ".webp",
        ".WEBP",
    ];
    EXTENSIONS.iter().map(|e| with(e)).find(|q| q.is_file()).unwrap_or_else(|| {
        if p.extension().is_some() {
            p.clone()
        } else {
            with(".png")
        }
    })
}

/// True if `dir/transforms_train.json` is an instant-ngp / nerfstudio
/// capture split into files rather than a Blender synthetic split: a file
/// without `camera_angle_x` (its focal length in other keys), or one whose
/// lens the Blender loader would drop (a distortion coefficient other than
/// 0, a fisheye), or whose frames carry intrinsics of their own; or a
/// capture one of whose split files names masks (`mask_path`). A
/// Blender-layout file that also states its pinhole's `fl_x`, `cx`, `w`, …
/// (as BlenderNeRF writes) stays Blender. A file that does not parse counts
/// as Blender, whose loader then names the fault.
pub(super) fn is_ngp_split(dir: &Path) -> bool {
    let path = dir.join("transforms_train.json");
    let Ok(t) = read_transforms(&path) else { return false };
    // a lens other than a pinhole, or one the ngp loader refuses (it then names the fault)
    let lens = |f: &Frame| ngp_lens(&path, "", &f.intr, &t.intr).map_or(true, |l| l != Lens::Pinhole);
    let own = |i: &Intrinsics| [i.fl_x, i.fl_y, i.cx, i.cy, i.w, i.h].iter().any(Option::is_some);
    let masks = [Split::Train, Split::Val, Split::Test].iter().any(|s| {
        let file = read_transforms(&dir.join(format!("transforms_{}.json", s.name())));
        file.is_ok_and(|f| f.frames.iter().any(|f| f.mask_path.is_some()))
    });
    t.camera_angle_x.is_none() || masks || t.frames.iter().any(|f| lens(f) || own(&f.intr))
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
        unbounded: None,
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
        let (w, h, rgb, alpha) = load_rgba(&img, downscale, white)?;
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
        let name = super::types::stem(&img);
        let alpha = alpha.unwrap_or_default();
        views.push(View { name, file: img, camera, rgb, alpha, lens: Lens::Pinhole, mask: Vec::new() });
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
    let masked = t.frames.iter().filter(|f| f.mask_path.is_some()).count();
    let notes = match masked {
        0 => Vec::new(),
        n => vec![format!(
            "{}: {n} frames name a mask_path, which the Blender loader does not apply (give --format ngp to apply \
             the masks)",
            path.display()
        )],
    };
    Ok(Dataset { scene, views, downscale, notes, capture: None })
}

/// Loads an instant-ngp / nerfstudio capture: `transforms_{split}.json` if
/// present (the frame is then fitted on the cameras, sparse points and
/// scene keys of `transforms_train.json`, or of `transforms.json` without
/// it, so that every split shares it), otherwise
/// `transforms.json` with every `holdout`-th frame as the val/test views.
pub fn load_ngp(dir: &Path, split: Split, opts: LoadOptions) -> Result<Dataset, DataError> {
    let own = dir.join(format!("transforms_{}.json", split.name()));
    let split_files = own.is_file();
    let (path, select_all) = if split_files { (own, true) } else { (dir.join("transforms.json"), false) };
    let t = read_transforms(&path)?;
    let (views, missing) = ngp_views(&path, dir, &t)?;
    // with split files, the other splits take the training file's frame: its cameras, sparse points,
    // aabb, near and far and background (transforms_train.json, else transforms.json)
    let fit_file = if select_all && split != Split::Train {
        Some(dir.join("transforms_train.json")).filter(|p| p.is_file()).unwrap_or(dir.join("transforms.json"))
    } else {
        path.clone()
    };
    let fit_t = if fit_file == path { None } else { Some(read_transforms(&fit_file)?) };
    let ft = fit_t.as_ref().unwrap_or(&t);
    let fit_views = match &fit_t {
        Some(f) => ngp_views(&fit_file, dir, f)?.0,
        None => Vec::new(),
    };
    let fixed = if ft.aabb.is_some() || ft.near.is_some() || ft.far.is_some() {
        let cams = if fit_t.is_some() { &fit_views } else { &views };
        let r = cams.iter().map(|v| v.pose.1.length()).fold(0.0f64, f64::max).max(1e-3);
        Some(scene_from(&fit_file, ft, SceneDefaults { near: 0.05 * r, far: 2.0 * r, half: r, white: false })?)
    } else {
        None
    };
    let (points, mut notes) = sparse_points(&fit_file, dir, ft)?;
    let copts = |select| CaptureOptions {
        split,
        select,
        downscale: opts.downscale,
        kind: opts.scene,
        lens: opts.lens,
        undistort: opts.undistort,
        white_background: ft.white_background.unwrap_or(false),
        nearest: None,
        // as stored: instant-ngp and nerfstudio read the pixels without the EXIF orientation, and
        // the poses and `w`, `h` describe those pixels
        upright: false,
        measure_exposure: true,
    };
    let mut data = if !select_all {
        build(&path, &views, &points, fixed, copts(Selection::Holdout(opts.holdout)))?
    } else if fit_t.is_some() {
        // the split's own file after the training cameras, on which alone the frame is fitted
        let first = fit_views.len();
        let all: Vec<CaptureView> = fit_views.into_iter().chain(views).collect();
        build(&path, &all, &points, fixed, copts(Selection::From(first)))?
    } else {
        build(&path, &views, &points, fixed, copts(Selection::From(0)))?
    };
    if ft.ply_file_path.is_none() && fixed.is_none() && data.scene.ndc.is_none() && split == Split::Train {
        notes.push(format!(
            "{}: no sparse points (no ply_file_path): the scene is fitted to the cameras alone, {}; a \
             ply_file_path (as nerfstudio's ns-process-data writes it), or training from the COLMAP folder the \
             cameras came from, gives the fit its points",
            fit_file.display(),
            super::fit::without_points()
        ));
    }
    data.notes.append(&mut notes);
    if missing > 0 {
        data.notes.push(format!(
            "{}: {missing} of {} frames skipped: image file not found",
            path.display(),
            t.frames.len()
        ));
    }
    Ok(data)
}

/// The sparse points that the file at `path` names (`ply_file_path`,
/// relative to `dir`), and a note if it names a file that is not there.
fn sparse_points(path: &Path, dir: &Path, t: &Transforms) -> Result<(Vec<glam::DVec3>, Vec<String>), DataError> {
    let Some(name) = &t.ply_file_path else { return Ok((Vec::new(), Vec::new())) };
    let ply = beside(dir, name);
    if !ply.is_file() {
        let note = format!(
            "{}: ply_file_path {name} not found: the scene is fitted to the cameras alone, {}",
            path.display(),
            super::fit::without_points()
        );
        return Ok((Vec::new(), vec![note]));
    }
    Ok((super::ply::read_ply_points(&ply)?, Vec::new()))
}

/// The frames of an ngp file whose images exist, as capture views, and
/// the number skipped because their image is missing.
fn ngp_views(path: &Path, dir: &Path, t: &Transforms) -> Result<(Vec<CaptureView>, usize), DataError> {
    let mut out = Vec::with_capacity(t.frames.len());
    let mut missing = 0;
    for (i, f) in t.frames.iter().enumerate() {
        let what = format!("frame {i} ({})", f.file_path);
        let image = image_path(dir, &f.file_path);
        if !image.exists() {
            missing += 1;
            continue;
        }
        let m = rigid_pose(path, &what, &f.transform_matrix)?;
        let rot = glam::DMat3::from_cols(
            glam::DVec3::new(m[0][0] as f64, m[1][0] as f64, m[2][0] as f64),
            glam::DVec3::new(m[0][1] as f64, m[1][1] as f64, m[2][1] as f64),
            glam::DVec3::new(m[0][2] as f64, m[1][2] as f64, m[2][2] as f64),
        );
        let pos = glam::DVec3::new(m[0][3] as f64, m[1][3] as f64, m[2][3] as f64);
        let pick = |a: Option<f64>, b: Option<f64>| a.or(b);
        let (w, h) = match (pick(f.intr.w, t.intr.w), pick(f.intr.h, t.intr.h)) {
            (Some(w), Some(h)) => (w, h),
            // without a stated size, the image's own (read from its header)
            _ => image::image_dimensions(&image)
                .map(|(w, h)| (w as f64, h as f64))
                .map_err(|e| DataError::new(&image, format!("cannot read image: {e}")))?,
        };
        // instant-ngp's order: fl_x, else camera_angle_x; a square pixel takes the other axis's
        let fx = pick(f.intr.fl_x, t.intr.fl_x).or(t.camera_angle_x.map(|a| 0.5 * w / (0.5 * a).tan()));
        let fy = pick(f.intr.fl_y, t.intr.fl_y).or(t.camera_angle_y.map(|a| 0.5 * h / (0.5 * a).tan()));
        let (fx, fy) = match (fx, fy) {
            (Some(fx), fy) => (fx, fy.unwrap_or(fx)),
            (None, Some(fy)) => (fy, fy),
            (None, None) => {
                return Err(DataError::new(
                    path,
                    format!(
                        "{what}: no fl_x or fl_y of its own and none for the file \
                         (nor camera_angle_x or camera_angle_y)"
                    ),
                ))
            }
        };
        let cx = pick(f.intr.cx, t.intr.cx).unwrap_or(w / 2.0);
        let cy = pick(f.intr.cy, t.intr.cy).unwrap_or(h / 2.0);
        let ok = [w, h, fx, fy, cx, cy].iter().all(|v| v.is_finite()) && w > 0.0 && h > 0.0 && fx > 0.0 && fy > 0.0;
        if !ok {
            return Err(DataError::new(path, format!("{what}: invalid intrinsics")));
        }
        if !(0.0..=w).contains(&cx) || !(0.0..=h).contains(&cy) {
            return Err(DataError::new(
                path,
                format!("{what}: principal point ({cx}, {cy}) lies outside the {w}x{h} image"),
            ));
        }
        let lens = ngp_lens(path, &what, &f.intr, &t.intr)?;
        let intrinsics = CaptureIntrinsics { size: [w, h], focal: [fx, fy], centre: [cx, cy] };
        let mask = f.mask_path.as_deref().map(|m| beside(dir, m));
        if let Some(m) = mask.as_ref().filter(|m| !m.is_file()) {
            return Err(DataError::new(path, format!("{what}: its mask_path {} is not a file", m.display())));
        }
        out.push(CaptureView { image, pose: (rot, pos), intrinsics, lens, mask });
    }
    if out.is_empty() {
        let first = t.frames.first().map(|f| f.file_path.as_str()).unwrap_or_default();
        return Err(DataError::new(
            path,
            format!(
                "none of the {} frames' images exist (the first names {first}, relative to the file's folder)",
                t.frames.len()
            ),
        ));
    }
    Ok((out, missing))
}

/// The lens of a frame: its own keys, else the file's.
fn ngp_lens(path: &Path, what: &str, f: &Intrinsics, g: &Intrinsics) -> Result<Lens, DataError> {
    let k = |a: Option<f64>, b: Option<f64>| a.or(b).unwrap_or(0.0);
    let model = f.camera_model.as_deref().or(g.camera_model.as_deref()).unwrap_or("OPENCV");
    let fisheye = f.is_fisheye.or(g.is_fisheye).unwrap_or(false);
    let (k1, k2, k3, k4) = (k(f.k1, g.k1), k(f.k2, g.k2), k(f.k3, g.k3), k(f.k4, g.k4));
    let (p1, p2) = (k(f.p1, g.p1), k(f.p2, g.p2));
    let perspective = matches!(model, "OPENCV" | "PINHOLE" | "SIMPLE_PINHOLE" | "SIMPLE_RADIAL" | "RADIAL");
    let lens = match model {
        "OPENCV_FISHEYE" => Lens::Fisheye { k: [k1, k2, k3, k4] },
        _ if perspective && fisheye => Lens::Fisheye { k: [k1, k2, k3, k4] },
        _ if perspective && k4 != 0.0 => {
            return Err(DataError::new(
                path,
                format!(
                    "{what}: k4 {k4} of a perspective camera (nerfstudio's r⁸ term) is not supported \
                     (k1, k2, k3, p1, p2 are; undistort the images with colmap image_undistorter)"
                ),
            ))
        }
        _ if perspective => Lens::Opencv { k: [k1, k2, k3, 0.0, 0.0, 0.0], p: [p1, p2] },
        other => {
            return Err(DataError::new(
                path,
                format!("{what}: camera_model {other} is not supported (OPENCV, OPENCV_FISHEYE, PINHOLE are)"),
            ))
        }
    }
    .simplified();
    if !lens.is_finite() {
        return Err(DataError::new(path, format!("{what}: non-finite distortion coefficient")));
    }
    Ok(lens)
}

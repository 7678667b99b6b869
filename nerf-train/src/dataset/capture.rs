//! From a real capture's cameras to a [`Dataset`]: the scene fitted to all
//! of the capture's cameras (so every split shares one frame), every
//! `holdout`-th image held out, images loaded and intrinsics scaled to
//! the loaded size. Used by the COLMAP and instant-ngp loaders.

use super::exposure::Loaded;
use super::fit::{fit_scene, pose_rows, Pose, SceneKind};
use super::forward::{ndc_scene, ForwardFrame};
use super::image_io::{image_size, load_mask, load_rgb, load_rgb_stored};
use super::lens::Lens;
use super::types::{capture_record, stem, DataError, Dataset, Split, View};
use glam::DVec3;
use nerf_infer::camera::Camera;
use nerf_infer::format::Framing;
use nerf_infer::format::Scene;
use std::path::{Path, PathBuf};

/// Pinhole intrinsics at an image's full resolution, pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intrinsics {
    /// Full width and height the other values refer to.
    pub size: [f64; 2],
    /// Focal lengths along x and y.
    pub focal: [f64; 2],
    /// Principal point from the top-left corner.
    pub centre: [f64; 2],
}

/// One registered image of a capture.
#[derive(Clone, Debug)]
pub struct CaptureView {
    /// The image file.
    pub image: PathBuf,
    /// Camera-to-world pose, OpenGL axes, capture units.
    pub pose: Pose,
    /// Intrinsics at the full resolution.
    pub intrinsics: Intrinsics,
    /// The lens's distortion.
    pub lens: Lens,
    /// The image's mask, if the capture gives one ([`View::mask`]; nerfstudio's
    /// `mask_path`): a pixel whose first channel is 0 is left out.
    pub mask: Option<PathBuf>,
}

/// Which views of a capture make a split.
#[derive(Clone, Copy, Debug)]
pub enum Selection {
    /// Every N-th view (0, N, 2N, … in capture order) is a val/test view,
    /// the others train (N ≥ 1).
    Holdout(usize),
    /// The views from this index on. The ones before are the capture's
    /// training views, on which alone the frame is fitted, so that every
    /// split shares the training split's frame; with none (`From(0)`) the
    /// frame is fitted on the views themselves.
    From(usize),
}

/// How to turn a capture into a dataset.
#[derive(Clone, Copy, Debug)]
pub struct CaptureOptions {
    /// Which split to load.
    pub split: Split,
    /// Which of the views make the split.
    pub select: Selection,
    /// Integer downscale of the images.
    pub downscale: u32,
    /// Scene treatment (`Auto`: fitted).
    pub kind: SceneKind,
    /// Bend rays by each view's lens (false: treat every photo as a pinhole).
    pub lens: bool,
    /// With `lens`: resample each distorted photo to a pinhole photo once
    /// instead ([`super::lens::undistort_image`]), leaving the pixels the
    /// lens did not image out of its mask ([`super::lens::undistort_mask`]).
    pub undistort: bool,
    /// Composite photos with an alpha channel on white (and render the
    /// scene on white) instead of black.
    pub white_background: bool,
    /// The nearest scene depth the capture's own files state (capture
    /// units, > 0; LLFF's near bounds): a forward-facing capture is scaled
    /// by it instead of by the sparse points' depths.
    pub nearest: Option<f64>,
    /// Apply each photo's EXIF orientation (false: the pixels as stored,
    /// as COLMAP, which ignores the tag, computed the poses on them).
    pub upright: bool,
    /// Whether the points are the capture's sparse points (COLMAP's, a
    /// `ply_file_path`'s), at which the training photos' exposure is
    /// measured ([`super::exposure`]); LLFF's stand-ins are not.
    pub measure_exposure: bool,
}

/// The views' names (what `eval --save` and `render` name their files
/// after): each image's file stem, or where two images share a stem (a
/// rig's `cam1/0001.jpg` and `cam2/0001.jpg`), each image's path from the
/// folder that holds them all, its separators turned into `_` (`cam1_0001`),
/// with its extension if the stems still collide.
fn view_names(all: &[CaptureView]) -> Vec<String> {
    // a name is unique if it stands for one file (a file listed twice keeps its one name)
    let unique = |names: &[String]| {
        let mut seen = std::collections::HashMap::new();
        names.iter().zip(all).all(|(n, v)| *seen.entry(n).or_insert(&v.image) == &v.image)
    };
    let stems: Vec<String> = all.iter().map(|v| stem(&v.image)).collect();
    if unique(&stems) {
        return stems;
    }
    // the deepest folder holding every image
    let mut root = all[0].image.parent().map(Path::to_path_buf).unwrap_or_default();
    while !all.iter().all(|v| v.image.starts_with(&root)) && root.pop() {}
    let relative = |v: &CaptureView, ext: bool| {
        let r = v.image.strip_prefix(&root).unwrap_or(&v.image);
        let r = if ext { r.to_path_buf() } else { r.with_extension("") };
        r.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect::<Vec<_>>().join("_")
    };
    let names: Vec<String> = all.iter().map(|v| relative(v, false)).collect();
    if unique(&names) {
        names
    } else {
        all.iter().map(|v| relative(v, true)).collect()
    }
}

/// Builds the split `opts.split` of a capture. `all` holds every view in
/// capture order (the fit uses them all, or with `Selection::From` the
/// training views before the split's); `points` the capture's sparse
/// points (may be empty); `fixed` a scene given by the capture's own
/// files, used as is with the poses unchanged. `path` names the capture's
/// pose file in errors. Fails if `opts.downscale` is 0 or `all` is empty.
pub fn build(
    path: &Path,
    all: &[CaptureView],
    points: &[DVec3],
    fixed: Option<Scene>,
    opts: CaptureOptions,
) -> Result<Dataset, DataError> {
    if all.is_empty() {
        return Err(DataError::new(path, "no registered images"));
    }
    if opts.downscale == 0 {
        return Err(DataError::new(path, "downscale must be at least 1"));
    }
    // `From(first)`: the training views before `first`, which alone the frame is fitted on
    let first = match opts.select {
        Selection::From(first) => first.min(all.len()),
        Selection::Holdout(_) => 0,
    };
    let fit_on = if first > 0 { &all[..first] } else { all };
    let poses: Vec<Pose> = fit_on.iter().map(|v| v.pose).collect();
    enum Frame {
        Fixed(Scene),
        Fitted(super::fit::Fitted),
        Forward(ForwardFrame),
    }
    let frame = match fixed {
        Some(s) => Frame::Fixed(s),
        None => {
            let f = fit_scene(&poses, points, opts.kind).ok_or_else(|| DataError::new(path, "no registered images"))?;
            if f.kind == SceneKind::Forward {
                Frame::Forward(ForwardFrame::new(&poses, opts.nearest.unwrap_or_else(|| nearest_depth(&poses, points))))
            } else {
                Frame::Fitted(f)
            }
        }
    };
    let keep = |i: usize| match opts.select {
        Selection::Holdout(n) => i.is_multiple_of(n.max(1)) != (opts.split == Split::Train),
        Selection::From(first) => i >= first,
    };
    // names among the views a split can hold: all of them (the record of a hold-out names them all), or
    // the split's own
    let names: Vec<String> = vec![String::new(); first].into_iter().chain(view_names(&all[first..])).collect();
    let (mut views, mut hidden, mut sources) = (Vec::new(), Vec::new(), Vec::new());
    for (i, v) in all.iter().enumerate().filter(|(i, _)| keep(*i)) {
        // the image's shape must be the camera's (the downscale crops at most n − 1 pixels a side); a photo
        // turned by its EXIF orientation, or another photo, is not what the poses were computed on: checked
        // on its header before its pixels are decoded
        let (fw, fh) = image_size(&v.image, opts.upright)?;
        let n = opts.downscale as f64;
        let (w, h) = (fw / opts.downscale, fh / opts.downscale);
        let k = &v.intrinsics;
        let (sx, sy) = (k.size[0] / w.max(1) as f64, k.size[1] / h.max(1) as f64);
        if (sx / sy - 1.0).abs() > 0.01 + n / k.size[0].min(k.size[1]) {
            return Err(DataError::new(
                &v.image,
                format!(
                    "image is {w}x{h} at downscale {n}{} but its camera is {}x{}: not the shape of the photo the \
                     poses were computed on",
                    if opts.upright { " (after its EXIF orientation)" } else { "" },
                    k.size[0],
                    k.size[1]
                ),
            ));
        }
        let (w, h, rgb) = match opts.upright {
            true => load_rgb(&v.image, opts.downscale, opts.white_background)?,
            false => load_rgb_stored(&v.image, opts.downscale, opts.white_background)?,
        };
        let c2w = match &frame {
            Frame::Fixed(_) => pose_rows(&v.pose),
            Frame::Fitted(f) => f.apply(&v.pose),
            Frame::Forward(f) => f.apply(&v.pose),
        };
        let [fx, fy] = [k.focal[0] / sx, k.focal[1] / sy];
        let [cx, cy] = [k.centre[0] / sx, k.centre[1] / sy];
        let camera = Camera::new(w, h, fx as f32, fy as f32, cx as f32, cy as f32, c2w)
            .map_err(|_| DataError::new(&v.image, "invalid camera (intrinsics or pose)"))?;
        let mut mask = match &v.mask {
            Some(m) => load_mask(m, opts.downscale, opts.upright, (&v.image, fw, fh))?,
            None => Vec::new(),
        };
        let (mut rgb, mut lens) = (rgb, if opts.lens { v.lens } else { Lens::Pinhole });
        if opts.undistort && lens != Lens::Pinhole {
            let px = super::lens::Pixels { fx, fy, cx, cy };
            let (w, h) = (w as usize, h as usize);
            rgb = super::lens::undistort_image(&rgb, w, h, px, lens);
            // a resampled pixel is kept only if the lens imaged it (the rest repeats the photo's edge) and
            // every photo pixel it blends is kept
            let kept = super::lens::undistort_mask(&mask, w, h, px, lens);
            mask = if kept.contains(&false) { kept } else { Vec::new() };
            lens = Lens::Pinhole;
        }
        let (name, file, alpha) = (names[i].clone(), v.image.clone(), Vec::new());
        // a held-out photo its mask hides whole has nothing to score
        if opts.split != Split::Train && !mask.is_empty() && !mask.contains(&true) {
            hidden.push(name);
            continue;
        }
        views.push(View { name, file, camera, rgb, alpha, lens, mask });
        sources.push(i);
    }
    if views.is_empty() {
        let hint = match opts.select {
            Selection::Holdout(n) => format!(
                " ({} registered photos, every {n}-th held out{})",
                all.len(),
                if all.len() < 2 { ": a capture needs at least two" } else { ": give a larger --llffhold" }
            ),
            Selection::From(_) => String::new(),
        };
        let hint = match hidden.len() {
            0 => hint,
            n => format!(
                " (all {n} of its photos hidden whole by their masks at this size: check the masks{})",
                if matches!(opts.select, Selection::Holdout(_)) { ", or give a smaller --llffhold" } else { "" }
            ),
        };
        return Err(DataError::new(path, format!("no images in the {} split{hint}", opts.split.name())));
    }
    let capture = match opts.select {
        Selection::Holdout(n) => {
            let framing = match &frame {
                Frame::Fixed(_) => Framing::Files,
                Frame::Forward(_) => Framing::Forward,
                Frame::Fitted(f) if f.kind == SceneKind::Unbounded => Framing::Unbounded,
                Frame::Fitted(_) => Framing::Object,
            };
            Some(capture_record(n, &names, framing, opts.lens))
        }
        Selection::From(_) => None,
    };
    let mut scene = match frame {
        Frame::Fixed(s) => s,
        Frame::Fitted(f) => f.scene,
        Frame::Forward(f) => {
            // the cameras the frame is fitted on, as pinholes at their own size (NDC is scale-free)
            let cameras: Vec<Camera> = fit_on
                .iter()
                .filter_map(|v| {
                    let k = &v.intrinsics;
                    let [w, h] = [k.size[0] as u32, k.size[1] as u32];
                    let c2w = f.apply(&v.pose);
                    Camera::new(w, h, k.focal[0] as f32, k.focal[1] as f32, k.centre[0] as f32, k.centre[1] as f32, c2w)
                        .ok()
                })
                .collect();
            ndc_scene(&views[0].camera, &cameras)
        }
    };
    scene.white_background = opts.white_background;
    let mut notes = match hidden.len() {
        0 => Vec::new(),
        n => vec![format!(
            "{}: {n} {} photo(s) left out, their masks hiding every pixel at this size ({})",
            path.display(),
            opts.split.name(),
            hidden.join(", ")
        )],
    };
    if opts.split == Split::Train && opts.measure_exposure && !points.is_empty() {
        let photos: Vec<Loaded<'_>> = views
            .iter()
            .zip(&sources)
            .map(|(v, &i)| {
                let k = &all[i].intrinsics;
                let (width, height) = (v.camera.width, v.camera.height);
                Loaded { pose: all[i].pose, focal: k.focal, centre: k.centre, size: k.size, width, height, rgb: &v.rgb }
            })
            .collect();
        notes.extend(super::exposure::note(path, &super::exposure::gains(&photos, points)));
    }
    Ok(Dataset { scene, views, downscale: opts.downscale, notes, capture })
}

/// The nearest scene depth of a forward-facing capture (capture units):
/// the 1st percentile of the depths of the sparse points in front of the
/// cameras (LLFF's bound), or without points half the distance from the
/// cameras to where their axes meet, or 1.
fn nearest_depth(poses: &[Pose], points: &[DVec3]) -> f64 {
    let mut depths = super::fit::point_depths(poses, points, points.len() / 4000, 0.0);
    if depths.len() >= 20 {
        depths.sort_by(f64::total_cmp);
        return depths[depths.len() / 100].max(1e-6);
    }
    let mean = poses.iter().map(|p| p.1).sum::<DVec3>() / poses.len().max(1) as f64;
    match super::fit::focus_point(poses) {
        Some(f) if (f - mean).length() > 1e-9 => 0.5 * (f - mean).length(),
        _ => 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_capture_at_downscale_0_is_refused_naming_the_option() {
        let view = CaptureView {
            image: "a.png".into(),
            pose: (glam::DMat3::IDENTITY, DVec3::ZERO),
            intrinsics: Intrinsics { size: [8.0; 2], focal: [8.0; 2], centre: [4.0; 2] },
            lens: Lens::Pinhole,
            mask: None,
        };
        let opts = CaptureOptions {
            split: Split::Train,
            select: Selection::Holdout(8),
            downscale: 0,
            kind: SceneKind::Auto,
            lens: true,
            undistort: false,
            white_background: false,
            nearest: None,
            upright: false,
            measure_exposure: false,
        };
        let e = build(Path::new("transforms.json"), &[view], &[], None, opts).unwrap_err().to_string();
        assert_eq!(e, "transforms.json: downscale must be at least 1");
    }
}

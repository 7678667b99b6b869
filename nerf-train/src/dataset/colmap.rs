//! COLMAP captures: `DIR/images/` and a sparse model in `DIR/sparse/N/`
//! (the one registering the most images, [`super::reconstructions`]), or
//! `DIR/sparse/`, or `DIR/`, as `.bin` or `.txt` ([`super::colmap_io`]).
//!
//! Camera models: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV,
//! FULL_OPENCV, OPENCV_FISHEYE, the radial and plain fisheyes
//! (SIMPLE_RADIAL_FISHEYE, RADIAL_FISHEYE, SIMPLE_FISHEYE, FISHEYE),
//! THIN_PRISM_FISHEYE and FOV: their
//! distortion becomes the view's [`Lens`]; any other is refused by name. Each image keeps its own
//! camera, so one capture may mix intrinsics and image sizes. Images are
//! taken in name order (as LLFF), every `holdout`-th held out; files in
//! `images/` that COLMAP did not register are counted in the notes. A
//! `masks/` folder beside `images/` gives photos masks ([`super::View::mask`];
//! `masks/0001.jpg.png` as COLMAP names them or `masks/0001.png` as nerfstudio does).
//! Poses: COLMAP stores world-to-camera `q, t` in OpenCV axes (x right,
//! y down, z forward); the camera-to-world pose in OpenGL axes is
//! `[Rᵀx, −Rᵀy, −Rᵀz | −Rᵀt]`.

use super::capture::{build, CaptureOptions, CaptureView, Intrinsics, Selection};
use super::colmap_io::{read_model, CameraModel, ColmapCamera, ColmapImage};
use super::lens::Lens;
use super::reconstructions::choose_model;
use super::types::{DataError, Dataset, LoadOptions, Split};
use crate::error::CameraError;
use glam::{DMat3, DQuat, DVec3};
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// Intrinsics and lens of a COLMAP camera, or the reason it is refused.
pub fn camera_lens(c: &ColmapCamera) -> Result<(Intrinsics, Lens), CameraError> {
    let p = &c.params;
    if p.len() != c.model.num_params() {
        return Err(CameraError::ParameterCount { model: c.model.name(), needs: c.model.num_params(), found: p.len() });
    }
    let size = [c.width as f64, c.height as f64];
    let k = |focal: [f64; 2], centre: [f64; 2]| Intrinsics { size, focal, centre };
    let z = 0.0;
    let (intr, lens) = match c.model {
        CameraModel::SimplePinhole => (k([p[0], p[0]], [p[1], p[2]]), Lens::Pinhole),
        CameraModel::Pinhole => (k([p[0], p[1]], [p[2], p[3]]), Lens::Pinhole),
        CameraModel::SimpleRadial => (k([p[0], p[0]], [p[1], p[2]]), Lens::opencv(p[3], z, z, z)),
        CameraModel::Radial => (k([p[0], p[0]], [p[1], p[2]]), Lens::opencv(p[3], p[4], z, z)),
        CameraModel::Opencv => (k([p[0], p[1]], [p[2], p[3]]), Lens::opencv(p[4], p[5], p[6], p[7])),
        CameraModel::FullOpencv => (
            k([p[0], p[1]], [p[2], p[3]]),
            Lens::Opencv { k: [p[4], p[5], p[8], p[9], p[10], p[11]], p: [p[6], p[7]] }.simplified(),
        ),
        CameraModel::OpencvFisheye => (k([p[0], p[1]], [p[2], p[3]]), Lens::Fisheye { k: [p[4], p[5], p[6], p[7]] }),
        // COLMAP's radial fisheyes: θ (1 + k1 θ² + k2 θ⁴), OpenCV's fisheye with k3 = k4 = 0
        CameraModel::SimpleRadialFisheye => (k([p[0], p[0]], [p[1], p[2]]), Lens::Fisheye { k: [p[3], z, z, z] }),
        CameraModel::RadialFisheye => (k([p[0], p[0]], [p[1], p[2]]), Lens::Fisheye { k: [p[3], p[4], z, z] }),
        CameraModel::SimpleFisheye => (k([p[0], p[0]], [p[1], p[2]]), Lens::Fisheye { k: [z; 4] }),
        CameraModel::Fisheye => (k([p[0], p[1]], [p[2], p[3]]), Lens::Fisheye { k: [z; 4] }),
        CameraModel::ThinPrismFisheye => (
            k([p[0], p[1]], [p[2], p[3]]),
            Lens::ThinPrismFisheye { k: [p[4], p[5], p[8], p[9]], p: [p[6], p[7]], s: [p[10], p[11]] }.simplified(),
        ),
        CameraModel::Fov if p[4].abs() >= std::f64::consts::PI => return Err(CameraError::FieldOfView { omega: p[4] }),
        CameraModel::Fov => (k([p[0], p[1]], [p[2], p[3]]), Lens::Fov { omega: p[4] }.simplified()),
        model => return Err(CameraError::Unsupported { model: model.name() }),
    };
    let ok = intr.focal.iter().all(|f| f.is_finite() && *f > 0.0) && intr.centre.iter().all(|c| c.is_finite());
    if !ok || !lens.is_finite() {
        return Err(CameraError::NotFinite);
    }
    // a principal point outside the photo is no lens a photo was taken with (a unit or field mix-up)
    if !(0.0..=size[0]).contains(&intr.centre[0]) || !(0.0..=size[1]).contains(&intr.centre[1]) {
        return Err(CameraError::CentreOutside { centre: intr.centre, width: c.width, height: c.height });
    }
    Ok((intr, lens))
}

/// The OpenGL camera-to-world pose of a COLMAP image, or `None` if its
/// quaternion is zero or not finite.
pub fn image_pose(im: &ColmapImage) -> Option<(DMat3, DVec3)> {
    let [w, x, y, z] = im.qvec;
    let q = DQuat::from_xyzw(x, y, z, w);
    if !q.is_finite() || q.length() < 1e-9 {
        return None;
    }
    let r = DMat3::from_quat(q.normalize()); // world → camera
    let rt = r.transpose();
    let centre = -(rt * DVec3::from(im.tvec));
    Some((DMat3::from_cols(rt.x_axis, -rt.y_axis, -rt.z_axis), centre))
}

/// The registered images of the COLMAP model in `model_dir` (a capture
/// whose photos are in `dir/images/`) in name order, with their poses,
/// intrinsics and lenses, and its sparse points (capture units).
pub fn colmap_views(dir: &Path, model_dir: &Path) -> Result<(Vec<CaptureView>, Vec<DVec3>), DataError> {
    let rec = read_model(model_dir)?;
    let cams: HashMap<u32, &ColmapCamera> = rec.cameras.iter().map(|c| (c.id, c)).collect();
    let img_dir = dir.join("images");
    if !img_dir.is_dir() {
        return Err(DataError::new(&img_dir, "no such directory (COLMAP's images/ folder)"));
    }
    let mut images: Vec<&ColmapImage> = rec.images.iter().collect();
    images.sort_by(|a, b| a.name.cmp(&b.name));
    let mut views = Vec::with_capacity(images.len());
    for im in &images {
        let what = format!("image {} ({})", im.id, im.name);
        let cam = cams
            .get(&im.camera_id)
            .ok_or_else(|| DataError::new(model_dir, format!("{what}: camera {} is not in the model", im.camera_id)))?;
        let (intrinsics, lens) =
            camera_lens(cam).map_err(|e| DataError::new(model_dir, format!("camera {}: {e}", cam.id)))?;
        let pose = image_pose(im).ok_or_else(|| DataError::new(model_dir, format!("{what}: invalid rotation")))?;
        // names are relative to the folder COLMAP was given: images/, or the capture's own folder
        // (`images/0001.jpg`)
        let image = Some(img_dir.join(&im.name)).filter(|p| p.is_file()).unwrap_or_else(|| {
            let beside = dir.join(&im.name);
            if beside.starts_with(&img_dir) && beside.is_file() {
                beside
            } else {
                img_dir.join(&im.name)
            }
        });
        if !image.is_file() {
            return Err(DataError::new(&image, format!("image not found (registered in {})", model_dir.display())));
        }
        let mask = mask_of(dir, &im.name)?;
        views.push(CaptureView { image, pose, intrinsics, lens, mask });
    }
    let points: Vec<DVec3> = rec.points.iter().map(|p| DVec3::from(p.xyz)).collect();
    Ok((views, points))
}

/// The mask of the image COLMAP names `name` in a capture's `masks/`
/// folder, if there is one: `masks/NAME.png` (COLMAP's own
/// `--ImageReader.mask_path` naming, `0001.jpg.png`) or `NAME` with its
/// extension replaced by `.png` (nerfstudio's `masks_path`, `0001.png`).
/// A `masks` that is not a folder, and a photo with a mask under each
/// name, are refused rather than read one way in silence.
fn mask_of(dir: &Path, name: &str) -> Result<Option<std::path::PathBuf>, DataError> {
    let masks = dir.join("masks");
    if !masks.exists() {
        return Ok(None);
    }
    if !masks.is_dir() {
        return Err(DataError::new(&masks, "is not a folder (masks are read from masks/, one PNG per photo)"));
    }
    let name = name.strip_prefix("images/").unwrap_or(name);
    let found: Vec<_> = [masks.join(format!("{name}.png")), masks.join(name).with_extension("png")]
        .into_iter()
        .filter(|p| p.is_file())
        .collect();
    match found.as_slice() {
        [a, b] if a != b => Err(DataError::new(
            &masks,
            format!(
                "two masks for photo {name}: {} and {}; keep one",
                a.file_name().unwrap_or_default().to_string_lossy(),
                b.file_name().unwrap_or_default().to_string_lossy()
            ),
        )),
        _ => Ok(found.into_iter().next()),
    }
}

/// Loads a COLMAP capture's split (see the module doc).
pub fn load_colmap(dir: &Path, split: Split, opts: LoadOptions) -> Result<Dataset, DataError> {
    let (model_dir, choice) = choose_model(dir, opts.sparse_model)?;
    let (views, points) = colmap_views(dir, &model_dir)?;
    let img_dir = dir.join("images");
    let copts = CaptureOptions {
        split,
        select: Selection::Holdout(opts.holdout),
        downscale: opts.downscale,
        kind: opts.scene,
        lens: opts.lens,
        undistort: opts.undistort,
        white_background: false,
        nearest: None,
        upright: false,
        measure_exposure: true,
    };
    let mut data = build(&model_dir, &views, &points, None, copts)?;
    let registered: HashSet<&Path> = views.iter().map(|v| v.image.as_path()).collect();
    let unregistered = files_under(&img_dir, 4).iter().filter(|f| !registered.contains(f.as_path())).count();
    data.notes.extend(choice);
    if unregistered > 0 {
        data.notes.push(format!("{}: {unregistered} images not registered by COLMAP, skipped", img_dir.display()));
    }
    let masked = views.iter().filter(|v| v.mask.is_some()).count();
    if masked == 0 && dir.join("masks").is_dir() {
        data.notes.push(format!(
            "{}: no file there is named as a registered photo's mask (0001.jpg.png or 0001.png for \
             images/0001.jpg): no masks applied",
            dir.join("masks").display()
        ));
    }
    if masked > 0 {
        data.notes.push(format!(
            "{}: {masked} of the {} registered photos have a mask there: their pixels at 0 neither train nor are \
             scored",
            dir.join("masks").display(),
            views.len()
        ));
    }
    Ok(data)
}

/// The files in `dir` and its folders, `depth` levels down at most (COLMAP
/// names images by their path under `images/`, folders included).
fn files_under(dir: &Path, depth: u32) -> Vec<std::path::PathBuf> {
    let Ok(rd) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut out = Vec::new();
    for e in rd.filter_map(|e| e.ok()) {
        let (p, kind) = (e.path(), e.file_type());
        match kind {
            Ok(k) if k.is_dir() && depth > 0 => out.extend(files_under(&p, depth - 1)),
            _ if p.is_file() => out.push(p),
            _ => {}
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(model: CameraModel, params: &[f64]) -> ColmapCamera {
        ColmapCamera { id: 1, model, width: 640, height: 480, params: params.to_vec() }
    }

    #[test]
    fn colmaps_fisheyes_become_the_fisheye_lens_with_their_coefficients() {
        let cases = [
            (CameraModel::SimpleRadialFisheye, vec![300.0, 320.0, 240.0, 0.05], [0.05, 0.0, 0.0, 0.0]),
            (CameraModel::RadialFisheye, vec![300.0, 320.0, 240.0, 0.05, -0.01], [0.05, -0.01, 0.0, 0.0]),
            (CameraModel::SimpleFisheye, vec![300.0, 320.0, 240.0], [0.0; 4]),
            (CameraModel::Fisheye, vec![300.0, 300.0, 320.0, 240.0], [0.0; 4]),
            (CameraModel::OpencvFisheye, vec![300.0, 300.0, 320.0, 240.0, 0.0, 0.0, 0.0, 0.0], [0.0; 4]),
        ];
        for (model, params, k) in cases {
            let (intr, lens) = camera_lens(&camera(model, &params)).unwrap();
            assert_eq!(lens, Lens::Fisheye { k }, "{}", model.name());
            assert_eq!((intr.focal, intr.centre), ([300.0, 300.0], [320.0, 240.0]), "{}", model.name());
        }
    }

    #[test]
    fn thin_prism_fisheye_and_fov_cameras_keep_their_coefficients_in_colmap_order() {
        // fx fy cx cy k1 k2 p1 p2 k3 k4 sx1 sy1
        let params = [300.0, 310.0, 320.0, 240.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8];
        let (intr, lens) = camera_lens(&camera(CameraModel::ThinPrismFisheye, &params)).unwrap();
        assert_eq!(lens, Lens::ThinPrismFisheye { k: [0.1, 0.2, 0.5, 0.6], p: [0.3, 0.4], s: [0.7, 0.8] });
        assert_eq!((intr.focal, intr.centre), ([300.0, 310.0], [320.0, 240.0]));
        // without tangential and prism terms it is the fisheye
        let params = [300.0, 310.0, 320.0, 240.0, 0.1, 0.2, 0.0, 0.0, 0.5, 0.6, 0.0, 0.0];
        let (_, lens) = camera_lens(&camera(CameraModel::ThinPrismFisheye, &params)).unwrap();
        assert_eq!(lens, Lens::Fisheye { k: [0.1, 0.2, 0.5, 0.6] });
        let (intr, lens) = camera_lens(&camera(CameraModel::Fov, &[300.0, 310.0, 320.0, 240.0, 0.9])).unwrap();
        assert_eq!((lens, intr.focal), (Lens::Fov { omega: 0.9 }, [300.0, 310.0]));
        let (_, lens) = camera_lens(&camera(CameraModel::Fov, &[300.0, 310.0, 320.0, 240.0, 0.0])).unwrap();
        assert_eq!(lens, Lens::Pinhole);
        let e = camera_lens(&camera(CameraModel::Fov, &[300.0, 310.0, 320.0, 240.0, 3.2])).unwrap_err();
        assert!(e.to_string().contains("ω = 3.2"), "{e}");
    }

    #[test]
    fn models_without_a_lens_here_are_refused_by_name() {
        for (model, n) in
            [(CameraModel::RadTanThinPrismFisheye, 16), (CameraModel::Eucm, 6), (CameraModel::Equirectangular, 2)]
        {
            let e = camera_lens(&camera(model, &vec![300.0; n])).unwrap_err().to_string();
            assert!(e.contains(model.name()) && e.contains("not supported"), "{e}");
        }
        assert_eq!(CameraModel::from_id(14), Some(CameraModel::SimpleFisheye));
        assert_eq!(CameraModel::from_name("EQUIRECTANGULAR").map(CameraModel::id), Some(17));
    }
}

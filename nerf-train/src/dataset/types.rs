//! The types every loader shares: the dataset, its views, the split, the
//! loading options and the error, with the helpers loaders use.

use super::fit::SceneKind;
use super::lens::Lens;
use crate::error::CameraError;
pub use crate::error::DataError;
use nerf_infer::camera::Camera;
use nerf_infer::format::{Capture, Framing, Scene};
use std::path::{Path, PathBuf};

/// Which part of a dataset to load.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
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
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Format {
    /// Detect from the files present ([`super::detect`]).
    #[default]
    Auto,
    /// `transforms_{train,val,test}.json` with `camera_angle_x`.
    Blender,
    /// `poses_bounds.npy` + `images/`.
    Llff,
    /// COLMAP: `images/` + `sparse/0/` (or `sparse/`) with `cameras`,
    /// `images`, `points3D` as `.bin` or `.txt`.
    Colmap,
    /// instant-ngp / nerfstudio `transforms.json` (or split into
    /// `transforms_{split}.json`) with `fl_x`, `cx`, ….
    Ngp,
}

/// One posed image, linear in stored sRGB values, `[0, 1]`.
#[derive(Clone, Debug)]
pub struct View {
    /// Image file stem, for reports.
    pub name: String,
    /// The image file the pixels were read from.
    pub file: PathBuf,
    /// Camera at the loaded (downscaled) resolution.
    pub camera: Camera,
    /// Pixels row-major, `camera.width × camera.height`, composited on
    /// the scene's background.
    pub rgb: Vec<[f32; 3]>,
    /// Opacity in `[0, 1]` of each pixel (row-major, as `rgb`) for photos
    /// with an alpha channel in a Blender-layout dataset
    /// (`transforms_{split}.json`); empty otherwise.
    /// Training composites such pixels on a random background
    /// ([`crate::config::SamplingConfig::random_background`]).
    pub alpha: Vec<f32>,
    /// The photo's lens distortion ([`Lens::Pinhole`] for rendered data):
    /// [`View::ray`] bends each pixel's ray by it.
    pub lens: Lens,
    /// Whether each pixel (row-major, as `rgb`) trains and is scored: false
    /// where the capture's mask (nerfstudio's `mask_path`) leaves it out;
    /// empty when every pixel does.
    pub mask: Vec<bool>,
}

impl View {
    /// Origin and direction (camera-space `z = −1`, as [`Camera::ray`]) of
    /// the ray through the centre of pixel `(x, y)` of the photo, through
    /// the lens: the ray of the ideal pinhole point the lens moved there.
    /// A pixel outside the lens model's invertible region keeps its pinhole ray.
    pub fn ray(&self, x: u32, y: u32) -> (glam::Vec3, glam::Vec3) {
        self.ray_at(x as f32 + 0.5, y as f32 + 0.5)
    }

    /// The ray through image point `(u, v)` (pixels from the photo's
    /// top-left corner, as [`Camera::ray_at`]), through the lens.
    pub fn ray_at(&self, u: f32, v: f32) -> (glam::Vec3, glam::Vec3) {
        let c = &self.camera;
        if self.lens == Lens::Pinhole {
            return c.ray_at(u, v);
        }
        let xd = (u as f64 - c.cx as f64) / c.fx as f64;
        let yd = (v as f64 - c.cy as f64) / c.fy as f64;
        let (ux, uy) = self.lens.undistort(xd, yd).unwrap_or((xd, yd));
        // OpenCV's y points down, the camera's (OpenGL) y up
        (c.position, c.rotation * glam::Vec3::new(ux as f32, -uy as f32, -1.0))
    }

    /// Whether pixel `i` (row-major) trains and is scored ([`View::mask`]).
    pub fn kept(&self, i: usize) -> bool {
        self.mask.get(i).copied().unwrap_or(true)
    }
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
    /// What the loader passed over, for the user (one line each): frames
    /// whose images are missing, images the capture did not register.
    pub notes: Vec<String>,
    /// How a capture split by hold-out (LLFF, COLMAP, instant-ngp without
    /// split files) was split and framed; `None` for datasets with split files.
    pub capture: Option<Capture>,
}

impl Dataset {
    /// Mean angular size of the views' pixels, radians (0 without views):
    /// the pixel footprint a model trained on them records.
    pub fn pixel_angle(&self) -> f32 {
        let n = self.views.len().max(1) as f32;
        self.views.iter().map(|v| v.camera.pixel_angle()).sum::<f32>() / n
    }
}

/// The file stem of `path` (a view's name), lossily as UTF-8.
pub fn stem(path: &Path) -> String {
    path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
}

/// The record of a capture split by hold-out: every `holdout`-th of the
/// views named `names` (capture order) is held out.
pub fn capture_record(holdout: usize, names: &[String], framing: Framing, lens: bool) -> Capture {
    let views = names.len() as u32;
    let mut held_out = Vec::new();
    for (i, n) in names.iter().enumerate() {
        if i.is_multiple_of(holdout.max(1)) {
            held_out.extend_from_slice(n.as_bytes());
            held_out.push(b'\n');
        }
    }
    Capture {
        holdout: holdout.clamp(1, Capture::MAX_HOLDOUT as usize) as u32,
        views,
        held_out_crc: nerf_infer::format::crc32(&held_out),
        framing,
        lens,
    }
}

impl Dataset {
    /// Number of pixels over all views.
    pub fn pixel_count(&self) -> usize {
        self.views.iter().map(|v| v.rgb.len()).sum()
    }

    /// The fraction of pixels that train ([`View::mask`]) and whose ray meets
    /// the scene's bounds within near..far, estimated on at most 4096 pixels
    /// spread evenly over all views.
    pub fn ray_hit_fraction(&self) -> f64 {
        let total = self.pixel_count();
        let step = (total / 4096).max(1);
        let (mut tried, mut hit) = (0usize, 0usize);
        let mut k = 0usize;
        for v in &self.views {
            let w = (v.camera.width as usize).max(1);
            while k < v.rgb.len() {
                let (o, d) = v.ray((k % w) as u32, (k / w) as u32);
                tried += 1;
                hit += (v.kept(k) && nerf_infer::Ray::new(&self.scene, o, d).is_some()) as usize;
                k += step;
            }
            k -= v.rgb.len();
        }
        hit as f64 / tried.max(1) as f64
    }

    /// Cells per axis the finest level of a feature grid needs to hold
    /// what these photos resolve: two cells per pixel footprint (the
    /// median over the views of the distance from the camera to the
    /// bounds' centre over the focal length, world units) along the bounds'
    /// longest side, rounded up to a power of two. In a forward-facing
    /// (NDC) scene a pixel of the reference camera spans `2 / width` in NDC
    /// x at every depth (`2 / height` in y): two cells per pixel along the
    /// box's x and y. `None` where the bounds' centre is not what the
    /// cameras look at from outside: unbounded scenes, bounds that hold
    /// half the cameras or more (an instant-ngp capture with `near`/`far`
    /// and no `aabb`), and datasets without views.
    pub fn resolvable_cells(&self) -> Option<u32> {
        let s = &self.scene;
        if s.unbounded.is_some() || self.views.is_empty() {
            return None;
        }
        if let Some(n) = s.ndc {
            let cells =
                ((s.bounds_max[0] - s.bounds_min[0]) * n.width).max((s.bounds_max[1] - s.bounds_min[1]) * n.height);
            return cells.is_finite().then(|| (cells.ceil().min(1e6) as u32).max(1).next_power_of_two());
        }
        let (lo, hi) = (glam::Vec3::from(s.bounds_min), glam::Vec3::from(s.bounds_max));
        let inside =
            self.views.iter().filter(|v| v.camera.position.cmpge(lo).all() && v.camera.position.cmple(hi).all());
        if 2 * inside.count() >= self.views.len() {
            return None;
        }
        let centre = (lo + hi) * 0.5;
        let mut footprints: Vec<f32> = self
            .views
            .iter()
            .map(|v| v.camera.position.distance(centre) / (0.5 * (v.camera.fx + v.camera.fy)))
            .filter(|f| f.is_finite() && *f > 0.0)
            .collect();
        if footprints.is_empty() {
            return None;
        }
        footprints.sort_by(f32::total_cmp);
        let footprint = footprints[footprints.len() / 2];
        let cells = 2.0 * (hi - lo).max_element() / footprint;
        // far beyond any grid: the caller clamps
        Some((cells.ceil().min(1e6) as u32).max(1).next_power_of_two())
    }

    /// Fails, saying why and what to try, if a view does not hold one
    /// colour per pixel of its camera (nor one mask value and opacity per
    /// pixel, where it has them), or if fewer than 1 % of the pixels train
    /// and have a ray that meets the scene: training would see almost
    /// nothing.
    pub fn check_rays(&self) -> Result<(), CameraError> {
        for v in &self.views {
            let (width, height) = (v.camera.width, v.camera.height);
            let pixels = width as usize * height as usize;
            let counts = [
                ("pixels", v.rgb.len(), false),
                ("mask values", v.mask.len(), true),
                ("opacities", v.alpha.len(), true),
            ];
            for (what, len, optional) in counts {
                if len != pixels && !(optional && len == 0) {
                    return Err(CameraError::PixelCount { view: v.name.clone(), what, len, width, height });
                }
            }
        }
        let f = self.ray_hit_fraction();
        if f >= 0.01 {
            return Ok(());
        }
        let kept = self.views.iter().map(|v| v.rgb.len() - v.mask.iter().filter(|&&k| !k).count()).sum::<usize>();
        if (kept as f64) < 0.01 * self.pixel_count() as f64 {
            return Err(CameraError::MasksLeave { kept, total: self.pixel_count() });
        }
        let s = &self.scene;
        Err(CameraError::RaysMiss {
            share: f,
            bounds_min: s.bounds_min,
            bounds_max: s.bounds_max,
            near: s.near,
            far: s.far,
        })
    }
}

/// Options of [`load`](super::load).
#[derive(Clone, Copy, Debug)]
pub struct LoadOptions {
    /// Layout (or auto-detect).
    pub format: Format,
    /// Integer downscale by area averaging (≥ 1).
    pub downscale: u32,
    /// LLFF / COLMAP / ngp hold-out: every `holdout`-th image is a test (and val) view.
    pub holdout: usize,
    /// Scene treatment of COLMAP and instant-ngp captures ([`SceneKind::Auto`]: fitted).
    pub scene: SceneKind,
    /// Bend rays by the photos' lens distortion (COLMAP, instant-ngp); false treats them as pinholes.
    pub lens: bool,
    /// With `lens`: resample each distorted photo to a pinhole photo once at
    /// load instead of bending its rays.
    pub undistort: bool,
    /// COLMAP: the reconstruction `sparse/N` to load (`None`: the one
    /// registering the most images).
    pub sparse_model: Option<u32>,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            format: Format::Auto,
            downscale: 1,
            holdout: 8,
            scene: SceneKind::Auto,
            lens: true,
            undistort: false,
            sparse_model: None,
        }
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

#[cfg(test)]
mod tests {
    use super::super::grey_views;

    #[test]
    fn a_view_not_holding_one_value_per_pixel_of_its_camera_is_refused_naming_it() {
        assert!(grey_views(2).check_rays().is_ok());
        let refused = |edit: fn(&mut super::View)| {
            let mut data = grey_views(2);
            edit(&mut data.views[1]);
            data.check_rays().unwrap_err().to_string()
        };
        let e = refused(|v| v.camera.width = 0);
        assert_eq!(
            e,
            "view `grey1`: 64 pixels for its 0x8 camera: a view holds one per pixel, row-major (its mask and \
             opacities may be empty)"
        );
        assert!(refused(|v| v.rgb.truncate(60)).contains("60 pixels for its 8x8 camera"));
        assert!(refused(|v| v.mask = vec![false; 65]).contains("65 mask values"));
        assert!(refused(|v| v.alpha = vec![1.0; 3]).contains("3 opacities"));
        // drawing rays skips such a view instead of dividing by its width
        let mut data = grey_views(2);
        data.views[1].camera.width = 0;
        let batch = crate::train::Trainer::draw_batch(
            &data,
            64,
            crate::train::Draw::CENTRES,
            &mut crate::util::rng::Rng::new(1),
        );
        assert!(!batch.is_empty() && batch.iter().all(|s| s.view == 0));
    }
}

//! The built-in scene seen by one camera, as the capture writers take
//! photos of it ([`Shot`]), and the scene inside its room as an
//! LLFF-layout capture ([`write_llff_room`]).

use super::{hemisphere, io, look_at, room, shade, SceneSpec, FOV_X};
use crate::dataset::types::DataError;
use glam::Vec3;
use std::path::Path;

/// One camera of the built-in scene's COLMAP-layout captures: where it
/// stands, its pinhole intrinsics (square pixels, fx) and lens.
pub(super) struct Shot {
    pub(super) eye: Vec3,
    pub(super) c2w: [[f32; 4]; 3],
    pub(super) size: (u32, u32),
    pub(super) fx: f64,
    pub(super) centre: (f64, f64),
    pub(super) lens: crate::dataset::Lens,
    pub(super) with_room: bool,
}

impl Shot {
    /// The camera's axes: right, up, back.
    pub(super) fn axes(&self) -> (Vec3, Vec3, Vec3) {
        let col = |c: usize| Vec3::new(self.c2w[0][c], self.c2w[1][c], self.c2w[2][c]);
        (col(0), col(1), col(2))
    }

    /// The colour seen along the unit direction `d` (black without the room).
    fn seen(&self, d: Vec3) -> Option<(Vec3, f32)> {
        match shade(self.eye, d) {
            Some(hit) => Some(hit),
            None if self.with_room => Some(room(self.eye, d)),
            None => None,
        }
    }

    /// The photo, 2×2 supersampled through the lens.
    pub(super) fn photo(&self) -> image::RgbImage {
        let (rx, ry, rz) = self.axes();
        let (cx, cy) = self.centre;
        let mut img = image::RgbImage::new(self.size.0, self.size.1);
        for (i, j, p) in img.enumerate_pixels_mut() {
            let mut acc = Vec3::ZERO;
            for sub in 0..4 {
                let xd = (i as f64 + 0.25 + 0.5 * (sub % 2) as f64 - cx) / self.fx;
                let yd = (j as f64 + 0.25 + 0.5 * (sub / 2) as f64 - cy) / self.fx;
                let (x, y) = self.lens.undistort(xd, yd).unwrap_or((xd, yd));
                let d = (rx * x as f32 - ry * y as f32 - rz).normalize();
                acc += self.seen(d).map_or(Vec3::ZERO, |(c, _)| c);
            }
            p.0 = (acc / 4.0).to_array().map(nerf_infer::composite::to_u8);
        }
        img
    }

    /// Surface points and their colours: the hits of every 8th pixel's ray.
    pub(super) fn surface_points(&self) -> impl Iterator<Item = (Vec3, [u8; 3])> + '_ {
        let (rx, ry, rz) = self.axes();
        let (cx, cy) = self.centre;
        let (w, h) = self.size;
        (0..h).step_by(8).flat_map(move |j| {
            (0..w).step_by(8).filter_map(move |i| {
                let x = ((i as f64 - cx) / self.fx) as f32;
                let y = ((j as f64 - cy) / self.fx) as f32;
                let d = (rx * x - ry * y - rz).normalize();
                let (c, t) = self.seen(d)?;
                Some((self.eye + t * d, c.to_array().map(|v| (v.clamp(0.0, 1.0) * 255.0) as u8)))
            })
        })
    }
}

/// Writes the scene inside its coloured room as an LLFF-layout capture
/// into `dir`: `images/` (JPEG, quality 95, `size × size` pinhole photos
/// from `spec.train + spec.val` cameras on the hemisphere around the
/// scene, a 360° capture with a background) and `poses_bounds.npy` as
/// LLFF's `imgs2poses` writes it ([`crate::dataset::write_poses_bounds`], bounds
/// from the surface points each camera sees).
pub fn write_llff_room(dir: &Path, spec: SceneSpec) -> Result<(), DataError> {
    use crate::dataset::capture::{CaptureView, Intrinsics};
    use crate::dataset::Lens;
    let img_dir = dir.join("images");
    std::fs::create_dir_all(&img_dir).map_err(io(&img_dir))?;
    let s = spec.size as f64;
    let f = 0.5 * s / (0.5 * FOV_X as f64).tan();
    let mut views = Vec::new();
    let mut points = Vec::new();
    for (k, eye) in hemisphere(spec.train + spec.val, 0.0).into_iter().enumerate() {
        let c2w = look_at(eye);
        let shot = Shot {
            eye,
            c2w,
            size: (spec.size, spec.size),
            fx: f,
            centre: (s / 2.0, s / 2.0),
            lens: Lens::Pinhole,
            with_room: true,
        };
        let path = img_dir.join(format!("img_{k:03}.jpg"));
        save_jpeg(&path, &shot.photo())?;
        points.extend(shot.surface_points().map(|(p, _)| p.as_dvec3()));
        let (rx, ry, rz) = shot.axes();
        let pose = (glam::DMat3::from_cols(rx.as_dvec3(), ry.as_dvec3(), rz.as_dvec3()), eye.as_dvec3());
        views.push(CaptureView {
            image: path,
            pose,
            intrinsics: Intrinsics { size: [s, s], focal: [f, f], centre: [s / 2.0, s / 2.0] },
            lens: Lens::Pinhole,
            mask: None,
        });
    }
    crate::dataset::write_poses_bounds(dir, &views, &points)
}

/// Writes `img` as a JPEG of quality 95.
pub(super) fn save_jpeg(path: &Path, img: &image::RgbImage) -> Result<(), DataError> {
    let mut buf = std::io::Cursor::new(Vec::new());
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, 95)
        .encode_image(img)
        .map_err(|e| DataError::new(path, format!("cannot encode JPEG: {e}")))?;
    crate::util::atomic::write(path, buf.get_ref()).map_err(io(path))
}

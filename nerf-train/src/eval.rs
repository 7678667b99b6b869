//! Rendering whole views through `nerf-infer` (the code users embed) and
//! scoring them, with per-ray timing.

use crate::dataset::View;
use crate::metrics::{psnr_kept, ssim_kept};
use nerf_infer::{AnyRenderer, AnyScratch, Camera, Model, RayRenderer, RenderOptions};
use rayon::prelude::*;
use std::time::Instant;

/// A rendered image with its depth and cost.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Colour, row-major.
    pub rgb: Vec<[f32; 3]>,
    /// Expected depth (ray parameter: camera-space z in scene units, or
    /// NDC `t` for forward-facing scenes), row-major.
    pub depth: Vec<f32>,
    /// Accumulated opacity in `[0, 1]`, row-major.
    pub opacity: Vec<f32>,
    /// Seconds of single-thread work per ray (sum of the threads' busy time / rays).
    pub secs_per_ray: f64,
    /// Mean network evaluations per ray.
    pub samples_per_ray: f64,
}

/// What a view is rendered through: a size and a ray per pixel. A
/// [`Camera`] is an ideal pinhole; a dataset [`View`] bends its rays by
/// the photo's lens, so its renders line up with its pixels.
pub trait PixelRays: Sync {
    /// Width and height in pixels.
    fn size(&self) -> (u32, u32);
    /// Origin and direction of the ray through pixel `(x, y)`.
    fn ray(&self, x: u32, y: u32) -> (glam::Vec3, glam::Vec3);
    /// Angular size of a pixel, radians (the footprint of models with one).
    fn pixel_angle(&self) -> f32;
}

impl PixelRays for Camera {
    fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }
    fn ray(&self, x: u32, y: u32) -> (glam::Vec3, glam::Vec3) {
        Camera::ray(self, x, y)
    }
    fn pixel_angle(&self) -> f32 {
        Camera::pixel_angle(self)
    }
}

impl PixelRays for View {
    fn size(&self) -> (u32, u32) {
        (self.camera.width, self.camera.height)
    }
    fn ray(&self, x: u32, y: u32) -> (glam::Vec3, glam::Vec3) {
        View::ray(self, x, y)
    }
    fn pixel_angle(&self) -> f32 {
        self.camera.pixel_angle()
    }
}

/// Renders every pixel of `camera` with the model's numeric path (f32 for
/// f32 models, fixed point otherwise), rows in parallel on the current
/// rayon pool.
pub fn render_view<C: PixelRays + ?Sized>(
    model: &Model<'_>,
    opts: RenderOptions,
    camera: &C,
) -> Result<Rendered, nerf_infer::Error> {
    render_view_marching(model, opts, camera, true)
}

/// [`render_view`] with the march's coarse occupancy level on or off
/// (`RendererFixed::with_coarse_skipping`): the same pixels, for timing
/// what the coarse level buys.
pub fn render_view_marching<C: PixelRays + ?Sized>(
    model: &Model<'_>,
    opts: RenderOptions,
    camera: &C,
    coarse_skipping: bool,
) -> Result<Rendered, nerf_infer::Error> {
    let (w, h) = camera.size();
    let (w, h) = (w as usize, h as usize);
    let r = AnyRenderer::new(model, opts)?.with_coarse_skipping(coarse_skipping).with_pixel(camera.pixel_angle());
    // blocks of 8 samples: the host's fastest
    let rows: Vec<Row> = (0..h)
        .into_par_iter()
        .map_init(|| Box::new(r.scratch::<8>()), |s, y| render_row(&r, camera, y as u32, w, s))
        .collect();
    let mut out = Rendered {
        width: w as u32,
        height: h as u32,
        rgb: Vec::with_capacity(w * h),
        depth: Vec::with_capacity(w * h),
        opacity: Vec::with_capacity(w * h),
        secs_per_ray: 0.0,
        samples_per_ray: 0.0,
    };
    let (mut secs, mut evals) = (0.0, 0u64);
    for (px, t, e) in rows {
        out.rgb.extend(px.iter().map(|p| p.rgb));
        out.depth.extend(px.iter().map(|p| p.depth));
        out.opacity.extend(px.iter().map(|p| p.opacity));
        secs += t;
        evals += e;
    }
    out.secs_per_ray = secs / (w * h) as f64;
    out.samples_per_ray = evals as f64 / (w * h) as f64;
    Ok(out)
}

/// One rendered row: pixels, busy seconds, network evaluations.
type Row = (Vec<nerf_infer::Pixel>, f64, u64);

fn render_row<C: PixelRays + ?Sized>(
    r: &AnyRenderer<'_, '_>,
    camera: &C,
    y: u32,
    w: usize,
    scratch: &mut AnyScratch<8>,
) -> Row {
    let e0 = scratch.evaluations();
    let start = Instant::now();
    let px: Vec<nerf_infer::Pixel> = (0..w as u32)
        .map(|x| {
            let (o, d) = camera.ray(x, y);
            r.render_ray(o, d, (x, y), scratch)
        })
        .collect();
    let t = start.elapsed().as_secs_f64();
    (px, t, scratch.evaluations() - e0)
}

/// Scores of one view.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ViewScore {
    /// View name.
    pub name: String,
    /// PSNR against ground truth, dB, over the pixels the view's mask keeps.
    pub psnr: f64,
    /// SSIM against ground truth, over the windows centred on the pixels the
    /// view's mask keeps.
    pub ssim: f64,
    /// Mean rendered opacity, in `[0, 1]`, over the pixels whose photo is
    /// fully transparent (alpha 0): density left in empty space (haze,
    /// floaters) that a white background hides; `None` for a photo
    /// without alpha or without a transparent pixel.
    pub clear_opacity: Option<f64>,
}

/// Renders `view` and scores it against its ground truth.
pub fn score_view(
    model: &Model<'_>,
    opts: RenderOptions,
    view: &View,
) -> Result<(Rendered, ViewScore), nerf_infer::Error> {
    let r = render_view(model, opts, view)?;
    let s = score_rendered(&r, view);
    Ok((r, s))
}

/// PSNR and SSIM of a render of `view` against its ground truth, over the
/// pixels its mask keeps ([`View::mask`]; SSIM over the windows centred on them).
pub fn score_rendered(r: &Rendered, view: &View) -> ViewScore {
    let (w, h) = (view.camera.width as usize, view.camera.height as usize);
    let clear = view.alpha.iter().zip(&r.opacity).filter(|(&a, _)| a == 0.0);
    let (sum, count) = clear.fold((0.0f64, 0usize), |(s, k), (_, &o)| (s + o as f64, k + 1));
    ViewScore {
        name: view.name.clone(),
        psnr: psnr_kept(&r.rgb, &view.rgb, &view.mask),
        ssim: ssim_kept(&r.rgb, &view.rgb, w, h, &view.mask),
        clear_opacity: (count > 0).then(|| sum / count as f64),
    }
}

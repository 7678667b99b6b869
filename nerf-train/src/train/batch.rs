//! Training rays: a batch drawn across every training image, each ray with
//! its ground truth and the background both are composited on.

use super::*;

/// A training ray, its ground-truth colour and the background both are
/// composited on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// The ray through the pixel.
    pub ray: Ray,
    /// The pixel's colour on `bg`, stored (sRGB-encoded) values in `[0, 1]`.
    pub rgb: [f32; 3],
    /// Background colour of this ray in `[0, 1]`: the scene's
    /// (white or black), or a random colour for a pixel with an alpha channel
    /// ([`SamplingConfig::random_background`](crate::config::SamplingConfig::random_background)).
    pub bg: [f32; 3],
    /// The index of the photo the pixel is from among the dataset's
    /// views (for its [`crate::per_photo::appearance`] correction).
    pub view: u32,
}

/// Where [`Trainer::draw_batch`] sends its rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Draw {
    /// Share of the pixels with an alpha channel, in `[0, 1]`, recomposited
    /// on a random background colour ([`SamplingConfig::random_background`](crate::config::SamplingConfig::random_background)).
    pub random_background: f32,
    /// Each ray through a uniformly random point of its pixel instead of
    /// its centre ([`SamplingConfig::pixel_jitter`](crate::config::SamplingConfig::pixel_jitter)).
    pub jitter: bool,
    /// Each ray with its pixel's footprint ([`FeatureConfig::footprint`](crate::config::FeatureConfig::footprint)),
    /// turned about the ray by a random angle.
    pub footprint: bool,
}

impl Draw {
    /// Rays through pixel centres, on the scene's background.
    pub const CENTRES: Self = Self { random_background: 0.0, jitter: false, footprint: false };

    /// The rays a training step of `cfg` draws at `progress` (the share of
    /// the run done, in `[0, 1]`).
    pub fn of(cfg: &TrainConfig, progress: f64) -> Self {
        Self {
            random_background: cfg.sampling.random_background,
            jitter: cfg.sampling.pixel_jitter,
            footprint: cfg.features.footprint
                && cfg.features.levels.is_some()
                && progress >= cfg.features.footprint_from as f64,
        }
    }
}

impl Sample {
    /// A ray on the scene's background with ground truth `rgb` from view 0.
    pub fn on_scene(scene: &Scene, ray: Ray, rgb: [f32; 3]) -> Self {
        Self { ray, rgb, bg: [scene.background(); 3], view: 0 }
    }
}

impl Trainer {
    /// Draws `n` training rays uniformly over all pixels of `data` (views
    /// may differ in size), through each view's lens: through the pixel's
    /// centre, or with `how.jitter` through a uniformly random point of it.
    /// Pixels whose ray misses the scene, or that their view's mask leaves
    /// out ([`crate::dataset::View::mask`]), are drawn again, at most `128 n`
    /// draws in all: [`crate::dataset::Dataset::check_rays`] makes sure at
    /// load time that at least 1 % of the pixels train and meet the scene
    /// (`100 n` draws expected at 1 %), so a short batch is rare.
    ///
    /// A share `how.random_background` (in `[0, 1]`) of the pixels of views
    /// with an alpha channel gets a uniformly random background colour,
    /// its ground truth recomposited on it (`rgb + (1 − alpha)·(bg − scene
    /// background)`); other pixels keep the scene's background. A view that
    /// does not hold one colour per pixel of its camera (which
    /// [`Dataset::check_rays`](crate::dataset::Dataset::check_rays) refuses) gives no rays.
    pub fn draw_batch(data: &Dataset, n: usize, how: Draw, rng: &mut Rng) -> Vec<Sample> {
        Self::draw_with(data, n, how, rng, |_, o, d| (o, d))
    }

    /// [`Trainer::draw_batch`] with each world-space ray `(origin, dir)` of
    /// view `v` replaced by `camera(v, origin, dir)` before it is prepared.
    pub(super) fn draw_with(
        data: &Dataset,
        n: usize,
        how: Draw,
        rng: &mut Rng,
        camera: impl Fn(usize, glam::Vec3, glam::Vec3) -> (glam::Vec3, glam::Vec3),
    ) -> Vec<Sample> {
        // the pixels drawn from of each view: all, or none where they are not one per pixel of its camera
        let drawn = |v: &crate::dataset::View| {
            let pixels = v.camera.width as usize * v.camera.height as usize;
            if v.rgb.len() == pixels {
                pixels
            } else {
                0
            }
        };
        let mut ends = Vec::with_capacity(data.views.len());
        let mut total = 0usize;
        for v in &data.views {
            total += drawn(v);
            ends.push(total);
        }
        let scene_bg = data.scene.background();
        let mut out = Vec::with_capacity(n);
        for _ in 0..n.saturating_mul(128) {
            if out.len() == n || total == 0 {
                break;
            }
            let k = rng.below(total);
            let vi = ends.partition_point(|&e| e <= k);
            let v = &data.views[vi];
            let px = k - (ends[vi] - drawn(v));
            if !v.kept(px) {
                continue;
            }
            let (x, y) = ((px % v.camera.width as usize) as u32, (px / v.camera.width as usize) as u32);
            let (o, d) = match how.jitter {
                true => v.ray_at(x as f32 + rng.f32(), y as f32 + rng.f32()),
                false => v.ray(x, y),
            };
            let (o, d) = camera(vi, o, d);
            let Some(mut ray) = Ray::new(&data.scene, o, d) else { continue };
            if how.footprint {
                ray = ray.with_footprint(&data.scene, v.camera.pixel_angle(), rng.f32() * std::f32::consts::TAU);
            }
            let mut s = Sample { view: vi as u32, ..Sample::on_scene(&data.scene, ray, v.rgb[px]) };
            let alpha = if how.random_background > 0.0 { v.alpha.get(px) } else { None };
            if let Some(&a) = alpha.filter(|_| rng.f32() < how.random_background) {
                s.bg = [rng.f32(), rng.f32(), rng.f32()];
                s.rgb = std::array::from_fn(|c| s.rgb[c] + (1.0 - a) * (s.bg[c] - scene_bg));
            }
            out.push(s);
        }
        out
    }
}

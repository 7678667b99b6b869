//! Rendering one ray: coarse pass over stratified samples, then (with a
//! fine network) a fine pass over coarse + importance samples, composited
//! front to back with early ray termination. With an occupancy grid
//! ([`crate::occupancy`]) both passes skip the samples in empty cells.
//!
//! The march ([`march`]) is written once over a numeric path
//! ([`NumericPath`], in [`path`]); [`F32`] and [`Fixed`] are its two
//! implementations. [`F32Renderer`] renders [`Scheme::F32`] models,
//! [`FixedRenderer`] renders the integer schemes with no float operation
//! per sample (per-ray setup converts the ray to fixed point once).
//!
//! [`Scheme::F32`]: crate::format::Scheme::F32

mod f32_path;
mod fixed_path;
mod march;
pub mod path;

pub use f32_path::F32;
pub use fixed_path::Fixed;
pub use path::{Kernel, NumericPath};

use crate::camera::Ray;
use crate::error::{Error, Result};
use crate::format::{Model, MAX_COARSE, MAX_FINE};
use crate::occupancy::{clip_to_box, occupied_box, CoarseOccupancy};
use crate::sampling::ray_key;
use glam::Vec3;

/// Render-time knobs; [`RenderOptions::from_model`] gives the model's defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Stratified samples for the coarse pass (2..=256).
    pub coarse: usize,
    /// Importance samples for the fine pass (0..=256; 0 renders the coarse
    /// network only; must be 0 if the model has no fine network).
    pub fine: usize,
    /// Early ray termination: a sample met with transmittance below this is
    /// not composited, nor any after it (in `[0, 1)`; 0 disables). Decided
    /// sample by sample, so the result does not depend on the block size.
    pub early_stop: f32,
    /// Jitter seed for stratified samples; `None` samples deterministically
    /// (evenly spaced, the paper's test-time sampling).
    pub seed: Option<u32>,
}

impl RenderOptions {
    /// The model's default sample counts, no early termination, no jitter.
    pub fn from_model(model: &Model<'_>) -> Self {
        Self { coarse: model.samples.coarse as usize, fine: model.samples.fine as usize, early_stop: 0.0, seed: None }
    }

    fn validate(&self, model: &Model<'_>) -> Result<()> {
        let fine_ok = self.fine <= MAX_FINE && (self.fine == 0 || model.fine.is_some());
        let stop_ok = self.early_stop.is_finite() && (0.0..1.0).contains(&self.early_stop);
        if !(2..=MAX_COARSE).contains(&self.coarse) || !fine_ok || !stop_ok {
            return Err(Error::InvalidSamples);
        }
        Ok(())
    }

    fn key(&self, pixel: (u32, u32)) -> Option<u32> {
        self.seed.map(|s| ray_key(s, pixel.0, pixel.1))
    }
}

/// The occupied box of a model's grid: `None` without a grid, `Some(None)`
/// if no cell is occupied.
type OccBox = Option<Option<([f32; 3], [f32; 3])>>;

fn occ_box(model: &Model<'_>) -> OccBox {
    // in an unbounded scene the grid is in contracted space: no box in `t`
    model.grid.as_ref().filter(|_| model.scene.unbounded.is_none()).map(occupied_box)
}

/// The coarse occupancy level, for models where runs of samples can be
/// ruled out by the cells at their ends: not in an unbounded scene, whose
/// contracted rays are curves.
fn coarse_level(model: &Model<'_>) -> Option<CoarseOccupancy> {
    model.grid.as_ref().filter(|_| model.scene.unbounded.is_none()).map(CoarseOccupancy::new)
}

/// What every renderer offers: a pixel type and a per-ray entry point
/// that works in caller-provided scratch memory `S` (of any block size).
pub trait RayRenderer<S> {
    /// The pixel this path produces.
    type Pixel: Copy + Default;
    /// The model being rendered.
    fn model(&self) -> &Model<'_>;
    /// Renders the world-space ray `origin + t·dir` (`dir` with camera-space
    /// `z = −1`, as [`crate::Camera::ray`] gives); `pixel` keys the jitter.
    /// A non-finite or degenerate ray, or one that misses the scene bounds,
    /// renders as the background at `far`.
    fn render_ray(&self, origin: Vec3, dir: Vec3, pixel: (u32, u32), scratch: &mut S) -> Self::Pixel;
}

/// Working memory of a renderer on path `P` for blocks of `B` samples:
/// f32 about 5 KiB + `B` · 2.4 KiB (≈ 25 KiB for the default `B = 8`);
/// fixed point about 7 KiB + `B` · 4.7 KiB + 2 KiB (≈ 47 KiB for `B = 8`,
/// ≈ 14 KiB for `B = 1`).
#[derive(Clone)]
pub struct Scratch<P: NumericPath, const B: usize = 8> {
    t_coarse: [P::T; MAX_COARSE],
    w_coarse: [P::W; MAX_COARSE],
    cdf: [P::Cdf; MAX_COARSE],
    t_fine: [P::T; MAX_FINE],
    t_all: [P::T; MAX_COARSE + MAX_FINE],
    block: P::Block<B>,
    /// Network evaluations performed since creation (for samples/ray).
    pub evaluations: u64,
}

impl<P: NumericPath, const B: usize> Default for Scratch<P, B> {
    fn default() -> Self {
        Self {
            t_coarse: [P::T::default(); MAX_COARSE],
            w_coarse: [P::W::default(); MAX_COARSE],
            cdf: [P::Cdf::default(); MAX_COARSE],
            t_fine: [P::T::default(); MAX_FINE],
            t_all: [P::T::default(); MAX_COARSE + MAX_FINE],
            block: P::Block::default(),
            evaluations: 0,
        }
    }
}

/// Working memory of [`F32Renderer`].
pub type ScratchF32<const B: usize = 8> = Scratch<F32, B>;
/// Working memory of [`FixedRenderer`].
pub type ScratchFixed<const B: usize = 8> = Scratch<Fixed, B>;

/// A renderer of one model on numeric path `P`, with its options and
/// occupancy fixed at creation.
#[derive(Clone, Copy, Debug)]
pub struct Renderer<'m, 'a, P: NumericPath> {
    model: &'m Model<'a>,
    opts: RenderOptions,
    /// `opts.early_stop` as a transmittance of the path.
    early_stop: P::W,
    /// The scene's far plane in the path's format: the depth of empty space.
    far: P::T,
    occ_box: OccBox,
    coarse: Option<CoarseOccupancy>,
}

/// The f32 reference path.
pub type F32Renderer<'m, 'a> = Renderer<'m, 'a, F32>;
/// The integer-only fixed-point path (int16 and int8 models).
pub type FixedRenderer<'m, 'a> = Renderer<'m, 'a, Fixed>;

impl<'m, 'a, P: NumericPath> Renderer<'m, 'a, P> {
    /// A renderer for `model`; fails with [`Error::WrongNumericPath`] if
    /// the path does not render the model's scheme, [`Error::InvalidScale`]
    /// if an int8 layer could overflow its i32 accumulator and
    /// [`Error::InvalidSamples`] for bad options.
    pub fn new(model: &'m Model<'a>, opts: RenderOptions) -> Result<Self> {
        P::check(model)?;
        opts.validate(model)?;
        Ok(Self {
            model,
            opts,
            early_stop: P::early_stop(opts.early_stop),
            far: P::t(model.scene.far),
            occ_box: occ_box(model),
            coarse: coarse_level(model),
        })
    }

    /// With `false`, the march tests every sample's grid cell instead of
    /// first ruling out runs of samples with the coarse level
    /// ([`CoarseOccupancy`], on by default). The pixels are the same
    /// either way; only the time differs.
    pub fn with_coarse_skipping(mut self, on: bool) -> Self {
        // on: keep the level `new` built (or build it again after an off)
        self.coarse = if on { self.coarse.or_else(|| coarse_level(self.model)) } else { None };
        self
    }

    /// The per-ray entry point ([`RayRenderer::render_ray`]).
    pub fn render_ray_in<const B: usize>(
        &self,
        origin: Vec3,
        dir: Vec3,
        pixel: (u32, u32),
        s: &mut Scratch<P, B>,
    ) -> P::Pixel {
        match Ray::new(&self.model.scene, origin, dir) {
            Some(ray) => P::render(self, &ray, self.opts.key(pixel), s),
            None => self.background(),
        }
    }

    /// The range of `t` worth sampling on `ray`: all of it without a grid,
    /// the part inside the occupied box with one, `None` if the ray misses it.
    fn occupied_span(&self, ray: &Ray) -> Option<(f32, f32)> {
        match &self.occ_box {
            None => Some((f32::NEG_INFINITY, f32::INFINITY)),
            Some(None) => None,
            Some(Some(b)) => clip_to_box(b, ray.norm_origin.to_array(), ray.norm_dir.to_array()),
        }
    }

    /// The pixel of a ray that meets nothing: the background at `far`.
    fn background(&self) -> P::Pixel {
        P::finish(&P::Compositor::default(), self.model.scene.white_background, self.far)
    }
}

impl<'m, 'a, P: NumericPath, const B: usize> RayRenderer<Scratch<P, B>> for Renderer<'m, 'a, P> {
    type Pixel = P::Pixel;

    fn model(&self) -> &Model<'_> {
        self.model
    }

    fn render_ray(&self, origin: Vec3, dir: Vec3, pixel: (u32, u32), s: &mut Scratch<P, B>) -> P::Pixel {
        self.render_ray_in(origin, dir, pixel, s)
    }
}

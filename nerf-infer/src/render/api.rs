//! What a renderer takes and offers: its options and the per-ray entry
//! point every numeric path implements.

use crate::error::{Error, Result};
use crate::format::{max_coarse, Model, MAX_FINE};
use crate::sampling::ray_key;
use glam::Vec3;

/// Render-time knobs; [`RenderOptions::from_model`] gives the model's defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Stratified samples for the coarse pass (2..=256 with a fine pass,
    /// 2..=1024 without); with a proposal grid, the samples that composite
    /// it ([`crate::proposal`]).
    pub coarse: usize,
    /// Importance samples for the fine pass (0..=256; 0 renders the coarse
    /// network only; must be 0 if the model has neither a fine network nor
    /// a proposal grid); with a proposal grid, the network's samples drawn
    /// from its weights (0..=255; 0: the network at the stratified samples).
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

    pub(super) fn validate(&self, model: &Model<'_>) -> Result<()> {
        // with a proposal grid the importance samples and the last stratified one share the fine buffer
        let fine_ok = match model.proposal {
            Some(_) => self.fine < MAX_FINE,
            None => self.fine <= MAX_FINE && (self.fine == 0 || model.fine.is_some()),
        };
        let stop_ok = self.early_stop.is_finite() && (0.0..1.0).contains(&self.early_stop);
        // importance samples need two bins of weights: three coarse samples
        let least = if self.fine > 0 { 3 } else { 2 };
        if !(least..=max_coarse(self.fine)).contains(&self.coarse) || !fine_ok || !stop_ok {
            return Err(Error::InvalidSamples);
        }
        Ok(())
    }

    pub(super) fn key(&self, pixel: (u32, u32)) -> Option<u32> {
        self.seed.map(|s| ray_key(s, pixel.0, pixel.1))
    }
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

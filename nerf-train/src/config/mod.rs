//! Training configuration: the model's shape (as the paper and its
//! ablations vary it) and the optimiser's settings, with named presets.

use crate::mlp::Mlp;
use nerf_infer::features::{geometric_resolutions, FeatureGrid, MAX_FEATURES, MAX_LEVELS, MAX_LOG2_TABLE, MAX_RES};
use nerf_infer::format::{Encoding, Samples, Topology};
use serde::{Deserialize, Serialize};
use std::num::{NonZeroU16, NonZeroU8};

pub mod json;
mod off;
mod presets;
mod sections;
mod validate;
pub use presets::Preset;
pub use sections::{
    FeatureConfig, GridConfig, LossConfig, ModelConfig, OptimiserConfig, PerPhotoConfig, SamplingConfig,
};

/// Most rays per batch (and per chunk) a configuration may ask for.
pub const MAX_BATCH_RAYS: usize = 1 << 20;

/// Everything that defines a training run except the data, by section.
/// A `--config` file writes it nested (`{"sampling": {"n_coarse": 64}}`)
/// or flat (`{"n_coarse": 64}`, each field by its flat name,
/// [`json::flat_names`]): [`Self::overlay`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrainConfig {
    /// The network.
    pub model: ModelConfig,
    /// The learned feature grid.
    pub features: FeatureConfig,
    /// Rays and samples.
    pub sampling: SamplingConfig,
    /// The occupancy grid.
    pub grid: GridConfig,
    /// The optimiser.
    pub optimiser: OptimiserConfig,
    /// The loss.
    pub loss: LossConfig,
    /// The corrections fitted per training photo.
    pub per_photo: PerPhotoConfig,
}

/// The default preset's ([`Preset::default`]): what `nerf train` trains
/// without `--preset`, and the fields a serialised configuration leaves
/// out when it is read on its own (a `--config` file's missing fields keep
/// the chosen preset's: [`Self::overlay`]).
impl Default for TrainConfig {
    fn default() -> Self {
        Preset::default().config()
    }
}

impl TrainConfig {
    /// Most table entries per level, as a power of two, that
    /// [`Self::fit_features_to`] grows a feature grid's table to
    /// (instant-ngp's largest: 2¹⁹ entries, 4 MiB of f32 per level of 2).
    pub const FITTED_LOG2_TABLE: u8 = 19;

    /// Resolvable cells (two per pixel footprint) per stratified sample
    /// that [`Self::fit_samples_to`] aims for along the bounds' longest side.
    pub const FITTED_CELLS_PER_SAMPLE: u32 = 4;

    /// The encoding this config trains.
    pub fn encoding(&self) -> Encoding {
        Encoding {
            pos_freqs: self.model.pos_freqs,
            dir_freqs: self.model.dir_freqs,
            include_input: self.model.include_input || self.model.pos_freqs == 0,
            raw_frac_bits: 12,
            grid_dim: self.features.levels.map_or(0, |l| l.get()) * self.features.width,
        }
    }

    /// The feature grid's shape (empty table), if the config has one.
    pub fn feature_grid(&self) -> Option<FeatureGrid<'static>> {
        self.features.levels.map(|levels| FeatureGrid {
            width: self.features.width,
            log2_table: self.features.log2_table,
            frac_bits: 0,
            resolutions: geometric_resolutions(levels.get() as usize, self.features.min_res, self.features.max_res),
            table: &[],
            narrow: None,
        })
    }

    /// The network (and feature grid) this config trains.
    ///
    /// # Panics
    /// `self` must pass [`TrainConfig::validate`].
    pub fn mlp(&self) -> Mlp {
        Mlp::new(self.topology(), self.encoding()).with_features(self.feature_grid())
    }

    /// The network shape this config trains.
    pub fn topology(&self) -> Topology {
        Topology {
            depth: self.model.depth,
            width: self.model.width,
            skip_mask: self.model.skips.iter().fold(0u16, |m, &s| m | 1u16.checked_shl(s as u32).unwrap_or(0)),
            view_dependent: self.model.view_dependent,
            view_width: if self.model.view_dependent { self.model.view_width } else { 0 },
        }
    }

    /// Default sample counts recorded in the model: with a proposal grid,
    /// [`SamplingConfig::n_main_render`] network samples (`n_main` if
    /// `None`); without one, [`SamplingConfig::n_fine`] (0 if `None`).
    pub fn samples(&self) -> Samples {
        let s = &self.sampling;
        let fine = match (s.proposal_res, s.n_main_render) {
            (None, _) => s.n_fine.map_or(0, NonZeroU16::get),
            (Some(_), None) => s.n_main,
            (Some(_), Some(n)) => n.get(),
        };
        Samples { coarse: s.n_coarse, fine }
    }

    /// The proposal grid's cells per axis that `nerf train` gives unbounded
    /// and forward-facing scenes ([`SamplingConfig::proposal_res`]).
    pub const PROPOSAL_RES: NonZeroU16 = NonZeroU16::new(64).unwrap();

    /// The feature grid's levels where [`Self::fit_features_to`] sizes it
    /// to the photos (unless the configuration names `features.levels`):
    /// 16, instant-ngp's, in place of the preset's 8, so that the levels
    /// stay about as close together. `nerf train` gives them to a
    /// forward-facing scene's sized grid (flower at 1008×756: 1.45× per level
    /// from 16 to 4 096 cells instead of 2.2×, +0.27 dB at equal time) and to
    /// an object scene's where 8 levels would be 2× apart or more (lego at
    /// 800×800, 16 to 2 048 cells: +0.58 dB in 60 minutes); docs/EXPERIMENTS.md,
    /// "The paper's protocol".
    pub const SIZED_LEVELS: NonZeroU8 = NonZeroU8::new(16).unwrap();

    /// The stratified samples per ray compositing the proposal grid where
    /// `nerf train` turns it on ([`SamplingConfig::n_coarse`], unless the
    /// configuration names it): 128, with the presets' 32 network samples
    /// ([`SamplingConfig::n_main`]). Measured against 192 and 48 on bird and fox in
    /// docs/RESULTS.md, "Configurations compared on a capture".
    pub const PROPOSAL_COARSE: u16 = 128;

    /// The distortion loss's weight ([`LossConfig::distortion`]) where `nerf
    /// train` turns the proposal grid on, in unbounded and forward-facing
    /// scenes (unless the configuration names it): 0.001, measured against
    /// 0 on bird, fox and the built-in room and forward-facing capture in
    /// docs/RESULTS.md, "Configurations compared on a capture".
    pub const PROPOSAL_DISTORTION: f32 = 0.001;

    /// The network samples per ray that a model renders with by default
    /// ([`SamplingConfig::n_main_render`]) where `nerf train` turns the
    /// proposal grid on in an unbounded scene (unless the configuration
    /// names it or `sampling.n_main`; a forward-facing scene renders at the
    /// 32 it trains with): 16 of the 32 it trains with. On bird, fox and the
    /// built-in room a model trained at 32 renders 0.23–0.28 dB lower at 16
    /// in about 0.6 of the time, and a model trained at 16 scores 0.6–2.2 dB
    /// lower than one trained at 32
    /// (docs/RESULTS.md, "The network's samples per ray in training" and
    /// "The network's samples per ray with a proposal grid").
    pub const PROPOSAL_RENDER_MAIN: NonZeroU16 = NonZeroU16::new(16).unwrap();
}

#[cfg(test)]
mod tests;

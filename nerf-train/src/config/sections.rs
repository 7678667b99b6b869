//! The configuration's sections, one per part of a run: the network, the
//! feature grid, the rays and samples, the occupancy grid, the optimiser,
//! the loss and the corrections fitted per photo. A section read on its own takes the fields it leaves out
//! from the default preset; a `--config` file's sections keep the chosen
//! preset's ([`TrainConfig::overlay`]).

use serde::{Deserialize, Serialize};
use std::num::{NonZeroU16, NonZeroU8};

use super::{off, TrainConfig};

/// The network: the encodings of position and direction, the trunk and
/// the view branch.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModelConfig {
    /// Frequencies `L` of the position encoding (0 = no encoding, raw xyz).
    pub pos_freqs: u8,
    /// Frequencies `L` of the direction encoding.
    pub dir_freqs: u8,
    /// Include the raw coordinate in γ (always on when `pos_freqs = 0`).
    pub include_input: bool,
    /// Trunk layers.
    pub depth: u8,
    /// Trunk width.
    pub width: u16,
    /// Trunk layers (≥ 1) that also take γ(x) as input (the paper: `[5]`).
    pub skips: Vec<u8>,
    /// View-dependent colour branch (the paper: on).
    pub view_dependent: bool,
    /// Width of the view layer (the paper: 128).
    pub view_width: u16,
}

/// The learned feature grid in front of the trunk (instant-ngp's
/// multiresolution hash encoding), and how samples read it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FeatureConfig {
    /// Levels of the learned feature grid in front of the trunk (1..=16;
    /// `None`, 0 in JSON: no feature grid). Needs one network
    /// (`sampling.n_fine` `None`, 0 in JSON).
    #[serde(with = "off")]
    pub levels: Option<NonZeroU8>,
    /// Values per level (1..=8; `levels × width` ≤ 32).
    pub width: u8,
    /// Table entries per level: `2^log2_table` (1..=22).
    pub log2_table: u8,
    /// Coarsest level's cells per axis.
    pub min_res: u16,
    /// Finest level's cells per axis (levels in between: geometric).
    pub max_res: u16,
    /// With a feature grid, outside forward-facing scenes: each sample's
    /// features are the mean of the grid's values at three points spread
    /// across its pixel's footprint (`nerf_infer::format::Footprint`; three
    /// lookups per sample instead of one), so a field fitted to pixels that
    /// average what they cover renders other views' pixels as averages too.
    pub footprint: bool,
    /// With `footprint`: the share of the run (`progress`, steps or
    /// minutes, in `[0, 1)`) trained on lines before the footprint starts.
    /// The first steps, with many samples per ray before the occupancy
    /// grid has emptied space, cost the most, and what the footprint
    /// refines (detail across a pixel) is not there yet.
    pub footprint_from: f32,
}

/// Rays and samples: how many rays a step takes, how many samples each,
/// and where they are placed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SamplingConfig {
    /// Coarse samples per ray `N_c` (2..=1024; 3..=256 with a fine network).
    pub n_coarse: u16,
    /// Fine samples per ray `N_f` (`None`, 0 in JSON: one network, no
    /// hierarchical sampling).
    #[serde(with = "off")]
    pub n_fine: Option<NonZeroU16>,
    /// Rays per optimisation step.
    pub batch_rays: usize,
    /// Rays per parallel work item (memory vs. scheduling granularity).
    pub chunk_rays: usize,
    /// Share of the rays, in `[0, 1]`, through photos with an alpha
    /// channel (a Blender-layout dataset, `transforms_{split}.json`) that
    /// train on a random background colour, as instant-ngp does with all of
    /// them: the photo's pixel and the render are both composited on it, so
    /// density left in empty space costs loss instead of hiding against a
    /// white background. The other rays, and photos without alpha, train
    /// on the scene's background.
    pub random_background: f32,
    /// Each training ray through a uniformly random point of its pixel
    /// instead of the pixel's centre (instant-ngp's practice). Off in every
    /// preset: `eval` and `render` trace pixel centres, and on lego the
    /// field fitted to jittered rays scores lower on the held-out views
    /// (docs/EXPERIMENTS.md).
    pub pixel_jitter: bool,
    /// Cells per axis (`1..=128`; `None`, 0 in JSON: none) of the proposal
    /// grid that places the network's samples ([`crate::sampling::proposal`]):
    /// [`Self::n_coarse`] stratified samples composite it, and the network
    /// is evaluated at [`Self::n_main`] samples drawn from its weights and
    /// the last stratified one (minus those in empty occupancy cells). `nerf train` turns it on at
    /// [`TrainConfig::PROPOSAL_RES`] for unbounded and forward-facing scenes
    /// unless the configuration names it; object scenes keep the
    /// occupancy grid's stratified samples.
    #[serde(with = "off")]
    pub proposal_res: Option<NonZeroU16>,
    /// With a proposal grid: the network's samples per ray drawn from its
    /// weights (`1..=255`; 32 in every preset), besides the last
    /// stratified one.
    pub n_main: u16,
    /// With a proposal grid: the network's samples per ray the model
    /// renders with unless told otherwise, written to its sample counts
    /// (`1..=255`; `None`, 0 in JSON: [`Self::n_main`], as in every
    /// preset). Fewer than `n_main` trades PSNR for time per ray; `nerf
    /// train` sets [`TrainConfig::PROPOSAL_RENDER_MAIN`] where it turns the
    /// proposal grid on, unless the configuration names it or `n_main`.
    #[serde(with = "off")]
    pub n_main_render: Option<NonZeroU16>,
}

/// The occupancy grid that keeps samples only in occupied cells, and its
/// updates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GridConfig {
    /// Occupancy grid cells per axis (`None`, 0 in JSON: no grid). With a
    /// grid the run has one network (`sampling.n_fine` `None`) whose
    /// `sampling.n_coarse` stratified samples are kept only in occupied
    /// cells, in training and in the exported model.
    #[serde(with = "off")]
    pub res: Option<NonZeroU16>,
    /// Steps before the first grid update (until then every cell counts as
    /// occupied).
    pub warmup: usize,
    /// Steps between grid updates.
    pub every: usize,
    /// A cell stays occupied while its density would make a sample of the
    /// default step (bounds diagonal / `sampling.n_coarse`) at least this opaque.
    pub alpha: f32,
}

/// Adam's settings, the learning rate's schedule, the table's weight
/// decay and the parameters' average.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OptimiserConfig {
    /// Initial Adam learning rate.
    pub lr: f32,
    /// Final learning rate as a fraction of `lr`; the rate decays
    /// exponentially over the run (the paper: 5e-4 → 5e-5 over 250k steps).
    pub lr_final_ratio: f32,
    /// Steps over which the exponential decay reaches `lr_final_ratio`
    /// (0: the length of the run, from `--iters` or `--minutes`).
    pub lr_decay_steps: usize,
    /// Adam β₁.
    pub beta1: f32,
    /// Adam β₂.
    pub beta2: f32,
    /// Adam ε (the paper: 1e-7).
    pub eps: f32,
    /// Decoupled weight decay λ of the feature grid's table (AdamW; 0:
    /// off): each step scales every table value by `1 − lr·λ` before
    /// Adam's update, so entries that rays stop asking for fade to zero.
    pub feature_decay: f32,
    /// Decay per step (`[0, 1)`; 0: off) of the moving average of the
    /// parameters that the run's model takes instead of its last step's
    /// (`Trainer::averaged`): `a ← β·a + (1 − β)·p` after each step, with
    /// `β = min(ema_decay, (1 + n)/(10 + n))` at step `n`, so that a short
    /// run averages its last tenth or so, a long one its last `1/(1 − β)`
    /// steps.
    pub ema_decay: f32,
    /// With a proposal grid: the learning rate of its log-densities (Adam,
    /// decaying as `lr` does).
    pub proposal_lr: f32,
}

/// What the loss adds to the mean squared colour error, and what it
/// compares.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LossConfig {
    /// Weight λ of the distortion loss (mip-NeRF 360, eq. 15; 0: off),
    /// added to the mean squared colour error as `λ · mean over rays of
    /// Σᵢⱼ wᵢwⱼ|sᵢ − sⱼ| + ⅓ Σᵢ wᵢ²Δsᵢ`, `s` the ray's normalised
    /// coordinate (even in `t` within the bounds, in `1/t` beyond them in an
    /// unbounded scene): it pulls each ray's weight into one short stretch,
    /// clearing the fog and floaters a capture with surroundings grows.
    pub distortion: f32,
    /// Weight μ of an L1 penalty on the optical depth (0: off), added to
    /// the mean squared colour error as `μ · mean over rays of Σᵢ
    /// max(σᵢ, 0)·δᵢ` (the ray's last, unbounded interval left out): density
    /// that no photo needs (inside solids, below surfaces the cameras never
    /// see from the side) fades, where the colour loss keeps what a photo shows.
    pub density_l1: f32,
    /// Distance `d₀` from the camera (world units: in a fitted capture the
    /// median camera is 1 from the centre) within which a sample's gradient
    /// is scaled by `(d/d₀)²` ("Floaters No More", Philip & Deschaintre
    /// 2023): space right in front of a lens covers many pixels of that one
    /// photo and few of any other, so the colour loss would otherwise grow
    /// floaters there that no other view explains. 0: off (every preset).
    /// Runs with one network only (`sampling.n_fine` `None`); forward-facing
    /// scenes, whose rays run in NDC, are left alone.
    pub near_gradient: f32,
    /// Transmittance, in `[0, 1)`, under which a training sample is left
    /// out of the backward pass (0: off, every preset): the samples of the
    /// coarse or only pass behind that much opacity on their ray (light
    /// left `1 − Σ w` of the samples before them) carry a gradient at most
    /// that share of their ray's, and the backward pass and the feature
    /// table's scatter skip them (instant-ngp ends a training ray at 10⁻⁴),
    /// except in a chunk that would keep more than 80 % of its samples,
    /// which takes them all. Applies with a feature grid, in runs that do
    /// not refine poses.
    pub backward_transmittance: f32,
}

/// The corrections fitted per training photo beside the model, each off
/// in every preset: a colour correction for photos that differ in
/// exposure or white balance, a pose correction for poses a little off.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PerPhotoConfig {
    /// Fit a colour correction per training photo beside the model
    /// ([`crate::per_photo::appearance`]: `A·c + b` on each pixel's composited colour)
    /// for photos that differ in exposure or white balance; the model and
    /// the held-out scores use the field's own colour, the photos' mean.
    /// Off in every preset.
    pub appearance: bool,
    /// Fit a pose correction per training photo beside the model
    /// ([`crate::per_photo::pose`]: a turn about the camera's centre and a shift),
    /// for captures whose poses are a little off; the held-out photos keep
    /// their poses. Object and unbounded scenes (forward-facing scenes keep
    /// their poses); runs with one network only (`sampling.n_fine` `None`).
    /// Off in every preset.
    pub pose_refine: bool,
    /// With [`Self::pose_refine`]: the learning rate of the photos' pose
    /// corrections (Adam, radians and world units, decaying as
    /// `optimiser.lr` does; 10⁻⁴ in every preset, where nerfacto's camera
    /// optimiser has 6·10⁻⁴: on bird and fox 10⁻⁴ measured better,
    /// docs/EXPERIMENTS.md).
    pub pose_lr: f32,
}

/// Each section's `Default`: the default preset's section.
macro_rules! default_preset_section {
    ($($section:ty => $field:ident),*) => {$(
        /// The default preset's ([`TrainConfig::default`]).
        impl Default for $section {
            fn default() -> Self {
                TrainConfig::default().$field
            }
        }
    )*};
}

default_preset_section!(
    ModelConfig => model,
    FeatureConfig => features,
    SamplingConfig => sampling,
    GridConfig => grid,
    OptimiserConfig => optimiser,
    LossConfig => loss,
    PerPhotoConfig => per_photo
);

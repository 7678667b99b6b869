//! Training configuration: the model's shape (as the paper and its
//! ablations vary it) and the optimiser's settings, with named presets.

use crate::mlp::Mlp;
use nerf_infer::features::{geometric_resolutions, FeatureGrid, MAX_FEATURES, MAX_LEVELS, MAX_LOG2_TABLE, MAX_RES};
use nerf_infer::format::{Encoding, Samples, Topology};
use serde::{Deserialize, Serialize};

/// Most rays per batch (and per chunk) a configuration may ask for.
pub const MAX_BATCH_RAYS: usize = 1 << 20;

/// Everything that defines a training run except the data.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrainConfig {
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
    /// Coarse samples per ray `N_c` (2..=1024; 2..=256 with a fine network).
    pub n_coarse: u16,
    /// Fine samples per ray `N_f` (0: one network, no hierarchical sampling).
    pub n_fine: u16,
    /// Rays per optimisation step.
    pub batch_rays: usize,
    /// Rays per parallel work item (memory vs. scheduling granularity).
    pub chunk_rays: usize,
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
    /// Occupancy grid cells per axis (0: no grid). With a grid the run has
    /// one network (`n_fine = 0`) whose `n_coarse` stratified samples are
    /// kept only in occupied cells, in training and in the exported model.
    pub grid_res: u16,
    /// Steps before the first grid update (until then every cell counts as
    /// occupied).
    pub grid_warmup: usize,
    /// Steps between grid updates.
    pub grid_every: usize,
    /// A cell stays occupied while its density would make a sample of the
    /// default step (bounds diagonal / `n_coarse`) at least this opaque.
    pub grid_alpha: f32,
    /// Levels of the learned feature grid in front of the trunk (0: none;
    /// 1..=16). Needs one network (`n_fine = 0`).
    pub feature_levels: u8,
    /// Values per level (1..=8; `levels × width` ≤ 32).
    pub feature_width: u8,
    /// Table entries per level: `2^feature_log2_table` (1..=22).
    pub feature_log2_table: u8,
    /// Coarsest level's cells per axis.
    pub feature_min_res: u16,
    /// Finest level's cells per axis (levels in between: geometric).
    pub feature_max_res: u16,
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
    /// preset: `eval` and `render` trace pixel centres, and on lego at
    /// 100×100 the field fitted to jittered rays scores 1.8 dB lower on the
    /// held-out views (docs/EXPERIMENTS.md).
    pub pixel_jitter: bool,
    /// Weight λ of the distortion loss (mip-NeRF 360, eq. 15; 0: off),
    /// added to the mean squared colour error as `λ · mean over rays of
    /// Σᵢⱼ wᵢwⱼ|sᵢ − sⱼ| + ⅓ Σᵢ wᵢ²Δsᵢ`, `s` the ray's normalised
    /// coordinate (even in `t` within the bounds, in `1/t` beyond them in an
    /// unbounded scene): it pulls each ray's weight into one short stretch,
    /// clearing the fog and floaters a capture with surroundings grows.
    pub distortion: f32,
    /// Decoupled weight decay λ of the feature grid's table (AdamW; 0:
    /// off): each step scales every table value by `1 − lr·λ` before
    /// Adam's update, so entries that rays stop asking for fade to zero.
    pub feature_decay: f32,
    /// Weight μ of an L1 penalty on the optical depth (0: off), added to
    /// the mean squared colour error as `μ · mean over rays of Σᵢ
    /// max(σᵢ, 0)·δᵢ` (the ray's last, unbounded interval left out): density
    /// that no photo needs (inside solids, below surfaces the cameras never
    /// see from the side) fades, where the colour loss keeps what a photo shows.
    pub density_l1: f32,
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
    /// Decay per step (`[0, 1)`; 0: off) of the moving average of the
    /// parameters that the run's model takes instead of its last step's
    /// (`Trainer::averaged`): `a ← β·a + (1 − β)·p` after each step, with
    /// `β = min(ema_decay, (1 + n)/(10 + n))` at step `n`, so that a short
    /// run averages its last tenth or so, a long one its last `1/(1 − β)`
    /// steps.
    pub ema_decay: f32,
    /// Cells per axis (`0..=128`; 0: none) of the proposal grid that places
    /// the network's samples ([`crate::proposal`]): `n_coarse` stratified
    /// samples composite it, and the network is evaluated at `n_main`
    /// samples drawn from its weights and the last stratified one (minus
    /// those in empty occupancy cells). `nerf train` turns it on at
    /// [`Self::PROPOSAL_RES`] for unbounded and forward-facing scenes
    /// unless the configuration names it; object scenes keep the
    /// occupancy grid's stratified samples.
    pub proposal_res: u16,
    /// With a proposal grid: the network's samples per ray drawn from its
    /// weights (`1..=255`), besides the last stratified one.
    pub n_main: u16,
    /// With a proposal grid: the learning rate of its log-densities (Adam,
    /// decaying as `lr` does).
    pub proposal_lr: f32,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self::fast()
    }
}

impl TrainConfig {
    /// The paper's model: 8×256, skip at layer 5, L = 10/4, 64 + 128
    /// samples, 4096 rays per batch, lr 5e-4 decaying 10× over 250k steps.
    pub fn paper() -> Self {
        Self {
            pos_freqs: 10,
            dir_freqs: 4,
            include_input: true,
            depth: 8,
            width: 256,
            skips: vec![5],
            view_dependent: true,
            view_width: 128,
            n_coarse: 64,
            n_fine: 128,
            batch_rays: 4096,
            chunk_rays: 32,
            lr: 5e-4,
            lr_final_ratio: 0.1,
            lr_decay_steps: 250_000,
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-7,
            grid_res: 0,
            grid_warmup: 256,
            grid_every: 16,
            grid_alpha: 0.01,
            feature_levels: 0,
            feature_width: 2,
            feature_log2_table: 15,
            feature_min_res: 16,
            feature_max_res: 256,
            random_background: 0.0,
            pixel_jitter: false,
            distortion: 0.0,
            feature_decay: 0.0,
            density_l1: 0.0,
            footprint: false,
            footprint_from: 0.0,
            ema_decay: 0.0,
            proposal_res: 0,
            n_main: 48,
            proposal_lr: 0.05,
        }
    }

    /// The CPU preset without grids: 4×64, L = 8/2, 48 + 48 samples,
    /// 1024-ray batches, lr 5e-3 decaying 10× over the run. On lego at
    /// 100×100 it reaches 27.35 dB in 10 minutes on a 2-core workstation
    /// (README); the paper preset manages about 60 steps in that time
    /// (6 steps took 62.7 s).
    pub fn fast() -> Self {
        Self {
            pos_freqs: 8,
            dir_freqs: 2,
            depth: 4,
            width: 64,
            skips: vec![],
            view_width: 32,
            n_coarse: 48,
            n_fine: 48,
            batch_rays: 1024,
            lr: 5e-3,
            lr_decay_steps: 0,
            ..Self::paper()
        }
    }

    /// The fast preset with an occupancy grid (64³) in place of the coarse
    /// network: one 4×64 network, 192 stratified samples per ray of which
    /// only those in occupied cells are evaluated.
    pub fn grid() -> Self {
        Self { n_coarse: 192, n_fine: 0, grid_res: 64, ..Self::fast() }
    }

    /// The grid preset with a learned feature grid (instant-ngp's
    /// encoding: 8 levels of 2 values, 16..256 cells per axis, 2¹⁵ entries
    /// per level) in place of the frequency encoding (raw xyz beside it)
    /// and a 2×64 network; instant-ngp's optimiser settings (lr 1e-2,
    /// β₂ 0.99, ε 1e-15); the occupancy grid first updated at step 64 and
    /// every 64 steps, a cell kept while a default step through it would be
    /// at least 3 % opaque (`grid_alpha` 0.03: on lego the same int8 PSNR
    /// at half the samples per ray of 0.01, on fox 1.9–2.3 dB more in 5
    /// minutes; docs/EXPERIMENTS.md), and a tenth of the rays through photos
    /// with alpha on a random background (`random_background` 0.1: on
    /// lego no haze left in empty space, 5.5 samples per ray in int8 where
    /// runs without it ended at 6.4 to 25.4; docs/EXPERIMENTS.md). The
    /// learning rate decays 10× over the run: 100× gains 0.1–0.4 dB on lego
    /// in 10 minutes but loses 3 dB in one (docs/EXPERIMENTS.md). The
    /// second half of the run reads the grid across each pixel's footprint
    /// (`footprint`, `footprint_from` 0.5: on lego 0.35 dB more in 10
    /// minutes than without, over two seeds, and 0.57 dB less in one;
    /// docs/EXPERIMENTS.md). The model takes the average of the parameters
    /// over about the last thousand steps (`ema_decay` 0.999: on lego 0.16
    /// dB more at 20 000 steps, over two seeds; docs/EXPERIMENTS.md).
    pub fn features() -> Self {
        Self {
            depth: 2,
            width: 64,
            view_width: 64,
            pos_freqs: 0,
            dir_freqs: 4,
            lr: 1e-2,
            beta2: 0.99,
            eps: 1e-15,
            grid_warmup: 64,
            grid_every: 64,
            grid_alpha: 0.03,
            random_background: 0.1,
            feature_levels: 8,
            feature_width: 2,
            feature_log2_table: 15,
            feature_min_res: 16,
            feature_max_res: 256,
            footprint: true,
            footprint_from: 0.5,
            ema_decay: 0.999,
            ..Self::grid()
        }
    }

    /// The configuration `nerf train` uses without `--preset` (its feature
    /// grid then sized to the photos, [`Self::fit_features_to`]): [`Self::features`],
    /// the highest held-out PSNR per minute measured on lego and on the real
    /// captures (`scripts/captures.sh`: bird 30.42 dB against `fast`'s 28.98
    /// after 5 minutes at 1/8 size).
    pub fn default_preset() -> Self {
        Self::features()
    }

    /// A preset by name (`paper`, `fast`, `grid`, `features`).
    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "paper" => Some(Self::paper()),
            "fast" => Some(Self::fast()),
            "grid" => Some(Self::grid()),
            "features" => Some(Self::features()),
            _ => None,
        }
    }

    /// Most table entries per level, as a power of two, that
    /// [`Self::fit_features_to`] grows a feature grid's table to
    /// (instant-ngp's largest: 2¹⁹ entries, 4 MiB of f32 per level of 2).
    pub const FITTED_LOG2_TABLE: u8 = 19;

    /// Sizes the feature grid to photos that resolve `cells` per axis
    /// ([`Dataset::resolvable_cells`](crate::dataset::Dataset::resolvable_cells)):
    /// when `cells` is above `feature_max_res`, the finest level becomes
    /// `cells` (at most 4096) and the table gains a power of two of
    /// entries per doubling of it (at most 2^[`Self::FITTED_LOG2_TABLE`]).
    /// A grid already as fine, a grid of one level (whose only level is
    /// `feature_min_res`) or no grid is left alone; returns whether
    /// anything changed. The finest levels share each entry among more
    /// cells than before (8× the cells, 2× the entries per doubling); on
    /// lego at 800×800 the fitted grid (2048 cells, 2¹⁸ entries) gains
    /// 0.2 dB in 4 minutes where 2048 cells in 2¹⁵ entries lose 0.7
    /// (docs/EXPERIMENTS.md).
    pub fn fit_features_to(&mut self, cells: u32) -> bool {
        let cells = cells.min(MAX_RES as u32);
        let max = self.feature_max_res as u32;
        if self.feature_levels < 2 || cells <= max {
            return false;
        }
        let doublings = cells.div_ceil(max.max(1)).next_power_of_two().trailing_zeros() as u8;
        self.feature_max_res = cells as u16;
        self.feature_log2_table =
            self.feature_log2_table.max((self.feature_log2_table + doublings).min(Self::FITTED_LOG2_TABLE));
        true
    }

    /// Resolvable cells (two per pixel footprint) per stratified sample
    /// that [`Self::fit_samples_to`] aims for along the bounds' longest side.
    pub const FITTED_CELLS_PER_SAMPLE: u32 = 4;

    /// Sets the samples per ray for photos that resolve `cells` per axis
    /// ([`Dataset::resolvable_cells`](crate::dataset::Dataset::resolvable_cells)):
    /// one per [`Self::FITTED_CELLS_PER_SAMPLE`] of those cells (two pixel
    /// footprints) along the bounds' longest side, at most
    /// [`MAX_MARCH`](nerf_infer::format::MAX_MARCH), whether or not a
    /// feature grid is sized to them. Only a one-pass configuration with
    /// an occupancy grid is changed, and only upwards; returns whether
    /// anything changed. The occupancy grid's density threshold follows
    /// the step ([`Trainer::grid_threshold`](crate::train::Trainer::grid_threshold)):
    /// at 512 samples it is 512/192 times the preset's. On lego at 800×800
    /// (2048 cells) this is 512 samples per ray where the preset has 192
    /// (docs/EXPERIMENTS.md).
    pub fn fit_samples_to(&mut self, cells: u32) -> bool {
        let fitted = (cells / Self::FITTED_CELLS_PER_SAMPLE).min(nerf_infer::format::MAX_MARCH as u32) as u16;
        if self.grid_res == 0 || self.n_fine > 0 || fitted <= self.n_coarse {
            return false;
        }
        self.n_coarse = fitted;
        true
    }

    /// The encoding this config trains.
    pub fn encoding(&self) -> Encoding {
        Encoding {
            pos_freqs: self.pos_freqs,
            dir_freqs: self.dir_freqs,
            include_input: self.include_input || self.pos_freqs == 0,
            raw_frac_bits: 12,
            grid_dim: self.feature_levels * self.feature_width,
        }
    }

    /// The feature grid's shape (empty table), if the config has one.
    pub fn feature_grid(&self) -> Option<FeatureGrid<'static>> {
        (self.feature_levels > 0).then(|| FeatureGrid {
            width: self.feature_width,
            log2_table: self.feature_log2_table,
            frac_bits: 0,
            resolutions: geometric_resolutions(
                self.feature_levels as usize,
                self.feature_min_res,
                self.feature_max_res,
            ),
            table: &[],
            narrow: None,
        })
    }

    /// The network (and feature grid) this config trains.
    pub fn mlp(&self) -> Mlp {
        Mlp::new(self.topology(), self.encoding()).with_features(self.feature_grid())
    }

    /// The network shape this config trains.
    pub fn topology(&self) -> Topology {
        Topology {
            depth: self.depth,
            width: self.width,
            skip_mask: self.skips.iter().fold(0u16, |m, &s| m | 1u16.checked_shl(s as u32).unwrap_or(0)),
            view_dependent: self.view_dependent,
            view_width: if self.view_dependent { self.view_width } else { 0 },
        }
    }

    /// Default sample counts recorded in the model.
    pub fn samples(&self) -> Samples {
        let fine = if self.proposal_res > 0 { self.n_main } else { self.n_fine };
        Samples { coarse: self.n_coarse, fine }
    }

    /// The proposal grid's cells per axis that `nerf train` gives unbounded
    /// and forward-facing scenes ([`Self::proposal_res`]).
    pub const PROPOSAL_RES: u16 = 64;

    /// Checks ranges; the message names the offending field.
    pub fn validate(&self) -> Result<(), String> {
        let t = self.topology();
        if self.depth == 0 || self.width == 0 || self.width > 256 || t.layer_count() > 24 {
            return Err("depth must be 1..=20 and width 1..=256".into());
        }
        if self.view_dependent && (self.view_width == 0 || self.view_width > 256) {
            return Err("view_width must be 1..=256".into());
        }
        if self.pos_freqs > 16 || self.dir_freqs > 16 {
            return Err("pos_freqs and dir_freqs must be at most 16".into());
        }
        if self.skips.iter().any(|&s| s == 0 || s >= self.depth) {
            return Err("skips must name trunk layers 1..depth".into());
        }
        let most = nerf_infer::format::max_coarse(self.n_fine as usize);
        if !(2..=most).contains(&(self.n_coarse as usize)) || self.n_fine as usize > nerf_infer::format::MAX_FINE {
            return Err("n_coarse must be 2..=1024 (2..=256 with n_fine) and n_fine at most 256".into());
        }
        if self.proposal_res > 0 {
            if self.proposal_res > nerf_infer::proposal::MAX_PROPOSAL_RES || self.n_fine > 0 {
                return Err("proposal_res must be 0..=128, and 0 with n_fine".into());
            }
            if !(1..=255).contains(&self.n_main) || !(3..=256).contains(&self.n_coarse) {
                return Err("with a proposal grid, n_main must be 1..=255 and n_coarse 3..=256".into());
            }
            if !(self.proposal_lr.is_finite() && self.proposal_lr > 0.0) {
                return Err(format!("proposal_lr {} must be a finite rate > 0", self.proposal_lr));
            }
        }
        if self.batch_rays == 0 || self.chunk_rays == 0 {
            return Err("batch_rays and chunk_rays must be positive".into());
        }
        if self.batch_rays > MAX_BATCH_RAYS || self.chunk_rays > MAX_BATCH_RAYS {
            // activations kept for the backward pass: rays × samples × width × depth, f32, forward and gradient
            let samples = (self.n_coarse + self.n_fine) as f64;
            let gb = self.batch_rays as f64 * samples * self.width as f64 * self.depth as f64 * 8.0 / 1e9;
            return Err(format!(
                "batch_rays {} and chunk_rays {} must be at most {MAX_BATCH_RAYS} (this batch would hold about \
                 {gb:.0} GB of activations)",
                self.batch_rays, self.chunk_rays
            ));
        }
        if !(self.distortion.is_finite() && self.distortion >= 0.0) {
            return Err(format!("distortion {} must be a finite weight ≥ 0", self.distortion));
        }
        if !(self.density_l1.is_finite() && self.density_l1 >= 0.0) {
            return Err(format!("density_l1 {} must be a finite weight ≥ 0", self.density_l1));
        }
        if self.pixel_jitter && self.footprint && self.feature_levels > 0 {
            return Err("pixel_jitter and footprint together spread each ray across its pixel twice".into());
        }
        if !(0.0..1.0).contains(&self.ema_decay) {
            return Err(format!("ema_decay {} must be a decay per step in [0, 1)", self.ema_decay));
        }
        if !(0.0..1.0).contains(&self.footprint_from) {
            return Err(format!("footprint_from {} must be a share of the run in [0, 1)", self.footprint_from));
        }
        // every step scales the table by 1 − lr·feature_decay: it must stay in [0, 1]
        if !(self.feature_decay >= 0.0 && self.lr * self.feature_decay <= 1.0) {
            return Err(format!(
                "feature_decay {} must be ≥ 0 and at most 1/lr ({})",
                self.feature_decay,
                1.0 / self.lr
            ));
        }
        if !(0.0..=1.0).contains(&self.random_background) {
            return Err(format!("random_background {} must be a share of the rays in [0, 1]", self.random_background));
        }
        if self.grid_res > nerf_infer::occupancy::MAX_GRID_RES {
            return Err("grid_res must be at most 256".into());
        }
        if self.grid_res > 0
            && (self.n_fine > 0 || self.grid_every == 0 || self.grid_alpha.is_nan() || self.grid_alpha <= 0.0)
        {
            return Err("an occupancy grid needs n_fine = 0, grid_every > 0 and grid_alpha > 0".into());
        }
        if self.feature_levels > 0 {
            let f = self;
            let dim = f.feature_levels as usize * f.feature_width as usize;
            if f.feature_levels as usize > MAX_LEVELS || !(1..=8).contains(&f.feature_width) || dim > MAX_FEATURES {
                return Err("feature_levels must be 1..=16, feature_width 1..=8, their product at most 32".into());
            }
            if !(1..=MAX_LOG2_TABLE).contains(&f.feature_log2_table) {
                return Err("feature_log2_table must be 1..=22".into());
            }
            if f.feature_min_res == 0 || f.feature_max_res < f.feature_min_res || f.feature_max_res > MAX_RES {
                return Err("need 1 <= feature_min_res <= feature_max_res <= 4096".into());
            }
            if f.n_fine > 0 {
                return Err("a feature grid needs one network (n_fine = 0)".into());
            }
        }
        let pos = |v: f32| v.is_finite() && v > 0.0;
        if !pos(self.lr)
            || !pos(self.lr_final_ratio)
            || !pos(self.eps)
            || !(0.0..1.0).contains(&self.beta1)
            || !(0.0..1.0).contains(&self.beta2)
        {
            return Err("lr, lr_final_ratio, eps must be positive and betas in [0, 1)".into());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fitted_samples_only_ever_grow_and_only_in_one_pass_marches_over_a_grid() {
        let mut c = TrainConfig::features();
        // lego at 100×100 resolves 256 cells: the preset's 192 samples stay
        assert!(!c.fit_samples_to(256));
        assert_eq!(c.n_coarse, 192);
        // at 800×800, 2048 cells: one sample per four cells
        assert!(c.fit_samples_to(2048));
        assert_eq!(c.n_coarse, 512);
        assert!(c.validate().is_ok());
        assert!(!c.fit_samples_to(1024));
        assert_eq!(c.n_coarse, 512);
        // at most the march's capacity
        assert!(c.fit_samples_to(1 << 20));
        assert_eq!(c.n_coarse as usize, nerf_infer::format::MAX_MARCH);
        assert!(c.validate().is_ok());
        // no occupancy grid, or a fine pass: left alone
        for c in [TrainConfig::fast(), TrainConfig { grid_res: 0, ..TrainConfig::features() }] {
            let mut fitted = c.clone();
            assert!(!fitted.fit_samples_to(4096));
            assert_eq!(fitted, c);
        }
    }

    #[test]
    fn the_regularisers_weights_must_be_finite_and_not_negative() {
        let c = TrainConfig::features();
        let with = |feature_decay: f32, density_l1: f32| TrainConfig { feature_decay, density_l1, ..c.clone() };
        assert!(with(0.0, 0.0).validate().is_ok());
        assert!(with(0.1, 1e-5).validate().is_ok());
        // lr 1e-2: a decay of 100 scales the table by 0 each step, above it by less than 0
        assert!(with(100.0, 0.0).validate().is_ok());
        for (d, l1) in [(-0.1, 0.0), (f32::NAN, 0.0), (f32::INFINITY, 0.0), (101.0, 0.0), (0.0, -1e-5), (0.0, f32::NAN)]
        {
            let e = with(d, l1).validate().unwrap_err();
            assert!(e.contains(if l1 != 0.0 { "density_l1" } else { "feature_decay" }), "{e}");
        }
    }

    #[test]
    fn the_footprint_starts_at_a_share_of_the_run_in_0_to_1() {
        let with = |footprint_from: f32| TrainConfig { footprint_from, ..TrainConfig::features() };
        assert!(with(0.0).validate().is_ok() && with(0.5).validate().is_ok());
        for v in [-0.1, 1.0, f32::NAN] {
            assert!(with(v).validate().unwrap_err().contains("footprint_from"), "{v}");
        }
        // a jittered ray across its pixel, read again across its footprint
        let jittered = TrainConfig { pixel_jitter: true, ..TrainConfig::features() };
        assert!(jittered.validate().unwrap_err().contains("pixel_jitter"));
        assert!(TrainConfig { footprint: false, ..jittered }.validate().is_ok());
    }

    #[test]
    fn the_parameters_average_decays_in_0_to_1() {
        let with = |ema_decay: f32| TrainConfig { ema_decay, ..TrainConfig::features() };
        assert!(with(0.0).validate().is_ok() && with(0.999).validate().is_ok());
        for v in [-0.1, 1.0, 2.0, f32::NAN] {
            assert!(with(v).validate().unwrap_err().contains("ema_decay"), "{v}");
        }
    }

    #[test]
    fn fitting_the_feature_grid_only_ever_refines_it() {
        // 256 cells in 2^15 entries: 2048 cells are three doublings, three more powers of two of entries
        let mut c = TrainConfig::features();
        assert!(c.fit_features_to(2048));
        assert_eq!((c.feature_max_res, c.feature_log2_table), (2048, 18));
        assert!(c.validate().is_ok());
        // a grid as fine as the photos, or finer, is left alone
        for cells in [2048, 1024, 1] {
            assert!(!c.fit_features_to(cells));
            assert_eq!((c.feature_max_res, c.feature_log2_table), (2048, 18));
        }
        // at most MAX_RES cells and 2^19 entries; a table already larger keeps its size
        let mut c = TrainConfig::features();
        assert!(c.fit_features_to(1 << 20));
        assert_eq!((c.feature_max_res, c.feature_log2_table), (MAX_RES, TrainConfig::FITTED_LOG2_TABLE));
        let mut c = TrainConfig { feature_log2_table: 21, ..TrainConfig::features() };
        assert!(c.fit_features_to(512));
        assert_eq!((c.feature_max_res, c.feature_log2_table), (512, 21));
        // a configuration without a feature grid, or with one level (at feature_min_res), has nothing to fit
        for c in [TrainConfig::grid(), TrainConfig { feature_levels: 1, ..TrainConfig::features() }] {
            let mut fitted = c.clone();
            assert!(!fitted.fit_features_to(4096));
            assert_eq!(fitted, c);
        }
    }
}

//! The named configurations (`--preset`), and a configuration refined to
//! the photos it trains on (the feature grid's finest level, the samples
//! per ray).

use super::*;
use std::num::NonZeroU8;

impl TrainConfig {
    /// The paper's model: 8×256, skip at layer 5, L = 10/4, 64 + 128
    /// samples, 4096 rays per batch, lr 5e-4 decaying 10× over 250k steps.
    pub fn paper() -> Self {
        Self {
            model: ModelConfig {
                pos_freqs: 10,
                dir_freqs: 4,
                include_input: true,
                depth: 8,
                width: 256,
                skips: vec![5],
                view_dependent: true,
                view_width: 128,
            },
            features: FeatureConfig {
                levels: None,
                width: 2,
                log2_table: 15,
                min_res: 16,
                max_res: 256,
                footprint: false,
                footprint_from: 0.0,
            },
            sampling: SamplingConfig {
                n_coarse: 64,
                n_fine: NonZeroU16::new(128),
                n_main: 32,
                n_main_render: None,
                proposal_res: None,
                batch_rays: 4096,
                chunk_rays: 32,
                random_background: 0.0,
                pixel_jitter: false,
            },
            grid: GridConfig { res: None, warmup: 256, every: 16, alpha: 0.01 },
            optimiser: OptimiserConfig {
                lr: 5e-4,
                lr_final_ratio: 0.1,
                lr_decay_steps: 250_000,
                beta1: 0.9,
                beta2: 0.999,
                eps: 1e-7,
                proposal_lr: 0.05,
                feature_decay: 0.0,
                ema_decay: 0.0,
            },
            loss: LossConfig { distortion: 0.0, density_l1: 0.0, near_gradient: 0.0, backward_transmittance: 0.0 },
            per_photo: PerPhotoConfig { appearance: false, pose_refine: false, pose_lr: 1e-4 },
        }
    }

    /// The CPU preset without grids: 4×64, L = 8/2, 48 + 48 samples,
    /// 1024-ray batches, lr 5e-3 decaying 10× over the run: thousands of
    /// steps in minutes on a workstation where the paper preset manages
    /// tens (docs/RESULTS.md).
    pub fn fast() -> Self {
        let paper = Self::paper();
        Self {
            model: ModelConfig {
                pos_freqs: 8,
                dir_freqs: 2,
                depth: 4,
                width: 64,
                skips: vec![],
                view_width: 32,
                ..paper.model
            },
            sampling: SamplingConfig { n_coarse: 48, n_fine: NonZeroU16::new(48), batch_rays: 1024, ..paper.sampling },
            optimiser: OptimiserConfig { lr: 5e-3, lr_decay_steps: 0, ..paper.optimiser },
            ..paper
        }
    }

    /// The fast preset with an occupancy grid (64³) in place of the coarse
    /// network: one 4×64 network, 192 stratified samples per ray of which
    /// only those in occupied cells are evaluated.
    pub fn grid() -> Self {
        let fast = Self::fast();
        Self {
            sampling: SamplingConfig { n_coarse: 192, n_fine: None, ..fast.sampling },
            grid: GridConfig { res: NonZeroU16::new(64), ..fast.grid },
            ..fast
        }
    }

    /// The grid preset with a learned feature grid (instant-ngp's
    /// encoding: 8 levels of 2 values, 16..256 cells per axis, 2¹⁵ entries
    /// per level) in place of the frequency encoding (raw xyz beside it)
    /// and a 2×64 network; instant-ngp's optimiser settings (lr 1e-2,
    /// β₂ 0.99, ε 1e-15); the occupancy grid first updated at step 64 and
    /// every 64 steps, a cell kept while a default step through it would be
    /// at least 3 % opaque (`grid.alpha` 0.03: the same int8 PSNR as 0.01
    /// at half the samples per ray on lego, more PSNR on fox), and a tenth
    /// of the rays through photos with alpha on a random background
    /// (`sampling.random_background` 0.1: no haze left in empty space, fewer
    /// samples per ray). The learning rate decays 10× over the run (100×
    /// gains on long runs and loses on short ones). The second half of the
    /// run reads the grid across each pixel's footprint (`features.footprint`,
    /// `features.footprint_from` 0.5: better in 10 minutes, worse in one). The
    /// model takes the average of the parameters over about the last
    /// thousand steps (`optimiser.ema_decay` 0.999). Each choice's measurement is in
    /// docs/EXPERIMENTS.md.
    pub fn features() -> Self {
        let grid = Self::grid();
        Self {
            model: ModelConfig { depth: 2, width: 64, view_width: 64, pos_freqs: 0, dir_freqs: 4, ..grid.model },
            features: FeatureConfig {
                levels: NonZeroU8::new(8),
                width: 2,
                log2_table: 15,
                min_res: 16,
                max_res: 256,
                footprint: true,
                footprint_from: 0.5,
            },
            sampling: SamplingConfig { random_background: 0.1, ..grid.sampling },
            grid: GridConfig { warmup: 64, every: 64, alpha: 0.03, ..grid.grid },
            optimiser: OptimiserConfig { lr: 1e-2, beta2: 0.99, eps: 1e-15, ema_decay: 0.999, ..grid.optimiser },
            ..grid
        }
    }

    /// Sizes the feature grid to photos that resolve `cells` per axis
    /// ([`Dataset::resolvable_cells`](crate::dataset::Dataset::resolvable_cells)):
    /// when `cells` is above `features.max_res`, the finest level becomes
    /// `cells` (at most 4096) and the table gains a power of two of
    /// entries per doubling of it (at most 2^[`Self::FITTED_LOG2_TABLE`]).
    /// A grid already as fine, a grid of one level (whose only level is
    /// `features.min_res`) or no grid is left alone; returns whether
    /// anything changed. The finest levels share each entry among more
    /// cells than before (8× the cells, 2× the entries per doubling): more
    /// cells without more entries lose PSNR on lego at 800×800, with them
    /// gain it (docs/EXPERIMENTS.md).
    pub fn fit_features_to(&mut self, cells: u32) -> bool {
        let cells = cells.min(MAX_RES as u32);
        let max = self.features.max_res as u32;
        if self.features.levels.is_none_or(|l| l.get() < 2) || cells <= max {
            return false;
        }
        let doublings = cells.div_ceil(max.max(1)).next_power_of_two().trailing_zeros() as u8;
        self.features.max_res = cells as u16;
        self.features.log2_table =
            self.features.log2_table.max((self.features.log2_table + doublings).min(Self::FITTED_LOG2_TABLE));
        true
    }

    /// Sets the samples per ray for photos that resolve `cells` per axis
    /// ([`Dataset::resolvable_cells`](crate::dataset::Dataset::resolvable_cells)):
    /// one per [`Self::FITTED_CELLS_PER_SAMPLE`] of those cells (two pixel
    /// footprints) along the bounds' longest side, at most
    /// [`MAX_MARCH`](nerf_infer::format::MAX_MARCH), whether or not a
    /// feature grid is sized to them. Only a one-pass configuration with
    /// an occupancy grid and no proposal grid (whose stratified samples
    /// are at most 256 and set apart) is changed, and only upwards; returns whether
    /// anything changed. The occupancy grid's density threshold follows
    /// the step ([`Trainer::grid_threshold`](crate::train::Trainer::grid_threshold)):
    /// at 512 samples it is 512/192 times the preset's. On lego at 800×800
    /// (2048 cells) this is 512 samples per ray where the preset has 192
    /// (docs/EXPERIMENTS.md).
    pub fn fit_samples_to(&mut self, cells: u32) -> bool {
        let fitted = (cells / Self::FITTED_CELLS_PER_SAMPLE).min(nerf_infer::format::MAX_MARCH as u32) as u16;
        if self.grid.res.is_none()
            || self.sampling.n_fine.is_some()
            || self.sampling.proposal_res.is_some()
            || fitted <= self.sampling.n_coarse
        {
            return false;
        }
        self.sampling.n_coarse = fitted;
        true
    }
}

/// A named configuration (`nerf train --preset`): the four general ones,
/// and the smaller and larger shapes `nerf fit` tries besides `grid` and
/// `features` ([`Preset::FIT`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Preset {
    /// An occupancy grid, a learned feature grid and a 2×64 network: the
    /// default, the highest held-out PSNR per minute measured on lego and
    /// on the real captures (`scripts/measure/captures.sh`; docs/RESULTS.md).
    #[default]
    Features,
    /// An occupancy grid and one 4×64 network.
    Grid,
    /// A 4×64 network, coarse and fine passes, no grid.
    Fast,
    /// The paper's network: 8×256, 64 + 128 samples.
    Paper,
    /// `grid` with a 2×32 network, L = 6 and no view branch (2.4 k
    /// multiply-accumulates a sample): the smallest `nerf fit` tries.
    #[cfg_attr(feature = "clap", value(name = "2x32-noview"))]
    Grid2x32NoView,
    /// `grid` with a 3×32 network (6.3 k multiply-accumulates a sample).
    #[cfg_attr(feature = "clap", value(name = "3x32"))]
    Grid3x32,
    /// `grid` with a 3×64 network (18 k multiply-accumulates a sample).
    #[cfg_attr(feature = "clap", value(name = "3x64"))]
    Grid3x64,
    /// `features` with 32-wide layers and no pixel footprint (4.7 k
    /// multiply-accumulates a sample and 8 feature-grid levels).
    #[cfg_attr(feature = "clap", value(name = "features-2x32"))]
    Features2x32,
    /// `grid` with a 6×96 network, L = 10/4 and a 32-wide view branch
    /// (65 k multiply-accumulates a sample): the largest `nerf fit` tries.
    #[cfg_attr(feature = "clap", value(name = "6x96"))]
    Grid6x96,
}

impl Preset {
    /// Every preset, the default first.
    pub const ALL: [Preset; 9] = [
        Preset::Features,
        Preset::Grid,
        Preset::Fast,
        Preset::Paper,
        Preset::Grid2x32NoView,
        Preset::Grid3x32,
        Preset::Grid3x64,
        Preset::Features2x32,
        Preset::Grid6x96,
    ];

    /// The presets `nerf fit` trains, smallest network first: all with an
    /// occupancy grid, widths multiples of 32 (the int8 kernel's output
    /// tile on AVX-512).
    pub const FIT: [Preset; 7] = [
        Preset::Grid2x32NoView,
        Preset::Grid3x32,
        Preset::Features2x32,
        Preset::Grid3x64,
        Preset::Grid,
        Preset::Features,
        Preset::Grid6x96,
    ];

    /// Its configuration.
    pub fn config(self) -> TrainConfig {
        let model = |edit: fn(&mut ModelConfig)| TrainConfig::grid().with(|c| edit(&mut c.model));
        match self {
            Preset::Features => TrainConfig::features(),
            Preset::Grid => TrainConfig::grid(),
            Preset::Fast => TrainConfig::fast(),
            Preset::Paper => TrainConfig::paper(),
            Preset::Grid2x32NoView => model(|m| {
                (m.depth, m.width, m.pos_freqs, m.view_dependent) = (2, 32, 6, false);
            }),
            Preset::Grid3x32 => model(|m| (m.depth, m.width) = (3, 32)),
            Preset::Grid3x64 => model(|m| m.depth = 3),
            Preset::Features2x32 => TrainConfig::features().with(|c| {
                (c.model.width, c.model.view_width, c.features.footprint) = (32, 32, false);
            }),
            Preset::Grid6x96 => model(|m| {
                (m.depth, m.width, m.view_width, m.pos_freqs, m.dir_freqs) = (6, 96, 32, 10, 4);
            }),
        }
    }

    /// Its name on the command line (`features`, `grid`, `fast`, `paper`,
    /// `2x32-noview`, `3x32`, `3x64`, `features-2x32`, `6x96`).
    pub fn name(self) -> &'static str {
        match self {
            Preset::Features => "features",
            Preset::Grid => "grid",
            Preset::Fast => "fast",
            Preset::Paper => "paper",
            Preset::Grid2x32NoView => "2x32-noview",
            Preset::Grid3x32 => "3x32",
            Preset::Grid3x64 => "3x64",
            Preset::Features2x32 => "features-2x32",
            Preset::Grid6x96 => "6x96",
        }
    }
}

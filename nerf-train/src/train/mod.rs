//! The training loop: random ray batches across all training images,
//! stratified coarse samples, hierarchical fine samples, loss = coarse MSE
//! + fine MSE, hand-written backward, Adam with exponential decay.
//!
//! With an occupancy grid (`grid.res` set) the run has one network: each
//! ray's stratified samples are kept only where the grid is occupied (the
//! others weigh nothing), and the grid is refreshed from the network's
//! density every `grid.every` steps.
//!
//! Work is split into chunks of `sampling.chunk_rays` rays processed in parallel by
//! rayon; each chunk draws its jitter from a hash of (seed, step, chunk), so
//! a run is reproducible whatever the thread count.
//!
//! Files: this one holds the run's state ([`Trainer`]) and its working
//! memory; `batch.rs` draws rays (their samples are the
//! [`Sampler`]'s, `crate::sampling`), `step.rs` takes a step, `loss.rs` is its loss and gradient, `pool.rs`
//! keeps gradient buffers, `average.rs` the run as its model takes it
//! (the [`Field`]'s average),
//! `proposal_pass.rs` trains the proposal grid, `pose_pass.rs` the
//! cameras' pose corrections, `calibrate.rs` measures
//! activation ranges for export, `checkpoint.rs` writes and reads the
//! state.

use crate::composite::{composite, push_deltas};
use crate::config::TrainConfig;
use crate::dataset::Dataset;
pub use crate::field::network_seed;
use crate::field::Field;
use crate::loss::distortion::push_interval;
use crate::mlp::{Acts, GridGrad, Mlp};
use crate::per_photo::appearance::{self, Appearance};
use crate::per_photo::pose::Poses;
use crate::sampling::proposal::ProposalGrid;
use crate::sampling::{RaySamples, Sampler};
use crate::util::rng::Rng;
use crate::util::timing::{timed, StepTimes};
use nerf_infer::camera::Ray;
use nerf_infer::format::{Footprint, Scene};
use nerf_infer::sampling::{hash32, jitter_q16, merge_sorted, sample_pdf_f32};
use rayon::prelude::*;

mod average;
mod batch;
mod calibrate;
mod checkpoint;
#[cfg(test)]
mod checkpoint_tests;
mod checkpoint_v18;
mod loss;
mod pool;
mod pose_pass;
mod proposal_pass;
mod step;
pub use batch::*;
pub use calibrate::*;
pub use checkpoint::*;
pub use loss::{live_samples, occluded_samples};
use pool::GradPool;

/// Statistics of one optimisation step.
#[derive(Clone, Copy, Debug, Default)]
pub struct StepStats {
    /// Mean of coarse MSE + fine MSE over the batch.
    pub loss: f32,
    /// PSNR (dB) of the final (fine, or coarse) colours against the batch.
    pub psnr: f32,
    /// Rays in the batch.
    pub rays: usize,
    /// Network evaluations (samples) in the step, both networks.
    pub samples: usize,
    /// Of those, the evaluations the backward pass took: the others had no
    /// gradient ([`live_samples`]) or lay behind the run's
    /// `loss.backward_transmittance` ([`occluded_samples`]).
    pub backward_samples: usize,
    /// The step was skipped because the loss or a gradient was not finite.
    pub skipped: bool,
    /// Where the step's time went.
    pub times: StepTimes,
}

/// The density (1/world units, the fitted scene's) an unbounded scene's network starts with,
/// the same at every point ([`Mlp::init_uniform_density`]). A ray there
/// crosses the bounds and then the contracted shell out to `far`: starting
/// from the bounded scenes' σ ≈ 1 ([`Mlp::SIGMA_BIAS_INIT`], with a random
/// density head), the bounds alone would absorb most of the light (optical
/// depth about 4 across the built-in room's 2.2-unit box) and the first
/// steps would fit a fog between the cameras and the walls. At 0.1 the
/// bounds' diagonal holds an optical depth well under 1 and the light
/// reaches the shell. Measured on the built-in room (docs/EXPERIMENTS.md).
pub const UNBOUNDED_SIGMA_INIT: f32 = 0.1;

/// A training run's state: everything a checkpoint holds.
#[derive(Clone, Debug)]
pub struct Trainer {
    /// The configuration.
    pub cfg: TrainConfig,
    /// The scene (bounds, near/far, background, unbounded space).
    pub scene: Scene,
    /// Dataset downscale the run trains at.
    pub downscale: u32,
    /// The field it fits: the networks, their parameters, Adam's state
    /// and the parameters' average.
    pub field: Field,
    /// Steps taken.
    pub step: u64,
    /// Seconds of training so far (across resumes).
    pub elapsed: f64,
    /// Run seed.
    pub seed: u64,
    /// Steps skipped for non-finite loss or gradients.
    pub skipped: u64,
    /// The grids that place the samples: occupancy and proposal.
    pub sampler: Sampler,
    /// What the run trains on, as the command names it (the dataset's
    /// absolute path and the loading flags), so `--resume` can refuse other
    /// data; empty when the caller does not say.
    pub data: String,
    /// Mean angular size of the training views' pixels, radians, once a
    /// step has trained with pixel footprints ([`FeatureConfig::footprint`](crate::config::FeatureConfig::footprint));
    /// 0 before (the exported model records it,
    /// `nerf_infer::format::Footprint`).
    pub pixel: f32,
    /// Each training photo's colour correction (runs with
    /// [`PerPhotoConfig::appearance`](crate::config::PerPhotoConfig::appearance), from their first step).
    pub appearance: Option<Appearance>,
    /// Each training photo's pose correction (runs that
    /// [`Trainer::refines_poses`], from their first step).
    pub poses: Option<Poses>,
    /// Zeroed gradient buffers kept between steps (not checkpointed).
    pool: GradPool,
}

/// Per-chunk working memory.
#[derive(Default)]
struct Workspace {
    /// The chunk's samples ([`Sampler::place`], the fine pass's after them).
    samples: RaySamples,
    /// ∂L/∂w of the distortion loss for one ray.
    dw: Vec<f32>,
    w_c: Vec<f32>,
    t_f: Vec<f32>,
    t_all: Vec<f32>,
    w_f: Vec<f32>,
    cdf: Vec<f32>,
    acts_c: Acts,
    acts_f: Acts,
    dsig: Vec<f32>,
    drgb: Vec<f32>,
    /// Which samples the backward pass takes ([`Trainer::drop_idle_samples`]).
    keep: Vec<bool>,
    /// The photos' colour corrections' gradient (runs with
    /// [`PerPhotoConfig::appearance`](crate::config::PerPhotoConfig::appearance); as [`Appearance::params`]).
    dapp: Vec<f32>,
    /// The photos' pose corrections' gradient (runs that
    /// [`Trainer::refines_poses`]; as [`Poses::params`]).
    dpose: Vec<f32>,
    /// The loss's gradient with respect to each sample's position through
    /// γ(x), and to each feature-grid point ([`Mlp::position_gradient`]).
    dpos: Vec<[f32; 3]>,
    dgrid: Vec<[f32; 3]>,
    /// The loss's gradient with respect to each view direction ([`Mlp::direction_gradient`]).
    ddir: Vec<[f32; 3]>,
}

/// The photos' corrections' gradients of a batch, each as its
/// parameters: colour ([`Appearance::params`], empty without
/// [`PerPhotoConfig::appearance`](crate::config::PerPhotoConfig::appearance)) and
/// pose ([`Poses::params`], empty unless the run [`Trainer::refines_poses`]).
#[derive(Clone, Debug, Default)]
pub struct PerPhoto {
    /// ∂L/∂ of the colour corrections.
    pub appearance: Vec<f32>,
    /// ∂L/∂ of the pose corrections.
    pub pose: Vec<f32>,
}

impl PerPhoto {
    /// Adds `other`'s gradients (the longer length kept).
    fn add(&mut self, other: &Self) {
        for (a, b) in [(&mut self.appearance, &other.appearance), (&mut self.pose, &other.pose)] {
            if a.len() < b.len() {
                a.resize(b.len(), 0.0);
            }
            a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
        }
    }
}

impl Trainer {
    /// A new run with freshly initialised networks; fails, naming the
    /// field, if `cfg` does not pass [`TrainConfig::validate`].
    pub fn new(cfg: TrainConfig, scene: Scene, downscale: u32, seed: u64) -> crate::error::Result<Self> {
        cfg.validate()?;
        let field = Field::new(&cfg, seed, scene.unbounded.map(|_| UNBOUNDED_SIGMA_INIT));
        let sampler = Sampler::new(&cfg, UNBOUNDED_SIGMA_INIT);
        Ok(Self {
            cfg,
            scene,
            downscale,
            field,
            step: 0,
            elapsed: 0.0,
            seed,
            skipped: 0,
            sampler,
            data: String::new(),
            pixel: 0.0,
            appearance: None,
            poses: None,
            pool: GradPool::default(),
        })
    }

    /// The network's samples per ray before the occupancy grid's skipping ([`Sampler::main_samples`]).
    fn main_samples(&self) -> usize {
        self.sampler.main_samples(&self.cfg)
    }

    /// The network shape (both networks share it).
    pub fn mlp(&self) -> &Mlp {
        &self.field.net
    }

    /// Coarse parameters.
    pub fn coarse_params(&self) -> &[f32] {
        self.field.coarse()
    }

    /// Fine parameters, if the run has a fine network.
    pub fn fine_params(&self) -> Option<&[f32]> {
        self.field.fine()
    }

    /// Learning rate at training progress `p ∈ [0, 1]` of the decay horizon.
    pub fn learning_rate(&self, progress: f64) -> f32 {
        let p = if self.cfg.optimiser.lr_decay_steps > 0 {
            self.step as f64 / self.cfg.optimiser.lr_decay_steps as f64
        } else {
            progress
        };
        self.cfg.optimiser.lr * (self.cfg.optimiser.lr_final_ratio as f64).powf(p.clamp(0.0, 1.0)) as f32
    }

    /// Density σ threshold of the grid: the density at which a sample of
    /// the default step (bounds diagonal / `sampling.n_coarse`, world units) has
    /// opacity `grid.alpha`.
    pub fn grid_threshold(&self) -> f32 {
        let s = &self.scene;
        let diag = (0..3).map(|k| (s.bounds_max[k] - s.bounds_min[k]).powi(2)).sum::<f32>().sqrt();
        let step = diag / self.cfg.sampling.n_coarse as f32;
        -(1.0 - self.cfg.grid.alpha).ln() / step
    }

    /// The pixel footprint the run trains with and its model records: the
    /// training views' pixel once a step has used it, if a model can hold
    /// it ([`Footprint::is_valid`]) and has a feature grid to read across
    /// it (forward-facing scenes' rays stay lines: their models record none).
    pub fn footprint(&self) -> Option<Footprint> {
        Some(Footprint { pixel: self.pixel }).filter(|f| f.is_valid() && self.cfg.features.levels.is_some())
    }

    /// Refreshes the occupancy grid from the network's current density.
    pub fn update_grid(&mut self) {
        let Some(mut grid) = self.sampler.occupancy.take() else { return };
        let net = self.mlp();
        let thr = self.grid_threshold();
        let params = self.field.coarse();
        let key = hash32(self.seed as u32 ^ crate::util::rng::stream::GRID_UPDATE);
        grid.update(key, thr, self.scene.unbounded.is_some(), |pts| {
            let mut acts = Acts::default();
            net.forward(params, pts, &[[0.0, 0.0, 1.0]], false, &mut acts);
            acts.sigma[..pts.len()].to_vec()
        });
        self.sampler.occupancy = Some(grid);
    }
}

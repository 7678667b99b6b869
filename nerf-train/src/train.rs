//! The training loop: random ray batches across all training images,
//! stratified coarse samples, hierarchical fine samples, loss = coarse MSE
//! + fine MSE, hand-written backward, Adam with exponential decay.
//!
//! With an occupancy grid (`grid_res > 0`) the run has one network: each
//! ray's stratified samples are kept only where the grid is occupied (the
//! others weigh nothing), and the grid is refreshed from the network's
//! density every `grid_every` steps.
//!
//! Work is split into chunks of `chunk_rays` rays processed in parallel by
//! rayon; each chunk draws its jitter from a hash of (seed, step, chunk), so
//! a run is reproducible whatever the thread count.

use crate::adam::Adam;
use crate::config::TrainConfig;
use crate::dataset::Dataset;
use crate::grid::DensityGrid;
use crate::mlp::{Acts, GridGrad, Mlp};
use crate::proposal::{ProposalGrid, RayProposal};
use crate::rng::Rng;
use crate::timing::{timed, StepTimes};
use crate::volume::{
    composite, composite_back, distortion, optical_depth_back, push_deltas, push_interval, LAST_DELTA,
};
use nerf_infer::camera::Ray;
use nerf_infer::format::{Footprint, Scene};
use nerf_infer::sampling::{hash32, jitter_q16, merge_sorted, sample_pdf_f32};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

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
    /// The step was skipped because the loss or a gradient was not finite.
    pub skipped: bool,
    /// Where the step's time went.
    pub times: StepTimes,
}

/// The first bytes of a checkpoint file.
pub const CHECKPOINT_MAGIC: &[u8; 8] = b"NERFCKPT";
/// The checkpoint format [`Trainer::to_bytes`] writes and reads.
pub const CHECKPOINT_VERSION: u16 = 11;

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

/// The initialisation seed of network `k` (0 coarse, 1 fine) of a run seeded `seed`.
pub fn network_seed(seed: u64, k: usize) -> u64 {
    if k == 0 {
        seed
    } else {
        seed ^ 0x5EED_F1E0
    }
}

/// Folds `params` into their moving average `ema` with decay `b`:
/// `ema ← b·ema + (1 − b)·params`, or a copy of `params` when `ema` does
/// not hold as many (the first step).
fn average_into(ema: &mut Vec<f32>, params: &[f32], b: f32) {
    if ema.len() != params.len() {
        ema.clear();
        ema.extend_from_slice(params);
        return;
    }
    ema.iter_mut().zip(params).for_each(|(a, &p)| *a += (1.0 - b) * (p - *a));
}

/// How many of a run's `params` parameters are a feature grid's table: the
/// last ones (a run with a feature grid has one network), none without one.
fn table_values(net: &Mlp, params: usize) -> usize {
    if net.features.is_some() {
        params - net.table
    } else {
        0
    }
}

/// A training run's state: everything a checkpoint holds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Trainer {
    /// The configuration.
    pub cfg: TrainConfig,
    /// The scene (bounds, near/far, background).
    pub scene: Scene,
    /// Dataset downscale the run trains at.
    pub downscale: u32,
    /// Coarse then fine parameters, concatenated.
    pub params: Vec<f32>,
    /// Optimiser state.
    pub adam: Adam,
    /// Steps taken.
    pub step: u64,
    /// Seconds of training so far (across resumes).
    pub elapsed: f64,
    /// Run seed.
    pub seed: u64,
    /// Steps skipped for non-finite loss or gradients.
    pub skipped: u64,
    /// Occupancy grid (runs with `grid_res > 0`).
    pub grid: Option<DensityGrid>,
    /// What the run trains on, as the command names it (the dataset's
    /// absolute path and the loading flags), so `--resume` can refuse other
    /// data; empty when the caller does not say.
    pub data: String,
    /// Mean angular size of the training views' pixels, radians, once a
    /// step has trained with pixel footprints ([`TrainConfig::footprint`]);
    /// 0 before (the exported model records it,
    /// `nerf_infer::format::Footprint`).
    pub pixel: f32,
    /// With [`TrainConfig::ema_decay`]: the moving average of `params`
    /// (as long as they, from the first step that updates them), which the model takes
    /// ([`Trainer::averaged`]); empty otherwise.
    pub ema: Vec<f32>,
    /// The proposal grid placing the network's samples (runs with
    /// `proposal_res > 0`).
    pub proposal: Option<ProposalGrid>,
    /// Zeroed gradient buffers kept between steps (not checkpointed).
    #[serde(skip)]
    pool: GradPool,
}

/// Zeroed gradient buffers and chunks' grid-value gradients reused from
/// step to step: a feature grid's table makes each gradient megabytes, a
/// chunk's corners hundreds of kilobytes, and fresh ones cost page faults.
#[derive(Default)]
struct GradPool(std::sync::Mutex<Vec<Vec<f32>>>, std::sync::Mutex<Vec<GridGrad>>, std::sync::Mutex<PropGrads>);

/// Each chunk's proposal-grid gradient, (cell, value) pairs, under the
/// chunk's key (summed in key order: the same sum whatever the threads).
type PropGrads = Vec<(u32, Vec<(u32, f32)>)>;

impl Clone for GradPool {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl std::fmt::Debug for GradPool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("GradPool")
    }
}

impl GradPool {
    /// A zeroed buffer of `n` values.
    fn take(&self, n: usize) -> Vec<f32> {
        let found = |p: &mut Vec<Vec<f32>>| p.iter().position(|v| v.len() == n).map(|i| p.swap_remove(i));
        self.0.lock().map(|mut p| found(&mut p)).unwrap_or(None).unwrap_or_else(|| vec![0.0; n])
    }
    /// Returns a buffer (zeroed here) for later steps.
    fn give(&self, mut v: Vec<f32>) {
        v.fill(0.0);
        if let Ok(mut p) = self.0.lock() {
            p.push(v);
        }
    }
    /// A chunk's grid-value gradient whose buffers a forward pass may reuse.
    fn take_grid(&self) -> GridGrad {
        self.1.lock().map(|mut p| p.pop()).unwrap_or(None).unwrap_or_default()
    }
    /// Returns grid-value gradients for later chunks.
    fn give_grids(&self, g: Vec<GridGrad>) {
        if let Ok(mut p) = self.1.lock() {
            p.extend(g);
        }
    }
}

/// Per-chunk working memory.
#[derive(Default)]
struct Workspace {
    pos: Vec<[f32; 3]>,
    /// The footprint points of each sample of `pos` (rays with a
    /// footprint), else empty.
    foot: Vec<[f32; 3]>,
    dirs: Vec<[f32; 3]>,
    /// Ray `i`'s samples are `offs[i]..offs[i + 1]` of `pos` and `delta`.
    offs: Vec<usize>,
    delta: Vec<f32>,
    /// Per sample (as `delta`) when the distortion loss is on: its interval
    /// in the ray's normalised coordinate, midpoint and length.
    s_mid: Vec<f32>,
    s_width: Vec<f32>,
    /// ∂L/∂w of the distortion loss for one ray.
    dw: Vec<f32>,
    t_c: Vec<f32>,
    w_c: Vec<f32>,
    t_f: Vec<f32>,
    t_all: Vec<f32>,
    w_f: Vec<f32>,
    cdf: Vec<f32>,
    acts_c: Acts,
    acts_f: Acts,
    /// Each kept sample's index among its ray's samples (as `delta`).
    kept: Vec<u32>,
    /// Each ray's proposal (runs with a proposal grid).
    props: Vec<RayProposal>,
    dsig: Vec<f32>,
    drgb: Vec<f32>,
}

/// The losses beside the colour's: the distortion loss's weight and each
/// sample's interval (see [`crate::volume::distortion`]), and the weight
/// of the optical depth's L1 penalty ([`TrainConfig::density_l1`]); a
/// weight 0 turns its loss off.
struct Priors<'a> {
    distortion: f32,
    mid: &'a [f32],
    width: &'a [f32],
    density_l1: f32,
}

/// Composites each ray's samples (`offs[i]..offs[i + 1]`, weights into
/// `w`) on the ray's background and writes the gradients of `scale · Σ (C − C_gt)²`
/// (plus `scale · 3/2 · λ · L_dist` per ray for the distortion weight λ, and
/// `scale · 3/2 · μ ·` [`optical_depth`](crate::volume::optical_depth) for the density weight μ) with respect to
/// the raw densities and colours into `dsig` and `drgb`; returns the summed
/// squared error over rays and channels.
#[allow(clippy::too_many_arguments)]
fn loss_gradients(
    rays: &[Sample],
    offs: &[usize],
    scale: f32,
    acts: &Acts,
    delta: &[f32],
    priors: Priors<'_>,
    w: &mut [f32],
    dw: &mut Vec<f32>,
    dsig: &mut Vec<f32>,
    drgb: &mut Vec<f32>,
) -> f64 {
    let n = offs[rays.len()];
    dsig.resize(n, 0.0);
    drgb.resize(n * 3, 0.0);
    let mut sq = 0.0f64;
    for (i, r) in rays.iter().enumerate() {
        let (s, gt, bg) = (offs[i]..offs[i + 1], r.rgb, r.bg);
        let c = 3 * s.start..3 * s.end;
        let (sig, rgb) = (&acts.sigma[s.clone()], &acts.rgb[c.clone()]);
        let col = composite(sig, rgb, &delta[s.clone()], bg, &mut w[s.clone()]);
        let dc: [f32; 3] = std::array::from_fn(|k| scale * (col[k] - gt[k]));
        sq += (0..3).map(|k| ((col[k] - gt[k]) as f64).powi(2)).sum::<f64>();
        dw.clear();
        // the colour loss is a mean over rays and channels, the priors means over rays
        if priors.distortion > 0.0 {
            dw.resize(s.len(), 0.0);
            let (mid, width) = (&priors.mid[s.clone()], &priors.width[s.clone()]);
            distortion(mid, width, &w[s.clone()], 1.5 * scale * priors.distortion, dw);
        }
        composite_back(sig, rgb, &delta[s.clone()], bg, &w[s.clone()], dc, dw, &mut dsig[s.clone()], &mut drgb[c]);
        if priors.density_l1 > 0.0 {
            optical_depth_back(sig, &delta[s.clone()], 1.5 * scale * priors.density_l1, &mut dsig[s]);
        }
    }
    sq
}

/// What [`Trainer::calibrate`] measures on calibration rays, per network
/// (coarse, and fine if the run has one).
#[derive(Clone, Debug)]
pub struct Calibration {
    /// Largest |output| of every layer of the coarse network.
    pub max_c: Vec<f32>,
    /// The same for the fine network.
    pub max_f: Option<Vec<f32>>,
    /// Largest |normalised coordinate| met.
    pub max_pos: f32,
    /// Per layer and output: was this ReLU output ever positive (coarse)?
    pub active_c: Vec<Vec<bool>>,
    /// The same for the fine network.
    pub active_f: Option<Vec<Vec<bool>>>,
}

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
    /// ([`TrainConfig::random_background`]).
    pub bg: [f32; 3],
}

/// Where [`Trainer::draw_batch`] sends its rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Draw {
    /// Share of the pixels with an alpha channel, in `[0, 1]`, recomposited
    /// on a random background colour ([`TrainConfig::random_background`]).
    pub random_background: f32,
    /// Each ray through a uniformly random point of its pixel instead of
    /// its centre ([`TrainConfig::pixel_jitter`]).
    pub jitter: bool,
    /// Each ray with its pixel's footprint ([`TrainConfig::footprint`]),
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
            random_background: cfg.random_background,
            jitter: cfg.pixel_jitter,
            footprint: cfg.footprint && cfg.feature_levels > 0 && progress >= cfg.footprint_from as f64,
        }
    }
}

impl Sample {
    /// A ray on the scene's background with ground truth `rgb`.
    pub fn on_scene(scene: &Scene, ray: Ray, rgb: [f32; 3]) -> Self {
        Self { ray, rgb, bg: [scene.background(); 3] }
    }
}

impl Trainer {
    /// A new run with freshly initialised networks.
    pub fn new(cfg: TrainConfig, scene: Scene, downscale: u32, seed: u64) -> Self {
        let net = cfg.mlp();
        let init = |seed| match scene.unbounded {
            Some(_) => net.init_uniform_density(seed, UNBOUNDED_SIGMA_INIT),
            None => net.init(seed),
        };
        let mut params = init(network_seed(seed, 0));
        if cfg.n_fine > 0 {
            params.extend(init(network_seed(seed, 1)));
        }
        let adam = Adam::new(params.len(), table_values(&net, params.len()));
        let grid = (cfg.grid_res > 0).then(|| DensityGrid::new(cfg.grid_res));
        let proposal = (cfg.proposal_res > 0).then(|| ProposalGrid::new(cfg.proposal_res, UNBOUNDED_SIGMA_INIT));
        Self {
            cfg,
            scene,
            downscale,
            params,
            adam,
            step: 0,
            elapsed: 0.0,
            seed,
            skipped: 0,
            grid,
            data: String::new(),
            pixel: 0.0,
            ema: Vec::new(),
            proposal,
            pool: GradPool::default(),
        }
    }

    /// The network's samples per ray before the occupancy grid's skipping:
    /// `n_main` drawn from the proposal grid and its last stratified one,
    /// else `n_coarse` stratified.
    fn main_samples(&self) -> usize {
        match self.proposal {
            Some(_) => self.cfg.n_main as usize + 1,
            None => self.cfg.n_coarse as usize,
        }
    }

    /// The network shape (both networks share it).
    pub fn mlp(&self) -> Mlp {
        self.cfg.mlp()
    }

    /// Coarse parameters.
    pub fn coarse_params(&self) -> &[f32] {
        &self.params[..self.mlp().n_params]
    }

    /// Fine parameters, if the run has a fine network.
    pub fn fine_params(&self) -> Option<&[f32]> {
        let n = self.mlp().n_params;
        (self.cfg.n_fine > 0).then(|| &self.params[n..])
    }

    /// Learning rate at training progress `p ∈ [0, 1]` of the decay horizon.
    pub fn learning_rate(&self, progress: f64) -> f32 {
        let p = if self.cfg.lr_decay_steps > 0 { self.step as f64 / self.cfg.lr_decay_steps as f64 } else { progress };
        self.cfg.lr * (self.cfg.lr_final_ratio as f64).powf(p.clamp(0.0, 1.0)) as f32
    }

    /// Draws `n` training rays uniformly over all pixels of `data` (views
    /// may differ in size), through each view's lens: through the pixel's
    /// centre, or with `how.jitter` through a uniformly random point of it.
    /// Pixels whose ray
    /// misses the scene are drawn again, at most `64 n` draws in all:
    /// [`crate::dataset::Dataset::check_rays`] makes sure at load time that
    /// enough rays meet the scene, so a short batch is rare.
    ///
    /// A share `how.random_background` (in `[0, 1]`) of the pixels of views
    /// with an alpha channel gets a uniformly random background colour,
    /// its ground truth recomposited on it (`rgb + (1 − alpha)·(bg − scene
    /// background)`); other pixels keep the scene's background.
    pub fn draw_batch(data: &Dataset, n: usize, how: Draw, rng: &mut Rng) -> Vec<Sample> {
        let mut ends = Vec::with_capacity(data.views.len());
        let mut total = 0usize;
        for v in &data.views {
            total += v.rgb.len();
            ends.push(total);
        }
        let scene_bg = data.scene.background();
        let mut out = Vec::with_capacity(n);
        for _ in 0..n.saturating_mul(64) {
            if out.len() == n || total == 0 {
                break;
            }
            let k = rng.below(total);
            let vi = ends.partition_point(|&e| e <= k);
            let v = &data.views[vi];
            let px = k - (ends[vi] - v.rgb.len());
            let (x, y) = ((px % v.camera.width as usize) as u32, (px / v.camera.width as usize) as u32);
            let (o, d) = match how.jitter {
                true => v.ray_at(x as f32 + rng.f32(), y as f32 + rng.f32()),
                false => v.ray(x, y),
            };
            let Some(mut ray) = Ray::new(&data.scene, o, d) else { continue };
            if how.footprint {
                ray = ray.with_footprint(&data.scene, v.camera.pixel_angle(), rng.f32() * std::f32::consts::TAU);
            }
            let mut s = Sample::on_scene(&data.scene, ray, v.rgb[px]);
            let alpha = if how.random_background > 0.0 { v.alpha.get(px) } else { None };
            if let Some(&a) = alpha.filter(|_| rng.f32() < how.random_background) {
                s.bg = [rng.f32(), rng.f32(), rng.f32()];
                s.rgb = std::array::from_fn(|c| s.rgb[c] + (1.0 - a) * (s.bg[c] - scene_bg));
            }
            out.push(s);
        }
        out
    }

    /// One optimisation step on a batch drawn from `data`; `progress` is
    /// the fraction of the run done (for the learning-rate decay).
    pub fn train_step(&mut self, data: &Dataset, progress: f64) -> StepStats {
        let c = &self.cfg;
        let mut times = StepTimes::default();
        if self.grid.is_some()
            && self.step as usize >= c.grid_warmup
            && (self.step as usize).is_multiple_of(c.grid_every)
        {
            timed(&mut times.grid, || self.update_grid());
        }
        let mut rng = Rng::new(self.seed ^ (self.step.wrapping_mul(0x9E37_79B9_7F4A_7C15)));
        let (n, mut how) = (self.cfg.batch_rays, Draw::of(&self.cfg, progress));
        if how.footprint && self.pixel == 0.0 {
            self.pixel = data.pixel_angle();
        }
        // pixels a model cannot record (wider than 0.1 rad) train as lines
        how.footprint &= self.footprint().is_some();
        let batch = timed(&mut times.draw, || Self::draw_batch(data, n, how, &mut rng));
        let step_key = hash32(self.seed as u32 ^ hash32(self.step as u32));
        let (grad, sq_c, sq_f, samples) = self.gradients_timed(&batch, step_key, &mut times);
        let n = batch.len() as f64 * 3.0;
        let mse_f = if self.cfg.n_fine > 0 { sq_f / n } else { sq_c / n };
        let loss = (sq_c + sq_f) / n;
        let mut stats = StepStats {
            loss: loss as f32,
            psnr: (-10.0 * mse_f.max(1e-12).log10()) as f32,
            rays: batch.len(),
            samples,
            skipped: false,
            times,
        };
        if !loss.is_finite() || grad.iter().any(|g| !g.is_finite()) {
            self.skipped += 1;
            stats.skipped = true;
        } else {
            let lr = self.learning_rate(progress);
            let c = &self.cfg;
            let (p, adam) = (&mut self.params, &mut self.adam);
            timed(&mut stats.times.adam, || adam.update(p, &grad, lr, c.beta1, c.beta2, c.eps, c.feature_decay));
            if c.ema_decay > 0.0 {
                let b = c.ema_decay.min((1.0 + self.step as f32) / (10.0 + self.step as f32));
                timed(&mut stats.times.adam, || average_into(&mut self.ema, p, b));
            }
            let lr_p = c.proposal_lr * lr / c.lr;
            timed(&mut stats.times.adam, || self.step_proposal(lr_p));
        }
        if let Ok(mut g) = self.pool.2.lock() {
            g.clear();
        }
        self.pool.give(grad);
        self.step += 1;
        stats
    }

    /// Gradient of (coarse MSE + fine MSE) over `batch`, with the summed
    /// squared errors and the number of network evaluations.
    ///
    /// Chunks run in parallel, each thread accumulating the layers'
    /// gradient; a feature grid's table (megabytes) is not copied per
    /// thread: each chunk keeps its grid-value gradient, and the table's
    /// gradient is scattered afterwards, one level per task, chunk after
    /// chunk ([`Mlp::scatter_table`]).
    pub fn gradients(&self, batch: &[Sample], step_key: u32) -> (Vec<f32>, f64, f64, usize) {
        self.gradients_timed(batch, step_key, &mut StepTimes::default())
    }

    /// [`Trainer::gradients`], adding the time of its stages to `times`
    /// (`chunks` and its split, `scatter`).
    fn gradients_timed(&self, batch: &[Sample], step_key: u32, times: &mut StepTimes) -> (Vec<f32>, f64, f64, usize) {
        let start = std::time::Instant::now();
        // the proposal grid's gradient is this batch's alone
        if let Ok(mut g) = self.pool.2.lock() {
            g.clear();
        }
        let net = self.mlp();
        let np = self.params.len();
        // the parameters each thread accumulates: all but a feature grid's table
        let dense = if net.features.is_some() { net.table } else { np };
        let scale = 2.0 / (3.0 * batch.len() as f32);
        let chunk = self.cfg.chunk_rays;
        // a few accumulators per thread, for balance
        let min_len = batch.len().div_ceil(chunk) / (4 * rayon::current_num_threads());
        type Acc = (Vec<f32>, f64, f64, usize, Vec<(usize, GridGrad)>, StepTimes);
        let (dense_grad, sq_c, sq_f, samples, mut grids, split): Acc = batch
            .par_chunks(chunk)
            .with_min_len(min_len.max(1))
            .enumerate()
            .fold(
                || {
                    let g = self.pool.take(dense);
                    (g, 0.0f64, 0.0f64, 0usize, Vec::new(), StepTimes::default(), Workspace::default())
                },
                |(mut g, c, f, n, mut grids, mut t, mut ws), (ci, rays)| {
                    let key = hash32(step_key ^ hash32(ci as u32));
                    let (a, b, k, grid) = self.chunk_gradient(&net, rays, key, scale, &mut ws, &mut g, &mut t);
                    grids.extend(grid.map(|gg| (ci, gg)));
                    (g, c + a, f + b, n + k, grids, t, ws)
                },
            )
            .map(|(g, c, f, n, grids, t, _)| (g, c, f, n, grids, t))
            .reduce(
                || (self.pool.take(dense), 0.0, 0.0, 0, Vec::new(), StepTimes::default()),
                |(mut g1, c1, f1, n1, mut r1, mut t1), (g2, c2, f2, n2, r2, t2)| {
                    g1.iter_mut().zip(&g2).for_each(|(a, b)| *a += b);
                    self.pool.give(g2);
                    r1.extend(r2);
                    t1.add(&t2);
                    (g1, c1 + c2, f1 + f2, n1 + n2, r1, t1)
                },
            );
        times.add(&split);
        times.chunks += start.elapsed().as_secs_f64();
        if dense == np {
            return (dense_grad, sq_c, sq_f, samples);
        }
        let start = std::time::Instant::now();
        let mut grad = self.pool.take(np);
        grad[..dense].copy_from_slice(&dense_grad);
        self.pool.give(dense_grad);
        grids.sort_unstable_by_key(|(ci, _)| *ci);
        let grids: Vec<GridGrad> = grids.into_iter().map(|(_, g)| g).collect();
        net.scatter_table(&grids, &mut grad[dense..]);
        self.pool.give_grids(grids);
        times.scatter += start.elapsed().as_secs_f64();
        (grad, sq_c, sq_f, samples)
    }

    /// One Adam step of the proposal grid (if the run has one) on the
    /// chunks' gradients of the step, at learning rate `lr`.
    fn step_proposal(&mut self, lr: f32) {
        let Some(pg) = self.proposal.as_mut() else { return };
        let mut chunks = self.pool.2.lock().map(|mut g| std::mem::take(&mut *g)).unwrap_or_default();
        chunks.sort_unstable_by_key(|(key, _)| *key);
        let mut grad = vec![0.0f32; pg.log_sigma.len()];
        for (c, g) in chunks.iter().flat_map(|(_, list)| list) {
            grad[*c as usize] += g;
        }
        if grad.iter().all(|g| g.is_finite()) {
            let c = &self.cfg;
            pg.step(&grad, lr, c.beta1, c.beta2, c.eps);
        }
    }

    /// The interlevel loss's gradient of a chunk's rays, whose network
    /// samples (`ws.t_c`, `main_samples` per ray, those kept in
    /// `ws.kept`) got the weights `ws.w_c`: kept under the chunk's `key`
    /// for [`Trainer::step_proposal`].
    fn proposal_backward(&self, pg: &ProposalGrid, n_rays: usize, key: u32, scale: f32, ws: &Workspace) {
        let nm = self.main_samples();
        let mut list = Vec::new();
        let mut w = vec![0.0f32; nm];
        for i in 0..n_rays {
            w.fill(0.0);
            for s in ws.offs[i]..ws.offs[i + 1] {
                w[ws.kept[s] as usize] = ws.w_c[s];
            }
            pg.backward(&ws.props[i], &ws.t_c[i * nm..(i + 1) * nm], &w, scale, &mut list);
        }
        if let Ok(mut g) = self.pool.2.lock() {
            g.push((key, list));
        }
    }

    /// With a proposal grid: the mean over `batch` of the network's weight
    /// along each ray that the grid's weights leave unbounded
    /// ([`crate::interlevel::unbounded_weight`]; 0 when they bound it
    /// everywhere, at most the ray's opacity), and the rays' mean opacity.
    pub fn proposal_bound(&self, batch: &[Sample]) -> Option<(f32, f32)> {
        self.proposal.as_ref()?;
        let net = self.mlp();
        let pc = &self.params[..net.n_params];
        let nm = self.main_samples();
        let mut ws = Workspace::default();
        let (mut unbounded, mut opacity) = (0.0f64, 0.0f64);
        for (ci, rays) in batch.chunks(self.cfg.chunk_rays).enumerate() {
            self.coarse_samples(rays, |i| hash32((ci * 7919 + i) as u32), &mut ws);
            let mut acts = Acts::default();
            if !ws.pos.is_empty() {
                net.encode_footprint(pc, &ws.pos, &ws.foot, &mut acts);
                net.forward_layers(pc, &ws.dirs, true, &mut acts);
            }
            for (i, Sample { bg, .. }) in rays.iter().enumerate() {
                let s = ws.offs[i]..ws.offs[i + 1];
                let mut kept_w = vec![0.0; s.len()];
                if !s.is_empty() {
                    let (sig, rgb) = (&acts.sigma[s.clone()], &acts.rgb[3 * s.start..3 * s.end]);
                    composite(sig, rgb, &ws.delta[s.clone()], *bg, &mut kept_w);
                }
                let mut w = vec![0.0f32; nm];
                for (k, j) in s.clone().enumerate() {
                    w[ws.kept[j] as usize] = kept_w[k];
                }
                let prop = &ws.props[i];
                let t = &ws.t_c[i * nm..(i + 1) * nm];
                unbounded += crate::interlevel::unbounded_weight(t, &w, &prop.edges(), &prop.w) as f64;
                opacity += w.iter().sum::<f32>() as f64;
            }
        }
        let n = batch.len().max(1) as f64;
        Some(((unbounded / n) as f32, (opacity / n) as f32))
    }

    /// Density σ threshold of the grid: the density at which a sample of
    /// the default step (bounds diagonal / `n_coarse`, world units) has
    /// opacity `grid_alpha`.
    pub fn grid_threshold(&self) -> f32 {
        let s = &self.scene;
        let diag = (0..3).map(|k| (s.bounds_max[k] - s.bounds_min[k]).powi(2)).sum::<f32>().sqrt();
        let step = diag / self.cfg.n_coarse as f32;
        -(1.0 - self.cfg.grid_alpha).ln() / step
    }

    /// The pixel footprint the run trains with and its model records: the
    /// training views' pixel once a step has used it, if a model can hold
    /// it ([`Footprint::is_valid`]) and has a feature grid to read across
    /// it (forward-facing scenes' rays stay lines: their models record none).
    pub fn footprint(&self) -> Option<Footprint> {
        Some(Footprint { pixel: self.pixel }).filter(|f| f.is_valid() && self.cfg.feature_levels > 0)
    }

    /// The run as its model takes it: with a parameters' average
    /// ([`TrainConfig::ema_decay`]), a copy holding the average as its
    /// parameters and its occupancy grid (once the run has refreshed it)
    /// refreshed once more, from the average's density; otherwise the run
    /// itself.
    pub fn averaged(&self) -> std::borrow::Cow<'_, Trainer> {
        if self.cfg.ema_decay <= 0.0 || self.ema.len() != self.params.len() {
            return std::borrow::Cow::Borrowed(self);
        }
        let mut t = self.clone();
        t.params.clone_from(&self.ema);
        if t.grid.as_ref().is_some_and(|g| g.updates > 0) {
            t.update_grid();
        }
        std::borrow::Cow::Owned(t)
    }

    /// Refreshes the occupancy grid from the network's current density.
    pub fn update_grid(&mut self) {
        let Some(mut grid) = self.grid.take() else { return };
        let net = self.mlp();
        let thr = self.grid_threshold();
        let params = &self.params[..net.n_params];
        let key = hash32(self.seed as u32 ^ 0x6121_D000);
        grid.update(key, thr, self.scene.unbounded.is_some(), |pts| {
            let mut acts = Acts::default();
            net.forward(params, pts, &[[0.0, 0.0, 1.0]], false, &mut acts);
            acts.sigma[..pts.len()].to_vec()
        });
        self.grid = Some(grid);
    }

    /// Stratified samples of every ray of a chunk (jitter key per ray from
    /// `key`), kept where the grid is occupied: fills `t_c` (all `n_coarse`
    /// per ray) and `pos`, `delta`, `offs`, `dirs` (per kept sample with a
    /// grid, per ray without).
    fn coarse_samples(&self, rays: &[Sample], key: impl Fn(usize) -> u32, ws: &mut Workspace) {
        let nc = self.main_samples();
        let intervals = self.cfg.distortion > 0.0;
        let grid = self.grid.as_ref().map(|g| g.view());
        ws.t_c.resize(rays.len() * nc, 0.0);
        ws.pos.clear();
        ws.foot.clear();
        ws.dirs.clear();
        ws.delta.clear();
        ws.s_mid.clear();
        ws.s_width.clear();
        ws.offs.clear();
        ws.offs.push(0);
        ws.kept.clear();
        if self.proposal.is_some() {
            ws.props.resize_with(rays.len(), Default::default);
        }
        // with footprints, every sample has its K points (a ray without one: its sample K times)
        const K: usize = nerf_infer::camera::FOOTPRINT_POINTS;
        let any_foot = rays.iter().any(|s| s.ray.foot.is_some());
        for (i, Sample { ray, .. }) in rays.iter().enumerate() {
            let t = &mut ws.t_c[i * nc..(i + 1) * nc];
            match &self.proposal {
                Some(pg) => pg.place(ray, key(i), self.cfg.n_coarse as usize, t, &mut ws.props[i]),
                None => ray.stratified(Some(key(i)), t),
            }
            match grid {
                None => {
                    ws.kept.extend(0..nc as u32);
                    for &ti in t.iter() {
                        let p = ray.at(ti).to_array();
                        ws.pos.push(p);
                        if any_foot {
                            ws.foot.extend(ray.foot_at(ti).unwrap_or([p; K]));
                        }
                    }
                    push_deltas(t, ray.dir_len, &mut ws.delta);
                    if intervals {
                        (0..nc).for_each(|j| push_interval(ray, t, j, &mut ws.s_mid, &mut ws.s_width));
                    }
                    ws.dirs.push(ray.viewdir.to_array());
                }
                Some(g) => {
                    for j in 0..nc {
                        let p = ray.at(t[j]).to_array();
                        if g.at_f32(p) {
                            ws.kept.push(j as u32);
                            ws.pos.push(p);
                            if any_foot {
                                ws.foot.extend(ray.foot_at(t[j]).unwrap_or([p; K]));
                            }
                            ws.delta.push(if j + 1 < nc { (t[j + 1] - t[j]) * ray.dir_len } else { LAST_DELTA });
                            if intervals {
                                push_interval(ray, t, j, &mut ws.s_mid, &mut ws.s_width);
                            }
                            ws.dirs.push(ray.viewdir.to_array());
                        }
                    }
                }
            }
            ws.offs.push(ws.pos.len());
        }
    }

    /// Forward and backward of one chunk; accumulates into `g` and returns
    /// the squared errors (coarse, fine) summed over rays and channels, the
    /// number of network evaluations and, with a feature grid, the grid
    /// values' gradient (`g` then holds the layers only: the table's
    /// gradient is left to [`Mlp::scatter_table`]). Adds the time of its
    /// parts to `t`'s thread stages.
    #[allow(clippy::too_many_arguments)]
    fn chunk_gradient(
        &self,
        net: &Mlp,
        rays: &[Sample],
        key: u32,
        scale: f32,
        ws: &mut Workspace,
        g: &mut [f32],
        t: &mut StepTimes,
    ) -> (f64, f64, usize, Option<GridGrad>) {
        let r = rays.len();
        let nc = self.cfg.n_coarse as usize;
        let nf = self.cfg.n_fine as usize;
        let np = net.n_params;
        let (pc, pf) = self.params.split_at(np);
        let (gc, gf) = g.split_at_mut(np.min(g.len()));
        timed(&mut t.sample, || self.coarse_samples(rays, |i| hash32(key ^ (i as u32).wrapping_mul(0x85EB_CA6B)), ws));
        let n_c = ws.pos.len();
        ws.w_c.resize(n_c, 0.0);
        if n_c > 0 {
            timed(&mut t.encode, || net.encode_footprint(pc, &ws.pos, &ws.foot, &mut ws.acts_c));
            timed(&mut t.forward, || net.forward_layers(pc, &ws.dirs, true, &mut ws.acts_c));
        }
        let sq_c = timed(&mut t.composite, || {
            let priors = self.priors(&ws.s_mid, &ws.s_width);
            let (w, dw) = (&mut ws.w_c, &mut ws.dw);
            loss_gradients(rays, &ws.offs, scale, &ws.acts_c, &ws.delta, priors, w, dw, &mut ws.dsig, &mut ws.drgb)
        });
        if let Some(pg) = &self.proposal {
            // the interlevel loss, a mean over the batch's rays as the colour loss is
            timed(&mut t.composite, || self.proposal_backward(pg, r, key, 1.5 * scale, ws));
        }
        let mut grid = None;
        if n_c > 0 && net.features.is_some() {
            timed(&mut t.backward, || net.backward_layers(pc, &mut ws.acts_c, &ws.dsig, &ws.drgb, gc));
            let mut gg = self.pool.take_grid();
            net.swap_grid_grad(&mut ws.acts_c, &mut gg);
            grid = Some(gg);
        } else if n_c > 0 {
            timed(&mut t.backward, || net.backward(pc, &mut ws.acts_c, &ws.dsig, &ws.drgb, gc));
        }
        if nf == 0 {
            return (sq_c, 0.0, n_c, grid);
        }
        // no grid (validated): every ray has its nc coarse samples
        let start = std::time::Instant::now();
        let na = nc + nf;
        ws.t_f.resize(nf, 0.0);
        ws.cdf.resize(nc, 0.0);
        ws.t_all.resize(r * na, 0.0);
        ws.w_f.resize(r * na, 0.0);
        ws.pos.clear();
        ws.delta.clear();
        ws.s_mid.clear();
        ws.s_width.clear();
        ws.offs.clear();
        ws.offs.push(0);
        for (i, Sample { ray, .. }) in rays.iter().enumerate() {
            let s = i * nc..(i + 1) * nc;
            let rk = hash32(key ^ 0xF1AE ^ (i as u32).wrapping_mul(0x27D4_EB2F));
            sample_pdf_f32(
                &ws.t_c[s.clone()],
                &ws.w_c[s.clone()],
                |j| (j as f32 + jitter_q16(rk, j) as f32 / 65536.0) / nf as f32,
                &mut ws.cdf,
                &mut ws.t_f,
            );
            let all = &mut ws.t_all[i * na..(i + 1) * na];
            merge_sorted(&ws.t_c[s], &ws.t_f, all);
            ws.pos.extend(all.iter().map(|&ti| ray.at(ti).to_array()));
            push_deltas(all, ray.dir_len, &mut ws.delta);
            if self.cfg.distortion > 0.0 {
                (0..na).for_each(|j| push_interval(ray, all, j, &mut ws.s_mid, &mut ws.s_width));
            }
            ws.offs.push(ws.pos.len());
        }
        t.sample += start.elapsed().as_secs_f64();
        timed(&mut t.encode, || net.encode(pf, &ws.pos, &mut ws.acts_f));
        timed(&mut t.forward, || net.forward_layers(pf, &ws.dirs, true, &mut ws.acts_f));
        let sq_f = timed(&mut t.composite, || {
            let priors = self.priors(&ws.s_mid, &ws.s_width);
            let (w, dw) = (&mut ws.w_f, &mut ws.dw);
            loss_gradients(rays, &ws.offs, scale, &ws.acts_f, &ws.delta, priors, w, dw, &mut ws.dsig, &mut ws.drgb)
        });
        timed(&mut t.backward, || net.backward(pf, &mut ws.acts_f, &ws.dsig, &ws.drgb, gf));
        (sq_c, sq_f, n_c + r * na, grid)
    }

    /// The run's losses beside the colour's, over the samples' intervals.
    fn priors<'a>(&self, mid: &'a [f32], width: &'a [f32]) -> Priors<'a> {
        Priors { distortion: self.cfg.distortion, mid, width, density_l1: self.cfg.density_l1 }
    }

    /// Largest |activation| of every layer of each network, measured on
    /// `batch` with the training-time sampling (for quantisation), the
    /// largest |normalised coordinate| met, and which ReLU outputs were
    /// ever active (for pruning).
    pub fn calibrate(&self, batch: &[Sample]) -> Calibration {
        let net = self.mlp();
        let nc = self.cfg.n_coarse as usize;
        let nf = self.cfg.n_fine as usize;
        let (pc, pf) = self.params.split_at(net.n_params);
        let mut max_c = vec![0.0f32; net.slots.len()];
        let mut max_f = vec![0.0f32; net.slots.len()];
        let mut max_pos = 0.0f32;
        let fresh = || net.slots.iter().map(|s| vec![false; s.dout]).collect::<Vec<_>>();
        let (mut active_c, mut active_f) = (fresh(), fresh());
        let mut acts = Acts::default();
        let mut ws = Workspace::default();
        // a run that trained with footprints is calibrated with them
        let with_foot: Vec<Sample>;
        let batch = match self.footprint() {
            Some(f) => {
                let foot = |s: &Sample| Sample { ray: s.ray.with_footprint(&self.scene, f.pixel, 0.0), ..*s };
                with_foot = batch.iter().map(foot).collect();
                &with_foot[..]
            }
            None => batch,
        };
        for (ci, rays) in batch.chunks(self.cfg.chunk_rays).enumerate() {
            self.coarse_samples(rays, |i| hash32((ci * 7919 + i) as u32), &mut ws);
            if ws.pos.is_empty() {
                continue;
            }
            net.encode_footprint(pc, &ws.pos, &ws.foot, &mut acts);
            net.forward_layers(pc, &ws.dirs, true, &mut acts);
            net.record_max_abs(&acts, &mut max_c);
            net.record_active(&acts, &mut active_c);
            max_pos = ws.pos.iter().flatten().fold(max_pos, |m, v| m.max(v.abs()));
            if nf == 0 {
                continue;
            }
            let mut pos_f = Vec::new();
            for (i, Sample { ray, bg, .. }) in rays.iter().enumerate() {
                let s = i * nc..(i + 1) * nc;
                let ts = &ws.t_c[s.clone()];
                let mut w = vec![0.0; nc];
                composite(&acts.sigma[s.clone()], &acts.rgb[3 * s.start..3 * s.end], &ws.delta[s], *bg, &mut w);
                let (mut cdf, mut tf, mut all) = (vec![0.0; nc], vec![0.0; nf], vec![0.0; nc + nf]);
                sample_pdf_f32(ts, &w, |j| (j as f32 + 0.5) / nf as f32, &mut cdf, &mut tf);
                merge_sorted(ts, &tf, &mut all);
                pos_f.extend(all.iter().map(|&ti| ray.at(ti).to_array()));
            }
            let mut acts_f = Acts::default();
            net.forward(pf, &pos_f, &ws.dirs, true, &mut acts_f);
            net.record_max_abs(&acts_f, &mut max_f);
            net.record_active(&acts_f, &mut active_f);
        }
        Calibration {
            max_c,
            max_f: (nf > 0).then_some(max_f),
            max_pos,
            active_c,
            active_f: (nf > 0).then_some(active_f),
        }
    }

    /// Serialises the run for a checkpoint: [`CHECKPOINT_MAGIC`], the
    /// format version (u16 LE), the payload's length (u64 LE) and CRC-32
    /// (u32 LE), then the payload (postcard).
    pub fn to_bytes(&self) -> Vec<u8> {
        let payload = postcard::to_stdvec(self).expect("trainer state serialises");
        let mut out = Vec::with_capacity(payload.len() + 22);
        out.extend_from_slice(CHECKPOINT_MAGIC);
        out.extend_from_slice(&CHECKPOINT_VERSION.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(&nerf_infer::format::crc32(&payload).to_le_bytes());
        out.extend_from_slice(&payload);
        out
    }

    /// Restores a run from [`Trainer::to_bytes`]; `None` if the header,
    /// length or checksum do not match (a damaged or foreign file) or the
    /// state is inconsistent (parameters that its configuration does not lay out).
    pub fn from_bytes(b: &[u8]) -> Option<Self> {
        let (head, payload) = b.split_at_checked(22)?;
        let version = u16::from_le_bytes([head[8], head[9]]);
        let len = u64::from_le_bytes(head[10..18].try_into().ok()?);
        let crc = u32::from_le_bytes(head[18..22].try_into().ok()?);
        let whole = &head[..8] == CHECKPOINT_MAGIC && version == CHECKPOINT_VERSION && len == payload.len() as u64;
        if !whole || nerf_infer::format::crc32(payload) != crc {
            return None;
        }
        let t: Self = postcard::from_bytes(payload).ok()?;
        let grid_ok = match &t.grid {
            None => t.cfg.grid_res == 0,
            Some(g) => g.res == t.cfg.grid_res && g.view().is_valid() && g.density.len() == (g.res as usize).pow(3),
        };
        let proposal_ok = match &t.proposal {
            None => t.cfg.proposal_res == 0,
            Some(p) => {
                let n = (p.res as usize).pow(3);
                p.res > 0
                    && p.res == t.cfg.proposal_res
                    && p.log_sigma.len() == n
                    && p.adam.m.len() == n
                    && p.adam.v.len() == n
                    && p.adam.steps.len() == n
            }
        };
        let nets = if t.cfg.n_fine > 0 { 2 } else { 1 };
        let sizes_ok = proposal_ok
            && t.cfg.validate().is_ok()
            && t.pixel.is_finite()
            && t.pixel >= 0.0
            && t.params.len() == t.mlp().n_params * nets
            && t.params.len() == t.adam.m.len()
            && t.params.len() == t.adam.v.len()
            && t.adam.steps.len() == table_values(&t.mlp(), t.params.len())
            && (t.ema.is_empty() || (t.cfg.ema_decay > 0.0 && t.ema.len() == t.params.len()));
        (sizes_ok && grid_ok).then_some(t)
    }
}

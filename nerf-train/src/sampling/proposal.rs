//! The proposal grid during training: where each ray's network samples go
//! in unbounded and forward-facing scenes ([`SamplingConfig::proposal_res`](crate::config::SamplingConfig::proposal_res)).
//!
//! A dense grid of log-densities `v` over the normalised (contracted)
//! coordinates, the cell layout of the occupancy grid, constant over each
//! cell: `σ = exp(v)` (1/world units). Per ray, `sampling.n_coarse` stratified
//! samples composite it into weights; the network's `sampling.n_main` samples are
//! drawn from them (`sample_pdf_f32`, as the renderer's
//! [`nerf_infer::render`] march draws them) and the last stratified sample
//! is added, so that the last interval still reaches the far plane. The
//! grid gets no gradient from the photo loss: it is fitted with the
//! interlevel loss ([`crate::loss::interlevel`]) so that its weights bound the
//! network's, by its own Adam (the occupancy grid's cells, sparse: cells no
//! ray crossed keep their moments). Exported as 8-bit codes
//! ([`nerf_infer::proposal`]).

use crate::composite::{composite, composite_back, push_deltas};
use crate::loss::interlevel::interlevel;
use crate::optim::adam::Adam;
use nerf_infer::camera::Ray;
use nerf_infer::occupancy::Occupancy;
use nerf_infer::sampling::sample_pdf_f32;
use serde::{Deserialize, Serialize};

/// Densities below this (1/world units) export as empty cells (code 0):
/// a fitted unit of such space lets 99 % of the light through.
pub const EMPTY_SIGMA: f32 = 0.01;

/// The grid and its optimiser.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ProposalGrid {
    /// Cells per axis.
    pub res: u16,
    /// `res³` log-densities, `ln(1/world units)`.
    pub log_sigma: Vec<f32>,
    /// Adam's state for `log_sigma`.
    pub adam: Adam,
}

/// One ray's proposal: its stratified samples, their cells, intervals and
/// weights, kept from the forward pass for the interlevel loss.
#[derive(Clone, Debug, Default)]
pub struct RayProposal {
    /// Stratified samples `t`.
    pub t: Vec<f32>,
    /// Each sample's cell (index into the grid).
    pub cell: Vec<u32>,
    /// Each sample's `δ` (world units; the last one infinite).
    pub delta: Vec<f32>,
    /// Each sample's density (1/world units).
    pub sigma: Vec<f32>,
    /// Each sample's weight.
    pub w: Vec<f32>,
    /// Working memory reused from ray to ray: the colours the weights are
    /// composited with (zeros, three per sample) and the CDF.
    zeros: Vec<f32>,
    cdf: Vec<f32>,
}

impl RayProposal {
    /// The edges of the proposal's intervals: `sample_pdf_f32`'s bins,
    /// between the midpoints of its samples (the first and last open).
    pub fn edges(&self) -> Vec<f32> {
        let n = self.t.len();
        let mut edges = Vec::with_capacity(n + 1);
        edges.push(f32::NEG_INFINITY);
        edges.extend((0..n - 1).map(|j| 0.5 * (self.t[j] + self.t[j + 1])));
        edges.push(f32::INFINITY);
        edges
    }
}

/// CDF level of the network's sample `j` of `n` in a stratum, jittered by
/// `key` as the renderer's march jitters it (`None`: the middle).
pub fn main_u(j: usize, n: usize, key: Option<u32>) -> f32 {
    nerf_infer::sampling::proposal_draw_q16(j, n, key) as f32 / 65536.0
}

impl ProposalGrid {
    /// A grid of `res` cells per axis, every cell at density `sigma0`.
    pub fn new(res: u16, sigma0: f32) -> Self {
        let n = (res as usize).pow(3);
        Self { res, log_sigma: vec![sigma0.ln(); n], adam: Adam::new(n, n) }
    }

    /// The cell holding normalised position `p` (the occupancy grid's arithmetic).
    pub fn cell(&self, p: [f32; 3]) -> u32 {
        let g = Occupancy { res: self.res, bits: &[] };
        g.index(g.cell_f32(p)) as u32
    }

    /// Fills `out` with the sorted `t` of the network's samples of `ray`
    /// (`out.len() − 1` drawn from the proposal's weights, then the last of
    /// `n_coarse` stratified samples, jittered by `key`), and `prop` with
    /// the proposal's samples for [`ProposalGrid::backward`].
    ///
    /// # Panics
    /// If `out` is empty or `n_coarse` is 0.
    pub fn place(&self, ray: &Ray, key: u32, n_coarse: usize, out: &mut [f32], prop: &mut RayProposal) {
        let n_main = out.len() - 1;
        prop.t.resize(n_coarse, 0.0);
        ray.stratified(Some(key), &mut prop.t);
        prop.cell.clear();
        prop.cell.extend(prop.t.iter().map(|&t| self.cell(ray.at(t).to_array())));
        prop.delta.clear();
        push_deltas(&prop.t, ray.dir_len, &mut prop.delta);
        prop.sigma.clear();
        prop.sigma.extend(prop.cell.iter().map(|&c| self.log_sigma[c as usize].exp()));
        prop.w.resize(n_coarse, 0.0);
        prop.zeros.resize(3 * n_coarse, 0.0);
        prop.cdf.resize(n_coarse, 0.0);
        composite(&prop.sigma, &prop.zeros, &prop.delta, [0.0; 3], &mut prop.w);
        let pdf_key = key ^ crate::util::rng::stream::PROPOSAL_PDF;
        sample_pdf_f32(&prop.t, &prop.w, |j| main_u(j, n_main, Some(pdf_key)), &mut prop.cdf, &mut out[..n_main]);
        out[n_main] = prop.t[n_coarse - 1];
    }

    /// The interlevel loss of one ray whose network samples `t` (from
    /// [`ProposalGrid::place`]) got weights `w`: returns it and appends
    /// `scale ·` its gradient with respect to each proposal sample's cell's
    /// log-density to `grad` as (cell, value) pairs.
    pub fn backward(&self, prop: &RayProposal, t: &[f32], w: &[f32], scale: f32, grad: &mut Vec<(u32, f32)>) -> f32 {
        let n = prop.t.len();
        let edges = prop.edges();
        let mut dw = vec![0.0; n];
        let loss = interlevel(t, w, &edges, &prop.w, scale, &mut dw);
        if dw.iter().all(|&g| g == 0.0) {
            return loss;
        }
        // the densities of the forward pass (the grid has not moved since)
        let (sigma, zeros) = (&prop.sigma, &prop.zeros);
        let mut dsigma = vec![0.0; n];
        let mut drgb = vec![0.0; 3 * n];
        composite_back(sigma, zeros, &prop.delta, [0.0; 3], &prop.w, [0.0; 3], &dw, &mut dsigma, &mut drgb);
        // σ = exp(v): ∂L/∂v = σ ∂L/∂σ
        grad.extend(prop.cell.iter().zip(sigma.iter().zip(&dsigma)).map(|(&c, (&s, &d))| (c, s * d)));
        loss
    }

    /// One Adam step on the summed gradient `grad` (dense, `res³`).
    pub fn step(&mut self, grad: &mut [f32], lr: f32, b1: f32, b2: f32, eps: f32) {
        self.adam.update(&mut self.log_sigma, grad, lr, b1, b2, eps, 0.0);
    }

    /// The grid as 8-bit codes ([`nerf_infer::proposal::Proposal`]): the
    /// log-density range from [`EMPTY_SIGMA`] to the largest (at most
    /// [`nerf_infer::proposal::MAX_PROPOSAL_SIGMA`]) in 254 even steps,
    /// cells below it empty. Returns `(log_min, log_step, codes)`.
    pub fn codes(&self) -> (f32, f32, Vec<u8>) {
        let lo = EMPTY_SIGMA.ln();
        let top = nerf_infer::proposal::MAX_PROPOSAL_SIGMA.ln() - 1e-3;
        let hi = self.log_sigma.iter().copied().filter(|v| v.is_finite()).fold(lo, f32::max).min(top);
        let step = (hi - lo) / 254.0;
        let codes = self
            .log_sigma
            .iter()
            .map(|&v| match v {
                v if v.is_nan() || v < lo => 0,
                _ if step == 0.0 => 1,
                v => 1 + ((v.min(hi) - lo) / step).round() as u8,
            })
            .collect();
        (lo, step, codes)
    }
}

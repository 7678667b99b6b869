//! Where a ray's network samples go during training ([`Sampler`]): the
//! occupancy grid that keeps them out of empty space ([`occupancy`]) and
//! the proposal grid that places them where its density says the surfaces
//! are ([`proposal`]), or stratified along the ray without either; a
//! chunk's samples land in [`RaySamples`]. Named as the renderer's
//! `nerf_infer::occupancy` and `nerf_infer::proposal`, which read what
//! these export.

pub mod occupancy;
pub mod proposal;

use crate::composite::{push_deltas, LAST_DELTA};
use crate::config::TrainConfig;
use crate::loss::distortion::push_interval;
use nerf_infer::camera::{Ray, FOOTPRINT_POINTS};
use occupancy::OccupancyGrid;
use proposal::{ProposalGrid, RayProposal};

/// The grids that place a run's samples, each with its own state (both
/// checkpointed): a run may have either, both (the proposal grid places
/// the samples, the occupancy grid drops those in empty cells) or
/// neither (stratified samples, and a fine network's hierarchical ones).
#[derive(Clone, Debug, Default)]
pub struct Sampler {
    /// The occupancy grid (runs with `grid.res` set), refreshed from the
    /// network's density every `grid.every` steps.
    pub occupancy: Option<OccupancyGrid>,
    /// The proposal grid placing the network's samples (runs with
    /// `sampling.proposal_res` set), fitted by the interlevel loss.
    pub proposal: Option<ProposalGrid>,
}

/// A chunk's samples, ray after ray, as [`Sampler::place`] leaves them.
#[derive(Clone, Debug, Default)]
pub struct RaySamples {
    /// Each ray's [`Sampler::main_samples`] positions `t` along it, kept or not.
    pub t: Vec<f32>,
    /// Each kept sample's position (the scene's normalised coordinates).
    pub pos: Vec<[f32; 3]>,
    /// The footprint points of each sample of `pos` (rays with a
    /// footprint), else empty.
    pub foot: Vec<[f32; 3]>,
    /// Each kept sample's view direction with an occupancy grid, each
    /// ray's without one.
    pub dirs: Vec<[f32; 3]>,
    /// Ray `i`'s samples are `offs[i]..offs[i + 1]` of `pos` and `delta`.
    pub offs: Vec<usize>,
    /// Each kept sample's δ (world units; [`LAST_DELTA`] for a ray's last).
    pub delta: Vec<f32>,
    /// Per sample (as `delta`) when the distortion loss is on: its interval
    /// in the ray's normalised coordinate, midpoint and length.
    pub s_mid: Vec<f32>,
    /// See `s_mid`.
    pub s_width: Vec<f32>,
    /// Each kept sample's index among its ray's samples (one per sample of
    /// `delta` as [`Sampler::place`] leaves it).
    pub kept: Vec<u32>,
    /// Each ray's proposal (runs with a proposal grid).
    pub props: Vec<RayProposal>,
}

impl RaySamples {
    /// Empties the per-sample buffers (`pos`, `delta`, the distortion's
    /// intervals) and starts `offs` at 0, for a pass to fill.
    pub fn start(&mut self) {
        self.pos.clear();
        self.delta.clear();
        self.s_mid.clear();
        self.s_width.clear();
        self.offs.clear();
        self.offs.push(0);
    }
}

impl Sampler {
    /// The grids `cfg` asks for, fresh: the occupancy grid all occupied,
    /// the proposal grid at the density `sigma` (1/world units) everywhere
    /// (an unbounded scene's network's starting density).
    ///
    /// # Panics
    /// `cfg` must pass [`TrainConfig::validate`].
    pub fn new(cfg: &TrainConfig, sigma: f32) -> Self {
        Sampler {
            occupancy: cfg.grid.res.map(|res| OccupancyGrid::new(res.get())),
            proposal: cfg.sampling.proposal_res.map(|res| ProposalGrid::new(res.get(), sigma)),
        }
    }

    /// The network's samples per ray before the occupancy grid's skipping:
    /// `sampling.n_main` drawn from the proposal grid and its last stratified one,
    /// else `sampling.n_coarse` stratified.
    pub fn main_samples(&self, cfg: &TrainConfig) -> usize {
        match self.proposal {
            Some(_) => cfg.sampling.n_main as usize + 1,
            None => cfg.sampling.n_coarse as usize,
        }
    }

    /// The samples of every ray of a chunk `rays` (jitter key per ray from
    /// `key`), placed by the proposal grid (its weights kept in
    /// `out.props`) or stratified, kept where the occupancy grid is
    /// occupied: fills `out.t` (all [`Sampler::main_samples`] per ray), and
    /// `pos`, `foot` (rays with a footprint), `delta`, `offs`, `dirs`,
    /// `kept` and, with the distortion loss, the intervals.
    pub fn place<'r>(
        &self,
        cfg: &TrainConfig,
        rays: impl ExactSizeIterator<Item = &'r Ray> + Clone,
        key: impl Fn(usize) -> u32,
        out: &mut RaySamples,
    ) {
        let nc = self.main_samples(cfg);
        let intervals = cfg.loss.distortion > 0.0;
        let grid = self.occupancy.as_ref().map(|g| g.view());
        out.t.resize(rays.len() * nc, 0.0);
        out.start();
        out.foot.clear();
        out.dirs.clear();
        out.kept.clear();
        if self.proposal.is_some() {
            out.props.resize_with(rays.len(), Default::default);
        }
        // with footprints, every sample has its K points (a ray without one: its sample K times)
        const K: usize = FOOTPRINT_POINTS;
        let any_foot = rays.clone().any(|r| r.foot.is_some());
        for (i, ray) in rays.enumerate() {
            let t = &mut out.t[i * nc..(i + 1) * nc];
            match &self.proposal {
                Some(pg) => pg.place(ray, key(i), cfg.sampling.n_coarse as usize, t, &mut out.props[i]),
                None => ray.stratified(Some(key(i)), t),
            }
            match grid {
                None => {
                    out.kept.extend(0..nc as u32);
                    for &ti in t.iter() {
                        let p = ray.at(ti).to_array();
                        out.pos.push(p);
                        if any_foot {
                            out.foot.extend(ray.foot_at(ti).unwrap_or([p; K]));
                        }
                    }
                    push_deltas(t, ray.dir_len, &mut out.delta);
                    if intervals {
                        (0..nc).for_each(|j| push_interval(ray, t, j, &mut out.s_mid, &mut out.s_width));
                    }
                    out.dirs.push(ray.viewdir.to_array());
                }
                Some(g) => {
                    for j in 0..nc {
                        let p = ray.at(t[j]).to_array();
                        if g.at_f32(p) {
                            out.kept.push(j as u32);
                            out.pos.push(p);
                            if any_foot {
                                out.foot.extend(ray.foot_at(t[j]).unwrap_or([p; K]));
                            }
                            out.delta.push(if j + 1 < nc { (t[j + 1] - t[j]) * ray.dir_len } else { LAST_DELTA });
                            if intervals {
                                push_interval(ray, t, j, &mut out.s_mid, &mut out.s_width);
                            }
                            out.dirs.push(ray.viewdir.to_array());
                        }
                    }
                }
            }
            out.offs.push(out.pos.len());
        }
    }
}

//! One optimisation step: each chunk of rays sampled, evaluated, composited
//! and differentiated in parallel, the gradients summed, Adam applied.

use super::*;
use crate::per_photo::pose::Poses;

/// Groups of chunks a batch is split into ([`Trainer::gradients_timed`]):
/// the most threads a step keeps busy, and the most gradient buffers it
/// holds at once.
const GROUPS: usize = 16;

/// One group's (or a sum of groups') share of a step: the layers' gradient,
/// the squared errors (coarse, fine), the network evaluations ([`Evals`]), each chunk's
/// grid-value gradient under its index, the time of its stages and the
/// photos' corrections' gradients.
type Acc = (Vec<f32>, f64, f64, Evals, Vec<(usize, GridGrad)>, StepTimes, PerPhoto);

/// Network evaluations: in the forward pass, and in the backward pass
/// (those left after [`Trainer::drop_idle_samples`]).
type Evals = [usize; 2];

impl Trainer {
    /// One optimisation step on a batch drawn from `data`; `progress` is
    /// the fraction of the run done (for the learning-rate decay).
    pub fn train_step(&mut self, data: &Dataset, progress: f64) -> StepStats {
        let c = &self.cfg;
        let mut times = StepTimes::default();
        if self.sampler.occupancy.is_some()
            && self.step as usize >= c.grid.warmup
            && (self.step as usize).is_multiple_of(c.grid.every)
        {
            timed(&mut times.grid, || self.update_grid());
        }
        let mut rng = Rng::new(self.seed ^ (self.step.wrapping_mul(0x9E37_79B9_7F4A_7C15)));
        let (n, mut how) = (self.cfg.sampling.batch_rays, Draw::of(&self.cfg, progress));
        if how.footprint && self.pixel == 0.0 {
            self.pixel = data.pixel_angle();
        }
        // pixels a model cannot record (wider than 0.1 rad) train as lines
        how.footprint &= self.footprint().is_some();
        if self.refines_poses() {
            let photos = data.views.len();
            if self.poses.as_ref().is_none_or(|p| p.photos() != photos) {
                self.poses = Some(Poses::new(photos));
            }
        }
        let poses = self.poses.as_ref().filter(|_| self.refines_poses());
        let batch = timed(&mut times.draw, || Self::draw_batch_posed(data, n, how, &mut rng, poses));
        let step_key = hash32(self.seed as u32 ^ hash32(self.step as u32));
        if self.cfg.per_photo.appearance {
            let photos = data.views.len();
            let a = self.appearance.get_or_insert_with(|| Appearance::new(photos));
            if a.photos() != photos {
                *a = Appearance::new(photos);
            }
        }
        let (mut grad, sq_c, sq_f, [samples, backward_samples], PerPhoto { appearance: mut photos, mut pose }, finite) =
            self.gradients_timed(&batch, step_key, &mut times);
        let n = batch.len() as f64 * 3.0;
        let mse_f = if self.cfg.sampling.n_fine.is_some() { sq_f / n } else { sq_c / n };
        let loss = (sq_c + sq_f) / n;
        let mut stats = StepStats {
            loss: loss as f32,
            psnr: (-10.0 * mse_f.max(1e-12).log10()) as f32,
            rays: batch.len(),
            samples,
            backward_samples,
            skipped: false,
            times,
        };
        if !loss.is_finite() || !finite {
            self.skipped += 1;
            stats.skipped = true;
            self.pool.give(grad);
        } else {
            let lr = self.learning_rate(progress);
            let c = &self.cfg;
            timed(&mut stats.times.adam, || self.field.apply(&mut grad, lr, &c.optimiser, self.step));
            let lr_p = c.optimiser.proposal_lr * lr / c.optimiser.lr;
            timed(&mut stats.times.adam, || self.step_proposal(lr_p));
            if let Some(a) = self.appearance.as_mut().filter(|_| !photos.is_empty()) {
                let c = &self.cfg;
                a.update(&mut photos, appearance::LR_SHARE * lr, c.optimiser.beta1, c.optimiser.beta2, c.optimiser.eps);
            }
            timed(&mut stats.times.adam, || self.step_poses(&mut pose, lr));
            // Adam left it zeroed
            self.pool.give_zeroed(grad);
        }
        if let Ok(mut g) = self.pool.2.lock() {
            g.clear();
        }
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
        let (g, c, f, [n, _], ..) = self.gradients_timed(batch, step_key, &mut StepTimes::default());
        (g, c, f, n)
    }

    /// [`Trainer::gradients`] with the network evaluations of both passes,
    /// adding the time of its stages to `times` (`chunks` and its split,
    /// `scatter`), the photos' corrections' gradients ([`PerPhoto`]) and
    /// whether every value of the gradient is finite.
    pub(super) fn gradients_timed(
        &self,
        batch: &[Sample],
        step_key: u32,
        times: &mut StepTimes,
    ) -> (Vec<f32>, f64, f64, Evals, PerPhoto, bool) {
        let start = std::time::Instant::now();
        // the proposal grid's gradient is this batch's alone
        if let Ok(mut g) = self.pool.2.lock() {
            g.clear();
        }
        let net = self.mlp();
        let np = self.field.params.len();
        // the parameters each group of chunks accumulates: all but a feature grid's table
        let dense = if net.features.is_some() { net.table } else { np };
        let scale = 2.0 / (3.0 * batch.len() as f32);
        let chunk = self.cfg.sampling.chunk_rays;
        // the batch in fixed groups of consecutive chunks, summed in a fixed tree: the sum's order (and so the
        // step's result) depends on the batch alone, not on the threads or their timing
        let per_group = batch.len().div_ceil(chunk).div_ceil(GROUPS).max(1);
        let groups: Vec<&[Sample]> = batch.chunks(per_group * chunk).collect();
        let group = |gi: usize| -> Acc {
            let mut ws = self.pool.take_workspace();
            let (mut g, mut c, mut f, mut n) = (self.pool.take(dense), 0.0f64, 0.0f64, [0usize; 2]);
            let (mut grids, mut t) = (Vec::new(), StepTimes::default());
            for (k, rays) in groups.get(gi).map_or(&[][..], |r| r).chunks(chunk).enumerate() {
                let ci = gi * per_group + k;
                let key = hash32(step_key ^ hash32(ci as u32));
                let (a, b, m, grid) = self.chunk_gradient(net, rays, key, scale, &mut ws, &mut g, &mut t);
                grids.extend(grid.map(|gg| (ci, gg)));
                (c, f, n) = (c + a, f + b, [n[0] + m[0], n[1] + m[1]]);
            }
            let photos = PerPhoto { appearance: std::mem::take(&mut ws.dapp), pose: std::mem::take(&mut ws.dpose) };
            self.pool.give_workspace(ws);
            (g, c, f, n, grids, t, photos)
        };
        let (dense_grad, sq_c, sq_f, samples, mut grids, split, photos) =
            self.sum_groups(0..groups.len().max(1), &group);
        times.add(&split);
        times.chunks += start.elapsed().as_secs_f64();
        if dense == np {
            let finite = all_finite(&dense_grad);
            return (dense_grad, sq_c, sq_f, samples, photos, finite);
        }
        let start = std::time::Instant::now();
        let mut grad = self.pool.take(np);
        grad[..dense].copy_from_slice(&dense_grad);
        self.pool.give(dense_grad);
        grids.sort_unstable_by_key(|(ci, _)| *ci);
        let grids: Vec<GridGrad> = grids.into_iter().map(|(_, g)| g).collect();
        // the table's part checked by the scatter as it writes (it starts zeroed)
        let finite = net.scatter_table(&grids, &mut grad[dense..]) && all_finite(&grad[..dense]);
        self.pool.give_grids(grids);
        times.scatter += start.elapsed().as_secs_f64();
        (grad, sq_c, sq_f, samples, photos, finite)
    }

    /// The accumulators of groups `range` ([`Trainer::gradients_timed`]),
    /// each made by `group` and summed pairwise, the left half's plus the
    /// right half's, down to single groups: the same sum in the same order
    /// whatever thread makes which group.
    fn sum_groups(&self, range: std::ops::Range<usize>, group: &(impl Fn(usize) -> Acc + Sync)) -> Acc {
        if range.len() == 1 {
            return group(range.start);
        }
        let mid = range.start + range.len() / 2;
        let ((mut g1, c1, f1, n1, mut r1, mut t1, mut p1), (g2, c2, f2, n2, r2, t2, p2)) =
            rayon::join(|| self.sum_groups(range.start..mid, group), || self.sum_groups(mid..range.end, group));
        g1.iter_mut().zip(&g2).for_each(|(a, b)| *a += b);
        self.pool.give(g2);
        r1.extend(r2);
        t1.add(&t2);
        p1.add(&p2);
        (g1, c1 + c2, f1 + f2, [n1[0] + n2[0], n1[1] + n2[1]], r1, t1, p1)
    }

    /// Forward and backward of one chunk; accumulates into `g` and returns
    /// the squared errors (coarse, fine) summed over rays and channels, the
    /// network evaluations of both passes and, with a feature grid, the grid
    /// values' gradient (`g` then holds the layers only: the table's
    /// gradient is left to [`Mlp::scatter_table`]). Adds the time of its
    /// parts to `t`'s thread stages.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn chunk_gradient(
        &self,
        net: &Mlp,
        rays: &[Sample],
        key: u32,
        scale: f32,
        ws: &mut Workspace,
        g: &mut [f32],
        t: &mut StepTimes,
    ) -> (f64, f64, Evals, Option<GridGrad>) {
        let r = rays.len();
        let nc = self.cfg.sampling.n_coarse as usize;
        let nf = self.cfg.sampling.n_fine.map_or(0, |n| n.get() as usize);
        let np = net.n_params;
        let (pc, pf) = self.field.params.split_at(np);
        let (gc, gf) = g.split_at_mut(np.min(g.len()));
        timed(&mut t.sample, || {
            self.sampler.place(
                &self.cfg,
                rays.iter().map(|s| &s.ray),
                |i| hash32(key ^ (i as u32).wrapping_mul(0x85EB_CA6B)),
                &mut ws.samples,
            )
        });
        let n_c = ws.samples.pos.len();
        ws.w_c.resize(n_c, 0.0);
        if n_c > 0 {
            timed(&mut t.encode, || net.encode_footprint(pc, &ws.samples.pos, &ws.samples.foot, &mut ws.acts_c));
            timed(&mut t.forward, || net.forward_layers(pc, &ws.samples.dirs, true, &mut ws.acts_c));
        }
        let sq_c = timed(&mut t.composite, || self.colour_loss(rays, scale, ws, false));
        self.scale_near_gradients(rays, ws);
        ws.acts_c.keep_input_gradient(self.poses.is_some() && self.refines_poses());
        if let Some(pg) = &self.sampler.proposal {
            // the interlevel loss, a mean over the batch's rays as the colour loss is
            timed(&mut t.composite, || self.proposal_backward(pg, r, key, 1.5 * scale, ws));
        }
        let (mut grid, mut n_back) = (None, n_c);
        if n_c > 0 && net.features.is_some() {
            if !self.refines_poses() {
                // a pose's gradient is read per sample of the forward pass
                n_back = timed(&mut t.backward, || self.drop_idle_samples(net, ws));
            }
            timed(&mut t.backward, || net.backward_layers(pc, &mut ws.acts_c, &ws.dsig, &ws.drgb, gc));
            if self.refines_poses() {
                timed(&mut t.backward, || self.pose_backward(net, pc, rays, ws));
            }
            let mut gg = self.pool.take_grid();
            net.swap_grid_grad(&mut ws.acts_c, &mut gg);
            grid = Some(gg);
        } else if n_c > 0 {
            timed(&mut t.backward, || net.backward(pc, &mut ws.acts_c, &ws.dsig, &ws.drgb, gc));
            if self.refines_poses() {
                timed(&mut t.backward, || self.pose_backward(net, pc, rays, ws));
            }
        }
        if nf == 0 {
            return (sq_c, 0.0, [n_c, n_back], grid);
        }
        // no grid (validated): every ray has its nc coarse samples
        let start = std::time::Instant::now();
        let na = nc + nf;
        ws.t_f.resize(nf, 0.0);
        ws.cdf.resize(nc, 0.0);
        ws.t_all.resize(r * na, 0.0);
        ws.w_f.resize(r * na, 0.0);
        ws.samples.start();
        for (i, Sample { ray, .. }) in rays.iter().enumerate() {
            let s = i * nc..(i + 1) * nc;
            let rk = hash32(key ^ crate::util::rng::stream::FINE_SAMPLES ^ (i as u32).wrapping_mul(0x27D4_EB2F));
            sample_pdf_f32(
                &ws.samples.t[s.clone()],
                &ws.w_c[s.clone()],
                |j| (j as f32 + jitter_q16(rk, j) as f32 / 65536.0) / nf as f32,
                &mut ws.cdf,
                &mut ws.t_f,
            );
            let all = &mut ws.t_all[i * na..(i + 1) * na];
            merge_sorted(&ws.samples.t[s], &ws.t_f, all);
            ws.samples.pos.extend(all.iter().map(|&ti| ray.at(ti).to_array()));
            push_deltas(all, ray.dir_len, &mut ws.samples.delta);
            if self.cfg.loss.distortion > 0.0 {
                (0..na).for_each(|j| push_interval(ray, all, j, &mut ws.samples.s_mid, &mut ws.samples.s_width));
            }
            ws.samples.offs.push(ws.samples.pos.len());
        }
        t.sample += start.elapsed().as_secs_f64();
        timed(&mut t.encode, || net.encode(pf, &ws.samples.pos, &mut ws.acts_f));
        timed(&mut t.forward, || net.forward_layers(pf, &ws.samples.dirs, true, &mut ws.acts_f));
        let sq_f = timed(&mut t.composite, || self.colour_loss(rays, scale, ws, true));
        timed(&mut t.backward, || net.backward(pf, &mut ws.acts_f, &ws.dsig, &ws.drgb, gf));
        (sq_c, sq_f, [n_c + r * na, n_back + r * na], grid)
    }
}

/// Whether every value of `g` is finite (checked in parallel blocks: a
/// model without a feature grid may hold a million parameters).
fn all_finite(g: &[f32]) -> bool {
    g.par_chunks(1 << 16).all(|b| b.iter().all(|g| g.is_finite()))
}

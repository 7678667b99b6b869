//! The proposal grid's part of a step: its interlevel gradient and update,
//! and how well it bounds the network's weights.

use super::*;

impl Trainer {
    /// One Adam step of the proposal grid (if the run has one) on the
    /// chunks' gradients of the step, at learning rate `optimiser.lr`.
    pub(super) fn step_proposal(&mut self, lr: f32) {
        let Some(pg) = self.sampler.proposal.as_mut() else { return };
        let mut chunks = self.pool.2.lock().map(|mut g| std::mem::take(&mut *g)).unwrap_or_default();
        chunks.sort_unstable_by_key(|(key, _)| *key);
        let mut grad = vec![0.0f32; pg.log_sigma.len()];
        for (c, g) in chunks.iter().flat_map(|(_, list)| list) {
            grad[*c as usize] += g;
        }
        if grad.iter().all(|g| g.is_finite()) {
            let c = &self.cfg;
            pg.step(&mut grad, lr, c.optimiser.beta1, c.optimiser.beta2, c.optimiser.eps);
        }
    }

    /// The interlevel loss's gradient of a chunk's rays, whose network
    /// samples (`ws.samples.t`, `main_samples` per ray, those kept in
    /// `ws.samples.kept`) got the weights `ws.w_c`: kept under the chunk's `key`
    /// for [`Trainer::step_proposal`].
    pub(super) fn proposal_backward(&self, pg: &ProposalGrid, n_rays: usize, key: u32, scale: f32, ws: &Workspace) {
        let nm = self.main_samples();
        let mut list = Vec::new();
        let mut w = vec![0.0f32; nm];
        for i in 0..n_rays {
            w.fill(0.0);
            for s in ws.samples.offs[i]..ws.samples.offs[i + 1] {
                w[ws.samples.kept[s] as usize] = ws.w_c[s];
            }
            pg.backward(&ws.samples.props[i], &ws.samples.t[i * nm..(i + 1) * nm], &w, scale, &mut list);
        }
        if let Ok(mut g) = self.pool.2.lock() {
            g.push((key, list));
        }
    }

    /// With a proposal grid: the mean over `batch` of the network's weight
    /// along each ray that the grid's weights leave unbounded
    /// ([`crate::loss::interlevel::unbounded_weight`]; 0 when they bound it
    /// everywhere, at most the ray's opacity), and the rays' mean opacity.
    pub fn proposal_bound(&self, batch: &[Sample]) -> Option<(f32, f32)> {
        self.sampler.proposal.as_ref()?;
        let net = self.mlp();
        let pc = self.field.coarse();
        let nm = self.main_samples();
        let mut ws = Workspace::default();
        let (mut unbounded, mut opacity) = (0.0f64, 0.0f64);
        for (ci, rays) in batch.chunks(self.cfg.sampling.chunk_rays).enumerate() {
            self.sampler.place(
                &self.cfg,
                rays.iter().map(|s| &s.ray),
                |i| hash32((ci * 7919 + i) as u32),
                &mut ws.samples,
            );
            let mut acts = Acts::default();
            if !ws.samples.pos.is_empty() {
                net.encode_footprint(pc, &ws.samples.pos, &ws.samples.foot, &mut acts);
                net.forward_layers(pc, &ws.samples.dirs, true, &mut acts);
            }
            for (i, Sample { bg, .. }) in rays.iter().enumerate() {
                let s = ws.samples.offs[i]..ws.samples.offs[i + 1];
                let mut kept_w = vec![0.0; s.len()];
                if !s.is_empty() {
                    let (sig, rgb) = (&acts.sigma[s.clone()], &acts.rgb[3 * s.start..3 * s.end]);
                    composite(sig, rgb, &ws.samples.delta[s.clone()], *bg, &mut kept_w);
                }
                let mut w = vec![0.0f32; nm];
                for (k, j) in s.clone().enumerate() {
                    w[ws.samples.kept[j] as usize] = kept_w[k];
                }
                let prop = &ws.samples.props[i];
                let t = &ws.samples.t[i * nm..(i + 1) * nm];
                unbounded += crate::loss::interlevel::unbounded_weight(t, &w, &prop.edges(), &prop.w) as f64;
                opacity += w.iter().sum::<f32>() as f64;
            }
        }
        let n = batch.len().max(1) as f64;
        Some(((unbounded / n) as f32, (opacity / n) as f32))
    }
}

//! Calibration for export: the ranges of every layer's activations over
//! calibration rays, and which ReLU outputs ever fire.

use super::*;

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

impl Trainer {
    /// Largest |activation| of every layer of each network, measured on
    /// `batch` with the training-time sampling (for quantisation), the
    /// largest |normalised coordinate| met, and which ReLU outputs were
    /// ever active (for pruning).
    pub fn calibrate(&self, batch: &[Sample]) -> Calibration {
        let net = self.mlp();
        let nc = self.cfg.sampling.n_coarse as usize;
        let nf = self.cfg.sampling.n_fine.map_or(0, |n| n.get() as usize);
        let (pc, pf) = self.field.params.split_at(net.n_params);
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
        for (ci, rays) in batch.chunks(self.cfg.sampling.chunk_rays).enumerate() {
            self.sampler.place(
                &self.cfg,
                rays.iter().map(|s| &s.ray),
                |i| hash32((ci * 7919 + i) as u32),
                &mut ws.samples,
            );
            if ws.samples.pos.is_empty() {
                continue;
            }
            net.encode_footprint(pc, &ws.samples.pos, &ws.samples.foot, &mut acts);
            net.forward_layers(pc, &ws.samples.dirs, true, &mut acts);
            net.record_max_abs(&acts, &mut max_c);
            net.record_active(&acts, &mut active_c);
            max_pos = ws.samples.pos.iter().flatten().fold(max_pos, |m, v| m.max(v.abs()));
            if nf == 0 {
                continue;
            }
            let mut pos_f = Vec::new();
            for (i, Sample { ray, bg, .. }) in rays.iter().enumerate() {
                let s = i * nc..(i + 1) * nc;
                let ts = &ws.samples.t[s.clone()];
                let mut w = vec![0.0; nc];
                composite(&acts.sigma[s.clone()], &acts.rgb[3 * s.start..3 * s.end], &ws.samples.delta[s], *bg, &mut w);
                let (mut cdf, mut tf, mut all) = (vec![0.0; nc], vec![0.0; nf], vec![0.0; nc + nf]);
                sample_pdf_f32(ts, &w, |j| (j as f32 + 0.5) / nf as f32, &mut cdf, &mut tf);
                merge_sorted(ts, &tf, &mut all);
                pos_f.extend(all.iter().map(|&ti| ray.at(ti).to_array()));
            }
            let mut acts_f = Acts::default();
            net.forward(pf, &pos_f, &ws.samples.dirs, true, &mut acts_f);
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
}

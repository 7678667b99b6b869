//! A chunk's loss as the run's configuration weighs it
//! ([`crate::loss::photo::photo_loss`] with its priors and the photos'
//! colour corrections), and the gradient's scaling near the cameras.

use super::*;
use crate::loss::photo::{photo_loss, Corrections, Priors, Target};

impl Trainer {
    /// [`photo_loss`] of a chunk's pass (the coarse or only pass's
    /// samples in `ws`, or with `fine` the fine pass's), with the run's
    /// losses beside the colour's and, with [`PerPhotoConfig::appearance`](crate::config::PerPhotoConfig::appearance),
    /// the photos' colour corrections, their gradient summed into `ws.dapp`.
    pub(super) fn colour_loss(&self, rays: &[Sample], scale: f32, ws: &mut Workspace, fine: bool) -> f64 {
        let c = &self.cfg;
        let priors = Priors {
            distortion: c.loss.distortion,
            mid: &ws.samples.s_mid,
            width: &ws.samples.s_width,
            density_l1: c.loss.density_l1,
        };
        let corr = self.appearance.as_ref().map(|a| Corrections { params: &a.params, grad: &mut ws.dapp });
        let (acts, w) = if fine { (&ws.acts_f, &mut ws.w_f) } else { (&ws.acts_c, &mut ws.w_c) };
        photo_loss(
            rays.iter().map(|r| Target { rgb: r.rgb, bg: r.bg, view: r.view }),
            &ws.samples.offs,
            scale,
            acts,
            &ws.samples.delta,
            priors,
            corr,
            w,
            &mut ws.dw,
            &mut ws.dsig,
            &mut ws.drgb,
        )
    }

    /// Scales the gradient (`dsig`, `drgb`) of each sample of the coarse or
    /// only pass that lies within [`LossConfig::near_gradient`](crate::config::LossConfig::near_gradient)
    /// `d₀` of its camera by `(d/d₀)²`, `d` its distance in world units;
    /// forward-facing scenes, whose rays run in NDC, are left alone.
    pub(super) fn scale_near_gradients(&self, rays: &[Sample], ws: &mut Workspace) {
        let d0 = self.cfg.loss.near_gradient;
        if d0 <= 0.0 || self.scene.ndc.is_some() {
            return;
        }
        let nc = self.main_samples();
        for (i, Sample { ray, .. }) in rays.iter().enumerate() {
            for k in ws.samples.offs[i]..ws.samples.offs[i + 1] {
                let d = ws.samples.t[i * nc + ws.samples.kept[k] as usize] * ray.dir_len;
                let f = (d / d0).min(1.0).powi(2);
                ws.dsig[k] *= f;
                ws.drgb[3 * k..3 * k + 3].iter_mut().for_each(|g| *g *= f);
            }
        }
    }
}

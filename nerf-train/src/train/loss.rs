//! A chunk's loss as the run's configuration weighs it
//! ([`crate::loss::photo::photo_loss`] with its priors and the photos'
//! colour corrections), the gradient's scaling near the cameras, and the
//! samples the backward pass can skip.

use super::*;
use crate::loss::photo::{photo_loss, Corrections, Priors, Target};
use crate::mlp::retain::retain_rows;

/// Marks in `keep` (one flag per sample) the samples whose gradient
/// (`dsig`, three values of `drgb` each) is not zero. Returns how many.
///
/// # Panics
/// If `drgb` holds fewer than three values per value of `dsig`.
pub fn live_samples(dsig: &[f32], drgb: &[f32], keep: &mut Vec<bool>) -> usize {
    keep.clear();
    keep.extend(
        dsig.iter().zip(drgb[..3 * dsig.len()].chunks_exact(3)).map(|(s, c)| *s != 0.0 || c.iter().any(|g| *g != 0.0)),
    );
    keep.iter().filter(|&&k| k).count()
}

/// Clears in `keep` (one flag per sample) the flags of the samples whose
/// transmittance, `1 − Σ w` over the samples before them on their ray, is
/// under `t_min`; ray `i`'s samples are `offs[i]..offs[i + 1]`, their
/// weights `w`. Returns how many flags it cleared.
///
/// # Panics
/// If `keep` or `w` hold fewer samples than `offs`'s last offset.
pub fn occluded_samples(offs: &[usize], w: &[f32], t_min: f32, keep: &mut [bool]) -> usize {
    let mut cleared = 0;
    for ray in offs.windows(2) {
        let mut seen = 0.0f32;
        for k in ray[0]..ray[1] {
            if 1.0 - seen < t_min {
                cleared += keep[k..ray[1]].iter().filter(|&&k| k).count();
                keep[k..ray[1]].fill(false);
                break;
            }
            seen += w[k];
        }
    }
    cleared
}

/// The share of a chunk's samples with a gradient above which the
/// backward pass takes them all ([`Trainer::drop_idle_samples`]): copying
/// the kept samples' activations makes each cost about a fifth more in the
/// backward pass (lego at 100×100, docs/EXPERIMENTS.md), which the dropped
/// ones must pay for (flower's proposal samples, nearly all live, trained
/// slower with them dropped).
const KEEP_ALL_ABOVE: f32 = 0.8;

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

    /// Drops from the chunk's coarse or only pass (its activations,
    /// `ws.dsig` and `ws.drgb`) the samples whose gradient is zero: a
    /// sample without density whose weight is zero (empty space inside an
    /// occupied cell) and one so far behind a surface that its weight and
    /// density gradient round to zero; with
    /// [`LossConfig::backward_transmittance`](crate::config::LossConfig::backward_transmittance)
    /// also those behind a transmittance under it ([`occluded_samples`]).
    /// The backward pass gives the others the gradient it gave before,
    /// summed over fewer terms. A chunk with more than [`KEEP_ALL_ABOVE`]
    /// of its samples kept keeps them all. Returns the samples kept.
    pub(super) fn drop_idle_samples(&self, net: &Mlp, ws: &mut Workspace) -> usize {
        let n = ws.acts_c.samples();
        ws.dsig.truncate(n);
        ws.drgb.truncate(3 * n);
        let mut live = live_samples(&ws.dsig, &ws.drgb, &mut ws.keep);
        let t_min = self.cfg.loss.backward_transmittance;
        if t_min > 0.0 {
            live -= occluded_samples(&ws.samples.offs, &ws.w_c, t_min, &mut ws.keep);
        }
        if live as f32 > KEEP_ALL_ABOVE * n as f32 {
            return n;
        }
        retain_rows(&mut ws.dsig, 1, &ws.keep);
        retain_rows(&mut ws.drgb, 3, &ws.keep);
        ws.acts_c.retain_samples(net, &ws.keep)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_with_any_gradient_are_live() {
        let dsig = [0.1, 0.0, 0.0, -0.0, -2e-30];
        let mut drgb = vec![0.0f32; 15];
        drgb[4] = 1e-20;
        drgb[9..12].fill(-0.0);
        let mut keep = vec![true; 2];
        assert_eq!(live_samples(&dsig, &drgb, &mut keep), 3);
        assert_eq!(keep, [true, true, false, false, true]);
    }

    #[test]
    fn samples_behind_the_transmittance_are_cleared_ray_by_ray() {
        // ray 0: 0.5 then 0.49995 of the light (T 1, 0.5, 5e-5, ...); ray 1: none taken
        let w = [0.5, 0.49995, 0.0, 0.0, 0.1, 0.1, 0.0];
        let offs = [0, 4, 7];
        let mut keep = [true, true, true, false, true, true, true];
        assert_eq!(occluded_samples(&offs, &w, 1e-4, &mut keep), 1);
        assert_eq!(keep, [true, true, false, false, true, true, true]);
        let mut keep = [true; 7];
        assert_eq!(occluded_samples(&offs, &w, 0.85, &mut keep), 3 + 1);
        assert_eq!(keep, [true, false, false, false, true, true, false]);
        let mut keep = [true; 7];
        assert_eq!(occluded_samples(&offs, &w, 0.0, &mut keep), 0);
    }
}

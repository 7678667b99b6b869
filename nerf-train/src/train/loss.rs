//! The loss of a chunk's rays and its gradient: the colour error after
//! compositing (and the photo's colour correction), with the distortion
//! and optical-depth terms the configuration weighs.

use super::*;

/// The losses beside the colour's: the distortion loss's weight and each
/// sample's interval (see [`crate::loss::distortion::distortion`]), and the weight
/// of the optical depth's L1 penalty ([`LossConfig::density_l1`](crate::config::LossConfig::density_l1)); a
/// weight 0 turns its loss off.
struct Priors<'a> {
    distortion: f32,
    mid: &'a [f32],
    width: &'a [f32],
    density_l1: f32,
}

/// The photos' colour corrections and their gradient, which
/// [`loss_gradients`] adds to.
struct Corrections<'a> {
    params: &'a [f32],
    grad: &'a mut Vec<f32>,
}

/// Composites each ray's samples (`offs[i]..offs[i + 1]`, weights into
/// `w`) on the ray's background, corrects the colour `C` by the ray's photo's
/// correction if `corrections` holds them (adding their gradient to its
/// `grad`), and writes the gradients of `scale · Σ (C − C_gt)²`
/// (plus `scale · 3/2 · λ · L_dist` per ray for the distortion weight λ, and
/// `scale · 3/2 · μ ·` [`optical_depth`](crate::loss::density::optical_depth) for the density weight μ) with respect to
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
    mut corrections: Option<Corrections<'_>>,
    w: &mut [f32],
    dw: &mut Vec<f32>,
    dsig: &mut Vec<f32>,
    drgb: &mut Vec<f32>,
) -> f64 {
    let n = offs[rays.len()];
    dsig.resize(n, 0.0);
    drgb.resize(n * 3, 0.0);
    if let Some(c) = corrections.as_mut() {
        c.grad.resize(c.params.len(), 0.0);
    }
    let mut sq = 0.0f64;
    for (i, r) in rays.iter().enumerate() {
        let (s, gt, bg) = (offs[i]..offs[i + 1], r.rgb, r.bg);
        let c = 3 * s.start..3 * s.end;
        let (sig, rgb) = (&acts.sigma[s.clone()], &acts.rgb[c.clone()]);
        let col = composite(sig, rgb, &delta[s.clone()], bg, &mut w[s.clone()]);
        // the photo's colour correction, if the run fits one
        let photo = r.view as usize * appearance::PER_PHOTO..(r.view as usize + 1) * appearance::PER_PHOTO;
        let y = corrections.as_ref().map_or(col, |k| appearance::apply(&k.params[photo.clone()], col));
        let dy: [f32; 3] = std::array::from_fn(|k| scale * (y[k] - gt[k]));
        let dc = match corrections.as_mut() {
            Some(k) => appearance::apply_back(&k.params[photo.clone()], col, dy, &mut k.grad[photo]),
            None => dy,
        };
        sq += (0..3).map(|k| ((y[k] - gt[k]) as f64).powi(2)).sum::<f64>();
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

impl Trainer {
    /// [`loss_gradients`] of a chunk's pass (the coarse or only pass's
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
        loss_gradients(
            rays,
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

//! The photo loss of a chunk's rays and its gradient: the colour error
//! after compositing (and the photo's colour correction), with the
//! [`distortion`] and optical-depth ([`density`](super::density)) terms weighed in.

use super::density::optical_depth_back;
use super::distortion::distortion;
use crate::composite::{composite, composite_back};
use crate::mlp::Acts;
use crate::per_photo::appearance;

/// What a ray's colour is compared with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Target {
    /// The pixel's colour on `bg`, stored (sRGB-encoded) values in `[0, 1]`.
    pub rgb: [f32; 3],
    /// The background the ray's samples are composited on, in `[0, 1]`.
    pub bg: [f32; 3],
    /// The photo the pixel is from (its colour correction's index).
    pub view: u32,
}

/// The losses beside the colour's: the distortion loss's weight and each
/// sample's interval (see [`crate::loss::distortion::distortion`]), and the weight
/// of the optical depth's L1 penalty ([`LossConfig::density_l1`](crate::config::LossConfig::density_l1)); a
/// weight 0 turns its loss off.
pub struct Priors<'a> {
    /// The distortion loss's weight λ.
    pub distortion: f32,
    /// Each sample's interval's midpoint and width along its ray.
    pub mid: &'a [f32],
    /// See `mid`.
    pub width: &'a [f32],
    /// The optical depth's weight μ.
    pub density_l1: f32,
}

/// The photos' colour corrections and their gradient, which
/// [`photo_loss`] adds to.
pub struct Corrections<'a> {
    /// Every photo's correction ([`Appearance::params`](crate::per_photo::appearance::Appearance::params)).
    pub params: &'a [f32],
    /// Their gradient, summed into.
    pub grad: &'a mut Vec<f32>,
}

/// Composites each ray's samples (`offs[i]..offs[i + 1]`, weights into
/// `w`) on the ray's background `bg`, corrects the colour `C` by the ray's photo's
/// correction if `corrections` holds them (adding their gradient to its
/// `grad`), and writes the gradients of `scale · Σ (C − C_gt)²`
/// (plus `scale · 3/2 · λ · L_dist` per ray for the distortion weight λ, and
/// `scale · 3/2 · μ ·` [`optical_depth`](crate::loss::density::optical_depth) for the density weight μ) with respect to
/// the raw densities and colours into `dsig` and `drgb`; returns the summed
/// squared error over rays and channels.
///
/// # Panics
/// If `offs` holds fewer than `rays.len() + 1` offsets, or `acts`, `delta`, `w` (and with the distortion loss the
/// priors' intervals) fewer samples than its last.
#[allow(clippy::too_many_arguments)]
pub fn photo_loss(
    rays: impl ExactSizeIterator<Item = Target>,
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
    for (i, r) in rays.enumerate() {
        let (s, gt, bg) = (offs[i]..offs[i + 1], r.rgb, r.bg);
        let c = 3 * s.start..3 * s.end;
        let (sig, rgb) = (&acts.sigma[s.clone()], &acts.rgb[c.clone()]);
        let col = composite(sig, rgb, &delta[s.clone()], bg, &mut w[s.clone()]);
        // the photo's colour correction, if the run fits one (a photo beyond the corrections' has none)
        let photo = r.view as usize * appearance::PER_PHOTO..(r.view as usize + 1) * appearance::PER_PHOTO;
        let fitted = corrections.as_mut().filter(|k| photo.end <= k.params.len());
        let y = fitted.as_ref().map_or(col, |k| appearance::apply(&k.params[photo.clone()], col));
        let dy: [f32; 3] = std::array::from_fn(|k| scale * (y[k] - gt[k]));
        let dc = match fitted {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ray_of_a_photo_beyond_the_corrections_is_scored_uncorrected() {
        let mut acts = Acts::default();
        (acts.sigma, acts.rgb) = (vec![1.0, 2.0], vec![0.2, 0.4, 0.6, 0.8, 0.1, 0.3]);
        let delta = [0.5, crate::composite::LAST_DELTA];
        // one photo's correction, doubling every colour
        let params: Vec<f32> = appearance::IDENTITY.iter().map(|v| 2.0 * v).collect();
        let loss = |view, corrections: Option<Corrections<'_>>| {
            let target = Target { rgb: [0.5; 3], bg: [1.0; 3], view };
            let priors = Priors { distortion: 0.0, mid: &[], width: &[], density_l1: 0.0 };
            let (mut w, mut dw, mut dsig, mut drgb) = (vec![0.0; 2], Vec::new(), Vec::new(), Vec::new());
            let rays = std::iter::once(target);
            photo_loss(rays, &[0, 2], 1.0, &acts, &delta, priors, corrections, &mut w, &mut dw, &mut dsig, &mut drgb)
        };
        let mut grad = Vec::new();
        let beyond = loss(3, Some(Corrections { params: &params, grad: &mut grad }));
        assert_eq!(beyond, loss(3, None));
        assert!(grad.len() == params.len() && grad.iter().all(|&g| g == 0.0));
        assert_ne!(loss(0, Some(Corrections { params: &params, grad: &mut grad })), beyond);
        assert!(grad.iter().any(|&g| g != 0.0));
    }
}

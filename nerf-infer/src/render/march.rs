//! The march, written once for every numeric path: stratified samples,
//! empty-space skipping, blocks of samples through the network, the
//! quadrature front to back with early termination, and (with a fine
//! network) a second pass over coarse + importance samples, or (with a
//! proposal grid) one pass over samples drawn from the grid's weights.

use super::path::NumericPath;
use super::renderer::Renderer;
use super::scratch::{two_pass, Scratch, TwoPass};
use crate::camera::{Ray, FOOTPRINT_POINTS};
use crate::composite::Compositor;
use crate::format::Network;
use crate::network::{Block, LayerKernel};
use crate::sampling::{jitter_q16, merge_sorted};

/// Fine-pass CDF level of importance sample `j` of `n`, Q16 in `[0, 65536]`:
/// evenly spaced without jitter (`j/(n−1)`), stratified with it.
#[inline]
fn fine_u_q16(j: usize, n: usize, key: Option<u32>) -> u32 {
    match key {
        None if n <= 1 => 0,
        None => ((j as u64 * 65536) / (n as u64 - 1)) as u32,
        Some(k) => ((j as u64 * 65536 + jitter_q16(k ^ crate::sampling::FINE_DRAW_SALT, j) as u64) / n as u64) as u32,
    }
}

#[cfg(feature = "proposal")]
/// The proposal grid `g` composited along `ray` at the samples `t`: writes
/// each sample's weight to `w` (its density from the code's entry of
/// `sigma`; 0 once the transmittance is below the early-termination
/// threshold, as the network's pass stops there).
fn propose<P: NumericPath>(
    r: &Renderer<'_, '_, P>,
    g: &crate::proposal::Proposal<'_>,
    sigma: &[P::Sigma; 256],
    ray: &P::Ray,
    t: &[P::T],
    w: &mut [P::W],
) {
    let mut comp = P::Compositor::default();
    for i in 0..t.len() {
        if comp.transmittance() < r.early_stop {
            w[i..].fill(P::W::default());
            return;
        }
        let s = sigma[P::proposal_code(g, P::at(ray, t[i])) as usize];
        w[i] = comp.add_factor(P::Compositor::factor(s, P::delta(ray, t, i)), P::Rgb::default(), t[i]);
    }
}

/// Renders `ray` (already known to meet the scene) with kernel `K`: the
/// coarse pass, then the fine pass if the options ask for one.
pub(super) fn render<P: NumericPath, K: LayerKernel<P>, const B: usize>(
    r: &Renderer<'_, '_, P>,
    ray: &Ray,
    key: Option<u32>,
    s: &mut Scratch<P, B>,
) -> P::Pixel {
    let m = r.model;
    let Some((lo, hi)) = r.occupied_span(ray) else {
        return r.background();
    };
    let span = P::span(lo, hi);
    let pr = P::ray(ray);
    let nc = r.opts.coarse;
    let Scratch { t, w_coarse, cdf, block, evaluations } = s;
    #[cfg(feature = "proposal")]
    if let (Some(sigma), Some(g)) = (&r.proposal, &m.proposal) {
        // the proposal grid composited at the stratified samples, the network at samples drawn from its
        // weights and at the last stratified sample (the interval out to the far plane)
        let TwoPass { coarse: t_coarse, fine: t_main, .. } = two_pass(t);
        let (t_p, w_p, nm) = (&mut t_coarse[..nc], &mut w_coarse[..nc], r.opts.fine);
        P::samples(&pr, key, t_p);
        propose::<P>(r, g, sigma, &pr, t_p, w_p);
        P::sample_pdf(t_p, w_p, |j| crate::sampling::proposal_draw_q16(j, nm, key), cdf, &mut t_main[..nm]);
        t_main[nm] = t_p[nc - 1];
        return pass::<P, K, B>(r, &m.coarse, &pr, &t_main[..=nm], span, true, block, None, evaluations);
    }
    let fine = if r.opts.fine > 0 { m.fine.as_ref() } else { None };
    let Some(fine_net) = fine else {
        // one pass: only the samples around the span are generated
        let t = P::samples_around(&pr, nc, key, span, t);
        return pass::<P, K, B>(r, &m.coarse, &pr, t, span, true, block, None, evaluations);
    };
    let TwoPass { coarse: t_coarse, fine: t_fine, all: t_all } = two_pass(t);
    let t_c = &mut t_coarse[..nc];
    P::samples(&pr, key, t_c);
    pass::<P, K, B>(r, &m.coarse, &pr, t_c, span, false, block, Some(&mut w_coarse[..nc]), evaluations);
    let nf = r.opts.fine;
    P::sample_pdf(t_c, &w_coarse[..nc], |j| fine_u_q16(j, nf, key), cdf, &mut t_fine[..nf]);
    let all = &mut t_all[..nc + nf];
    merge_sorted(t_c, &t_fine[..nf], all);
    pass::<P, K, B>(r, fine_net, &pr, all, span, true, block, None, evaluations)
}

/// One pass of `net` over the sorted samples `t` of `ray`: returns the
/// composited pixel and writes each sample's weight to `weights` if given
/// (0 for samples skipped as empty or after the ray stopped).
#[allow(clippy::too_many_arguments)]
fn pass<P: NumericPath, K: LayerKernel<P>, const B: usize>(
    r: &Renderer<'_, '_, P>,
    net: &Network<'_>,
    ray: &P::Ray,
    t: &[P::T],
    span: (P::T, P::T),
    need_rgb: bool,
    block: &mut Block<P, B>,
    mut weights: Option<&mut [P::W]>,
    evaluations: &mut u64,
) -> P::Pixel {
    let m = r.model;
    let zero = P::W::default();
    // the view direction's part of the colour branch, folded in at the
    // first sample that needs colour (many rays have none)
    let mut prepared = false;
    let mut comp = P::Compositor::default();
    let (grid, coarse) = (m.grid.as_ref(), r.coarse.as_ref());
    let n = t.len();
    let run = coarse.map_or(0, |c| P::run_len(c, ray, t));
    // the features averaged over the pixel footprint, if the model and ray have one
    // (only models with a feature grid have one: a build without them has none)
    let with_foot = cfg!(feature = "feature-grid") && m.footprint.is_some() && n > 0 && P::foot_at(ray, t[0]).is_some();
    let (mut next, mut tested) = (0, 0);
    while next < n {
        if comp.transmittance() < r.early_stop {
            if let Some(w) = weights.as_deref_mut() {
                w[next..n].fill(zero);
            }
            break;
        }
        // gather up to B samples in occupied cells (all of them without a grid)
        let (mut idx, mut pos, mut len) = ([0usize; B], [P::Pos::default(); B], 0);
        while next < n && len < B {
            if t[next] > span.1 {
                // past the occupied box: nothing more to evaluate
                if let Some(w) = weights.as_deref_mut() {
                    w[next..n].fill(zero);
                }
                next = n;
                break;
            }
            if let (Some(g), Some(c), true) = (grid, coarse, next >= tested) {
                // the next `run` samples, ruled out together if their
                // coarse cells are all empty
                let last = (next + run).min(n) - 1;
                let cell = |i: usize| P::cell(g, P::at(ray, t[i]));
                if c.box_is_empty(cell(next), cell(last)) {
                    if let Some(w) = weights.as_deref_mut() {
                        w[next..=last].fill(zero);
                    }
                    next = last + 1;
                    continue;
                }
                tested = last + 1;
            }
            // branch-free compaction: occupancy is too irregular to predict
            let p = P::at(ray, t[next]);
            let occupied = (t[next] >= span.0) & grid.is_none_or(|g| P::occupied(g, p));
            (idx[len], pos[len]) = (next, p);
            len += occupied as usize;
            if let Some(w) = weights.as_deref_mut().filter(|_| !occupied) {
                w[next] = zero;
            }
            next += 1;
        }
        if len == 0 {
            break;
        }
        if with_foot {
            for j in 0..len {
                block.foot[j] = P::foot_at(ray, t[idx[j]]).unwrap_or([pos[j]; FOOTPRINT_POINTS]);
            }
        }
        block.eval_density::<K>(m, net, &pos[..len], with_foot);
        *evaluations += len as u64;
        // which samples are composited (the ray stops before the first one
        // met with transmittance below the threshold) and which of those
        // carry weight: only they need the colour branch
        let mut factor = [<P::Compositor as Compositor<_, _, _, _>>::Factor::default(); B];
        let (mut probe, mut used, mut rows, mut n_rows) = (comp, 0, [0usize; B], 0);
        while used < len && probe.transmittance() >= r.early_stop {
            factor[used] = P::Compositor::factor(block.sigma[used], P::delta(ray, t, idx[used]));
            let w = probe.add_factor(factor[used], P::Rgb::default(), t[idx[used]]);
            rows[n_rows] = used;
            n_rows += (need_rgb && w > zero) as usize;
            used += 1;
        }
        if n_rows > 0 {
            if !prepared {
                block.prepare_ray::<K>(m, net, P::viewdir(ray));
                prepared = true;
            }
            block.eval_colour::<K>(m, net, &rows[..n_rows]);
        }
        let mut j = 0;
        for k in 0..used {
            let rgb = if j < n_rows && rows[j] == k {
                j += 1;
                block.rgb[j - 1]
            } else {
                P::Rgb::default() // weight 0: the colour adds nothing
            };
            let w = comp.add_factor(factor[k], rgb, t[idx[k]]);
            if let Some(ws) = weights.as_deref_mut() {
                ws[idx[k]] = w;
            }
        }
        if used < len {
            if let Some(ws) = weights.as_deref_mut() {
                idx[used..len].iter().for_each(|&i| ws[i] = zero);
            }
        }
    }
    comp.finish(m.scene.white_background, r.far)
}

//! Rendering one ray: coarse pass over stratified samples, then (with a
//! fine network) a fine pass over coarse + importance samples, composited
//! front to back with early ray termination. With an occupancy grid
//! ([`crate::occupancy`]) both passes skip the samples in empty cells.
//!
//! The two numeric paths share this structure and the [`RayRenderer`]
//! trait: [`F32Renderer`] renders [`Scheme::F32`] models, [`FixedRenderer`]
//! renders the integer schemes with no float operation per sample (per-ray
//! setup converts the ray to fixed point once).

use crate::camera::Ray;
use crate::composite::{CompositorF32, CompositorFixed, FixedPixel, Pixel, DELTA_INF_Q16};
use crate::encoding::NPOS_FRAC;
use crate::error::{Error, Result};
use crate::fixed::{sat_i32, shr_round_i64, to_fixed, POS_FRAC, T_ONE};
use crate::format::{Model, Network, Scheme, MAX_COARSE, MAX_FINE};
use crate::network::{check_i8_headroom, BlockF32, BlockFixed, IntWeight, W16, W8};
use crate::occupancy::{clip_to_box, occupied_box, CoarseOccupancy};
use crate::sampling::{
    jitter_q16, merge_sorted, ray_key, sample_pdf_f32, sample_pdf_fixed, stratified_fixed, stratified_fixed_from,
};
use crate::unbounded::{contract_q24, s_of_t_q30, t_of_s_q16};
use glam::Vec3;

/// Render-time knobs; [`RenderOptions::from_model`] gives the model's defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Stratified samples for the coarse pass (2..=256).
    pub coarse: usize,
    /// Importance samples for the fine pass (0..=256; 0 renders the coarse
    /// network only; must be 0 if the model has no fine network).
    pub fine: usize,
    /// Early ray termination: a sample met with transmittance below this is
    /// not composited, nor any after it (in `[0, 1)`; 0 disables). Decided
    /// sample by sample, so the result does not depend on the block size.
    pub early_stop: f32,
    /// Jitter seed for stratified samples; `None` samples deterministically
    /// (evenly spaced, the paper's test-time sampling).
    pub seed: Option<u32>,
}

impl RenderOptions {
    /// The model's default sample counts, no early termination, no jitter.
    pub fn from_model(model: &Model<'_>) -> Self {
        Self { coarse: model.samples.coarse as usize, fine: model.samples.fine as usize, early_stop: 0.0, seed: None }
    }

    fn validate(&self, model: &Model<'_>) -> Result<()> {
        let fine_ok = self.fine <= MAX_FINE && (self.fine == 0 || model.fine.is_some());
        let stop_ok = self.early_stop.is_finite() && (0.0..1.0).contains(&self.early_stop);
        if !(2..=MAX_COARSE).contains(&self.coarse) || !fine_ok || !stop_ok {
            return Err(Error::InvalidSamples);
        }
        Ok(())
    }

    fn key(&self, pixel: (u32, u32)) -> Option<u32> {
        self.seed.map(|s| ray_key(s, pixel.0, pixel.1))
    }
}

/// The occupied box of a model's grid: `None` without a grid, `Some(None)`
/// if no cell is occupied.
type OccBox = Option<Option<([f32; 3], [f32; 3])>>;

fn occ_box(model: &Model<'_>) -> OccBox {
    // in an unbounded scene the grid is in contracted space: no box in `t`
    model.grid.as_ref().filter(|_| model.scene.unbounded.is_none()).map(occupied_box)
}

/// The coarse occupancy level, for models where runs of samples can be
/// ruled out by the cells at their ends: not in an unbounded scene, whose
/// contracted rays are curves.
fn coarse_level(model: &Model<'_>) -> Option<CoarseOccupancy> {
    model.grid.as_ref().filter(|_| model.scene.unbounded.is_none()).map(CoarseOccupancy::new)
}

/// The range of `t` worth sampling on `ray`: all of it without a grid, the
/// part inside the occupied box with one, `None` if the ray misses it.
fn occupied_span(b: &OccBox, ray: &Ray) -> Option<(f32, f32)> {
    match b {
        None => Some((f32::NEG_INFINITY, f32::INFINITY)),
        Some(None) => None,
        Some(Some(b)) => clip_to_box(b, ray.norm_origin.to_array(), ray.norm_dir.to_array()),
    }
}

/// What both numeric paths offer: a pixel type and a per-ray entry point
/// that works in caller-provided scratch memory `S` (of any block size).
pub trait RayRenderer<S> {
    /// The pixel this path produces.
    type Pixel: Copy + Default;
    /// The model being rendered.
    fn model(&self) -> &Model<'_>;
    /// Renders the world-space ray `origin + t·dir` (`dir` with camera-space
    /// `z = −1`, as [`crate::Camera::ray`] gives); `pixel` keys the jitter.
    /// A non-finite or degenerate ray, or one that misses the scene bounds,
    /// renders as the background at `far`.
    fn render_ray(&self, origin: Vec3, dir: Vec3, pixel: (u32, u32), scratch: &mut S) -> Self::Pixel;
}

/// Working memory of [`F32Renderer`] for blocks of `B` samples:
/// about 5 KiB + `B` · 2.4 KiB (≈ 25 KiB for the default `B = 8`).
#[derive(Clone)]
pub struct ScratchF32<const B: usize = 8> {
    t_coarse: [f32; MAX_COARSE],
    w_coarse: [f32; MAX_COARSE],
    cdf: [f32; MAX_COARSE],
    t_fine: [f32; MAX_FINE],
    t_all: [f32; MAX_COARSE + MAX_FINE],
    block: BlockF32<B>,
    /// Network evaluations performed since creation (for samples/ray).
    pub evaluations: u64,
}

impl<const B: usize> Default for ScratchF32<B> {
    fn default() -> Self {
        Self {
            t_coarse: [0.0; MAX_COARSE],
            w_coarse: [0.0; MAX_COARSE],
            cdf: [0.0; MAX_COARSE],
            t_fine: [0.0; MAX_FINE],
            t_all: [0.0; MAX_COARSE + MAX_FINE],
            block: BlockF32::default(),
            evaluations: 0,
        }
    }
}

/// The f32 reference path.
#[derive(Clone, Copy, Debug)]
pub struct F32Renderer<'m, 'a> {
    model: &'m Model<'a>,
    opts: RenderOptions,
    occ_box: OccBox,
    coarse: Option<CoarseOccupancy>,
}

/// Fine-pass CDF level of importance sample `j` of `n`, Q16 in `[0, 65536]`:
/// evenly spaced without jitter (`j/(n−1)`), stratified with it.
#[inline]
fn fine_u_q16(j: usize, n: usize, key: Option<u32>) -> u32 {
    match key {
        None if n <= 1 => 0,
        None => ((j as u64 * 65536) / (n as u64 - 1)) as u32,
        Some(k) => ((j as u64 * 65536 + jitter_q16(k ^ 0xA511_E9B3, j) as u64) / n as u64) as u32,
    }
}

impl<'m, 'a> F32Renderer<'m, 'a> {
    /// A renderer for an f32 model; fails with [`Error::WrongNumericPath`]
    /// for an integer model and [`Error::InvalidSamples`] for bad options.
    pub fn new(model: &'m Model<'a>, opts: RenderOptions) -> Result<Self> {
        if model.scheme() != Scheme::F32 {
            return Err(Error::WrongNumericPath);
        }
        opts.validate(model)?;
        Ok(Self { model, opts, occ_box: occ_box(model), coarse: coarse_level(model) })
    }

    /// With `false`, the march tests every sample's grid cell instead of
    /// first ruling out runs of samples with the coarse level
    /// ([`CoarseOccupancy`], on by default). The pixels are the same
    /// either way; only the time differs.
    pub fn with_coarse_skipping(mut self, on: bool) -> Self {
        // on: keep the level `new` built (or build it again after an off)
        self.coarse = if on { self.coarse.or_else(|| coarse_level(self.model)) } else { None };
        self
    }

    #[allow(clippy::too_many_arguments)]
    /// One pass of `net` over the sorted `t`; returns the composited pixel
    /// and writes each sample's weight to `weights` if given.
    fn pass<const B: usize>(
        &self,
        net: &Network<'_>,
        ray: &Ray,
        t: &[f32],
        span: (f32, f32),
        need_rgb: bool,
        block: &mut BlockF32<B>,
        mut weights: Option<&mut [f32]>,
        evaluations: &mut u64,
    ) -> Pixel {
        let m = self.model;
        // the view branch only feeds colour (a density-only pass skips it),
        // folded in before the first block (many rays have none)
        let mut prepared = !need_rgb;
        let mut comp = CompositorF32::default();
        let (grid, coarse) = (m.grid.as_ref(), self.coarse.as_ref());
        let n = t.len();
        let run = coarse.map_or(0, |c| {
            let spacing = if n > 1 { (t[n - 1] - t[0]) / (n - 1) as f32 } else { 0.0 };
            c.run_len((spacing * ray.norm_dir.abs().max_element() * (1u32 << 24) as f32) as u64)
        });
        let (mut next, mut tested) = (0, 0);
        while next < n {
            if comp.transmittance < self.opts.early_stop {
                if let Some(w) = weights.as_deref_mut() {
                    w[next..n].fill(0.0);
                }
                break;
            }
            // gather up to B samples in occupied cells (all of them without a grid)
            let (mut idx, mut pos, mut len) = ([0usize; B], [[0.0f32; 3]; B], 0);
            while next < n && len < B {
                if t[next] > span.1 {
                    // past the occupied box: nothing more to evaluate
                    if let Some(w) = weights.as_deref_mut() {
                        w[next..n].fill(0.0);
                    }
                    next = n;
                    break;
                }
                if let (Some(g), Some(c), true) = (grid, coarse, next >= tested) {
                    // the next `run` samples, ruled out together if their
                    // coarse cells are all empty
                    let last = (next + run).min(n) - 1;
                    let cell = |i: usize| g.cell_f32(ray.at(t[i]).to_array());
                    if c.box_is_empty(cell(next), cell(last)) {
                        if let Some(w) = weights.as_deref_mut() {
                            w[next..=last].fill(0.0);
                        }
                        next = last + 1;
                        continue;
                    }
                    tested = last + 1;
                }
                let p = (t[next] >= span.0).then(|| ray.at(t[next]).to_array());
                if let Some(p) = p.filter(|&p| grid.is_none_or(|g| g.at_f32(p))) {
                    (idx[len], pos[len]) = (next, p);
                    len += 1;
                } else if let Some(w) = weights.as_deref_mut() {
                    w[next] = 0.0;
                }
                next += 1;
            }
            if len == 0 {
                break;
            }
            if !prepared {
                block.prepare_ray(m, net, ray.viewdir.to_array());
                prepared = true;
            }
            block.eval(m, net, &pos[..len], need_rgb);
            *evaluations += len as u64;
            for k in 0..len {
                let i = idx[k];
                if comp.transmittance < self.opts.early_stop {
                    // the ray stops before this sample (as in the fixed path)
                    if let Some(ws) = weights.as_deref_mut() {
                        idx[k..len].iter().for_each(|&i| ws[i] = 0.0);
                    }
                    break;
                }
                let delta = if i + 1 < n { (t[i + 1] - t[i]) * ray.dir_len } else { f32::INFINITY };
                let rgb = if need_rgb { block.rgb[k] } else { [0.0; 3] };
                let w = comp.add(block.sigma[k], delta, rgb, t[i]);
                if let Some(ws) = weights.as_deref_mut() {
                    ws[i] = w;
                }
            }
        }
        comp.finish(m.scene.white_background, m.scene.far)
    }

    fn background(&self) -> Pixel {
        CompositorF32::default().finish(self.model.scene.white_background, self.model.scene.far)
    }
}

impl<'m, 'a, const B: usize> RayRenderer<ScratchF32<B>> for F32Renderer<'m, 'a> {
    type Pixel = Pixel;

    fn model(&self) -> &Model<'_> {
        self.model
    }

    fn render_ray(&self, origin: Vec3, dir: Vec3, pixel: (u32, u32), s: &mut ScratchF32<B>) -> Pixel {
        self.render_ray_in(origin, dir, pixel, s)
    }
}

impl<'m, 'a> F32Renderer<'m, 'a> {
    /// The per-ray entry point ([`RayRenderer::render_ray`]).
    pub fn render_ray_in<const B: usize>(
        &self,
        origin: Vec3,
        dir: Vec3,
        pixel: (u32, u32),
        s: &mut ScratchF32<B>,
    ) -> Pixel {
        let m = self.model;
        let Some(ray) = Ray::new(&m.scene, origin, dir) else {
            return self.background();
        };
        let Some(span) = occupied_span(&self.occ_box, &ray) else {
            return self.background();
        };
        let key = self.opts.key(pixel);
        let nc = self.opts.coarse;
        let ScratchF32 { t_coarse, w_coarse, cdf, t_fine, t_all, block, evaluations } = s;
        let t_c = &mut t_coarse[..nc];
        ray.stratified(key, t_c);
        let fine = if self.opts.fine > 0 { m.fine.as_ref() } else { None };
        let Some(fine_net) = fine else {
            return self.pass(&m.coarse, &ray, t_c, span, true, block, None, evaluations);
        };
        self.pass(&m.coarse, &ray, t_c, span, false, block, Some(&mut w_coarse[..nc]), evaluations);
        let nf = self.opts.fine;
        sample_pdf_f32(t_c, &w_coarse[..nc], |j| fine_u_q16(j, nf, key) as f32 / 65536.0, cdf, &mut t_fine[..nf]);
        let all = &mut t_all[..nc + nf];
        merge_sorted(t_c, &t_fine[..nf], all);
        self.pass(fine_net, &ray, all, span, true, block, None, evaluations)
    }
}

/// Working memory of [`FixedRenderer`] for blocks of `B` samples:
/// about 7 KiB + `B` · 4.7 KiB + 2 KiB (≈ 47 KiB for `B = 8`, ≈ 14 KiB for `B = 1`).
#[derive(Clone)]
pub struct ScratchFixed<const B: usize = 8> {
    t_coarse: [i32; MAX_COARSE],
    w_coarse: [u32; MAX_COARSE],
    cdf: [u64; MAX_COARSE],
    t_fine: [i32; MAX_FINE],
    t_all: [i32; MAX_COARSE + MAX_FINE],
    block: BlockFixed<B>,
    /// Network evaluations performed since creation (for samples/ray).
    pub evaluations: u64,
}

impl<const B: usize> Default for ScratchFixed<B> {
    fn default() -> Self {
        Self {
            t_coarse: [0; MAX_COARSE],
            w_coarse: [0; MAX_COARSE],
            cdf: [0; MAX_COARSE],
            t_fine: [0; MAX_FINE],
            t_all: [0; MAX_COARSE + MAX_FINE],
            block: BlockFixed::default(),
            evaluations: 0,
        }
    }
}

/// A ray in the fixed-point path's formats.
struct FixedRay {
    origin: [i32; 3], // Q24 normalised
    dir: [i32; 3],    // Q24 normalised per unit t
    viewdir: [i32; 3],
    dir_len: i32,              // Q16
    near: i32,                 // Q16
    far: i32,                  // Q16
    linear_until: Option<i32>, // Q16: unbounded scene (contracted positions, spaced samples)
}

impl FixedRay {
    fn new(r: &Ray) -> Self {
        let q24 = |v: Vec3| v.to_array().map(|x| to_fixed(x, NPOS_FRAC));
        Self {
            origin: q24(r.norm_origin),
            dir: q24(r.norm_dir),
            viewdir: q24(r.viewdir),
            dir_len: to_fixed(r.dir_len, POS_FRAC),
            near: to_fixed(r.near, POS_FRAC),
            far: to_fixed(r.far, POS_FRAC),
            linear_until: r.linear_until.map(|t| to_fixed(t, POS_FRAC).max(1)),
        }
    }

    /// Q24 position at Q16 parameter `t` (saturating; contracted in an unbounded scene).
    #[inline(always)]
    fn at(&self, t: i32) -> [i32; 3] {
        let u =
            core::array::from_fn(|c| self.origin[c] as i64 + shr_round_i64(t as i64 * self.dir[c] as i64, POS_FRAC));
        match self.linear_until {
            None => u.map(sat_i32),
            Some(_) => contract_q24(u),
        }
    }

    /// The `out.len()` stratified samples of `near..far` (Q16), spaced as
    /// the scene says (see [`Ray::stratified`]).
    fn stratified(&self, key: Option<u32>, out: &mut [i32]) {
        match self.linear_until {
            None => stratified_fixed(self.near, self.far, key, out),
            Some(lin) => {
                stratified_fixed(s_of_t_q30(self.near, lin), s_of_t_q30(self.far, lin), key, out);
                out.iter_mut().for_each(|s| *s = t_of_s_q16(*s, lin));
            }
        }
    }
}

/// The `n` stratified samples of `ray` that a pass over `span` (Q16) can
/// use, written to `out`: from the last one before `span.0` to the first one
/// after `span.1` (or the end). The pass reads the same samples and deltas
/// as over all `n` (the one after the span bounds the last delta, and the
/// one before it confirms that no earlier sample is inside), so the pixel is
/// bit-identical; only their generation is saved.
fn stratified_fixed_around<'o>(
    ray: &FixedRay,
    n: usize,
    key: Option<u32>,
    span: (i32, i32),
    out: &'o mut [i32],
) -> &'o [i32] {
    let (near, len) = (ray.near as i64, (ray.far as i64 - ray.near as i64).max(0));
    // an unbounded scene's samples are not evenly spaced in `t` (and its span is the whole ray)
    if n < 3 || len == 0 || ray.linear_until.is_some() {
        ray.stratified(key, &mut out[..n]);
        return &out[..n];
    }
    // unjittered index of a Q16 parameter, rounded down; jitter moves a
    // sample by less than one stratum, so one more on each side is enough
    let d = (n - 1) as i64;
    let index = |t: i32| ((t as i64 - near).clamp(0, len) * d / len) as usize;
    let first = index(span.0).saturating_sub(1);
    let end = (index(span.1) + 3).min(n);
    let part = &mut out[..end - first];
    stratified_fixed_from(ray.near, ray.far, n, key, first, part);
    let starts_before = first == 0 || part[0] < span.0;
    let ends_after = end == n || part[part.len() - 1] > span.1;
    if starts_before && ends_after {
        return &out[..end - first];
    }
    // not reached for valid rays; kept so the result never depends on it
    stratified_fixed(ray.near, ray.far, key, &mut out[..n]);
    &out[..n]
}

/// The integer-only fixed-point path.
#[derive(Clone, Copy, Debug)]
pub struct FixedRenderer<'m, 'a> {
    model: &'m Model<'a>,
    opts: RenderOptions,
    early_stop_q30: u32,
    far: i32,
    occ_box: OccBox,
    coarse: Option<CoarseOccupancy>,
}

impl<'m, 'a> FixedRenderer<'m, 'a> {
    /// A renderer for an int16 or int8 model; fails with
    /// [`Error::WrongNumericPath`] for an f32 model, [`Error::InvalidScale`]
    /// if an int8 layer could overflow its i32 accumulator.
    pub fn new(model: &'m Model<'a>, opts: RenderOptions) -> Result<Self> {
        if !model.scheme().is_fixed() {
            return Err(Error::WrongNumericPath);
        }
        opts.validate(model)?;
        check_i8_headroom(&model.coarse)?;
        if let Some(f) = &model.fine {
            check_i8_headroom(f)?;
        }
        Ok(Self {
            model,
            opts,
            early_stop_q30: (opts.early_stop as f64 * T_ONE as f64) as u32,
            far: to_fixed(model.scene.far, POS_FRAC),
            occ_box: occ_box(model),
            coarse: coarse_level(model),
        })
    }

    /// With `false`, the march tests every sample's grid cell instead of
    /// first ruling out runs of samples with the coarse level
    /// ([`CoarseOccupancy`], on by default). The pixels are the same
    /// either way; only the time differs.
    pub fn with_coarse_skipping(mut self, on: bool) -> Self {
        // on: keep the level `new` built (or build it again after an off)
        self.coarse = if on { self.coarse.or_else(|| coarse_level(self.model)) } else { None };
        self
    }

    #[allow(clippy::too_many_arguments)]
    fn pass<W: IntWeight, const B: usize>(
        &self,
        net: &Network<'_>,
        ray: &FixedRay,
        t: &[i32],
        span: (i32, i32),
        need_rgb: bool,
        block: &mut BlockFixed<B>,
        mut weights: Option<&mut [u32]>,
        evaluations: &mut u64,
    ) -> FixedPixel {
        let m = self.model;
        // the view direction's part of the colour branch, folded in at the
        // first sample that needs colour (many rays have none)
        let mut prepared = false;
        let mut comp = CompositorFixed::default();
        let (grid, coarse) = (m.grid.as_ref(), self.coarse.as_ref());
        let n = t.len();
        let run = coarse.map_or(0, |c| {
            let spacing = if n > 1 { (t[n - 1] as i64 - t[0] as i64) / (n - 1) as i64 } else { 0 };
            let fastest = ray.dir.iter().map(|d| d.unsigned_abs() as u64).max().unwrap_or(0);
            c.run_len((spacing.max(0) as u64 * fastest) >> 16)
        });
        let (mut next, mut tested) = (0, 0);
        while next < n {
            if comp.transmittance < self.early_stop_q30 {
                if let Some(w) = weights.as_deref_mut() {
                    w[next..n].fill(0);
                }
                break;
            }
            // gather up to B samples in occupied cells (all of them without a grid)
            let (mut idx, mut pos, mut len) = ([0usize; B], [[0i32; 3]; B], 0);
            while next < n && len < B {
                if t[next] > span.1 {
                    // past the occupied box: nothing more to evaluate
                    if let Some(w) = weights.as_deref_mut() {
                        w[next..n].fill(0);
                    }
                    next = n;
                    break;
                }
                if let (Some(g), Some(c), true) = (grid, coarse, next >= tested) {
                    // the next `run` samples, ruled out together if their
                    // coarse cells are all empty
                    let last = (next + run).min(n) - 1;
                    let cell = |i: usize| g.cell_fixed(ray.at(t[i]), NPOS_FRAC);
                    if c.box_is_empty(cell(next), cell(last)) {
                        if let Some(w) = weights.as_deref_mut() {
                            w[next..=last].fill(0);
                        }
                        next = last + 1;
                        continue;
                    }
                    tested = last + 1;
                }
                // branch-free compaction: occupancy is too irregular to predict
                let p = ray.at(t[next]);
                let occupied = (t[next] >= span.0) & grid.is_none_or(|g| g.at_fixed(p, NPOS_FRAC));
                (idx[len], pos[len]) = (next, p);
                len += occupied as usize;
                if let Some(w) = weights.as_deref_mut().filter(|_| !occupied) {
                    w[next] = 0;
                }
                next += 1;
            }
            if len == 0 {
                break;
            }
            block.eval_density::<W>(m, net, &pos[..len]);
            *evaluations += len as u64;
            let delta = |i: usize| {
                if i + 1 < n {
                    let dt = t[i + 1] as i64 - t[i] as i64;
                    shr_round_i64(dt * ray.dir_len as i64, POS_FRAC).clamp(0, DELTA_INF_Q16 as i64 - 1) as i32
                } else {
                    DELTA_INF_Q16
                }
            };
            // which samples are composited (the ray stops before the first
            // one met with transmittance below the threshold) and which of
            // those carry weight: only they need the colour branch
            let (mut probe, mut used, mut rows, mut n_rows) = (comp, 0, [0usize; B], 0);
            while used < len && probe.transmittance >= self.early_stop_q30 {
                let w = probe.add(block.sigma[used], delta(idx[used]), [0; 3], 0);
                rows[n_rows] = used;
                n_rows += (need_rgb && w > 0) as usize;
                used += 1;
            }
            if n_rows > 0 {
                if !prepared {
                    block.prepare_ray::<W>(m, net, ray.viewdir);
                    prepared = true;
                }
                block.eval_colour::<W>(m, net, &rows[..n_rows]);
            }
            let mut j = 0;
            for k in 0..used {
                let rgb = if j < n_rows && rows[j] == k {
                    j += 1;
                    block.rgb[j - 1]
                } else {
                    [0; 3] // weight 0: the colour adds nothing
                };
                let w = comp.add(block.sigma[k], delta(idx[k]), rgb, t[idx[k]]);
                if let Some(ws) = weights.as_deref_mut() {
                    ws[idx[k]] = w;
                }
            }
            if used < len {
                if let Some(ws) = weights.as_deref_mut() {
                    idx[used..len].iter().for_each(|&i| ws[i] = 0);
                }
            }
        }
        comp.finish(m.scene.white_background, self.far)
    }

    fn render<W: IntWeight, const B: usize>(&self, ray: &Ray, key: Option<u32>, s: &mut ScratchFixed<B>) -> FixedPixel {
        let m = self.model;
        let Some((lo, hi)) = occupied_span(&self.occ_box, ray) else {
            return CompositorFixed::default().finish(m.scene.white_background, self.far);
        };
        // Q16, widened outward (saturating casts; the box margin covers rounding)
        let span = (libm::floorf(lo * 65536.0) as i32, libm::ceilf(hi * 65536.0) as i32);
        let fr = FixedRay::new(ray);
        let nc = self.opts.coarse;
        let ScratchFixed { t_coarse, w_coarse, cdf, t_fine, t_all, block, evaluations } = s;
        let fine = if self.opts.fine > 0 { m.fine.as_ref() } else { None };
        let Some(fine_net) = fine else {
            // one pass: only the samples around the span are generated
            let t = stratified_fixed_around(&fr, nc, key, span, t_coarse);
            return self.pass::<W, B>(&m.coarse, &fr, t, span, true, block, None, evaluations);
        };
        let t_c = &mut t_coarse[..nc];
        fr.stratified(key, t_c);
        self.pass::<W, B>(&m.coarse, &fr, t_c, span, false, block, Some(&mut w_coarse[..nc]), evaluations);
        let nf = self.opts.fine;
        sample_pdf_fixed(t_c, &w_coarse[..nc], |j| fine_u_q16(j, nf, key), cdf, &mut t_fine[..nf]);
        let all = &mut t_all[..nc + nf];
        merge_sorted(t_c, &t_fine[..nf], all);
        self.pass::<W, B>(fine_net, &fr, all, span, true, block, None, evaluations)
    }

    /// The per-ray entry point ([`RayRenderer::render_ray`]).
    pub fn render_ray_in<const B: usize>(
        &self,
        origin: Vec3,
        dir: Vec3,
        pixel: (u32, u32),
        s: &mut ScratchFixed<B>,
    ) -> FixedPixel {
        let m = self.model;
        let Some(ray) = Ray::new(&m.scene, origin, dir) else {
            return CompositorFixed::default().finish(m.scene.white_background, self.far);
        };
        let key = self.opts.key(pixel);
        match m.scheme() {
            Scheme::I16 => self.render::<W16, B>(&ray, key, s),
            _ => self.render::<W8, B>(&ray, key, s),
        }
    }
}

impl<'m, 'a, const B: usize> RayRenderer<ScratchFixed<B>> for FixedRenderer<'m, 'a> {
    type Pixel = FixedPixel;

    fn model(&self) -> &Model<'_> {
        self.model
    }

    fn render_ray(&self, origin: Vec3, dir: Vec3, pixel: (u32, u32), s: &mut ScratchFixed<B>) -> FixedPixel {
        self.render_ray_in(origin, dir, pixel, s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::hash32;

    /// What makes a pass over the samples around the span bit-identical to
    /// one over all of them: they are a contiguous run of the full set that
    /// holds every sample inside the span, begins before it (or at the
    /// first sample) and ends after it (or at the last).
    #[test]
    fn the_samples_around_the_span_are_a_run_of_the_full_set_covering_it() {
        let mut out = [0i32; MAX_COARSE];
        let mut full = [0i32; MAX_COARSE];
        let mut shortened = 0;
        for case in 0..4000u32 {
            let h = |k: u32| hash32(case.wrapping_mul(7919) ^ k);
            let near = (h(1) % (8 << 16)) as i32;
            let far = near + (h(2) % (8 << 16)) as i32;
            let n = [2, 3, 5, 64, 192, MAX_COARSE][(h(3) % 6) as usize];
            let key = (h(4) % 2 == 0).then(|| h(5));
            let a = near - (1 << 16) + (h(6) % (10 << 16)) as i32;
            let span = (a, a + (h(7) % (4 << 16)) as i32);
            let ray = FixedRay {
                origin: [0; 3],
                dir: [0; 3],
                viewdir: [0; 3],
                dir_len: 1 << 16,
                near,
                far,
                linear_until: None,
            };
            stratified_fixed(near, far, key, &mut full[..n]);
            let part = stratified_fixed_around(&ray, n, key, span, &mut out);
            let len = part.len();
            let first = (0..=n - len).find(|&k| full[k..k + len] == *part);
            let first = first.unwrap_or_else(|| panic!("case {case}: not a run of the full set"));
            let end = first + len;
            assert!(first == 0 || part[0] < span.0, "case {case}: starts inside the span");
            assert!(end == n || part[len - 1] > span.1, "case {case}: ends inside the span");
            let inside = |t: &i32| (span.0..=span.1).contains(t);
            let all = full[..n].iter().filter(|t| inside(t)).count();
            assert_eq!(part.iter().filter(|t| inside(t)).count(), all, "case {case}");
            shortened += (len < n) as u32;
        }
        // and the point of it: most rays generate fewer samples
        assert!(shortened > 2000, "{shortened} of 4000 shortened");
    }
}

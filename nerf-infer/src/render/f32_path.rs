//! The f32 reference path: every format is f32, world units for `t` and
//! `δ`, normalised coordinates for positions, `[0, 1]` for weights and
//! colours.

use super::march::render;
use super::path::NumericPath;
use super::renderer::{Dispatch, Renderer};
use super::scratch::Scratch;
use crate::camera::{Ray, FOOTPRINT_POINTS};
use crate::composite::{CompositorF32, Pixel};
use crate::error::{Error, Result};
use crate::format::{Model, Scheme};
use crate::network::F32;
use crate::occupancy::{CoarseOccupancy, Occupancy};
use crate::proposal::Proposal;
use crate::sampling::sample_pdf_f32;

impl NumericPath for F32 {
    type T = f32;
    type W = f32;
    type Cdf = f32;
    type Ray = Ray;
    type Compositor = CompositorF32;
    type Pixel = Pixel;

    fn check(model: &Model<'_>) -> Result<()> {
        if model.scheme() != Scheme::F32 {
            return Err(Error::WrongNumericPath(model.scheme()));
        }
        Ok(())
    }

    fn early_stop(e: f32) -> f32 {
        e
    }

    fn t(t: f32) -> f32 {
        t
    }

    fn span(lo: f32, hi: f32) -> (f32, f32) {
        (lo, hi)
    }

    fn ray(r: &Ray) -> Ray {
        *r
    }

    #[inline(always)]
    fn at(ray: &Ray, t: f32) -> [f32; 3] {
        ray.at(t).to_array()
    }

    #[inline(always)]
    fn foot_at(ray: &Ray, t: f32) -> Option<[[f32; 3]; FOOTPRINT_POINTS]> {
        ray.foot_at(t)
    }

    #[inline(always)]
    fn cell(grid: &Occupancy<'_>, p: [f32; 3]) -> [usize; 3] {
        grid.cell_f32(p)
    }

    fn sigma(s: f32) -> f32 {
        s
    }

    #[inline(always)]
    fn proposal_code(g: &Proposal<'_>, p: [f32; 3]) -> u8 {
        g.code_f32(p)
    }

    #[inline(always)]
    fn occupied(grid: &Occupancy<'_>, p: [f32; 3]) -> bool {
        grid.at_f32(p)
    }

    fn run_len(coarse: &CoarseOccupancy, ray: &Ray, t: &[f32]) -> usize {
        let n = t.len();
        let spacing = if n > 1 { (t[n - 1] - t[0]) / (n - 1) as f32 } else { 0.0 };
        coarse.run_len((spacing * ray.norm_dir.abs().max_element() * (1u32 << 24) as f32) as u64)
    }

    #[inline(always)]
    fn delta(ray: &Ray, t: &[f32], i: usize) -> f32 {
        if i + 1 < t.len() {
            (t[i + 1] - t[i]) * ray.dir_len
        } else {
            f32::INFINITY
        }
    }

    fn samples(ray: &Ray, key: Option<u32>, out: &mut [f32]) {
        ray.stratified(key, out);
    }

    fn samples_around<'o>(ray: &Ray, n: usize, key: Option<u32>, _span: (f32, f32), out: &'o mut [f32]) -> &'o [f32] {
        ray.stratified(key, &mut out[..n]);
        &out[..n]
    }

    fn sample_pdf(t: &[f32], w: &[f32], u_q16: impl Fn(usize) -> u32, cdf: &mut [f32], out: &mut [f32]) {
        sample_pdf_f32(t, w, |j| u_q16(j) as f32 / 65536.0, cdf, out);
    }

    fn viewdir(ray: &Ray) -> [f32; 3] {
        ray.viewdir.to_array()
    }
}

/// One kernel: f32 weights.
impl Dispatch for F32 {
    fn render<const B: usize>(
        r: &Renderer<'_, '_, F32>,
        ray: &Ray,
        key: Option<u32>,
        s: &mut Scratch<F32, B>,
    ) -> Pixel {
        render::<F32, F32, B>(r, ray, key, s)
    }
}

//! A renderer chosen at run time: [`AnyRenderer`] opens a model of any
//! numeric scheme and renders it on the path the scheme needs, into one
//! pixel type ([`Pixel`]).

use super::api::{RayRenderer, RenderOptions};
use super::{RendererF32, RendererFixed, ScratchF32, ScratchFixed, DEFAULT_BLOCK};
use crate::error::Result;
use crate::format::Model;
use crate::pixel::Pixel;
use glam::Vec3;

/// A renderer of any model: [`RendererF32`] for f32 models,
/// [`RendererFixed`] for int16 and int8 ones, picked from the model's
/// scheme. Its pixels are [`Pixel`]s (fixed-point pixels converted
/// exactly); its working memory an [`AnyScratch`]. The typed renderers
/// stay for code that knows its model's scheme (and for `no_std` builds
/// that want only one path's code).
#[derive(Clone, Copy, Debug)]
pub enum AnyRenderer<'m, 'a> {
    /// An f32 model.
    F32(RendererF32<'m, 'a>),
    /// An int16 or int8 model.
    Fixed(RendererFixed<'m, 'a>),
}

/// Working memory of an [`AnyRenderer`] for blocks of `B` samples
/// ([`DEFAULT_BLOCK`] unless named: 8 with `std`, 1
/// without): the scratch of the path it renders. [`AnyRenderer::scratch`] makes the one
/// a renderer needs; given the other path's, a render replaces it first.
/// As big as the larger of the two ([`ScratchFixed`]); keep it in a `Box`
/// or a `static` on small stacks.
#[derive(Clone)]
pub enum AnyScratch<const B: usize = DEFAULT_BLOCK> {
    /// For an f32 model.
    F32(ScratchF32<B>),
    /// For an int16 or int8 model.
    Fixed(ScratchFixed<B>),
}

impl<'m, 'a> AnyRenderer<'m, 'a> {
    /// The renderer `model`'s scheme needs, with `opts`; fails as
    /// [`RendererF32::new`] and [`RendererFixed::new`] do.
    pub fn new(model: &'m Model<'a>, opts: RenderOptions) -> Result<Self> {
        Ok(if model.scheme().is_fixed() {
            AnyRenderer::Fixed(RendererFixed::new(model, opts)?)
        } else {
            AnyRenderer::F32(RendererF32::new(model, opts)?)
        })
    }

    /// [`RendererF32::with_pixel`] on whichever path renders.
    pub fn with_pixel(self, pixel: f32) -> Self {
        match self {
            AnyRenderer::F32(r) => AnyRenderer::F32(r.with_pixel(pixel)),
            AnyRenderer::Fixed(r) => AnyRenderer::Fixed(r.with_pixel(pixel)),
        }
    }

    /// [`RendererF32::with_coarse_skipping`] on whichever path renders.
    pub fn with_coarse_skipping(self, on: bool) -> Self {
        match self {
            AnyRenderer::F32(r) => AnyRenderer::F32(r.with_coarse_skipping(on)),
            AnyRenderer::Fixed(r) => AnyRenderer::Fixed(r.with_coarse_skipping(on)),
        }
    }

    /// Whether the fixed-point path renders (an int16 or int8 model).
    pub fn is_fixed(&self) -> bool {
        matches!(self, AnyRenderer::Fixed(_))
    }

    /// Working memory of the path this renderer runs.
    pub fn scratch<const B: usize>(&self) -> AnyScratch<B> {
        match self {
            AnyRenderer::F32(_) => AnyScratch::F32(ScratchF32::new()),
            AnyRenderer::Fixed(_) => AnyScratch::Fixed(ScratchFixed::new()),
        }
    }
}

impl<const B: usize> AnyScratch<B> {
    /// Network evaluations performed with this scratch since it was made.
    pub fn evaluations(&self) -> u64 {
        match self {
            AnyScratch::F32(s) => s.evaluations,
            AnyScratch::Fixed(s) => s.evaluations,
        }
    }
}

impl<const B: usize> RayRenderer<AnyScratch<B>> for AnyRenderer<'_, '_> {
    type Pixel = Pixel;

    fn model(&self) -> &Model<'_> {
        match self {
            AnyRenderer::F32(r) => r.model,
            AnyRenderer::Fixed(r) => r.model,
        }
    }

    fn render_ray(&self, origin: Vec3, dir: Vec3, pixel: (u32, u32), s: &mut AnyScratch<B>) -> Pixel {
        loop {
            match (self, &mut *s) {
                (AnyRenderer::F32(r), AnyScratch::F32(s)) => return r.render_ray_in(origin, dir, pixel, s),
                (AnyRenderer::Fixed(r), AnyScratch::Fixed(s)) => return r.render_ray_in(origin, dir, pixel, s).into(),
                // the other path's scratch: replaced by this one's
                (r, s) => *s = r.scratch(),
            }
        }
    }
}

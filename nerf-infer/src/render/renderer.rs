//! A renderer: one model on one numeric path, with its options and
//! occupancy fixed at creation; its per-ray entry picks the layer kernel
//! for the model ([`Dispatch`]) and runs the march.

use super::api::{RayRenderer, RenderOptions};
use super::path::NumericPath;
use super::scratch::Scratch;
use crate::camera::Ray;
use crate::composite::Compositor;
use crate::error::Result;
use crate::format::Model;
use crate::occupancy::{clip_to_box, occupied_box, CoarseOccupancy};
use glam::Vec3;

/// A numeric path's choice of layer kernel for a renderer's model: the
/// march (`render/march.rs`) instantiated with it.
pub trait Dispatch: NumericPath {
    /// Renders `ray` (a ray that meets the scene bounds), jittered by `key`.
    fn render<const B: usize>(
        r: &Renderer<'_, '_, Self>,
        ray: &Ray,
        key: Option<u32>,
        s: &mut Scratch<Self, B>,
    ) -> Self::Pixel;
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

/// A renderer of one model on numeric path `P`, with its options and
/// occupancy fixed at creation.
#[derive(Clone, Copy, Debug)]
pub struct Renderer<'m, 'a, P: NumericPath> {
    pub(super) model: &'m Model<'a>,
    pub(super) opts: RenderOptions,
    /// `opts.early_stop` as a transmittance of the path.
    pub(super) early_stop: P::W,
    /// The scene's far plane in the path's format: the depth of empty space.
    pub(super) far: P::T,
    occ_box: OccBox,
    pub(super) coarse: Option<CoarseOccupancy>,
    /// The pixel angle (radians) of the rays' footprints: the model's
    /// [`crate::format::Footprint::pixel`] unless [`Renderer::with_pixel`]
    /// says otherwise; `None` for a model without a footprint.
    pixel: Option<f32>,
    /// The density of each proposal code in the path's format, for a
    /// model with a proposal grid rendered with importance samples.
    #[cfg(feature = "proposal")]
    pub(super) proposal: Option<[P::Sigma; 256]>,
}

impl<'m, 'a, P: NumericPath> Renderer<'m, 'a, P> {
    /// A renderer for `model`; fails with [`Error::WrongNumericPath`](crate::Error::WrongNumericPath) if
    /// the path does not render the model's scheme ([`crate::AnyRenderer`]
    /// picks the path from the model), [`Error::InvalidScale`](crate::Error::InvalidScale)
    /// if an int8 layer could overflow its i32 accumulator and
    /// [`Error::InvalidSamples`](crate::Error::InvalidSamples) for bad options.
    pub fn new(model: &'m Model<'a>, opts: RenderOptions) -> Result<Self> {
        P::check(model)?;
        opts.validate(model)?;
        Ok(Self {
            model,
            opts,
            early_stop: P::early_stop(opts.early_stop),
            far: P::t(model.scene.far),
            occ_box: occ_box(model),
            coarse: coarse_level(model),
            pixel: model.footprint.map(|f| f.pixel),
            #[cfg(feature = "proposal")]
            proposal: model
                .proposal
                .filter(|_| opts.fine > 0)
                .map(|g| core::array::from_fn(|k| P::sigma(g.sigma_of(k as u8)))),
        })
    }

    /// For a model with a pixel footprint ([`crate::format::Footprint`]):
    /// renders rays through pixels of angular size `pixel` radians (1/focal
    /// length in pixels of the camera rendered), instead of the model's
    /// training pixels. No effect on a model without one.
    pub fn with_pixel(mut self, pixel: f32) -> Self {
        if self.pixel.is_some() {
            self.pixel = Some(pixel);
        }
        self
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

    /// The range of `t` worth sampling on `ray`: all of it without a grid,
    /// the part inside the occupied box with one, `None` if the ray misses it.
    pub(super) fn occupied_span(&self, ray: &Ray) -> Option<(f32, f32)> {
        match &self.occ_box {
            None => Some((f32::NEG_INFINITY, f32::INFINITY)),
            Some(None) => None,
            Some(Some(b)) => clip_to_box(b, ray.norm_origin.to_array(), ray.norm_dir.to_array()),
        }
    }

    /// The pixel of a ray that meets nothing: the background at `far`.
    pub(super) fn background(&self) -> P::Pixel {
        P::Compositor::default().finish(self.model.scene.white_background, self.far)
    }
}

impl<'m, 'a, P: Dispatch> Renderer<'m, 'a, P> {
    /// The per-ray entry point ([`RayRenderer::render_ray`]).
    pub fn render_ray_in<const B: usize>(
        &self,
        origin: Vec3,
        dir: Vec3,
        pixel: (u32, u32),
        s: &mut Scratch<P, B>,
    ) -> P::Pixel {
        match Ray::new(&self.model.scene, origin, dir) {
            Some(ray) => {
                // (footprints belong to feature grids: a build without them has none)
                #[cfg(feature = "feature-grid")]
                let ray = match self.pixel {
                    Some(a) => ray.with_footprint(&self.model.scene, a, 0.0),
                    None => ray,
                };
                P::render(self, &ray, self.opts.key(pixel), s)
            }
            None => self.background(),
        }
    }
}

impl<'m, 'a, P: Dispatch, const B: usize> RayRenderer<Scratch<P, B>> for Renderer<'m, 'a, P> {
    type Pixel = P::Pixel;

    fn model(&self) -> &Model<'_> {
        self.model
    }

    fn render_ray(&self, origin: Vec3, dir: Vec3, pixel: (u32, u32), s: &mut Scratch<P, B>) -> P::Pixel {
        self.render_ray_in(origin, dir, pixel, s)
    }
}

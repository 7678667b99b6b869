//! The contract between the march and a numeric path.
//!
//! The march (`render/march.rs`) is written once over [`NumericPath`]: the
//! formats of a ray, its samples, their weights and the pixel, and the
//! per-sample operations in them. The network's numbers come from
//! [`Numbers`], its layers from a [`LayerKernel`](crate::network::LayerKernel) the path picks per model
//! ([`super::Dispatch`]), so that one path carries several kernels (the
//! fixed-point path has int16 and int8 weights) and a new kernel (say int4
//! weights) plugs in without touching the march.

use crate::camera::{Ray, FOOTPRINT_POINTS};
use crate::composite::Compositor;
use crate::error::Result;
use crate::format::Model;
use crate::network::Numbers;
use crate::occupancy::{CoarseOccupancy, Occupancy};
use crate::proposal::Proposal;
use crate::tensor::Zero;
use core::fmt::Debug;

/// A numeric path: the formats the march works in and its per-sample
/// operations. Implemented by [`super::F32`] (f32 throughout) and
/// [`super::Fixed`] (integers only after a per-ray setup).
pub trait NumericPath: Numbers + Debug {
    /// Ray parameter `t` and interval length `δ` (f32 world units; Q16).
    type T: Copy + Default + PartialOrd + Debug + Zero;
    /// Compositing weight and transmittance (f32 in `[0, 1]`; Q30).
    type W: Copy + Default + PartialOrd + Debug + Zero;
    /// Cumulative-distribution entry of importance sampling.
    type Cdf: Copy + Default + Zero;
    /// A ray in this path's formats.
    type Ray;
    /// Front-to-back accumulator of the quadrature.
    type Compositor: Compositor<Self::T, Self::Sigma, Self::T, Self::Rgb, W = Self::W, Pixel = Self::Pixel>;
    /// The rendered pixel.
    type Pixel: Copy + Default;

    /// `Ok` if this path renders `model` (its scheme, and for the integer
    /// path accumulators that cannot overflow).
    fn check(model: &Model<'_>) -> Result<()>;
    /// The early-termination threshold (`[0, 1)`) as a transmittance.
    fn early_stop(e: f32) -> Self::W;
    /// A world-space `t` (the scene's far plane) in this path's format.
    fn t(t: f32) -> Self::T;
    /// The span `[lo, hi]` of `t` worth sampling, widened outward.
    fn span(lo: f32, hi: f32) -> (Self::T, Self::T);
    /// The ray in this path's formats.
    fn ray(r: &Ray) -> Self::Ray;
    /// Normalised position at `t` (contracted in an unbounded scene).
    fn at(ray: &Self::Ray, t: Self::T) -> Self::Pos;
    /// The points of the ray's pixel footprint at `t` (see
    /// [`Ray::foot_at`]), `None` for a ray without one.
    fn foot_at(ray: &Self::Ray, t: Self::T) -> Option<[Self::Pos; FOOTPRINT_POINTS]>;
    /// The grid cell holding `p`.
    fn cell(grid: &Occupancy<'_>, p: Self::Pos) -> [usize; 3];
    /// A density (1/world units, `0..=`[`crate::proposal::MAX_PROPOSAL_SIGMA`])
    /// in the network's density format (f32; Q10 rounded to nearest).
    fn sigma(s: f32) -> Self::Sigma;
    /// The code of the proposal grid's cell holding `p`.
    fn proposal_code(g: &Proposal<'_>, p: Self::Pos) -> u8;
    /// Whether the grid cell holding `p` is occupied.
    fn occupied(grid: &Occupancy<'_>, p: Self::Pos) -> bool;
    /// How many samples of `t` the coarse occupancy level can rule out
    /// together on `ray` (see [`CoarseOccupancy::run_len`]).
    fn run_len(coarse: &CoarseOccupancy, ray: &Self::Ray, t: &[Self::T]) -> usize;
    /// `δ` of sample `i` of `t`: to the next sample in world units, the
    /// infinite interval for the last one.
    fn delta(ray: &Self::Ray, t: &[Self::T], i: usize) -> Self::T;
    /// The `out.len()` stratified samples of the ray, jittered by `key`.
    fn samples(ray: &Self::Ray, key: Option<u32>, out: &mut [Self::T]);
    /// Of the `n` stratified samples, the run that a pass over `span` needs
    /// (all of them where the path does not shorten it): the pixel is the
    /// same as over all `n`.
    fn samples_around<'o>(
        ray: &Self::Ray,
        n: usize,
        key: Option<u32>,
        span: (Self::T, Self::T),
        out: &'o mut [Self::T],
    ) -> &'o [Self::T];
    /// Importance samples of the weights `w` at `t`
    /// ([`crate::sampling::sample_pdf_f32`] and its fixed-point twin);
    /// `u_q16(j)` is sample `j`'s CDF level in Q16.
    fn sample_pdf(
        t: &[Self::T],
        w: &[Self::W],
        u_q16: impl Fn(usize) -> u32,
        cdf: &mut [Self::Cdf],
        out: &mut [Self::T],
    );
    /// The unit view direction of `ray`, the view branch's input.
    fn viewdir(ray: &Self::Ray) -> Self::Pos;
}

//! Rendering one ray: coarse pass over stratified samples, then (with a
//! fine network) a fine pass over coarse + importance samples, composited
//! front to back with early ray termination. With an occupancy grid
//! ([`crate::occupancy`]) both passes skip the samples in empty cells.
//!
//! The march (`render/march.rs`) is written once over a numeric path
//! ([`NumericPath`], in [`path`]); [`F32`] and [`Fixed`] are its two
//! implementations. [`RendererF32`] renders [`Scheme::F32`] models,
//! [`RendererFixed`] renders the integer schemes with no float operation
//! per sample (per-ray setup converts the ray to fixed point once).
//!
//! [`Scheme::F32`]: crate::format::Scheme::F32

mod any;
mod api;
mod f32_path;
mod fixed_path;
mod march;
pub mod path;
mod renderer;
mod scratch;
pub mod tile;

pub use crate::network::{Fixed, F32};
pub use any::{AnyRenderer, AnyScratch};
pub use api::{RayRenderer, RenderOptions};
pub use fixed_path::RayFixed;
pub use path::NumericPath;
pub use renderer::{Dispatch, Renderer};
pub use scratch::Scratch;

/// Samples per block of the scratch types when none is named
/// (`AnyScratch`, `ScratchF32`, `ScratchFixed`): 8 with the `std` feature,
/// a host's build (from a crate outside this workspace on an AMD EPYC,
/// int8 renders lego in 0.52 of the time of blocks of 1, f32 in 0.70:
/// `scripts/measure/block_sizes.sh`, docs/RESULTS.md "Samples per block"); 1
/// without, where the scratch must fit a microcontroller's stack or RAM
/// (`ScratchFixed<1>` 13.3 KiB, `<8>` 43.4 KiB).
pub const DEFAULT_BLOCK: usize = if cfg!(feature = "std") { 8 } else { 1 };

/// Working memory of [`RendererF32`].
pub type ScratchF32<const B: usize = DEFAULT_BLOCK> = Scratch<F32, B>;
/// Working memory of [`RendererFixed`].
pub type ScratchFixed<const B: usize = DEFAULT_BLOCK> = Scratch<Fixed, B>;

/// The f32 reference path.
pub type RendererF32<'m, 'a> = Renderer<'m, 'a, F32>;
/// The integer-only fixed-point path (int16 and int8 models).
pub type RendererFixed<'m, 'a> = Renderer<'m, 'a, Fixed>;

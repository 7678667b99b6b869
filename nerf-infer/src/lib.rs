//! `nerf-infer`: renders Neural Radiance Fields (Mildenhall et al., 2020)
//! without `std` and without an allocator, in f32 or integer-only fixed
//! point, from a model blob that can sit in flash.
//!
//! # Quick start
//!
//! ```toml
//! [dependencies]
//! nerf-infer = { path = "../nerf/nerf-infer", features = ["std"] }
//!
//! # the renderer is generic, compiled in this crate: optimise debug builds
//! # (at opt-level 0 a ray costs 135× its release time, at 1 2.6×)
//! [profile.dev]
//! opt-level = 1
//! [profile.dev.package.nerf-infer]
//! opt-level = 3
//! ```
//!
//! On a host, turn on `std`: it picks the SIMD kernels the CPU has at run
//! time (AVX2, AVX-512 VNNI) and adds the model writer; without it (a
//! microcontroller) the crate is `no_std` and picks kernels at compile time
//! from the target features. Then (the workspace's `examples/quickstart`
//! is this as a program that writes a picture):
//!
//! ```
//! use nerf_infer::prelude::*;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // any .nerf file `nerf train` or `nerf export` wrote; decoding borrows, it never copies
//! # let bytes = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/golden8.nerf")).to_vec();
//! let model = Model::from_bytes(&bytes)?;
//! // f32 models render in f32, int16 and int8 ones in fixed point: AnyRenderer picks
//! let renderer = AnyRenderer::new(&model, RenderOptions::from_model(&model))?;
//! // the first camera of the orbit the model was trained around, 64×64 pixels
//! let camera = Orbit::of(&model).camera(0.0, 64, 64)?;
//! let mut scratch: AnyScratch = renderer.scratch(); // working memory: 43 KiB with `std`, 13 KiB without
//! let mut rgb = Vec::new();
//! for y in 0..camera.height {
//!     for x in 0..camera.width {
//!         let (origin, dir) = camera.ray(x, y);
//!         rgb.extend(renderer.render_ray(origin, dir, (x, y), &mut scratch).to_rgb888());
//!     }
//! }
//! assert_eq!(rgb.len(), 3 * 64 * 64);
//! # Ok(())
//! # }
//! ```
//!
//! Without an allocator, on a microcontroller: the typed renderer of the
//! model's path, a tile at a time into a caller-owned buffer, the scratch in
//! a `static` (its `new` is a `const fn`). The workspace's
//! `examples/cortex-m` is this as firmware.
//!
//! ```
//! use nerf_infer::{render_tile, Camera, Model, PixelFixed, RenderOptions, RendererFixed, ScratchFixed, Tile};
//!
//! // in flash
//! static MODEL: &[u8] = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/golden.nerf"));
//!
//! # fn main() -> nerf_infer::Result<()> {
//! let model = Model::from_bytes(MODEL)?;
//! let renderer = RendererFixed::new(&model, RenderOptions::from_model(&model))?;
//! let pose = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 3.0]];
//! let camera = Camera::from_fov(16, 16, 0.7, pose)?;
//! let tile = Tile { x0: 4, y0: 4, width: 4, height: 2 };
//! let mut scratch = ScratchFixed::<1>::new(); // one sample per block: 13.3 KiB
//! let mut pixels = [PixelFixed::default(); 8];
//! render_tile(&renderer, &camera, tile, &mut scratch, &mut pixels)?;
//! // colours are Q15 in [0, 32768]: convert for a display
//! let rgb565: [u16; 8] = pixels.map(|p| p.to_rgb565());
//! # let _ = rgb565;
//! # Ok(())
//! # }
//! ```
//!
//! # Pipeline
//!
//! One module per stage: [`camera`] (pixel → ray; [`orbit`] for cameras
//! around a model) → [`sampling`] (where along the ray; [`unbounded`] for
//! scenes without bounds, [`occupancy`] to skip empty space, [`proposal`]
//! to place the network's samples in unbounded and forward-facing scenes)
//! → [`encoding`] (γ, and the learned [`features`]) → the network (the MLP)
//! → [`composite`] (the quadrature) → [`render`] (the march over one ray,
//! written once for both numeric paths, and [`render::tile`]) → [`pixel`]
//! (conversions for displays and files). [`format`](mod@format) decodes
//! models. Below them: [`limits`] (capacities and format constants) and
//! [`fixed`] (Q formats and integer primitives); the dense-layer kernels and
//! the SIMD kernels ([`Kernels`]) are internal.
//!
//! # Numeric formats
//!
//! [`RendererF32`] renders f32 models in f32. [`RendererFixed`] renders int16
//! and int8 models with integers only after a per-ray setup: ray origins
//! and `t` in Q16 (±32768 world units), normalised positions and view
//! directions in Q24, encoding features in Q15, colours and
//! opacity in Q15 (`[0, 32768]`, [`PixelFixed`]), transmittance and weights
//! in Q30, layer activations at per-layer scales fixed at export; the
//! feature table i16 in the grid's Q format, or 8- or 4-bit indices into a
//! per-level codebook of such values (format version 7); int8 models keep
//! the view layer's direction rows and the colour and density heads at 16
//! bits (format versions 6 and 8). Every shift
//! rounds half up and every narrowing saturates; the table and the rounding
//! rules are in [`fixed`]. [`AnyRenderer`] picks the path from the model.
//! Colours are sRGB-encoded values, as the training photos store them.
//!
//! # Memory
//!
//! Nothing is allocated. Working memory is a scratch value the caller owns
//! ([`ScratchF32`], [`ScratchFixed`], [`AnyScratch`]) for blocks of `B`
//! samples evaluated together ([`DEFAULT_BLOCK`] unless named: 8 with
//! `std`, the fastest on a desktop CPU; 1 without, for small stacks):
//! `ScratchFixed<1>` 13.3 KiB, `ScratchFixed<8>` 43.4 KiB, `ScratchF32<1>`
//! 9.6 KiB, `ScratchF32<8>` 27.5 KiB. Beyond it, on a Cortex-M4 at
//! opt-level `s`, `Model::from_bytes` needs 13.1 KiB of stack and
//! `render_tile` 4.3 KiB (5.2 KiB with the feature and proposal grids);
//! `Model` is 2 636 bytes there, 4 608 on x86-64. `STACK.md` has the table
//! per target, which CI checks.
//!
//! # Cargo features
//!
//! - `feature-grid` (default): the learned feature grid's lookups (models
//!   of format version 3 and later with `features`). Without it such models are
//!   refused at load with [`Error::Capacity`], and a Cortex-M build's flash
//!   is smaller by the lookup code (docs/EXPERIMENTS.md measures it).
//! - `proposal` (default): the proposal grid's pass (format version 11
//!   models with `proposal`); without it such models are refused, and a
//!   Cortex-M build is smaller by the pass's code.
//! - `alloc`: the model writer (`format::to_bytes`).
//! - `std`: `alloc`, and the SIMD kernels chosen at run time from the CPU's
//!   features ([`kernels`]). [`Error`] implements `core::error::Error`
//!   with or without it.
//!
//! [`glam`] (the `Vec3` of rays) and [`heapless`] (the bounded vectors of
//! [`format`](mod@format)) appear in the API and are re-exported.
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]
// Unsafe code only in `arch` (SIMD loads and stores of checked slices, and
// the prefetch hint, which reads nothing).
#![deny(unsafe_code)]
// Numeric kernels index several arrays by the same sample/channel index;
// iterator chains would hide that symmetry.
#![allow(clippy::needless_range_loop)]

#[cfg(feature = "alloc")]
extern crate alloc;

#[doc(hidden)]
pub mod arch;
pub mod camera;
pub mod composite;
pub mod encoding;
pub mod error;
pub mod features;
pub mod fixed;
pub mod format;
#[doc(hidden)]
pub mod layer;
pub mod limits;
#[doc(hidden)]
pub mod network;
pub mod occupancy;
pub mod orbit;
pub mod pixel;
pub mod prelude;
pub mod proposal;
pub mod render;
pub mod sampling;
#[doc(hidden)]
pub mod tensor;
pub mod unbounded;

pub use arch::{kernels, use_kernels, Kernels};
pub use camera::{Camera, Ray};
pub use error::{Error, Result};
pub use format::{Model, Scheme};
pub use glam::{self, Vec3};
pub use heapless;
pub use orbit::Orbit;
pub use pixel::{to_u8, Pixel, PixelFixed};
pub use render::tile::{render_tile, Tile};
pub use render::{
    AnyRenderer, AnyScratch, Fixed, NumericPath, RayRenderer, RenderOptions, Renderer, RendererF32, RendererFixed,
    Scratch, ScratchF32, ScratchFixed, DEFAULT_BLOCK, F32,
};

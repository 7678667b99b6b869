//! `nerf-infer`: renders Neural Radiance Fields (Mildenhall et al., 2020)
//! without `std` and without an allocator, in f32 or integer-only fixed
//! point, from a model blob that can sit in flash.
//!
//! Pipeline, one module per stage: [`camera`] (pixel → ray) →
//! [`sampling`] (where along the ray; [`unbounded`] for scenes without
//! bounds, [`occupancy`] to skip empty space, [`proposal`] to place the
//! network's samples in unbounded and forward-facing scenes) → [`encoding`] (γ, and the
//! learned [`features`]) → [`network`] (the MLP) → [`composite`] (the
//! quadrature) → [`render`] (the march over one ray, written once for both
//! numeric paths, and [`render::tile`]). [`format`](mod@format) decodes
//! models. Below them: [`limits`] (capacities and format constants),
//! [`fixed`] (Q formats and integer primitives), [`tensor`] (tensor
//! elements), [`layer`] (the portable dense-layer kernels); [`arch`] holds
//! the SIMD kernels and is the one place that picks them.
//!
//! Memory: nothing is allocated. Working memory is a scratch value the
//! caller owns ([`ScratchF32`], [`ScratchFixed`]), sized by the constants in
//! [`format`](mod@format) (`MAX_WIDTH = 256`, `MAX_COARSE = MAX_FINE = 256`,
//! `MAX_MARCH = 1024` samples per ray without a fine pass) and a block
//! size `B` (samples evaluated together).
//!
//! # Numeric formats
//!
//! [`RendererF32`] renders f32 models in f32. [`RendererFixed`] renders int16
//! and int8 models with integers only after a per-ray setup: positions and
//! `t` in Q16 (±32768 world units), encoding features in Q15, colours and
//! opacity in Q15 (`[0, 32768]`, [`PixelFixed`]), transmittance and weights
//! in Q30, layer activations at per-layer scales fixed at export; the
//! feature table i16 in the grid's Q format, or 8- or 4-bit indices into a
//! per-level codebook of such values (format version 7); int8 models keep
//! the view layer's direction rows and the colour and density heads at 16
//! bits (format versions 6 and 8). Every shift
//! rounds half up and every narrowing saturates; the table and the rounding
//! rules are in [`fixed`]. The two paths agree within bounds the workspace
//! tests hold (on lego, int16 within 0.01 dB of f32).
//!
//! # Stack
//!
//! The scratch is the bulk of what a render needs: about 14 KiB for
//! `ScratchFixed<1>`, 47 KiB for `ScratchFixed<8>`, 25 KiB for
//! `ScratchF32<8>`; keep it in a `static` or on a stack that holds it. The
//! Cortex-M firmware of the workspace (`examples/cortex-m`, `ScratchFixed<4>`)
//! peaks at 39.3 KB of stack and 16 B of static RAM.
//!
//! # Cargo features
//!
//! - `feature-grid` (default): the learned feature grid's lookups (models
//!   of format version 3 and later with `features`). Without it such models are
//!   refused at load with [`Error::Capacity`], and a Cortex-M3 build is about
//!   7 KB of flash smaller.
//! - `alloc`: the model writer (`format::to_bytes`).
//! - `std`: `alloc`, and `std::error::Error` for [`Error`].
//!
//! [`glam`] (the `Vec3` of rays) and [`heapless`] (the bounded vectors of
//! [`format`](mod@format)) appear in the API and are re-exported.
//!
//! # Embedding example
//!
//! ```
//! use nerf_infer::{render_tile, Camera, PixelFixed, RendererFixed, Model, RayRenderer, RenderOptions, ScratchFixed, Tile};
//!
//! // The model can live in flash: decoding borrows, it never copies.
//! static MODEL: &[u8] = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/golden.nerf"));
//!
//! let model = Model::from_bytes(MODEL).expect("valid model");
//! let renderer = RendererFixed::new(&model, RenderOptions::from_model(&model)).unwrap();
//! let pose = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 3.0]];
//! let camera = Camera::from_fov(16, 16, 0.7, pose).unwrap();
//! let tile = Tile { x0: 4, y0: 4, width: 4, height: 2 };
//! let mut scratch = ScratchFixed::<1>::default(); // one sample per block: ~14 KiB
//! let mut pixels = [PixelFixed::default(); 8];
//! for (k, px) in pixels.iter_mut().enumerate() {
//!     let (x, y) = (tile.x0 + k as u32 % 4, tile.y0 + k as u32 / 4);
//!     let (o, d) = camera.ray(x, y);
//!     *px = renderer.render_ray(o, d, (x, y), &mut scratch);
//! }
//! // Or the whole tile at once (here with the default block size, 8):
//! let mut scratch: ScratchFixed = ScratchFixed::default();
//! let mut tile_px = [PixelFixed::default(); 8];
//! render_tile(&renderer, &camera, tile, &mut scratch, &mut tile_px).unwrap();
//! assert_eq!(pixels, tile_px);
//! assert!(pixels.iter().all(|p| p.rgb.iter().all(|&c| c <= 32768)));
//! ```
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]
// Unsafe code only in `arch` (SIMD loads and stores of checked slices).
#![deny(unsafe_code)]
// Numeric kernels index several arrays by the same sample/channel index;
// iterator chains would hide that symmetry.
#![allow(clippy::needless_range_loop)]

#[cfg(feature = "alloc")]
extern crate alloc;

pub mod arch;
pub mod camera;
pub mod composite;
pub mod encoding;
pub mod error;
pub mod features;
pub mod fixed;
pub mod format;
pub mod layer;
pub mod limits;
pub mod network;
pub mod occupancy;
pub mod proposal;
pub mod render;
pub mod sampling;
pub mod tensor;
pub mod unbounded;

pub use arch::{kernels, use_kernels, Kernels};
pub use camera::{Camera, Ray};
pub use composite::{Pixel, PixelFixed};
pub use error::{Error, Result};
pub use format::{Model, Scheme};
pub use glam::{self, Vec3};
pub use heapless;
pub use render::tile::{render_tile, Tile};
pub use render::{
    Fixed, NumericPath, RayRenderer, RenderOptions, Renderer, RendererF32, RendererFixed, Scratch, ScratchF32,
    ScratchFixed, F32,
};

//! `nerf-train`: trains NeRF models in f32 on the CPU and exports them in
//! `nerf-infer`'s model format.
//!
//! Modules follow the pipeline: [`dataset`] (posed images) → [`mlp`] (the
//! network, forward and backward) and [`volume`] (the quadrature, forward
//! and backward) → [`train`] (batches, Adam) → [`export`] (model files,
//! quantisation) → [`eval`] (rendering views through `nerf-infer`, PSNR,
//! SSIM). [`run`] is a whole training run as `nerf train` makes it: the
//! choices for the data and the loop, for any program.
#![deny(missing_docs)]
// Numeric code indexes several arrays by the same index on purpose.
#![allow(clippy::needless_range_loop)]

pub mod adam;
pub mod appearance;
pub mod atomic;
pub mod config;
pub mod dataset;
pub mod error;
pub mod eval;
pub mod export;
pub mod gemm;
pub mod grid;
pub mod interlevel;
pub mod mesh;
pub mod metrics;
pub mod mlp;
pub mod path;
pub mod plot;
pub mod pose;
pub mod proposal;
pub mod rng;
pub mod run;
pub mod timing;
pub mod train;
pub mod userfile;
pub mod volume;

pub use error::{Error, Result};

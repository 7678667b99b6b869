//! `nerf-train`: trains NeRF models in f32 on the CPU and exports them in
//! `nerf-infer`'s model format.
//!
//! Modules follow the pipeline, by stage:
//! - [`dataset`], posed photos, from each layout, fitted to a scene;
//! - [`config`], what a run trains ([`config::TrainConfig`], the presets);
//! - [`sampling`], where a ray's samples go (the occupancy grid, the
//!   proposal grid);
//! - [`field`], what a run fits: the networks' parameters, their Adam
//!   state and their average, as one part;
//! - [`mlp`], the networks' shape: the feature grid and the layers,
//!   forward and backward;
//! - [`composite`], the volume-rendering quadrature, forward and backward;
//! - [`loss`], the terms beside the colour error (distortion, density,
//!   interlevel);
//! - [`per_photo`], each photo's colour and pose corrections;
//! - [`optim`], Adam;
//! - [`train`], a step composed of the above, the run's state and its
//!   checkpoints; [`run`], a whole run as `nerf train` makes it (the
//!   choices for the data and the loop), for any program;
//! - [`export`], model files, quantisation.
//!
//! Products of a trained model: [`eval`] (views through `nerf-infer`, with
//! [`metrics`]: PSNR, SSIM), [`mesh`], [`path`] (camera paths), [`plot`].
//! [`error`] is the crate's error; [`util`] holds the helpers the stages
//! share.
#![deny(missing_docs)]
// Numeric code indexes several arrays by the same index on purpose.
#![allow(clippy::needless_range_loop)]

pub mod composite;
pub mod config;
pub mod dataset;
pub mod error;
pub mod eval;
pub mod export;
pub mod field;
pub mod loss;
pub mod mesh;
pub mod metrics;
pub mod mlp;
pub mod optim;
pub mod path;
pub mod per_photo;
pub mod plot;
pub mod run;
pub mod sampling;
pub mod train;
pub mod util;

pub use error::{Error, Result};

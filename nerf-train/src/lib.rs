//! `nerf-train`: trains NeRF models in f32 on the CPU and exports them in
//! `nerf-infer`'s model format.
#![deny(missing_docs)]

pub mod gemm;
pub mod mlp;
pub mod rng;
pub mod volume;

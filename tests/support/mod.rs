//! Helpers shared by the workspace tests: nerf-train's test helpers
//! (`nerf-train/tests/support/mod.rs`: `TestDir`, `unit_scene`,
//! `small_config`, `psnr`, `render`, ...), the synthetic captures and the
//! `nerf` command's runners.
#![allow(dead_code)]

pub mod captures;
pub mod cli;

#[path = "../../nerf-train/tests/support/mod.rs"]
mod shared;
pub use shared::*;

//! What a program that renders models uses, in one import:
//! `use nerf_infer::prelude::*;`. (`Result` and `Error` stay out, so as not
//! to shadow the program's own: they are `nerf_infer::Result` and
//! `nerf_infer::Error`.)

pub use crate::camera::Camera;
pub use crate::format::{Model, Scheme};
pub use crate::orbit::Orbit;
pub use crate::pixel::{Pixel, PixelFixed};
pub use crate::render::tile::{render_tile, Tile};
pub use crate::render::{
    AnyRenderer, AnyScratch, RayRenderer, RenderOptions, RendererF32, RendererFixed, ScratchF32, ScratchFixed,
};
pub use glam::Vec3;

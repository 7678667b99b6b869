//! Rendering a rectangular tile of a frame into a caller-provided buffer.

use super::api::RayRenderer;
use crate::camera::Camera;
use crate::error::{Error, Result};

/// A rectangle of pixels: columns `x0..x0+width`, rows `y0..y0+height`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    /// Left column.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// Width in pixels (≥ 1).
    pub width: u32,
    /// Height in pixels (≥ 1).
    pub height: u32,
}

impl Tile {
    /// Number of pixels in the tile.
    pub fn len(&self) -> usize {
        self.width as usize * self.height as usize
    }
    /// True if the tile has no pixels.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Renders `tile` of `camera`'s image into `out` (row-major, `tile.width`
/// pixels per row; `out.len() ≥ tile.len()`). Fails with
/// [`Error::InvalidTile`] if the tile is empty, leaves the image, or `out`
/// is too small; no pixel is written then. A model with a pixel footprint
/// ([`crate::format::Footprint`]) renders the renderer's pixel: the
/// model's training pixel unless the renderer was made
/// `.with_pixel(camera.pixel_angle())` for a camera of another resolution.
pub fn render_tile<S, R: RayRenderer<S>>(
    renderer: &R,
    camera: &Camera,
    tile: Tile,
    scratch: &mut S,
    out: &mut [R::Pixel],
) -> Result<()> {
    let inside = tile.x0.checked_add(tile.width).is_some_and(|x| x <= camera.width)
        && tile.y0.checked_add(tile.height).is_some_and(|y| y <= camera.height);
    if tile.is_empty() || !inside || out.len() < tile.len() {
        return Err(Error::InvalidTile);
    }
    for (k, px) in out[..tile.len()].iter_mut().enumerate() {
        let x = tile.x0 + (k % tile.width as usize) as u32;
        let y = tile.y0 + (k / tile.width as usize) as u32;
        let (o, d) = camera.ray(x, y);
        *px = renderer.render_ray(o, d, (x, y), scratch);
    }
    Ok(())
}

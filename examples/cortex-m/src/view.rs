//! The fixed view the firmware renders, shared with the host test that
//! generates `expected.rs` (`tests/firmware_expected.rs` in the workspace).

use nerf_infer::{PixelFixed, Tile};

/// Image width and height in pixels (the shipped models' training size).
pub const WIDTH: u32 = 64;
/// Image height in pixels.
pub const HEIGHT: u32 = 64;
/// Horizontal field of view in radians (the built-in scene's cameras).
pub const FOV_X: f32 = 0.691_111_2;
/// Camera-to-world matrix (OpenGL axes): an eye 4 units from the origin at
/// 30° elevation, looking at the origin, z up.
pub const POSE: [[f32; 4]; 3] = [
    [-0.783_326_9, -0.310_805, 0.538_33, 2.153_32],
    [0.621_61, -0.391_663_5, 0.678_381, 2.713_524],
    [0.0, 0.866_025_4, 0.5, 2.0],
];
/// The tile rendered: 8×8 pixels across the object's edge.
pub const TILE: Tile = Tile { x0: 39, y0: 27, width: 8, height: 8 };
/// Pixels in the tile.
pub const PIXELS: usize = 64;

/// FNV-1a (32-bit) over every pixel's fields, little-endian, in order
/// r, g, b, opacity (u16, Q15) and depth (i32, Q16).
pub fn checksum(pixels: &[PixelFixed]) -> u32 {
    let mut h: u32 = 0x811c_9dc5;
    for p in pixels {
        let fields = [p.rgb[0] as u32, p.rgb[1] as u32, p.rgb[2] as u32, p.opacity as u32];
        let bytes = fields.iter().flat_map(|f| (*f as u16).to_le_bytes()).chain(p.depth.to_le_bytes());
        for b in bytes {
            h = (h ^ b as u32).wrapping_mul(0x0100_0193);
        }
    }
    h
}

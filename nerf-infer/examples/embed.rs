//! Embedding `nerf-infer` on the host: a model compiled into the binary with
//! `include_bytes!`, decoded in place (no copy, no allocation) and rendered
//! one 16×16 tile at a time into an image printed as PPM on stdout.
//!
//!     cargo run -p nerf-infer --example embed > view.ppm
//!
//! The model is the workspace's int8 model of the built-in scene
//! (`models/scene_int8.nerf`, 58 KiB); any `.nerf` file that `nerf train` or
//! `nerf export` writes works the same way. Without `std` (a
//! microcontroller), the same calls render into a caller-owned buffer:
//! see `examples/cortex-m` in the workspace.

use nerf_infer::{render_tile, Camera, Model, PixelFixed, RenderOptions, RendererFixed, ScratchFixed, Tile, Vec3};
use std::io::Write;

/// The model, in the binary's read-only data (flash on a microcontroller).
static MODEL: &[u8] = include_bytes!("../../models/scene_int8.nerf");

/// Image side, pixels.
const SIZE: u32 = 64;
/// Tile side, pixels: the unit of work (and of working memory for the pixels).
const TILE: u32 = 16;

/// Renders the view into 8-bit RGB, row-major from the top row.
fn render(model: &Model<'_>) -> nerf_infer::Result<Vec<u8>> {
    let renderer = RendererFixed::new(model, RenderOptions::from_model(model))?;
    // a camera 4 units from the origin, 30° above the xy plane, looking at
    // the origin; the built-in scene's up is +z
    let eye = Vec3::new(0.0, -4.0 * 0.866, 4.0 * 0.5);
    let camera = Camera::look_at(SIZE, SIZE, 0.69, eye, Vec3::ZERO, Vec3::Z)?;
    // working memory: one sample per block, 13.3 KiB
    let mut scratch: ScratchFixed<1> = ScratchFixed::new();
    let mut tile_px = [PixelFixed::default(); (TILE * TILE) as usize];
    let mut image = vec![0u8; (3 * SIZE * SIZE) as usize];
    for y0 in (0..SIZE).step_by(TILE as usize) {
        for x0 in (0..SIZE).step_by(TILE as usize) {
            let tile = Tile { x0, y0, width: TILE, height: TILE };
            render_tile(&renderer, &camera, tile, &mut scratch, &mut tile_px)?;
            for (k, p) in tile_px.iter().enumerate() {
                let (x, y) = (x0 + k as u32 % TILE, y0 + k as u32 / TILE);
                let at = 3 * (y * SIZE + x) as usize;
                // colours are Q15 in [0, 32768]: 8 bits each, integers only
                image[at..at + 3].copy_from_slice(&p.to_rgb888());
            }
        }
    }
    Ok(image)
}

fn main() -> std::io::Result<()> {
    let model = Model::from_bytes(MODEL).map_err(|e| std::io::Error::other(e.to_string()))?;
    let image = render(&model).map_err(|e| std::io::Error::other(e.to_string()))?;
    let mut out = std::io::stdout().lock();
    write!(out, "P6\n{SIZE} {SIZE}\n255\n")?;
    out.write_all(&image)?;
    eprintln!(
        "rendered {SIZE}x{SIZE} from a {} B {:?} model in {} tiles",
        MODEL.len(),
        model.scheme(),
        (SIZE / TILE).pow(2)
    );
    Ok(())
}

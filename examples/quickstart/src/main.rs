//! Renders the first view of a model's orbit into view.ppm and says how
//! long a ray took: `cargo run --release -- model.nerf [size]`.
use nerf_infer::prelude::*;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args.next().ok_or("usage: nerf-quickstart MODEL.nerf [SIZE]")?;
    let size: u32 = args.next().map_or(Ok(128), |s| s.parse())?;
    let bytes = std::fs::read(&path).map_err(|e| format!("{path}: {e}"))?;
    let model = Model::from_bytes(&bytes).map_err(|e| format!("{path}: {e}"))?;
    // early termination: rays stop once less than 0.1 % of their light is left
    let opts = RenderOptions { early_stop: 1e-3, ..RenderOptions::from_model(&model) };
    let camera = Orbit::of(&model).camera(0.0, size, size)?;
    // f32 models render in f32, int16 and int8 ones in fixed point
    let renderer = AnyRenderer::new(&model, opts)?.with_pixel(camera.pixel_angle());
    // working memory: the default block of samples (8 with `std`, the fastest on a desktop CPU)
    let mut scratch: Box<AnyScratch> = Box::new(renderer.scratch());
    let mut ppm = format!("P6\n{size} {size}\n255\n").into_bytes();
    let start = Instant::now();
    for y in 0..size {
        for x in 0..size {
            let (origin, dir) = camera.ray(x, y);
            ppm.extend(renderer.render_ray(origin, dir, (x, y), &mut scratch).to_rgb888());
        }
    }
    let us = start.elapsed().as_secs_f64() * 1e6 / (size * size) as f64;
    std::fs::write("view.ppm", &ppm)?;
    let kernels = nerf_infer::kernels();
    println!("{path}: {:?} model, {us:.2} µs per ray ({kernels:?} kernels); wrote view.ppm", model.scheme());
    Ok(())
}

//! `nerf render`: PNGs (colour and depth) of a split's views or of an
//! orbit around the scene, plus an animated GIF for orbits.

use super::{create_dir, decode, load_split, read_model, with_threads, CmdResult, FormatArg, SplitArg};
use nerf_infer::{Camera, RenderOptions};
use nerf_train::dataset::save_png_rgb;
use nerf_train::eval::{render_view, Rendered};
use nerf_train::export::orbit_camera;
use std::path::{Path, PathBuf};

/// Arguments of `nerf render`.
#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("views").required(true).args(["data", "orbit"])))]
pub struct Args {
    /// Model file (.nerf).
    model: PathBuf,
    /// Render the views of this dataset's split.
    #[arg(long, requires = "split")]
    data: Option<PathBuf>,
    /// Split whose views to render.
    #[arg(long, value_enum)]
    split: Option<SplitArg>,
    /// Dataset layout.
    #[arg(long, value_enum, default_value = "auto")]
    format: FormatArg,
    /// LLFF / instant-ngp hold-out: every N-th image is a test/val view.
    #[arg(long, default_value_t = 8)]
    llffhold: usize,
    /// Downscale factor (default: the model's training downscale).
    #[arg(long)]
    downscale: Option<u32>,
    /// Render N views on an orbit around the scene instead.
    #[arg(long)]
    orbit: Option<usize>,
    /// Orbit image side in pixels.
    #[arg(long, default_value_t = 100)]
    size: u32,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    /// Worker threads (0: all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
}

fn save_depth(path: &Path, r: &Rendered, near: f32, far: f32) -> Result<(), String> {
    let grey: Vec<[f32; 3]> = r.depth.iter().map(|&d| [1.0 - ((d - near) / (far - near)).clamp(0.0, 1.0); 3]).collect();
    save_png_rgb(path, r.width, r.height, &grey).map_err(|e| e.to_string())
}

/// Runs `nerf render`.
pub fn run(a: Args) -> CmdResult {
    let bytes = read_model(&a.model)?;
    let model = decode(&a.model, &bytes)?;
    create_dir(&a.out)?;
    let cams: Vec<(String, Camera)> = match (&a.data, a.split, a.orbit) {
        (Some(dir), Some(split), _) => {
            let ds = a.downscale.unwrap_or(model.meta.train_downscale.max(1) as u32);
            load_split(dir, split.into(), a.format, ds, a.llffhold)?
                .views
                .into_iter()
                .map(|v| (v.name, v.camera))
                .collect()
        }
        (_, _, Some(n)) => (0..n)
            .map(|k| (format!("orbit_{k:03}"), orbit_camera(&model.scene, k as f32 / n as f32, a.size, a.size)))
            .collect(),
        _ => return Err("give --data DIR --split S, or --orbit N".into()),
    };
    let opts = RenderOptions::from_model(&model);
    let (near, far) = (model.scene.near, model.scene.far);
    let pb = super::progress(cams.len() as u64, "{bar:30} {pos}/{len} views ({eta})");
    let mut frames = Vec::new();
    for (name, cam) in &cams {
        let r = with_threads(a.threads, || render_view(&model, opts, cam))?
            .map_err(|e| format!("{}: {e}", a.model.display()))?;
        save_png_rgb(&a.out.join(format!("{name}.png")), r.width, r.height, &r.rgb).map_err(|e| e.to_string())?;
        save_depth(&a.out.join(format!("{name}_depth.png")), &r, near, far)?;
        frames.push(r);
        pb.inc(1);
    }
    pb.finish_and_clear();
    if a.orbit.is_some() {
        write_gif(&a.out.join("orbit.gif"), &frames)?;
    }
    eprintln!("wrote {} views to {}", cams.len(), a.out.display());
    Ok(())
}

fn write_gif(path: &Path, frames: &[Rendered]) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: cannot write GIF: {e}", path.display());
    let mut bytes = Vec::new();
    {
        let mut enc = image::codecs::gif::GifEncoder::new_with_speed(&mut bytes, 10);
        enc.set_repeat(image::codecs::gif::Repeat::Infinite).map_err(|e| err(&e))?;
        for r in frames {
            let mut img = image::RgbaImage::new(r.width, r.height);
            for (p, c) in img.pixels_mut().zip(&r.rgb) {
                let q = c.map(|v| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8);
                p.0 = [q[0], q[1], q[2], 255];
            }
            let frame = image::Frame::from_parts(img, 0, 0, image::Delay::from_numer_denom_ms(80, 1));
            enc.encode_frame(frame).map_err(|e| err(&e))?;
        }
    }
    nerf_train::atomic::write(path, &bytes).map_err(|e| err(&e))
}

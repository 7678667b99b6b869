//! `nerf eval`: renders a split through nerf-infer and prints one JSON
//! object with PSNR, SSIM, per-view scores, µs per ray and model size.

use super::{
    create_dir, decode, load_split, num_in, read_model, with_threads, CaptureArgs, CmdResult, FormatArg, SplitArg,
};
use clap::Parser;
use nerf_infer::RenderOptions;
use nerf_train::dataset::save_png_rgb;
use nerf_train::eval::{render_view, render_view_marching, score_rendered};
use nerf_train::metrics::psnr;
use std::path::PathBuf;

/// Arguments of `nerf eval`.
#[derive(Parser)]
pub struct Args {
    /// Model file (.nerf).
    model: PathBuf,
    /// Dataset directory.
    #[arg(long)]
    data: PathBuf,
    /// Split to evaluate.
    #[arg(long, value_enum, default_value = "test")]
    split: SplitArg,
    /// Dataset layout.
    #[arg(long, value_enum, default_value = "auto")]
    format: FormatArg,
    #[command(flatten)]
    capture: CaptureArgs,
    /// Downscale factor (default: the one the model was trained at).
    #[arg(long, value_name = "1..=64", value_parser = num_in(1u32, 64))]
    downscale: Option<u32>,
    /// Worker threads (0: all cores); µs per ray is per core either way.
    #[arg(long, default_value_t = 0, value_name = "0..=1024", value_parser = num_in(0usize, 1024))]
    threads: usize,
    /// Write each render and its ground truth as PNG into this directory.
    #[arg(long)]
    save: Option<PathBuf>,
    /// Coarse samples per ray (default: the model's).
    #[arg(long, value_name = "2..=256", value_parser = num_in(2usize, nerf_infer::format::MAX_COARSE))]
    coarse: Option<usize>,
    /// Fine samples per ray (default: the model's).
    #[arg(long, value_name = "0..=256", value_parser = num_in(0usize, nerf_infer::format::MAX_FINE))]
    fine: Option<usize>,
    /// Early ray termination threshold on transmittance (0: off).
    #[arg(long, default_value_t = 0.0, value_name = "0.0..=0.5", value_parser = num_in(0.0f32, 0.5))]
    early_stop: f32,
    /// Also render with this model (e.g. the f32 original of a quantised
    /// model) and report `psnr_vs_reference`, the mean PSNR between the two.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Render each view this many times and time the fastest: steadier µs
    /// per ray on a shared machine (the images are identical every time).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    repeat: u32,
    /// March without the coarse occupancy level (test every sample's grid
    /// cell): the same images, slower; for measuring what the level buys.
    #[arg(long)]
    no_coarse_skip: bool,
}

/// Runs `nerf eval`.
pub fn run(a: Args) -> CmdResult {
    out!("{}", evaluate(a)?);
    Ok(())
}

/// Evaluates and returns the report `nerf eval` prints.
pub fn evaluate(a: Args) -> Result<serde_json::Value, String> {
    let bytes = read_model(&a.model)?;
    let model = decode(&a.model, &bytes)?;
    let downscale = a.downscale.unwrap_or(model.meta.train_downscale.max(1) as u32);
    let capture = a.capture.for_model(&model, &a.model)?;
    let data = load_split(&a.data, a.split.into(), a.format, downscale, capture)?;
    super::same_frame(&data, &model, &a.model)?;
    let mut opts = RenderOptions::from_model(&model);
    opts.coarse = a.coarse.unwrap_or(opts.coarse);
    opts.fine = a.fine.unwrap_or(opts.fine);
    opts.early_stop = a.early_stop;
    if let Some(dir) = &a.save {
        super::refuse_inside(dir, "--save", &a.data)?;
        create_dir(dir)?;
    }
    let ref_bytes = a.reference.as_ref().map(|p| read_model(p)).transpose()?;
    let reference = match (&a.reference, &ref_bytes) {
        (Some(p), Some(b)) => Some(decode(p, b)?),
        _ => None,
    };
    let pb = super::progress(data.views.len() as u64, "{bar:30} {pos}/{len} views ({eta})");
    let results = with_threads(a.threads, || -> Result<Vec<(_, _, Option<f64>)>, String> {
        let mut out = Vec::new();
        for v in &data.views {
            let render = || {
                render_view_marching(&model, opts, v, !a.no_coarse_skip)
                    .map_err(|e| format!("{}: {e}", a.model.display()))
            };
            let mut r = render()?;
            let s = score_rendered(&r, v);
            for _ in 1..a.repeat {
                let again = render()?;
                r.secs_per_ray = r.secs_per_ray.min(again.secs_per_ray);
            }
            if let Some(dir) = &a.save {
                save_png_rgb(&dir.join(format!("{}.png", v.name)), r.width, r.height, &r.rgb)
                    .map_err(|e| e.to_string())?;
                save_png_rgb(&dir.join(format!("{}_gt.png", v.name)), r.width, r.height, &v.rgb)
                    .map_err(|e| e.to_string())?;
            }
            let vs_ref = match &reference {
                Some(m) => {
                    let rr = render_view(m, RenderOptions::from_model(m), v).map_err(|e| format!("reference: {e}"))?;
                    Some(psnr(&r.rgb, &rr.rgb))
                }
                None => None,
            };
            pb.inc(1);
            out.push((r, s, vs_ref));
        }
        Ok(out)
    })??;
    pb.finish_and_clear();
    let n = results.len() as f64;
    let mut us: Vec<f64> = results.iter().map(|(r, _, _)| r.secs_per_ray * 1e6).collect();
    us.sort_by(f64::total_cmp);
    let report = serde_json::json!({
        "psnr": results.iter().map(|(_, s, _)| s.psnr).sum::<f64>() / n,
        "ssim": results.iter().map(|(_, s, _)| s.ssim).sum::<f64>() / n,
        "views": results.iter().map(|(_, s, _)| s).collect::<Vec<_>>(),
        "psnr_vs_reference": reference.as_ref().map(|_| results.iter().filter_map(|(_, _, p)| *p).sum::<f64>() / n),
        "us_per_ray": us[us.len() / 2],
        "samples_per_ray": results.iter().map(|(r, _, _)| r.samples_per_ray).sum::<f64>() / n,
        "model_bytes": bytes.len(),
        "scheme": format!("{:?}", model.scheme()),
        "downscale": downscale,
    });
    Ok(report)
}

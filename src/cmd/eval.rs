//! `nerf eval`: renders a split through nerf-infer and prints one JSON
//! object with PSNR, SSIM, per-view scores, µs per ray and model size.

use super::{decode, load_split, num_in, read_model, with_threads, CaptureArgs, CmdError, CmdResult, Split};
use clap::Parser;
use nerf_infer::RenderOptions;
use nerf_train::dataset::save_png_rgb;
use nerf_train::eval::{render_view, render_view_marching, score_rendered, ViewScore};
use nerf_train::metrics::psnr;
use std::path::PathBuf;

/// Arguments of `nerf eval`.
#[derive(Parser, Debug)]
pub struct Args {
    /// Model file (.nerf).
    pub(crate) model: PathBuf,
    /// Dataset directory.
    #[arg(long)]
    pub(crate) data: PathBuf,
    /// Split to evaluate.
    #[arg(long, value_enum, default_value_t = Split::Test)]
    pub(crate) split: Split,
    #[command(flatten)]
    pub(crate) capture: CaptureArgs,
    /// Worker threads (0: all cores); µs per ray is per core either way.
    #[arg(long, default_value_t = 0, value_name = "0..=1024", value_parser = num_in(0usize, 1024))]
    pub(crate) threads: usize,
    /// Write each render and its ground truth as PNG into this directory.
    #[arg(long)]
    pub(crate) save: Option<PathBuf>,
    /// Replace what nerf wrote in the --save folder before (another command's outputs, as its
    /// `.nerf-outputs` record lists them); files nerf did not write are never removed.
    #[arg(long, requires = "save")]
    pub(crate) force: bool,
    /// Coarse samples per ray (default: the model's; at most 256 with a
    /// fine pass).
    #[arg(long, value_name = "2..=1024", value_parser = num_in(2usize, nerf_infer::format::MAX_MARCH))]
    pub(crate) coarse: Option<usize>,
    /// Fine samples per ray (default: the model's).
    #[arg(long, value_name = "0..=256", value_parser = num_in(0usize, nerf_infer::format::MAX_FINE))]
    pub(crate) fine: Option<usize>,
    /// Early ray termination threshold on transmittance (0: off).
    #[arg(long, default_value_t = 0.0, value_name = "0.0..=0.5", value_parser = num_in(0.0f32, 0.5))]
    pub(crate) early_stop: f32,
    /// Also render with this model (e.g. the f32 original of a quantised
    /// model) and report `psnr_vs_reference`, the mean PSNR between the two.
    #[arg(long)]
    pub(crate) reference: Option<PathBuf>,
    /// Render each view this many times and time the fastest: steadier µs
    /// per ray on a shared machine (the images are identical every time).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub(crate) repeat: u32,
    /// March without the coarse occupancy level (test every sample's grid
    /// cell): the same images, slower; for measuring what the level buys.
    #[arg(long)]
    pub(crate) no_coarse_skip: bool,
}

impl Args {
    /// `nerf eval MODEL --data DATA` with every other flag at its default.
    pub fn new(model: PathBuf, data: PathBuf) -> Self {
        Self {
            model,
            data,
            split: Split::Test,
            capture: CaptureArgs::default(),
            threads: 0,
            save: None,
            force: false,
            coarse: None,
            fine: None,
            early_stop: 0.0,
            reference: None,
            repeat: 1,
            no_coarse_skip: false,
        }
    }
}

/// What `nerf eval` prints, as one JSON object.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Report {
    /// Downscale factor the views were rendered at.
    pub downscale: u32,
    /// Size of the model file in bytes.
    pub model_bytes: usize,
    /// Mean PSNR over the views, dB.
    pub psnr: f64,
    /// Mean PSNR against the `--reference` model's renders, dB.
    pub psnr_vs_reference: Option<f64>,
    /// Mean network evaluations per ray.
    pub samples_per_ray: f64,
    /// Rays rendered (one per pixel, over every view; once, whatever
    /// `--repeat` says): the divisor for a count over the whole render.
    pub rays: u64,
    /// Mean rendered opacity, in `[0, 1]`, over the pixels whose photo is
    /// fully transparent (alpha 0), over the views that have such pixels:
    /// density left in empty space that a white background hides (0 for a
    /// clean model); `null` for photos without alpha.
    pub clear_opacity: Option<f64>,
    /// Numeric scheme of the model (`F32`, `I16`, `I8`).
    pub scheme: String,
    /// Mean SSIM over the views.
    pub ssim: f64,
    /// Median over the views of the render time per ray, µs per core.
    pub us_per_ray: f64,
    /// Each view's scores.
    pub views: Vec<ViewScore>,
}

/// Runs `nerf eval`.
pub fn run(a: Args) -> CmdResult {
    out!("{}", serde_json::to_string(&evaluate(&a)?)?);
    Ok(())
}

/// Evaluates and returns the report `nerf eval` prints.
pub fn evaluate(a: &Args) -> CmdResult<Report> {
    let bytes = read_model(&a.model)?;
    let model = decode(&a.model, &bytes)?;
    let downscale = a.capture.downscale_for(&model);
    let capture = a.capture.for_model(&model, &a.model)?;
    let data = load_split(&a.data, a.split, downscale, capture)?;
    super::same_frame(&data, &model, &a.model)?;
    let mut opts = RenderOptions::from_model(&model);
    opts.coarse = a.coarse.unwrap_or(opts.coarse);
    opts.fine = a.fine.unwrap_or(opts.fine);
    opts.early_stop = a.early_stop;
    let _out = match &a.save {
        Some(dir) => {
            super::refuse_inside(dir, "--save", &a.data)?;
            Some(super::outdir::OutDir::claim(dir, "--save", "eval", super::outdir::Earlier::Replace, a.force)?)
        }
        None => None,
    };
    let ref_bytes = a.reference.as_ref().map(|p| read_model(p)).transpose()?;
    let reference = match (&a.reference, &ref_bytes) {
        (Some(p), Some(b)) => Some(decode(p, b)?),
        _ => None,
    };
    let pb = super::progress(data.views.len() as u64, "{bar:30} {pos}/{len} views ({eta})");
    let results = with_threads(a.threads, || -> CmdResult<Vec<(_, _, Option<f64>)>> {
        let mut out = Vec::new();
        for v in &data.views {
            let render = || render_view_marching(&model, opts, v, !a.no_coarse_skip).map_err(CmdError::file(&a.model));
            let mut r = render()?;
            let s = score_rendered(&r, v);
            for _ in 1..a.repeat {
                let again = render()?;
                r.secs_per_ray = r.secs_per_ray.min(again.secs_per_ray);
            }
            if let Some(dir) = &a.save {
                save_png_rgb(&dir.join(format!("{}.png", v.name)), r.width, r.height, &r.rgb)?;
                save_png_rgb(&dir.join(format!("{}_gt.png", v.name)), r.width, r.height, &v.rgb)?;
            }
            let vs_ref = match &reference {
                Some(m) => {
                    let rr = render_view(m, RenderOptions::from_model(m), v).map_err(CmdError::within("reference"))?;
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
    let report = Report {
        downscale,
        model_bytes: bytes.len(),
        psnr: results.iter().map(|(_, s, _)| s.psnr).sum::<f64>() / n,
        psnr_vs_reference: reference.as_ref().map(|_| results.iter().filter_map(|(_, _, p)| *p).sum::<f64>() / n),
        samples_per_ray: results.iter().map(|(r, _, _)| r.samples_per_ray).sum::<f64>() / n,
        rays: results.iter().map(|(r, _, _)| r.width as u64 * r.height as u64).sum(),
        clear_opacity: mean_some(results.iter().map(|(_, s, _)| s.clear_opacity)),
        scheme: format!("{:?}", model.scheme()),
        ssim: results.iter().map(|(_, s, _)| s.ssim).sum::<f64>() / n,
        us_per_ray: us[us.len() / 2],
        views: results.into_iter().map(|(_, s, _)| s).collect(),
    };
    Ok(report)
}

/// Mean of the values present; `None` if there are none.
fn mean_some(v: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let (sum, n) = v.flatten().fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    (n > 0).then(|| sum / n as f64)
}

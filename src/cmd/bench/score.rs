//! A scene's scores: PSNR and SSIM over every scored view as the model
//! renders them (all threads, no early termination), and µs per ray timed
//! on one core with early termination at 10⁻³ transmittance.

use super::suite::Scene;
use crate::cmd::{decode, load_split, read_model, with_threads, CaptureArgs, CmdError, CmdResult};
use nerf_infer::RenderOptions;
use nerf_train::dataset::Dataset;
use nerf_train::eval::{render_view, score_rendered};
use std::path::Path;

/// Early termination of the timed renders (transmittance).
pub const TIMED_EARLY_STOP: f32 = 1e-3;
/// Views rendered again on one core for the time per ray (the first ones).
const TIMED_VIEWS: usize = 2;

/// One model's scores on a scene's scored views.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Scores {
    /// Mean PSNR over the views, dB.
    pub psnr: f64,
    /// Mean SSIM over the views.
    pub ssim: f64,
    /// Median over the timed views (the mean of the middle two of an even
    /// count) of µs per ray on one core, early termination at
    /// [`TIMED_EARLY_STOP`].
    pub us_per_ray: f64,
    /// Mean network evaluations per ray in the timed renders.
    pub samples_per_ray: f64,
    /// Model file size, bytes.
    pub bytes: usize,
}

/// The views `scene` is scored on, at its protocol.
pub fn load_scored(scene: &Scene) -> CmdResult<Dataset> {
    let capture = CaptureArgs { downscale: Some(scene.downscale), ..CaptureArgs::default() };
    let data = load_split(&scene.dir, scene.scored_split(), scene.downscale, capture)?;
    if data.views.is_empty() {
        return Err(CmdError::File {
            path: scene.dir.clone(),
            reason: format!("no {} views to score", scene.scored_split().name()),
        });
    }
    Ok(data)
}

/// Scores the model in `path` on `data`; writes its render of the first
/// view beside the photo into `first` (PNG) if given. An interrupt
/// ([`crate::cmd::interrupt::received`]) stops it after the view being
/// rendered.
pub fn score(path: &Path, data: &Dataset, threads: usize, first: Option<&Path>) -> CmdResult<Scores> {
    let bytes = read_model(path)?;
    let model = decode(path, &bytes)?;
    let err = |e: nerf_infer::Error| CmdError::file(path)(e);
    let pb = crate::cmd::progress(data.views.len() as u64, "scoring {bar:30} {pos}/{len} views ({eta})");
    let (mut psnr, mut ssim) = (0.0, 0.0);
    with_threads(threads, || -> CmdResult {
        for (i, v) in data.views.iter().enumerate() {
            let r = render_view(&model, RenderOptions::from_model(&model), v).map_err(err)?;
            let s = score_rendered(&r, v);
            (psnr, ssim) = (psnr + s.psnr, ssim + s.ssim);
            if let (0, Some(f)) = (i, first) {
                side_by_side(f, r.width, r.height, &r.rgb, &v.rgb)?;
            }
            pb.inc(1);
            if crate::cmd::interrupt::received() {
                return Err(CmdError::Interrupted(
                    "interrupted while scoring: the same nerf bench command (or its --task) resumes it".into(),
                ));
            }
        }
        Ok(())
    })??;
    pb.finish_and_clear();
    let mut opts = RenderOptions::from_model(&model);
    opts.early_stop = TIMED_EARLY_STOP;
    let timed = with_threads(1, || -> CmdResult<Vec<(f64, f64)>> {
        let views = &data.views[..TIMED_VIEWS.min(data.views.len())];
        views
            .iter()
            .map(|v| render_view(&model, opts, v).map(|r| (r.secs_per_ray * 1e6, r.samples_per_ray)).map_err(err))
            .collect()
    })??;
    let mut us: Vec<f64> = timed.iter().map(|t| t.0).collect();
    us.sort_by(f64::total_cmp);
    let median = (us[(us.len() - 1) / 2] + us[us.len() / 2]) / 2.0;
    let n = data.views.len() as f64;
    Ok(Scores {
        psnr: psnr / n,
        ssim: ssim / n,
        us_per_ray: median,
        samples_per_ray: timed.iter().map(|t| t.1).sum::<f64>() / timed.len() as f64,
        bytes: bytes.len(),
    })
}

/// Writes the render (left) and the photo (right) of one view as one PNG.
fn side_by_side(path: &Path, w: u32, h: u32, render: &[[f32; 3]], photo: &[[f32; 3]]) -> CmdResult {
    let (wu, hu) = (w as usize, h as usize);
    let mut rgb = vec![[0.0f32; 3]; 2 * wu * hu];
    for y in 0..hu {
        rgb[2 * y * wu..2 * y * wu + wu].copy_from_slice(&render[y * wu..(y + 1) * wu]);
        rgb[2 * y * wu + wu..2 * (y + 1) * wu].copy_from_slice(&photo[y * wu..(y + 1) * wu]);
    }
    // the data error names the file
    Ok(nerf_train::dataset::save_png_rgb(path, 2 * w, h, &rgb)?)
}

//! `nerf demo`: generate the built-in scene, train with the default
//! configuration, export, render in f32 and fixed point, print the PSNRs,
//! write the images, an orbit GIF of the int8 model and the speed/accuracy
//! plot — each step the command a user would type, called with its typed
//! arguments.

use super::{eval, num_in, CmdResult};
use nerf_infer::Scheme;
use std::path::PathBuf;

/// Arguments of `nerf demo`.
#[derive(clap::Args)]
pub struct Args {
    /// Output directory (a demo run there before is replaced).
    #[arg(long, default_value = "runs/demo")]
    out: PathBuf,
    /// Minutes of training.
    #[arg(long, default_value_t = 2.0, value_name = "0.01..=10000.0", value_parser = num_in(0.01f64, 10_000.0))]
    minutes: f64,
}

/// Runs `nerf demo`.
pub fn run(a: Args) -> CmdResult {
    let out = &a.out;
    let scene = out.join("scene");
    let data = scene.join("blender");
    let run_dir = out.join("run");
    eprintln!("1/6 generating the built-in scene in {}", scene.display());
    super::scene::run(super::scene::Args::new(scene.clone()))?;
    eprintln!("2/6 training for {} minutes into {}", a.minutes, run_dir.display());
    let train = super::train::Args {
        val_views: 0,
        force: true,
        ..super::train::Args::new(data.clone(), a.minutes, run_dir.clone())
    };
    super::train::run(train)?;
    eprintln!("3/6 exporting int16 and int8 models");
    let model = run_dir.join("model.nerf");
    for bits in [Scheme::I16, Scheme::I8] {
        let file = run_dir.join(format!("model_int{}.nerf", bits.bits()));
        // the demo's own exports of an earlier run, beside the run it has just replaced
        super::export::run(super::export::Args { force: true, ..super::export::Args::new(model.clone(), bits, file) })?;
    }
    eprintln!("4/6 rendering the test views");
    let mut rows = Vec::new();
    for (name, file) in [("f32", "model.nerf"), ("int16", "model_int16.nerf"), ("int8", "model_int8.nerf")] {
        let eval = eval::Args {
            save: Some(out.join("renders").join(name)),
            ..eval::Args::new(run_dir.join(file), data.clone())
        };
        rows.push((name, eval::evaluate(&eval)?));
    }
    out!("{:<6} {:>9} {:>7} {:>10} {:>12}", "model", "PSNR dB", "SSIM", "µs/ray", "bytes");
    for (name, r) in &rows {
        out!("{:<6} {:>9.2} {:>7.4} {:>10.1} {:>12}", name, r.psnr, r.ssim, r.us_per_ray, r.model_bytes);
    }
    eprintln!("5/6 rendering an orbit of the int8 model");
    let orbit = super::render::Args {
        size: 96,
        ..super::render::Args::orbit(run_dir.join("model_int8.nerf"), 24, out.join("orbit"))
    };
    super::render::run(orbit)?;
    eprintln!("6/6 sweeping bits, samples and early termination (speed against accuracy)");
    let tradeoff = super::tradeoff::Args { views: 1, ..super::tradeoff::Args::new(model, data, out.join("tradeoff")) };
    super::tradeoff::run(tradeoff)?;
    let out = out.display();
    out!("images: {out}/renders/{{f32,int16,int8}}/ (render beside *_gt.png ground truth)");
    out!("orbit:  {out}/orbit/orbit.gif; speed against accuracy: {out}/tradeoff/tradeoff.png");
    Ok(())
}

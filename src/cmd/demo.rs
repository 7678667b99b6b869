//! `nerf demo`: generate the built-in scene, train with the default
//! configuration, export, render in f32 and fixed point, print the PSNRs,
//! write the images, an orbit GIF of the int8 model and the speed/accuracy
//! plot — the commands a user would type, run through the same parser.

use super::{num_in, CmdResult};
use crate::Cli;
use clap::Parser;
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

fn run_cli(args: &[&str]) -> CmdResult {
    let cli = Cli::try_parse_from(std::iter::once("nerf").chain(args.iter().copied())).map_err(|e| e.to_string())?;
    crate::dispatch(cli.command)
}

/// Runs `nerf demo`.
pub fn run(a: Args) -> CmdResult {
    let out = a.out.display().to_string();
    let scene = format!("{out}/scene");
    let data = format!("{scene}/blender");
    let run_dir = format!("{out}/run");
    eprintln!("1/6 generating the built-in scene in {scene}");
    run_cli(&["scene", "--out", &scene])?;
    eprintln!("2/6 training for {} minutes into {run_dir}", a.minutes);
    let minutes = a.minutes.to_string();
    run_cli(&["train", "--data", &data, "--out", &run_dir, "--minutes", &minutes, "--val-views", "0", "--force"])?;
    eprintln!("3/6 exporting int16 and int8 models");
    let model = format!("{run_dir}/model.nerf");
    for bits in ["16", "8"] {
        run_cli(&["export", &model, "--bits", bits, "--out", &format!("{run_dir}/model_int{bits}.nerf")])?;
    }
    eprintln!("4/6 rendering the test views");
    let mut rows = Vec::new();
    for (name, file) in [("f32", "model.nerf"), ("int16", "model_int16.nerf"), ("int8", "model_int8.nerf")] {
        let save = format!("{out}/renders/{name}");
        let path = format!("{run_dir}/{file}");
        let args = super::eval::Args::try_parse_from([
            "eval",
            path.as_str(),
            "--data",
            &data,
            "--split",
            "test",
            "--save",
            &save,
        ])
        .map_err(|e| e.to_string())?;
        let r = super::eval::evaluate(args)?;
        rows.push((name, r));
    }
    out!("{:<6} {:>9} {:>7} {:>10} {:>12}", "model", "PSNR dB", "SSIM", "µs/ray", "bytes");
    for (name, r) in &rows {
        out!(
            "{:<6} {:>9.2} {:>7.4} {:>10.1} {:>12}",
            name,
            r["psnr"].as_f64().unwrap_or(0.0),
            r["ssim"].as_f64().unwrap_or(0.0),
            r["us_per_ray"].as_f64().unwrap_or(0.0),
            r["model_bytes"]
        );
    }
    eprintln!("5/6 rendering an orbit of the int8 model");
    let int8 = format!("{run_dir}/model_int8.nerf");
    run_cli(&["render", &int8, "--orbit", "24", "--size", "96", "--out", &format!("{out}/orbit")])?;
    eprintln!("6/6 sweeping bits, samples and early termination (speed against accuracy)");
    run_cli(&["tradeoff", &model, "--data", &data, "--views", "1", "--out", &format!("{out}/tradeoff")])?;
    out!("images: {out}/renders/{{f32,int16,int8}}/ (render beside *_gt.png ground truth)");
    out!("orbit:  {out}/orbit/orbit.gif; speed against accuracy: {out}/tradeoff/tradeoff.png");
    Ok(())
}

//! `nerf tradeoff`: what each knob costs and buys. Sweeps weight bits,
//! sample counts and the early-termination threshold one at a time around
//! the model's defaults; for each point measures PSNR and SSIM on the views
//! and µs per ray (median of repeated single-thread runs in this process);
//! writes `tradeoff.csv` and `tradeoff.png` (PSNR against µs/ray, Pareto
//! front marked) and prints the table.

use super::{create_dir, decode, load_split, read_model, with_threads, write_atomic, CmdResult, FormatArg, SplitArg};
use nerf_infer::{Model, RenderOptions, Scheme};
use nerf_train::eval::score_view;
use nerf_train::export::quantise;
use nerf_train::plot::{pareto, scatter, Point};
use std::path::PathBuf;

/// Arguments of `nerf tradeoff`.
#[derive(clap::Args)]
pub struct Args {
    /// The f32 model (.nerf) as `nerf train` writes it; int16 and int8
    /// variants are quantised from it in memory.
    model: PathBuf,
    /// Dataset directory.
    #[arg(long)]
    data: PathBuf,
    /// Split whose views are rendered.
    #[arg(long, value_enum, default_value = "val")]
    split: SplitArg,
    /// Dataset layout.
    #[arg(long, value_enum, default_value = "auto")]
    format: FormatArg,
    /// LLFF / instant-ngp hold-out: every N-th image is a test/val view.
    #[arg(long, default_value_t = 8)]
    llffhold: usize,
    /// Downscale factor (default: the model's training downscale).
    #[arg(long)]
    downscale: Option<u32>,
    /// Views rendered per point (the first N of the split).
    #[arg(long, default_value_t = 2)]
    views: usize,
    /// Timed repetitions per point; the median is reported.
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Output directory for tradeoff.csv and tradeoff.png.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Clone, Copy)]
struct Knobs {
    bits: u32,
    coarse: usize,
    fine: usize,
    early_stop: f32,
}

impl Knobs {
    fn label(&self) -> String {
        let mut s = format!(
            "{} {}+{}",
            if self.bits == 32 { "f32".to_string() } else { format!("int{}", self.bits) },
            self.coarse,
            self.fine
        );
        if self.early_stop > 0.0 {
            s += &format!(" ert {}", self.early_stop);
        }
        s
    }
}

/// The sweep: each knob varied alone around the defaults.
fn sweep(m: &Model<'_>) -> Vec<Knobs> {
    let (nc, nf) = (m.samples.coarse as usize, m.samples.fine as usize);
    let base = Knobs { bits: 32, coarse: nc, fine: nf, early_stop: 0.0 };
    let mut v = vec![base, Knobs { bits: 16, ..base }, Knobs { bits: 8, ..base }];
    let half = |n: usize| (n / 2).max(2);
    if nf > 0 {
        v.push(Knobs { fine: half(nf), ..base });
        v.push(Knobs { coarse: half(nc), fine: half(nf), ..base });
        v.push(Knobs { fine: 0, ..base });
        v.push(Knobs { bits: 8, coarse: half(nc), fine: half(nf), ..base });
    } else {
        v.push(Knobs { coarse: half(nc), ..base });
        v.push(Knobs { coarse: half(half(nc)), ..base });
    }
    for e in [1e-3, 1e-2] {
        v.push(Knobs { early_stop: e, ..base });
        v.push(Knobs { bits: 8, early_stop: e, ..base });
    }
    v
}

/// Runs `nerf tradeoff`.
pub fn run(a: Args) -> CmdResult {
    let bytes = read_model(&a.model)?;
    let mf = decode(&a.model, &bytes)?;
    if mf.scheme() != Scheme::F32 {
        return Err(format!("{}: give the f32 model; its int16 and int8 variants are made from it", a.model.display()));
    }
    let q16 = quantise(&mf, Scheme::I16).and_then(|m| m.to_bytes().map_err(|e| e.to_string()))?;
    let q8 = quantise(&mf, Scheme::I8).and_then(|m| m.to_bytes().map_err(|e| e.to_string()))?;
    let m16 = Model::from_bytes(&q16).map_err(|e| e.to_string())?;
    let m8 = Model::from_bytes(&q8).map_err(|e| e.to_string())?;
    let downscale = a.downscale.unwrap_or(mf.meta.train_downscale.max(1) as u32);
    let data = load_split(&a.data, a.split.into(), a.format, downscale, a.llffhold)?;
    let views = &data.views[..a.views.clamp(1, data.views.len())];
    create_dir(&a.out)?;
    let knobs = sweep(&mf);
    let pb = super::progress(knobs.len() as u64, "{bar:30} {pos}/{len} points ({eta}) {msg}");
    let mut rows = Vec::new();
    for k in &knobs {
        pb.set_message(k.label());
        let model = match k.bits {
            32 => &mf,
            16 => &m16,
            _ => &m8,
        };
        let opts = RenderOptions {
            coarse: k.coarse,
            fine: k.fine,
            early_stop: k.early_stop,
            ..RenderOptions::from_model(model)
        };
        let (mut psnr, mut ssim, mut spr) = (0.0, 0.0, 0.0);
        let mut times = Vec::new();
        for rep in 0..a.repeats.max(1) {
            let mut secs = 0.0;
            for v in views {
                let (r, s) =
                    with_threads(1, || score_view(model, opts, v))?.map_err(|e| format!("{}: {e}", k.label()))?;
                secs += r.secs_per_ray;
                if rep == 0 {
                    psnr += s.psnr / views.len() as f64;
                    ssim += s.ssim / views.len() as f64;
                    spr += r.samples_per_ray / views.len() as f64;
                }
            }
            times.push(secs / views.len() as f64 * 1e6);
        }
        times.sort_by(f64::total_cmp);
        rows.push((*k, psnr, ssim, times[times.len() / 2], spr));
        pb.inc(1);
    }
    pb.finish_and_clear();
    let mut points: Vec<Point> =
        rows.iter().map(|(k, p, _, us, _)| Point { x: *us, y: *p, label: k.label(), front: false }).collect();
    pareto(&mut points);
    let mut csv = String::from("label,bits,coarse,fine,early_stop,psnr,ssim,us_per_ray,samples_per_ray,pareto\n");
    println!("{:<22} {:>9} {:>7} {:>9} {:>12} {:>7}", "point", "PSNR dB", "SSIM", "µs/ray", "samples/ray", "pareto");
    for ((k, p, s, us, spr), pt) in rows.iter().zip(&points) {
        csv += &format!(
            "{},{},{},{},{},{p:.4},{s:.5},{us:.2},{spr:.2},{}\n",
            pt.label, k.bits, k.coarse, k.fine, k.early_stop, pt.front
        );
        println!("{:<22} {p:>9.3} {s:>7.4} {us:>9.1} {spr:>12.1} {:>7}", pt.label, if pt.front { "*" } else { "" });
    }
    write_atomic(&a.out.join("tradeoff.csv"), csv.as_bytes())?;
    let title = format!(
        "{}: psnr vs cost ({} {} views)",
        a.model.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
        views.len(),
        data.views[0].camera.width
    );
    scatter(&a.out.join("tradeoff.png"), &title, "us per ray (one core)", "psnr db", &points)?;
    eprintln!("wrote {} and {}", a.out.join("tradeoff.csv").display(), a.out.join("tradeoff.png").display());
    Ok(())
}

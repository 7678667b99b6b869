//! `nerf tradeoff`: what each knob costs and buys. Sweeps weight bits (and
//! int8 weights with 8-bit activations),
//! sample counts and the early-termination threshold one at a time around
//! the model's defaults; for each point measures PSNR and SSIM on the views
//! and µs per ray (median of repeated single-thread runs in this process,
//! the repetitions interleaved across points);
//! writes `tradeoff.csv` and `tradeoff.png` (PSNR against µs/ray, Pareto
//! front marked) and prints the table.

use super::{
    decode, load_split, num_in, read_model, with_threads, write_atomic, CaptureArgs, CmdError, CmdResult, Split,
};
use nerf_infer::{Model, RenderOptions, Scheme};
use nerf_train::eval::score_view;
use nerf_train::export::{quantise_with, ActBits, Quantisation};
use nerf_train::plot::{pareto, scatter, Point};
use std::path::PathBuf;

/// Arguments of `nerf tradeoff`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The f32 model (.nerf) as `nerf train` writes it; int16 and int8
    /// variants are quantised from it in memory.
    pub(crate) model: PathBuf,
    /// Dataset directory.
    #[arg(long)]
    pub(crate) data: PathBuf,
    /// Split whose views are rendered.
    #[arg(long, value_enum, default_value_t = Split::Val)]
    pub(crate) split: Split,
    #[command(flatten)]
    pub(crate) capture: CaptureArgs,
    /// Views rendered per point (the first N of the split).
    #[arg(long, default_value_t = 2, value_name = "1..=10000", value_parser = num_in(1usize, 10_000))]
    pub(crate) views: usize,
    /// Timed repetitions per point; the median is reported.
    #[arg(long, default_value_t = 3, value_name = "1..=100", value_parser = num_in(1usize, 100))]
    pub(crate) repeats: usize,
    /// Output directory for tradeoff.csv and tradeoff.png.
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Replace what nerf wrote in the output folder before (another command's outputs, as its
    /// `.nerf-outputs` record lists them); files nerf did not write are never removed.
    #[arg(long)]
    pub(crate) force: bool,
}

#[derive(Clone, Copy)]
struct Knobs {
    bits: u32,
    /// Hidden-activation bits of the integer path (16, or 8 with int8).
    act_bits: u8,
    coarse: usize,
    fine: usize,
    early_stop: f32,
}

impl Knobs {
    fn label(&self) -> String {
        let mut s = format!(
            "{} {}+{}",
            match (self.bits, self.act_bits) {
                (32, _) => "f32".to_string(),
                (b, 8) => format!("int{b}/a8"),
                (b, _) => format!("int{b}"),
            },
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
    let base = Knobs { bits: 32, act_bits: 16, coarse: nc, fine: nf, early_stop: 0.0 };
    let mut v =
        vec![base, Knobs { bits: 16, ..base }, Knobs { bits: 8, ..base }, Knobs { bits: 8, act_bits: 8, ..base }];
    let half = |n: usize| (n / 2).max(2);
    if nf > 0 {
        v.push(Knobs { fine: half(nf), ..base });
        v.push(Knobs { coarse: half(nc), fine: half(nf), ..base });
        v.push(Knobs { fine: 0, ..base });
        v.push(Knobs { bits: 8, coarse: half(nc), fine: half(nf), ..base });
    } else {
        v.push(Knobs { coarse: half(nc), ..base });
        v.push(Knobs { coarse: half(half(nc)), ..base });
        // the cheap corner: int8, two thirds of the samples, early termination
        v.push(Knobs { bits: 8, coarse: (2 * nc / 3).max(2), early_stop: 1e-3, ..base });
    }
    for e in [1e-3, 1e-2] {
        v.push(Knobs { early_stop: e, ..base });
        v.push(Knobs { bits: 8, early_stop: e, ..base });
    }
    v
}

impl Args {
    /// `nerf tradeoff MODEL --data DATA --out OUT` with every other flag at its default.
    pub fn new(model: PathBuf, data: PathBuf, out: PathBuf) -> Self {
        Self {
            model,
            data,
            split: Split::Val,
            capture: CaptureArgs::default(),
            views: 2,
            repeats: 3,
            out,
            force: false,
        }
    }
}

/// Runs `nerf tradeoff`.
pub fn run(a: Args) -> CmdResult {
    super::refuse_inside(&a.out, "--out", &a.data)?;
    let bytes = read_model(&a.model)?;
    let mf = decode(&a.model, &bytes)?;
    if mf.scheme() != Scheme::F32 {
        return Err(CmdError::File {
            path: a.model.clone(),
            reason: "give the f32 model; its int16 and int8 variants are made from it".into(),
        });
    }
    let quantised = |scheme, act_bits| -> CmdResult<Vec<u8>> {
        Ok(quantise_with(&mf, &Quantisation::new(scheme).with_act_bits(act_bits))?.to_bytes()?)
    };
    let (q16, q8, q8a8) = (
        quantised(Scheme::I16, ActBits::A16)?,
        quantised(Scheme::I8, ActBits::A16)?,
        quantised(Scheme::I8, ActBits::A8)?,
    );
    let (m16, m8, m8a8) = (Model::from_bytes(&q16)?, Model::from_bytes(&q8)?, Model::from_bytes(&q8a8)?);
    let downscale = a.capture.downscale_for(&mf);
    let capture = a.capture.for_model(&mf, &a.model)?;
    let data = load_split(&a.data, a.split, downscale, capture)?;
    super::same_frame(&data, &mf, &a.model)?;
    let views = &data.views[..a.views.clamp(1, data.views.len())];
    let _out = super::outdir::OutDir::claim(&a.out, "--out", "tradeoff", super::outdir::Earlier::Replace, a.force)?;
    let knobs = sweep(&mf);
    // Repetitions are interleaved (every point once, then again), so drift
    // in the machine's speed reaches all points alike.
    let reps = a.repeats.max(1);
    let pb = super::progress((knobs.len() * reps) as u64, "{bar:30} {pos}/{len} point runs ({eta}) {msg}");
    let mut scores = vec![(0.0, 0.0, 0.0); knobs.len()];
    let mut times = vec![Vec::new(); knobs.len()];
    for rep in 0..reps {
        for (i, k) in knobs.iter().enumerate() {
            pb.set_message(k.label());
            let model = match (k.bits, k.act_bits) {
                (32, _) => &mf,
                (16, _) => &m16,
                (_, 8) => &m8a8,
                _ => &m8,
            };
            let opts = RenderOptions {
                coarse: k.coarse,
                fine: k.fine,
                early_stop: k.early_stop,
                ..RenderOptions::from_model(model)
            };
            let mut secs = 0.0;
            for v in views {
                let (r, s) = with_threads(1, || score_view(model, opts, v))?.map_err(CmdError::within(k.label()))?;
                secs += r.secs_per_ray;
                if rep == 0 {
                    let n = views.len() as f64;
                    let (p, ss, spr) = &mut scores[i];
                    (*p, *ss, *spr) = (*p + s.psnr / n, *ss + s.ssim / n, *spr + r.samples_per_ray / n);
                }
            }
            times[i].push(secs / views.len() as f64 * 1e6);
            pb.inc(1);
        }
    }
    let rows: Vec<_> = knobs
        .iter()
        .zip(scores)
        .zip(&mut times)
        .map(|((k, (psnr, ssim, spr)), t)| {
            t.sort_by(f64::total_cmp);
            (*k, psnr, ssim, t[t.len() / 2], spr)
        })
        .collect();
    pb.finish_and_clear();
    let mut points: Vec<Point> =
        rows.iter().map(|(k, p, _, us, _)| Point { x: *us, y: *p, label: k.label(), front: false }).collect();
    pareto(&mut points);
    let mut csv =
        String::from("label,bits,coarse,fine,early_stop,psnr,ssim,us_per_ray,samples_per_ray,pareto,act_bits\n");
    out!("{:<22} {:>9} {:>7} {:>9} {:>12} {:>7}", "point", "PSNR dB", "SSIM", "µs/ray", "samples/ray", "pareto");
    for ((k, p, s, us, spr), pt) in rows.iter().zip(&points) {
        csv += &format!(
            "{},{},{},{},{},{p:.4},{s:.5},{us:.2},{spr:.2},{},{}\n",
            pt.label, k.bits, k.coarse, k.fine, k.early_stop, pt.front, k.act_bits
        );
        out!("{:<22} {p:>9.3} {s:>7.4} {us:>9.1} {spr:>12.1} {:>7}", pt.label, if pt.front { "*" } else { "" });
    }
    write_atomic(&a.out.join("tradeoff.csv"), csv.as_bytes())?;
    let title = format!(
        "{}: PSNR against cost ({} views, {}×{})",
        a.model.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
        views.len(),
        data.views[0].camera.width,
        data.views[0].camera.height
    );
    scatter(&a.out.join("tradeoff.png"), &title, "µs per ray (one core)", "PSNR (dB)", &points)?;
    eprintln!("wrote {} and {}", a.out.join("tradeoff.csv").display(), a.out.join("tradeoff.png").display());
    Ok(())
}

//! `nerf train`: fits a model to a dataset, with a progress bar, periodic
//! validation, atomic checkpoints and `--resume`.

use super::runlog::RunLog;
use super::{
    create_dir, load_split, lock_run_dir, num_in, progress, refuse_inside, with_threads, write_atomic, CaptureArgs,
    CmdResult,
};
use nerf_infer::{Model, RenderOptions};
use nerf_train::config::{Preset, TrainConfig};
use nerf_train::dataset::{Dataset, Split};
use nerf_train::eval::score_view;
use nerf_train::export::{trainer_model, OwnedModel, Prune};
use nerf_train::mlp::Mlp;
use nerf_train::path::fit_orbit;
use nerf_train::rng::Rng;
use nerf_train::timing::StepTimes;
use nerf_train::train::{Draw, Trainer};
use std::path::{Path, PathBuf};
use std::time::Instant;

mod new_run;
mod report;
mod resume;
use new_run::*;
use report::*;
use resume::*;

/// Arguments of `nerf train`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("budget").required(true).args(["iters", "minutes"])))]
pub struct Args {
    /// Dataset directory.
    #[arg(long)]
    pub(crate) data: PathBuf,
    #[command(flatten)]
    pub(crate) capture: CaptureArgs,
    /// Named configuration [default: features]
    #[arg(long, value_enum)]
    pub(crate) preset: Option<Preset>,
    /// Configuration as JSON: fields of the preset (`features` without `--preset`) to override, by section
    /// (`{"sampling": {"n_coarse": 64}}`) or by flat name (`{"n_coarse": 64}`); see docs/CLI.md.
    /// A feature grid is sized to the photos of an object scene unless the file names `features.max_res` or
    /// `features.log2_table`, and so are the samples per ray unless it names `sampling.n_coarse`.
    #[arg(long)]
    pub(crate) config: Option<PathBuf>,
    /// Train until this many steps in total.
    #[arg(long, value_name = "1..=1000000000", value_parser = num_in(1u64, 1_000_000_000))]
    pub(crate) iters: Option<u64>,
    /// Train until this many minutes of training in total.
    #[arg(long, value_name = "0.001..=100000.0", value_parser = num_in(0.001f64, 100_000.0))]
    pub(crate) minutes: Option<f64>,
    /// Run directory: model.nerf, train.jsonl, checkpoint.bin.
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Continue from RUN_DIR/checkpoint.bin (the same data, downscale, preset and configuration).
    #[arg(long, conflicts_with = "force")]
    pub(crate) resume: bool,
    /// Start a new run in a RUN_DIR that holds one, replacing its checkpoint, model and log.
    #[arg(long)]
    pub(crate) force: bool,
    /// Seed of initialisation and ray sampling.
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
    /// Worker threads (0: all cores).
    #[arg(long, default_value_t = 0, value_name = "0..=1024", value_parser = num_in(0usize, 1024))]
    pub(crate) threads: usize,
    /// Seconds of training between checkpoints (0: after every step).
    #[arg(long, default_value_t = 60.0, value_name = "0.0..=1e6", value_parser = num_in(0.0f64, 1e6))]
    pub(crate) checkpoint_secs: f64,
    /// Seconds of training between validation renders (0: after every step).
    #[arg(long, default_value_t = 120.0, value_name = "0.0..=1e6", value_parser = num_in(0.0f64, 1e6))]
    pub(crate) val_secs: f64,
    /// Validation views rendered each time (0: no periodic validation).
    #[arg(long, default_value_t = 2, value_name = "0..=10000", value_parser = num_in(0usize, 10_000))]
    pub(crate) val_views: usize,
    /// Steps between lines of train.jsonl.
    #[arg(long, default_value_t = 10, value_name = "1..=1000000000", value_parser = num_in(1u64, 1_000_000_000))]
    pub(crate) log_every: u64,
    /// Neurons never active on the calibration rays that model.nerf drops.
    #[arg(long, value_enum, default_value_t = Prune::Tiles)]
    pub(crate) prune: Prune,
}

/// The validation views, or none if the dataset has no such split.
fn load_val(a: &Args, downscale: u32) -> Option<Dataset> {
    if a.val_views == 0 {
        return None;
    }
    load_split(&a.data, Split::Val, downscale, a.capture).ok()
}

/// Mean PSNR of the first `n` validation views rendered by the kernel's f32 path.
fn validate(tr: &Trainer, val: &Dataset, n: usize, calib: &[nerf_train::train::Sample]) -> Result<f64, String> {
    let bytes = trainer_model(tr, calib, Prune::Off).to_bytes().map_err(|e| e.to_string())?;
    let model = Model::from_bytes(&bytes).map_err(|e| e.to_string())?;
    let views = &val.views[..n.min(val.views.len())];
    let mut sum = 0.0;
    for v in views {
        sum += score_view(&model, RenderOptions::from_model(&model), v).map_err(|e| e.to_string())?.1.psnr;
    }
    Ok(sum / views.len() as f64)
}

/// Writes the checkpoint and the model; `data` is the training split (the
/// model records how its capture was split and the orbit fitted to its
/// cameras).
fn save(tr: &Trainer, out: &Path, calib: &[nerf_train::train::Sample], prune: Prune, data: &Dataset) -> CmdResult {
    let cams: Vec<_> = data.views.iter().map(|v| v.camera).collect();
    let orbit = fit_orbit(&data.scene, &cams);
    let model = OwnedModel { capture: data.capture, orbit, ..trainer_model(tr, calib, prune) };
    let bytes = model.to_bytes().map_err(|e| format!("exporting the model: {e}"))?;
    // the model first: a checkpoint on disk always has its model beside it (a run stopped between the two
    // resumes from the earlier checkpoint and writes the model again)
    write_atomic(&out.join("model.nerf"), &bytes)?;
    // the checkpoint is several times the model: a disk that filled for it keeps the model, and says so
    write_atomic(&out.join("checkpoint.bin"), &tr.to_bytes().map_err(|e| e.to_string())?).map_err(|e| {
        format!(
            "{e}; the model of step {} is written ({}), the checkpoint is not: this run can be used but not resumed \
             from here",
            tr.step,
            out.join("model.nerf").display()
        )
    })
}

impl Args {
    /// `nerf train --data DATA --minutes MINUTES --out OUT` with every other
    /// flag at its default.
    pub fn new(data: PathBuf, minutes: f64, out: PathBuf) -> Self {
        Self {
            data,
            capture: CaptureArgs::default(),
            preset: None,
            config: None,
            iters: None,
            minutes: Some(minutes),
            out,
            resume: false,
            force: false,
            seed: 0,
            threads: 0,
            checkpoint_secs: 60.0,
            val_secs: 120.0,
            val_views: 2,
            log_every: 10,
            prune: Prune::Tiles,
        }
    }
}

/// Runs `nerf train`.
pub fn run(a: Args) -> CmdResult {
    // the arguments first (configuration, where the output goes), then the run folder
    let new_run = if a.resume { None } else { Some(load_config(&a)?) };
    with_threads(a.threads, || train(a, new_run))?
}

/// Runs `nerf train` as a new run of configuration `cfg` (in place of
/// `--preset` and `--config`).
pub fn run_config(a: Args, cfg: TrainConfig) -> CmdResult {
    cfg.validate().map_err(|e| format!("invalid configuration: {e}"))?;
    let run = NewRun {
        cfg,
        fit_features: false,
        fit_samples: false,
        fit_proposal: true,
        fit_distortion: true,
        fit_render: true,
    };
    with_threads(a.threads, || train(Args { resume: false, ..a }, Some(run)))?
}

/// Trains into `a.out`; a run folder this call created is removed again
/// if the run fails before writing anything into it.
fn train(a: Args, new_run: Option<NewRun>) -> CmdResult {
    refuse_inside(&a.out, "--out", &a.data)?;
    let created = !a.out.exists();
    let out = a.out.clone();
    let result = train_in(a, new_run);
    if result.is_err() && created && std::fs::read_dir(&out).is_ok_and(|mut d| d.next().is_none()) {
        let _ = std::fs::remove_dir(&out);
    }
    result
}

fn train_in(a: Args, new_run: Option<NewRun>) -> CmdResult {
    create_dir(&a.out)?;
    let _lock = lock_run_dir(&a.out)?;
    let ckpt = a.out.join("checkpoint.bin");
    let held = ["checkpoint.bin", "model.nerf", "train.jsonl"].into_iter().find(|f| a.out.join(f).exists());
    if let (Some(f), false, false) = (held, a.resume, a.force) {
        return Err(match ckpt.is_file() {
            true => {
                format!("{}: holds a run ({f}): continue it with --resume, or start over with --force", a.out.display())
            }
            // a model without its checkpoint (copied, or exported there) cannot be continued
            false => format!(
                "{}: holds {f} and no checkpoint to resume from: start over with --force (replacing it), or choose \
                 another --out",
                a.out.display()
            ),
        });
    }
    let load = |downscale| load_split(&a.data, Split::Train, downscale, a.capture);
    let (mut tr, data) = if a.resume && ckpt.is_file() {
        let b = nerf_train::userfile::read_user_file(&ckpt, 16 << 30, "checkpoint")?;
        let tr = Trainer::from_bytes(&b).map_err(|e| format!("{}: {e}", ckpt.display()))?;
        let mut tr = tr;
        let moved_from = check_resume(&a, &tr)?;
        let data = load(tr.downscale)?;
        check_resumed_data(&a, &mut tr, &data, moved_from)?;
        check_resume_config(&a, &tr, &data)?;
        (tr, data)
    } else if a.resume {
        return Err(format!("{}: no checkpoint to resume from", ckpt.display()));
    } else {
        let run = new_run.ok_or("a configuration for a new run")?;
        let downscale = a.capture.downscale.unwrap_or(1);
        let data = load(downscale)?;
        let cfg = run.for_data(&data)?;
        if cfg.features.max_res != run.cfg.features.max_res {
            eprintln!(
                "feature grid sized to the photos: finest level {} cells per axis (was {}), 2^{} table entries per \
                 level (was 2^{}); set features.max_res or features.log2_table with --config to choose",
                cfg.features.max_res, run.cfg.features.max_res, cfg.features.log2_table, run.cfg.features.log2_table
            );
        }
        if cfg.sampling.proposal_res != run.cfg.sampling.proposal_res {
            eprintln!(
                "{} scene: the network's {} samples per ray (the model renders at {} unless told otherwise; set \
                 sampling.n_main_render with --config) placed by a {}³ proposal grid composited at {} \
                 stratified samples{}; set sampling.proposal_res 0 with --config for the occupancy grid's {} stratified samples",
                if data.scene.ndc.is_some() { "forward-facing" } else { "unbounded" },
                cfg.sampling.n_main,
                cfg.samples().fine,
                cfg.sampling.proposal_res,
                cfg.sampling.n_coarse,
                match cfg.loss.distortion != run.cfg.loss.distortion {
                    true => format!(", the distortion loss at {} (set loss.distortion with --config)", cfg.loss.distortion),
                    false => String::new(),
                },
                run.cfg.sampling.n_coarse
            );
        }
        if cfg.sampling.n_coarse != run.cfg.sampling.n_coarse
            && cfg.sampling.proposal_res == run.cfg.sampling.proposal_res
        {
            eprintln!(
                "samples per ray set for the photos: {} (was {}); set sampling.n_coarse with --config to choose",
                cfg.sampling.n_coarse, run.cfg.sampling.n_coarse
            );
        }
        if cfg.loss.pose_refine && data.scene.ndc.is_some() {
            eprintln!("forward-facing scene: loss.pose_refine leaves the photos' poses as loaded (rays in NDC)");
        }
        let mut tr = Trainer::new(cfg, data.scene, downscale, a.seed);
        tr.data = data_source(&a);
        (tr, data)
    };
    data.check_rays().map_err(|e| format!("{}: {e}", a.data.display()))?;
    let val = load_val(&a, tr.downscale);
    let calib =
        Trainer::draw_batch(&data, 4096, Draw::CENTRES, &mut Rng::new(tr.seed ^ nerf_train::rng::stream::CALIBRATION));
    let budget_secs = a.minutes.map(|m| m * 60.0);
    let total = match (a.iters, budget_secs) {
        (Some(n), _) => n,
        (None, Some(s)) => (s * 1000.0) as u64,
        _ => unreachable!("clap requires a budget"),
    };
    let progress_of = |tr: &Trainer| match (a.iters, budget_secs) {
        (Some(n), _) => tr.step as f64 / n as f64,
        (None, Some(s)) => tr.elapsed / s,
        _ => 1.0,
    };
    let pb = progress(total, "{bar:30} {pos}/{len} ({eta}) {msg}");
    let mut log = RunLog::open(&a.out.join("train.jsonl"), a.resume.then_some(tr.step))?;
    super::interrupt::catch();
    let mlp = tr.mlp();
    let flops_per_sample = 6.0 * mlp.macs_per_sample() as f64;
    let (mut last_ckpt, mut last_val) = (tr.elapsed, tr.elapsed);
    let (mut win_rays, mut win_samples, mut win_secs) = (0usize, 0usize, 0.0f64);
    let (mut win_times, mut run_times, mut run_samples) = (StepTimes::default(), StepTimes::default(), 0usize);
    let (mut win_steps, run_start) = (0u64, tr.step);
    let mut last_val_psnr = None;
    let wall = Instant::now();
    if progress_of(&tr) >= 1.0 {
        return Err(format!(
            "{}: the checkpoint is at step {} ({:.2} training minutes), already the end of this budget: give a larger \
             --iters or --minutes",
            ckpt.display(),
            tr.step,
            tr.elapsed / 60.0
        ));
    }
    while progress_of(&tr) < 1.0 {
        let t0 = Instant::now();
        let st = tr.train_step(&data, progress_of(&tr));
        let dt = t0.elapsed().as_secs_f64();
        tr.elapsed += dt;
        win_rays += st.rays;
        win_samples += st.samples;
        win_secs += dt;
        win_steps += 1;
        win_times.add(&st.times);
        run_times.add(&st.times);
        run_samples += st.samples;
        if st.skipped {
            pb.println(format!("step {}: loss or gradient not finite, step skipped", tr.step));
        }
        let mut val_psnr = None;
        if let Some(v) = val.as_ref().filter(|_| tr.elapsed - last_val >= a.val_secs) {
            val_psnr = Some(validate(&tr, v, a.val_views, &calib[..256])?);
            last_val_psnr = val_psnr;
            last_val = tr.elapsed;
        }
        if tr.step % a.log_every == 0 || val_psnr.is_some() {
            let line = serde_json::json!({
                "step": tr.step,
                "train_secs": tr.elapsed,
                "wall_secs": wall.elapsed().as_secs_f64(),
                "loss": st.loss,
                "psnr": st.psnr,
                "lr": tr.learning_rate(progress_of(&tr)),
                "rays_per_sec": win_rays as f64 / win_secs,
                "samples_per_sec": win_samples as f64 / win_secs,
                "gflops": win_samples as f64 * flops_per_sample / win_secs / 1e9,
                "val_psnr": val_psnr,
                "skipped_steps": tr.skipped,
                "step_ms": stage_ms(&win_times, win_steps),
                "mlp_gflops_per_thread": mlp_gflops(&win_times, win_samples, &mlp),
            });
            log.append(&line)?;
            pb.set_message(format!(
                "loss {:.4} psnr {:.2} dB, {:.0} rays/s{}",
                st.loss,
                st.psnr,
                win_rays as f64 / win_secs,
                last_val_psnr.map(|v| format!(", val {v:.2} dB")).unwrap_or_default()
            ));
            (win_rays, win_samples, win_secs) = (0, 0, 0.0);
            (win_times, win_steps) = (StepTimes::default(), 0);
        }
        pb.set_position(match a.iters {
            Some(_) => tr.step,
            None => (tr.elapsed * 1000.0) as u64,
        });
        // an interrupt at the last step lets the run finish: there would be nothing left to resume
        if super::interrupt::received() && progress_of(&tr) < 1.0 {
            pb.finish_and_clear();
            save(&tr, &a.out, &calib, a.prune, &data)?;
            return Err(format!(
                "interrupted at step {}: checkpoint saved to {}; continue with --resume",
                tr.step,
                ckpt.display()
            ));
        }
        if tr.elapsed - last_ckpt >= a.checkpoint_secs {
            save(&tr, &a.out, &calib, a.prune, &data)?;
            last_ckpt = tr.elapsed;
        }
    }
    pb.finish_and_clear();
    save(&tr, &a.out, &calib, a.prune, &data)?;
    let val_psnr = match &val {
        Some(v) => Some(validate(&tr, v, a.val_views, &calib[..256])?),
        None => None,
    };
    eprintln!("{}", time_summary(&run_times, tr.step - run_start, run_samples, &mlp));
    eprintln!(
        "trained {} steps in {:.1} s; wrote {}{}",
        tr.step,
        tr.elapsed,
        a.out.join("model.nerf").display(),
        val_psnr
            .zip(val.as_ref())
            .map(|(v, d)| format!("; validation PSNR {v:.2} dB on {} views", a.val_views.min(d.views.len())))
            .unwrap_or_default()
    );
    Ok(())
}

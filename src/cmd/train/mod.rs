//! `nerf train`: fits a model to a dataset, with a progress bar, periodic
//! validation, atomic checkpoints and `--resume`.

use super::runlog::RunLog;
use super::{
    create_dir, load_split, lock_run_dir, num_in, progress, refuse_inside, with_threads, write_atomic, CaptureArgs,
    CmdError, CmdResult,
};
use nerf_train::config::{Preset, TrainConfig};
use nerf_train::dataset::{Dataset, Split};
use nerf_train::export::Prune;
use nerf_train::run::{
    fit_to_data, mlp_gflops, stage_ms, time_summary, Budget, Fit, Flow, Observer, Outcome, Run, Schedule, StepEvent,
};
use nerf_train::train::Trainer;
use std::path::{Path, PathBuf};
use std::time::Instant;

mod new_run;
mod resume;
use new_run::*;
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
    #[arg(long, default_value_t = Schedule::default().checkpoint_secs, value_name = "0.0..=1e6", value_parser = num_in(0.0f64, 1e6))]
    pub(crate) checkpoint_secs: f64,
    /// Seconds of training between validation renders (0: after every step).
    #[arg(long, default_value_t = Schedule::default().val_secs, value_name = "0.0..=1e6", value_parser = num_in(0.0f64, 1e6))]
    pub(crate) val_secs: f64,
    /// Validation views rendered each time (0: no periodic validation).
    #[arg(long, default_value_t = Schedule::default().val_views, value_name = "0..=10000", value_parser = num_in(0usize, 10_000))]
    pub(crate) val_views: usize,
    /// Steps between lines of train.jsonl.
    #[arg(long, default_value_t = Schedule::default().log_every, value_name = "1..=1000000000", value_parser = num_in(1u64, 1_000_000_000))]
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

/// Writes the checkpoint and the model (the model first: a checkpoint on
/// disk always has its model beside it; a run stopped between the two
/// resumes from the earlier checkpoint and writes the model again).
fn save(run: &Run<'_>, out: &Path, prune: Prune) -> CmdResult {
    let bytes = run.model(prune).to_bytes().map_err(CmdError::within("exporting the model"))?;
    write_atomic(&out.join("model.nerf"), &bytes)?;
    // the checkpoint is several times the model: a disk that filled for it keeps the model, and says so
    write_atomic(&out.join("checkpoint.bin"), &run.trainer.to_bytes()?).map_err(|e| {
        e.noted(format!(
            "; the model of step {} is written ({}), the checkpoint is not: this run can be used but not resumed \
             from here",
            run.trainer.step,
            out.join("model.nerf").display()
        ))
    })
}

impl Args {
    /// `nerf train --data DATA --minutes MINUTES --out OUT` with every other
    /// flag at its default.
    pub fn new(data: PathBuf, minutes: f64, out: PathBuf) -> Self {
        let schedule = Schedule::default();
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
            checkpoint_secs: schedule.checkpoint_secs,
            val_secs: schedule.val_secs,
            val_views: schedule.val_views,
            log_every: schedule.log_every,
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
    cfg.validate().map_err(CmdError::within("invalid configuration"))?;
    let run = NewRun { cfg, fit: Fit::KEEP_SIZES };
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
        let reason = match ckpt.is_file() {
            true => format!("holds a run ({f}): continue it with --resume, or start over with --force"),
            // a model without its checkpoint (copied, or exported there) cannot be continued
            false => format!(
                "holds {f} and no checkpoint to resume from: start over with --force (replacing it), or choose \
                 another --out"
            ),
        };
        return Err(CmdError::File { path: a.out.clone(), reason });
    }
    let load = |downscale| load_split(&a.data, Split::Train, downscale, a.capture);
    let (tr, data) = if a.resume && ckpt.is_file() {
        let b = nerf_train::util::userfile::read_user_file(&ckpt, 16 << 30, "checkpoint")?;
        let mut tr = Trainer::from_bytes(&b).map_err(CmdError::file(&ckpt))?;
        let moved_from = check_resume(&a, &tr)?;
        let data = load(tr.downscale)?;
        check_resumed_data(&a, &mut tr, &data, moved_from)?;
        check_resume_config(&a, &tr, &data)?;
        (tr, data)
    } else if a.resume {
        return Err(CmdError::File { path: ckpt, reason: "no checkpoint to resume from".into() });
    } else {
        let run = new_run.ok_or_else(|| CmdError::Usage("a configuration for a new run".into()))?;
        let downscale = a.capture.downscale.unwrap_or(1);
        let data = load(downscale)?;
        let fitted = fit_to_data(&run.cfg, run.fit, &data)?;
        for note in &fitted.notes {
            eprintln!("{note}");
        }
        let mut tr = Trainer::new(fitted.cfg, data.scene, downscale, a.seed)?;
        tr.data = data_source(&a);
        (tr, data)
    };
    let val = load_val(&a, tr.downscale);
    let budget = match (a.iters, a.minutes) {
        (Some(n), _) => Budget::Steps(n),
        (None, Some(m)) => Budget::Seconds(m * 60.0),
        _ => unreachable!("clap requires a budget"),
    };
    if budget.progress(&tr) >= 1.0 {
        return Err(CmdError::File {
            path: ckpt,
            reason: format!(
                "the checkpoint is at step {} ({:.2} training minutes), already the end of this budget: give a \
                 larger --iters or --minutes",
                tr.step,
                tr.elapsed / 60.0
            ),
        });
    }
    let mut run = Run::new(tr, &data, val.as_ref(), budget).map_err(CmdError::file(&a.data))?;
    run.schedule = Schedule {
        checkpoint_secs: a.checkpoint_secs,
        val_secs: a.val_secs,
        val_views: a.val_views,
        log_every: a.log_every,
    };
    // from before the log exists: an interrupt once it does stops at a step
    // and checkpoints, never exits with a log and no checkpoint
    super::interrupt::catch();
    let mut progress = Progress {
        bar: progress(budget.ticks(), "{bar:30} {pos}/{len} ({eta}) {msg}"),
        log: RunLog::open(&a.out.join("train.jsonl"), a.resume.then_some(run.trainer.step))?,
        out: a.out.clone(),
        prune: a.prune,
        mlp: run.trainer.mlp().clone(),
        wall: Instant::now(),
        last_val_psnr: None,
    };
    let start_step = run.trainer.step;
    let outcome = run.train(&mut progress);
    progress.bar.finish_and_clear();
    let val_psnr = match outcome? {
        Outcome::Stopped => {
            return Err(CmdError::Interrupted(format!(
                "interrupted at step {}: checkpoint saved to {}; continue with --resume",
                run.trainer.step,
                ckpt.display()
            )))
        }
        Outcome::Finished { val_psnr } => val_psnr,
    };
    let totals = &run.totals;
    eprintln!("{}", time_summary(totals, run.trainer.step - start_step, &progress.mlp));
    eprintln!(
        "trained {} steps in {:.1} s; wrote {}{}",
        run.trainer.step,
        run.trainer.elapsed,
        a.out.join("model.nerf").display(),
        val_psnr
            .zip(val.as_ref())
            .map(|(v, d)| format!("; validation PSNR {v:.2} dB on {} views", a.val_views.min(d.views.len())))
            .unwrap_or_default()
    );
    Ok(())
}

/// What `nerf train` shows and writes while a run trains: the progress
/// bar, train.jsonl, the model and the checkpoint; it stops the run on an
/// interrupt.
struct Progress {
    bar: indicatif::ProgressBar,
    log: RunLog,
    out: PathBuf,
    prune: Prune,
    mlp: nerf_train::mlp::Mlp,
    wall: Instant,
    last_val_psnr: Option<f64>,
}

impl Observer for Progress {
    type Error = CmdError;

    fn step(&mut self, run: &Run<'_>, ev: &StepEvent<'_>) -> CmdResult<Flow> {
        let tr = &run.trainer;
        let st = &ev.stats;
        if st.skipped {
            self.bar.println(format!("step {}: loss or gradient not finite, step skipped", tr.step));
        }
        if ev.val_psnr.is_some() {
            self.last_val_psnr = ev.val_psnr;
        }
        if let Some(w) = ev.window {
            let flops_per_sample = 6.0 * self.mlp.macs_per_sample() as f64;
            let line = serde_json::json!({
                "step": tr.step,
                "train_secs": tr.elapsed,
                "wall_secs": self.wall.elapsed().as_secs_f64(),
                "loss": st.loss,
                "psnr": st.psnr,
                "lr": tr.learning_rate(run.progress()),
                "rays_per_sec": w.rays_per_sec(),
                "samples_per_sec": w.samples as f64 / w.secs,
                "gflops": w.samples as f64 * flops_per_sample / w.secs / 1e9,
                "val_psnr": ev.val_psnr,
                "skipped_steps": tr.skipped,
                "step_ms": stage_ms(&w.times, w.steps),
                "backward_share": w.backward_samples as f64 / w.samples.max(1) as f64,
                "mlp_gflops_per_thread": mlp_gflops(w, &self.mlp),
            });
            self.log.append(&line)?;
            self.bar.set_message(format!(
                "loss {:.4} psnr {:.2} dB, {:.0} rays/s{}",
                st.loss,
                st.psnr,
                w.rays_per_sec(),
                self.last_val_psnr.map(|v| format!(", val {v:.2} dB")).unwrap_or_default()
            ));
        }
        self.bar.set_position(run.budget.tick(tr));
        Ok(if super::interrupt::received() { Flow::Stop } else { Flow::Continue })
    }

    fn checkpoint(&mut self, run: &Run<'_>) -> CmdResult {
        save(run, &self.out, self.prune)
    }
}

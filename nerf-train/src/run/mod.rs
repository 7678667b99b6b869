//! A training run as a program gets it: the configuration fitted to the
//! data ([`fit_to_data`]), then [`Run::train`], the loop `nerf train`
//! runs — steps until the [`Budget`] is spent, validation renders and
//! checkpoints on a [`Schedule`] of training seconds — telling an
//! [`Observer`] what happens (progress, log lines, when to write a
//! checkpoint) and stopping when it asks. The command adds only argument
//! parsing, progress bars and files, so a program that trains through
//! this module gets the command's model byte for byte.

mod fit;
mod report;
pub use fit::*;
pub use report::*;

use crate::dataset::Dataset;
use crate::error::Result;
use crate::eval::score_view;
use crate::export::{trainer_model, OwnedModel, Prune};
use crate::path::fit_orbit;
use crate::train::{Draw, Sample, StepStats, Trainer};
use crate::util::rng::Rng;
use crate::util::timing::StepTimes;
use nerf_infer::{Model, RenderOptions};
use std::time::Instant;

/// How long a run trains: a step count or seconds of training, both
/// counted from the run's start across resumes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// Until this many steps in total.
    Steps(u64),
    /// Until this many seconds of training in total ([`Trainer::elapsed`]).
    Seconds(f64),
}

impl Budget {
    /// The share of the budget `tr` has spent, 0.0 at the start, ≥ 1.0 at the end.
    pub fn progress(&self, tr: &Trainer) -> f64 {
        match *self {
            Budget::Steps(n) => tr.step as f64 / n as f64,
            Budget::Seconds(s) => tr.elapsed / s,
        }
    }

    /// The budget in ticks of a progress bar: steps, or milliseconds of training.
    pub fn ticks(&self) -> u64 {
        match *self {
            Budget::Steps(n) => n,
            Budget::Seconds(s) => (s * 1000.0) as u64,
        }
    }

    /// Where `tr` is, in [`Budget::ticks`].
    pub fn tick(&self, tr: &Trainer) -> u64 {
        match self {
            Budget::Steps(_) => tr.step,
            Budget::Seconds(_) => (tr.elapsed * 1000.0) as u64,
        }
    }
}

/// When a run validates, logs and checkpoints (`nerf train`'s defaults:
/// [`Schedule::default`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Schedule {
    /// Seconds of training between checkpoints (0: after every step).
    pub checkpoint_secs: f64,
    /// Seconds of training between validation renders (0: after every step).
    pub val_secs: f64,
    /// Validation views rendered each time, the first ones of the split (0: none).
    pub val_views: usize,
    /// Steps between log lines ([`StepEvent::window`]); a step that validates logs too.
    pub log_every: u64,
}

impl Default for Schedule {
    fn default() -> Self {
        Schedule { checkpoint_secs: 60.0, val_secs: 120.0, val_views: 2, log_every: 10 }
    }
}

/// What the steps since the last log line did: rays, network samples,
/// seconds and where they went.
#[derive(Clone, Copy, Debug, Default)]
pub struct Window {
    /// Rays trained on.
    pub rays: usize,
    /// Network evaluations.
    pub samples: usize,
    /// Network evaluations the backward pass took ([`StepStats::backward_samples`]).
    pub backward_samples: usize,
    /// Seconds of training.
    pub secs: f64,
    /// Steps taken.
    pub steps: u64,
    /// Where the steps' time went.
    pub times: StepTimes,
}

impl Window {
    fn add(&mut self, st: &StepStats, secs: f64) {
        self.rays += st.rays;
        self.samples += st.samples;
        self.backward_samples += st.backward_samples;
        self.secs += secs;
        self.steps += 1;
        self.times.add(&st.times);
    }

    /// Rays trained on per second of training.
    pub fn rays_per_sec(&self) -> f64 {
        self.rays as f64 / self.secs
    }
}

/// One step as the observer sees it.
#[derive(Clone, Copy, Debug)]
pub struct StepEvent<'w> {
    /// The step's loss, PSNR and timing.
    pub stats: StepStats,
    /// Mean PSNR (dB) of the validation views, on a step that rendered them.
    pub val_psnr: Option<f64>,
    /// The steps since the last log line, on a step that logs
    /// ([`Schedule::log_every`], or a validation).
    pub window: Option<&'w Window>,
}

/// What the loop does after a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    /// Go on.
    Continue,
    /// Stop: the run writes a checkpoint ([`Observer::checkpoint`]) and
    /// returns [`Outcome::Stopped`], unless the step was its last.
    Stop,
}

/// How [`Run::train`] ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome {
    /// The budget is spent; the validation PSNR (dB) of the final model
    /// where the run has validation views.
    Finished {
        /// Mean PSNR of the validation views.
        val_psnr: Option<f64>,
    },
    /// The observer stopped the run before the end; a checkpoint was written.
    Stopped,
}

/// What a program does while a run trains. Every method has a default that
/// does nothing.
pub trait Observer {
    /// The error the observer's work can fail with, and the run's own.
    type Error: From<crate::Error>;

    /// After every step.
    fn step(&mut self, _run: &Run<'_>, _event: &StepEvent<'_>) -> std::result::Result<Flow, Self::Error> {
        Ok(Flow::Continue)
    }

    /// When the schedule calls for a checkpoint, when the budget is spent
    /// and when the run stops: write [`Run::model`] and the trainer's
    /// state ([`Trainer::to_bytes`]) where they belong.
    fn checkpoint(&mut self, _run: &Run<'_>) -> std::result::Result<(), Self::Error> {
        Ok(())
    }
}

/// An observer that lets a run train to the end and keeps nothing.
impl Observer for () {
    type Error = crate::Error;
}

/// A run: its state, its data and how long it trains.
pub struct Run<'d> {
    /// The state a checkpoint holds.
    pub trainer: Trainer,
    /// The training split.
    pub data: &'d Dataset,
    /// The validation split, where validation views are rendered.
    pub val: Option<&'d Dataset>,
    /// How long it trains.
    pub budget: Budget,
    /// When it validates, logs and checkpoints.
    pub schedule: Schedule,
    /// Rays through the centres of pixels the export calibrates the
    /// fixed-point formats on (4 096, drawn from the run's seed).
    pub calibration: Vec<Sample>,
    /// Where the time of this call's steps went (not those before a resume).
    pub totals: Window,
}

impl<'d> Run<'d> {
    /// The calibration rays a run of `seed` draws from `data`.
    pub fn calibration(data: &Dataset, seed: u64) -> Vec<Sample> {
        Trainer::draw_batch(data, 4096, Draw::CENTRES, &mut Rng::new(seed ^ crate::util::rng::stream::CALIBRATION))
    }

    /// A run of `trainer` (new, or read from a checkpoint) on `data`;
    /// fails if some training ray is not finite ([`Dataset::check_rays`]).
    pub fn new(trainer: Trainer, data: &'d Dataset, val: Option<&'d Dataset>, budget: Budget) -> Result<Self> {
        data.check_rays()?;
        let calibration = Self::calibration(data, trainer.seed);
        Ok(Run { trainer, data, val, budget, schedule: Schedule::default(), calibration, totals: Window::default() })
    }

    /// A new run of `cfg` fitted to `data` as `fit` says ([`fit_to_data`]),
    /// seeded `seed`, at the dataset's `downscale`; with the fit's notes.
    /// Fails, naming the field, if `cfg` does not pass
    /// [`TrainConfig::validate`](crate::config::TrainConfig::validate).
    pub fn fitted(
        cfg: &crate::config::TrainConfig,
        fit: Fit,
        data: &'d Dataset,
        downscale: u32,
        seed: u64,
        budget: Budget,
    ) -> Result<(Self, Vec<String>)> {
        let fitted = fit_to_data(cfg, fit, data)?;
        let trainer = Trainer::new(fitted.cfg, data.scene, downscale, seed)?;
        Ok((Self::new(trainer, data, None, budget)?, fitted.notes))
    }

    /// The share of the budget spent ([`Budget::progress`]).
    pub fn progress(&self) -> f64 {
        self.budget.progress(&self.trainer)
    }

    /// The model as `nerf train` writes it: the averaged parameters,
    /// calibrated for export, pruned as `prune` says, recording how the
    /// capture was split and the orbit fitted to its cameras.
    pub fn model(&self, prune: Prune) -> OwnedModel {
        let cams: Vec<_> = self.data.views.iter().map(|v| v.camera).collect();
        let orbit = fit_orbit(&self.data.scene, &cams);
        OwnedModel { capture: self.data.capture, orbit, ..trainer_model(&self.trainer, &self.calibration, prune) }
    }

    /// Mean PSNR (dB) of the first [`Schedule::val_views`] validation views
    /// rendered by the kernel's f32 path; `None` without validation views.
    pub fn validate(&self) -> Result<Option<f64>> {
        let Some(val) = self.val.filter(|_| self.schedule.val_views > 0) else { return Ok(None) };
        let model = trainer_model(&self.trainer, &self.calibration[..256.min(self.calibration.len())], Prune::Off)
            .to_bytes()?;
        let model = Model::from_bytes(&model)?;
        let views = &val.views[..self.schedule.val_views.min(val.views.len())];
        let mut sum = 0.0;
        for v in views {
            sum += score_view(&model, RenderOptions::from_model(&model), v)?.1.psnr;
        }
        Ok(Some(sum / views.len() as f64))
    }

    /// Trains until the budget is spent or `obs` stops the run, telling
    /// `obs` of every step and asking it to checkpoint on the schedule and
    /// at the end.
    pub fn train<O: Observer>(&mut self, obs: &mut O) -> std::result::Result<Outcome, O::Error> {
        let (mut last_ckpt, mut last_val) = (self.trainer.elapsed, self.trainer.elapsed);
        let mut window = Window::default();
        while self.progress() < 1.0 {
            let t0 = Instant::now();
            let stats = self.trainer.train_step(self.data, self.progress());
            let dt = t0.elapsed().as_secs_f64();
            self.trainer.elapsed += dt;
            window.add(&stats, dt);
            self.totals.add(&stats, dt);
            let mut val_psnr = None;
            if self.trainer.elapsed - last_val >= self.schedule.val_secs {
                val_psnr = self.validate()?;
                last_val = self.trainer.elapsed;
            }
            let logs = self.trainer.step.is_multiple_of(self.schedule.log_every) || val_psnr.is_some();
            let event = StepEvent { stats, val_psnr, window: logs.then_some(&window) };
            let flow = obs.step(self, &event)?;
            if logs {
                window = Window::default();
            }
            // a stop at the last step lets the run finish: there would be nothing left to resume
            if flow == Flow::Stop && self.progress() < 1.0 {
                obs.checkpoint(self)?;
                return Ok(Outcome::Stopped);
            }
            if self.trainer.elapsed - last_ckpt >= self.schedule.checkpoint_secs {
                obs.checkpoint(self)?;
                last_ckpt = self.trainer.elapsed;
            }
        }
        obs.checkpoint(self)?;
        Ok(Outcome::Finished { val_psnr: self.validate()? })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::TrainConfig;
    use crate::dataset::grey_views;

    /// Two small networks.
    fn small() -> TrainConfig {
        TrainConfig::fast().with(|c| {
            (c.model.depth, c.model.width, c.model.view_width) = (2, 16, 8);
            c.model.skips.clear();
            (c.sampling.n_coarse, c.sampling.n_fine) = (8, std::num::NonZeroU16::new(8));
        })
    }

    #[test]
    fn a_run_validates_with_fewer_calibration_rays_than_the_256_it_renders_with() {
        let data = grey_views(2);
        let (mut run, _) = Run::fitted(&small(), Fit::ALL, &data, 1, 1, Budget::Steps(1)).unwrap();
        (run.val, run.schedule.val_views) = (Some(&data), 1);
        run.calibration.truncate(16);
        assert!(run.validate().unwrap().is_some_and(f64::is_finite));
    }

    #[test]
    fn a_run_a_fit_and_a_random_model_are_refused_an_invalid_configuration_naming_the_field() {
        let data = grey_views(2);
        let bad = small().with(|c| c.model.depth = 0);
        let says = |e: crate::Error| assert!(e.to_string().starts_with("model.depth must be"), "{e}");
        says(fit_to_data(&bad, Fit::ALL, &data).unwrap_err());
        says(Run::fitted(&bad, Fit::ALL, &data, 1, 1, Budget::Steps(1)).err().unwrap());
        says(crate::export::random_model(&bad, data.scene, 1, 1.0).unwrap_err());
    }
}

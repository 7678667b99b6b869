//! A program that trains through `nerf_train::run` gets the model `nerf
//! train` writes, byte for byte, and a run its observer stops resumes to
//! the model of a run never stopped.

mod support;

use nerf_train::config::Preset;
use nerf_train::dataset::{self, LoadOptions, Split};
use nerf_train::export::Prune;
use nerf_train::run::{Budget, Fit, Flow, Observer, Outcome, Run, StepEvent};
use nerf_train::train::Trainer;
use support::cli::{ok, s, tmp};

/// Trains the default on `data` for `steps` steps, seed 3, through the library.
fn library_run(data: &dataset::Dataset, steps: u64) -> Vec<u8> {
    let (mut run, _) = Run::fitted(&Preset::default().config(), Fit::ALL, data, 1, 3, Budget::Steps(steps)).unwrap();
    assert_eq!(run.train(&mut ()).unwrap(), Outcome::Finished { val_psnr: None });
    run.model(Prune::Tiles).to_bytes().unwrap()
}

#[test]
fn a_library_run_writes_the_model_nerf_train_writes() {
    let d = tmp("library-run");
    ok(&["scene", "--out", s(&d.join("scene")), "--size", "16", "--train", "6"]);
    // an object scene, and an open one (the proposal grid and the distortion loss chosen for it)
    for (name, steps) in [("blender", 12u64), ("room", 8)] {
        let path = d.join("scene").join(name);
        let out = d.join(name);
        let n = steps.to_string();
        ok(&["train", "--data", s(&path), "--iters", &n, "--seed", "3", "--val-views", "0", "--out", s(&out)]);
        let data = dataset::load(&path, Split::Train, LoadOptions::default()).unwrap();
        let model = std::fs::read(out.join("model.nerf")).unwrap();
        assert!(library_run(&data, steps) == model, "{name}: the library's model differs from nerf train's");
    }
}

/// Stops the run after `at` steps, keeping its last checkpoint.
struct StopAt {
    at: u64,
    checkpoint: Option<Vec<u8>>,
    steps_seen: u64,
}

impl Observer for StopAt {
    type Error = nerf_train::Error;

    fn step(&mut self, run: &Run<'_>, _: &StepEvent<'_>) -> Result<Flow, Self::Error> {
        self.steps_seen += 1;
        Ok(if run.trainer.step == self.at { Flow::Stop } else { Flow::Continue })
    }

    fn checkpoint(&mut self, run: &Run<'_>) -> Result<(), Self::Error> {
        self.checkpoint = Some(run.trainer.to_bytes()?);
        Ok(())
    }
}

#[test]
fn a_stopped_library_run_resumes_to_the_model_of_a_run_never_stopped() {
    let d = tmp("library-stop");
    ok(&["scene", "--out", s(&d.join("scene")), "--size", "16", "--train", "6"]);
    let data = dataset::load(&d.join("scene").join("blender"), Split::Train, LoadOptions::default()).unwrap();
    let (mut run, _) = Run::fitted(&Preset::default().config(), Fit::ALL, &data, 1, 3, Budget::Steps(12)).unwrap();
    let mut stop = StopAt { at: 5, checkpoint: None, steps_seen: 0 };
    assert_eq!(run.train(&mut stop).unwrap(), Outcome::Stopped);
    assert_eq!((run.trainer.step, stop.steps_seen), (5, 5));
    // the checkpoint written on the stop, read back as a resumed run would
    let trainer = Trainer::from_bytes(&stop.checkpoint.take().expect("a checkpoint on stopping")).unwrap();
    let mut resumed = Run::new(trainer, &data, None, Budget::Steps(12)).unwrap();
    let mut rest = StopAt { at: 0, checkpoint: None, steps_seen: 0 };
    assert!(matches!(resumed.train(&mut rest).unwrap(), Outcome::Finished { .. }));
    assert_eq!((resumed.trainer.step, rest.steps_seen), (12, 7));
    assert!(rest.checkpoint.is_some(), "a checkpoint at the end");
    let model = resumed.model(Prune::Tiles).to_bytes().unwrap();
    assert!(model == library_run(&data, 12), "the resumed run's model differs from the run never stopped");
}

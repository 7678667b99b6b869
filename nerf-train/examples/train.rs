//! Trains a model through the library, as `nerf train --data DATA --iters
//! STEPS --downscale D --seed S --val-views 0` does, and writes the same
//! model file byte for byte:
//!
//! `cargo run --release -p nerf-train --example train -- DATA STEPS OUT.nerf [DOWNSCALE] [SEED]`
use nerf_train::config::Preset;
use nerf_train::dataset::{self, LoadOptions, Split};
use nerf_train::export::Prune;
use nerf_train::run::{Budget, Fit, Run};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [data, steps, out, rest @ ..] = &args[..] else {
        return Err("usage: train DATA STEPS OUT.nerf [DOWNSCALE] [SEED]".into());
    };
    let downscale: u32 = rest.first().map_or(Ok(1), |s| s.parse())?;
    let seed: u64 = rest.get(1).map_or(Ok(0), |s| s.parse())?;
    // the training split, every 8th photo of a capture held out
    let data = dataset::load(data.as_ref(), Split::Train, LoadOptions { downscale, ..LoadOptions::default() })?;
    // the default preset, with every choice `nerf train` makes for the data
    let cfg = Preset::default().config();
    let (mut run, notes) = Run::fitted(&cfg, Fit::ALL, &data, downscale, seed, Budget::Steps(steps.parse()?))?;
    for note in notes {
        eprintln!("{note}");
    }
    run.train(&mut ())?;
    std::fs::write(out, run.model(Prune::Tiles).to_bytes()?)?;
    eprintln!("trained {} steps in {:.1} s; wrote {out}", run.trainer.step, run.trainer.elapsed);
    Ok(())
}

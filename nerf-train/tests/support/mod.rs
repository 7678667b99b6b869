//! Helpers shared by nerf-train's tests, and by the workspace tests through
//! `tests/support/mod.rs`.
#![allow(dead_code)]

use nerf_infer::format::Scene;
use nerf_infer::{Camera, Model, RenderOptions};
use nerf_train::config::TrainConfig;
use nerf_train::eval::render_view;
use std::num::NonZeroU16;
use std::path::{Path, PathBuf};

/// A fresh, empty directory under the system temp dir
/// (`nerf-test-NAME-PID`), removed when it goes out of scope, unless the
/// test is failing (then it stays for a look).
pub struct TestDir(PathBuf);

impl TestDir {
    /// Makes the directory for test `name`, emptied if it exists.
    pub fn new(name: &str) -> Self {
        let d = std::env::temp_dir().join(format!("nerf-test-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Self(d)
    }
}

impl std::ops::Deref for TestDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for TestDir {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for TestDir {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// The scene of the built-in dataset (bounds ±1, near 2, far 6, white).
pub fn unit_scene() -> Scene {
    Scene::blender(1.0, 2.0, 6.0)
}

/// A small configuration for tests.
pub fn small_config() -> TrainConfig {
    TrainConfig::fast().with(|c| {
        c.model.depth = 3;
        c.model.width = 32;
        c.model.skips = vec![2];
        c.model.view_width = 16;
        c.model.pos_freqs = 6;
        c.model.dir_freqs = 2;
        c.sampling.n_coarse = 24;
        c.sampling.n_fine = NonZeroU16::new(24);
    })
}

/// PSNR between two renders, dB.
pub fn psnr(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    nerf_train::metrics::psnr(a, b)
}

/// Renders `model` from `camera` with its default options.
pub fn render(model: &Model<'_>, camera: &Camera) -> Vec<[f32; 3]> {
    render_view(model, RenderOptions::from_model(model), camera).expect("render").rgb
}

/// Trains `tr` on `data`: three steps at progress 0, `steps` steps with
/// progress running from 0 to 1, three at 1; returns the mean loss of the
/// first three and of the last three.
pub fn loss_before_and_after(
    tr: &mut nerf_train::train::Trainer,
    data: &nerf_train::dataset::Dataset,
    steps: usize,
) -> (f32, f32) {
    let first: f32 = (0..3).map(|_| tr.train_step(data, 0.0).loss).sum::<f32>() / 3.0;
    for i in 0..steps {
        tr.train_step(data, i as f64 / steps as f64);
    }
    let last: f32 = (0..3).map(|_| tr.train_step(data, 1.0).loss).sum::<f32>() / 3.0;
    (first, last)
}

/// Trains `tr` 120 steps on `data` ([`loss_before_and_after`]) and
/// checks that the loss, the mean of three steps, falls to less than half
/// from the first steps to the last; returns both.
pub fn train_until_the_loss_halves(
    tr: &mut nerf_train::train::Trainer,
    data: &nerf_train::dataset::Dataset,
) -> (f32, f32) {
    let (first, last) = loss_before_and_after(tr, data, 120);
    println!("loss {first:.4} -> {last:.4}");
    assert!(last < 0.5 * first, "loss did not fall: {first} -> {last}");
    (first, last)
}

//! Per-photo appearance: on a capture whose photos alternate between two
//! exposures, the run's colour corrections take the difference, and the
//! photos are fitted better than without them.

mod support;

use nerf_train::config::TrainConfig;
use nerf_train::dataset::synthetic::{write_colmap, ColmapText, SceneSpec};
use nerf_train::dataset::{load, LoadOptions, Split};
use nerf_train::per_photo::appearance::IDENTITY;
use nerf_train::train::Trainer;
use std::num::NonZeroU16;
use support::cli::tmp;

/// Every other training photo's exposure.
const DARK: f32 = 0.6;

/// Mean of the diagonal of a correction's matrix.
fn gain(p: &[f32]) -> f32 {
    (p[0] + p[4] + p[8]) / 3.0
}

#[test]
fn corrections_take_each_photos_exposure() {
    let d = tmp("appearance");
    write_colmap(&d, SceneSpec { size: 24, train: 12, val: 2, test: 0 }, ColmapText::Binary, true).unwrap();
    let mut data = load(&d, Split::Train, LoadOptions { holdout: 8, ..Default::default() }).unwrap();
    for v in data.views.iter_mut().skip(1).step_by(2) {
        v.rgb.iter_mut().flatten().for_each(|c| *c *= DARK);
    }
    let steps = 400;
    let run = |appearance: bool| {
        // a colour without the view direction: only the corrections can tell the photos apart
        let cfg = TrainConfig::features().with(|c| {
            c.sampling.proposal_res = NonZeroU16::new(32);
            c.sampling.batch_rays = 256;
            c.per_photo.appearance = appearance;
            c.model.view_dependent = false;
        });
        let mut tr = Trainer::new(cfg, data.scene, 1, 0).unwrap();
        let mut last = 0.0;
        for k in 0..steps {
            let loss = tr.train_step(&data, k as f64 / steps as f64).loss;
            if k >= steps - 20 {
                last += loss / 20.0;
            }
        }
        (tr, last)
    };
    let (with, loss_with) = run(true);
    let (_, loss_without) = run(false);
    let a = with.appearance.as_ref().expect("the run fits corrections");
    assert_eq!(a.photos(), data.views.len());
    let mean = |odd: usize| {
        let g: Vec<f32> = (odd..a.photos()).step_by(2).map(|i| gain(a.of(i))).collect();
        g.iter().sum::<f32>() / g.len() as f32
    };
    let (bright, dark) = (mean(0), mean(1));
    let gains: Vec<f32> = (0..a.photos()).map(|i| gain(a.of(i))).collect();
    println!("gains {gains:.3?}: bright photos {bright:.3}, dark {dark:.3}; loss {loss_with:.5} with corrections, {loss_without:.5} without");
    // every dark photo's correction darkens the field's colour more than every bright photo's does
    let darkest_bright = gains.iter().step_by(2).copied().fold(f32::INFINITY, f32::min);
    let brightest_dark = gains.iter().skip(1).step_by(2).copied().fold(f32::NEG_INFINITY, f32::max);
    assert!(brightest_dark < darkest_bright, "gains {gains:?}");
    // and the corrections' mean is the identity
    let all = (0..a.photos()).map(|i| gain(a.of(i))).sum::<f32>() / a.photos() as f32;
    assert!((all - 1.0).abs() < 1e-4, "mean gain {all}");
    assert!(loss_with < loss_without, "loss {loss_with} with corrections, {loss_without} without");
    // a checkpoint keeps them
    let back = Trainer::from_bytes(&with.to_bytes().unwrap()).unwrap();
    assert_eq!(back.appearance.as_ref().unwrap().params, a.params);
    assert_ne!(a.of(1), &IDENTITY[..]);
}

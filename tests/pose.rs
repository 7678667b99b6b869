//! Camera pose refinement: the pose corrections' gradient against finite
//! differences of the loss, and a capture whose training cameras are all
//! a little off, where the corrections raise the held-out views' PSNR.

mod support;

use glam::{Mat3, Vec3};
use nerf_infer::{Model, RenderOptions};
use nerf_train::config::TrainConfig;
use nerf_train::dataset::synthetic::{write_colmap, ColmapText, SceneSpec};
use nerf_train::dataset::{load, Dataset, LoadOptions, Split};
use nerf_train::eval::score_view;
use nerf_train::export::{trainer_model, Prune};
use nerf_train::per_photo::pose::{Poses, PER_PHOTO};
use nerf_train::train::{Draw, Trainer};
use nerf_train::util::rng::Rng;
use std::num::NonZeroU16;
use support::cli::tmp;

/// The built-in scene inside its room (an unbounded scene: its samples are
/// contracted), `size` pixels square.
fn room(name: &str, size: u32) -> Dataset {
    let d = tmp(name);
    write_colmap(&d, SceneSpec { size, train: 12, val: 2, test: 0 }, ColmapText::Binary, true).unwrap();
    let data = load(&d, Split::Train, LoadOptions { holdout: 8, ..Default::default() }).unwrap();
    assert!(data.scene.unbounded.is_some(), "the room is unbounded");
    data
}

/// Mean squared colour error over `n` rays drawn (seed 7) through the
/// cameras as `tr.poses` corrects them, with the step key `key`.
fn loss(tr: &Trainer, data: &Dataset, n: usize, how: Draw, key: u32) -> f64 {
    let batch = Trainer::draw_batch_posed(data, n, how, &mut Rng::new(7), tr.poses.as_ref());
    assert_eq!(batch.len(), n);
    let (_, sq, _, _) = tr.gradients(&batch, key);
    sq / (3.0 * n as f64)
}

#[test]
fn pose_gradient_matches_finite_differences() {
    let data = room("pose_fd", 16);
    // stratified samples (no proposal or occupancy grid), so that the
    // samples' t do not move with the camera
    let cfg = TrainConfig::features().with(|c| {
        c.sampling.proposal_res = None;
        c.grid.res = None;
        c.sampling.n_coarse = 48;
        c.sampling.batch_rays = 256;
        c.loss.distortion = 0.0;
        c.loss.density_l1 = 0.0;
        c.per_photo.pose_refine = true;
    });
    let mut tr = Trainer::new(cfg, data.scene, 1, 0).unwrap();
    for k in 0..150 {
        tr.train_step(&data, k as f64 / 150.0);
    }
    // lines through pixel centres: every part of the gradient is exact;
    // with footprints (turned about the ray at random, their basis taken
    // as fixed) the shift's part is
    for (how, parts) in [(Draw::CENTRES, 0..PER_PHOTO), (Draw { footprint: true, ..Draw::CENTRES }, 3..PER_PHOTO)] {
        let mut at = tr.clone();
        at.poses = Some(Poses::new(data.views.len()));
        let n = 96;
        let batch = Trainer::draw_batch_posed(&data, n, how, &mut Rng::new(7), at.poses.as_ref());
        let grad = at.photo_gradients(&batch, 11).pose;
        assert_eq!(grad.len(), data.views.len() * PER_PHOTO);
        // steps much longer than this see the loss's curvature; the
        // network's kinks (ReLUs, the grid's cell faces) are what remains
        let h = 2.5e-4;
        let (mut analytic, mut numeric) = (Vec::new(), Vec::new());
        for photo in 0..3 {
            for i in parts.clone() {
                let k = photo * PER_PHOTO + i;
                let step = |s: f32| {
                    let mut p = at.clone();
                    p.poses.as_mut().unwrap().params[k] += s;
                    loss(&p, &data, n, how, 11)
                };
                let fd = (step(h) - step(-h)) / (2.0 * h as f64);
                println!("photo {photo} value {i}: analytic {:.3e}, finite differences {fd:.3e}", grad[k]);
                analytic.push(grad[k] as f64);
                numeric.push(fd);
            }
        }
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let cosine = dot(&analytic, &numeric) / (dot(&analytic, &analytic) * dot(&numeric, &numeric)).sqrt();
        let largest = numeric.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = analytic.iter().zip(&numeric).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(largest > 1e-4, "the loss moves with the cameras ({largest})");
        assert!(cosine > 0.99, "{how:?}: cosine {cosine}");
        assert!(worst < 0.1 * largest, "{how:?}: worst difference {worst:.3e}, largest gradient {largest:.3e}");
    }
}

#[test]
fn cameras_that_are_off_are_corrected_and_the_held_out_views_gain() {
    let d = tmp("pose_off");
    write_colmap(&d, SceneSpec { size: 32, train: 24, val: 3, test: 0 }, ColmapText::Binary, true).unwrap();
    let opts = LoadOptions { holdout: 8, ..Default::default() };
    let mut data = load(&d, Split::Train, opts).unwrap();
    let val = load(&d, Split::Val, opts).unwrap();
    // every training camera turned about its centre and moved at random
    // (about a pixel each); the held-out cameras keep their poses
    let mut rng = Rng::new(5);
    let mut normal = || {
        let (u, v) = (1.0 - rng.f32(), rng.f32());
        (-2.0 * u.ln()).sqrt() * (std::f32::consts::TAU * v).cos()
    };
    for v in data.views.iter_mut() {
        let w = Vec3::new(normal(), normal(), normal()) * 0.015;
        v.camera.rotation = Mat3::from_axis_angle(w.normalize(), w.length()) * v.camera.rotation;
        v.camera.position += Vec3::new(normal(), normal(), normal()) * 0.015;
    }
    let steps = 600;
    let run = |refine: bool| {
        let cfg = TrainConfig::features().with(|c| {
            c.sampling.proposal_res = NonZeroU16::new(32);
            c.sampling.batch_rays = 512;
            c.per_photo.pose_refine = refine;
            // a short run: nerfacto's rate, where the default suits thousands of steps
            c.per_photo.pose_lr = 6e-4;
        });
        let mut tr = Trainer::new(cfg, data.scene, 1, 0).unwrap();
        for k in 0..steps {
            tr.train_step(&data, k as f64 / steps as f64);
        }
        let calib = Trainer::draw_batch(&data, 512, Draw::CENTRES, &mut Rng::new(3));
        let bytes = trainer_model(&tr, &calib, Prune::Off).to_bytes().unwrap();
        let m = Model::from_bytes(&bytes).unwrap();
        let psnr = val.views.iter().map(|v| score_view(&m, RenderOptions::from_model(&m), v).unwrap().1.psnr);
        (tr, psnr.sum::<f64>() / val.views.len() as f64)
    };
    let (with, psnr_with) = run(true);
    let (_, psnr_without) = run(false);
    let poses = with.poses.as_ref().expect("the run fits pose corrections");
    let turned = (0..poses.photos()).map(|k| poses.of(k).0.length()).sum::<f32>() / poses.photos() as f32;
    println!("held-out PSNR {psnr_with:.2} dB with corrections, {psnr_without:.2} without; mean turn {turned:.4} rad");
    assert!(psnr_with > psnr_without + 0.5, "held-out PSNR {psnr_with} with corrections, {psnr_without} without");
    // a checkpoint keeps them
    let back = Trainer::from_bytes(&with.to_bytes().unwrap()).unwrap();
    assert_eq!(back.poses.as_ref().unwrap().params, poses.params);
}

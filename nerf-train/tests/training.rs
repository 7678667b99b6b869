//! Training on tiny data: the loss falls, checkpoints round-trip, and the
//! exported model renders through the kernel like the trainer predicts.
//! The field's density is in `density.rs`.

mod support;

use nerf_infer::{Model, RenderOptions};
use nerf_train::dataset::synthetic::{write_blender, SceneSpec};
use nerf_train::dataset::View;
use nerf_train::dataset::{load, LoadOptions, Split};
use nerf_train::eval::{score_rendered, score_view, Rendered};
use nerf_train::export::{trainer_model, Prune};
use nerf_train::train::{Draw, Trainer};
use nerf_train::util::rng::Rng;
use std::num::NonZeroU16;
use support::small_config;

#[test]
fn a_checkpoint_keeps_its_scenes_unbounded_space() {
    let scene = nerf_infer::format::Scene {
        unbounded: Some(nerf_infer::format::Unbounded { linear_until: 2.5 }),
        far: 2500.0,
        ..support::unit_scene()
    };
    let tr = Trainer::new(small_config(), scene, 1, 1).unwrap();
    let back = Trainer::from_bytes(&tr.to_bytes().unwrap()).unwrap();
    // a resumed run marches and contracts its rays as the run it continues
    assert_eq!(back.scene, scene);
    assert_eq!(back.scene.unbounded, scene.unbounded);
}

#[test]
fn a_trainer_is_refused_an_invalid_configuration_naming_the_field() {
    let features = nerf_train::config::TrainConfig::features();
    for (cfg, says) in [
        (small_config().with(|c| c.model.depth = 0), "model.depth"),
        (small_config().with(|c| c.sampling.chunk_rays = 0), "sampling.chunk_rays"),
        (features.clone().with(|c| c.features.levels = std::num::NonZeroU8::new(17)), "features.levels"),
        (features.with(|c| c.grid.res = NonZeroU16::new(u16::MAX)), "grid.res"),
    ] {
        let e = Trainer::new(cfg, support::unit_scene(), 1, 1).unwrap_err().to_string();
        assert!(e.contains(says), "{says}: {e}");
    }
}

#[test]
fn loss_falls_and_the_exported_model_renders_the_scene() {
    let d = support::TestDir::new("train-test");
    write_blender(&d, SceneSpec { size: 24, train: 12, val: 1, test: 1 }).unwrap();
    let data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    let val = load(&d, Split::Val, LoadOptions::default()).unwrap();
    let cfg = small_config().with(|c| {
        c.sampling.batch_rays = 256;
        c.optimiser.lr = 1e-2;
    });
    let mut tr = Trainer::new(cfg, data.scene, 1, 1).unwrap();
    support::train_until_the_loss_halves(&mut tr, &data);
    // checkpoints round-trip exactly
    let back = Trainer::from_bytes(&tr.to_bytes().unwrap()).unwrap();
    assert_eq!(back.field.params, tr.field.params);
    assert_eq!(back.step, tr.step);
    assert_eq!(back.scene, tr.scene);
    // the exported model renders a validation view far better than a constant
    let calib = Trainer::draw_batch(&data, 512, Draw::CENTRES, &mut Rng::new(3));
    let bytes = trainer_model(&tr, &calib, Prune::Off).to_bytes().unwrap();
    let m = Model::from_bytes(&bytes).unwrap();
    let (_, s) = score_view(&m, RenderOptions::from_model(&m), &val.views[0]).unwrap();
    let white = vec![[1.0f32; 3]; val.views[0].rgb.len()];
    let base = nerf_train::metrics::psnr(&white, &val.views[0].rgb);
    println!("validation PSNR {:.2} dB (all-white baseline {base:.2} dB)", s.psnr);
    assert!(s.psnr > base + 3.0);
}

#[test]
fn both_networks_learn_from_every_seed() {
    // Regression: a density head negative everywhere at initialisation got
    // no gradient through the compositor's ReLU and never trained.
    let d = support::TestDir::new("seeds-test");
    write_blender(&d, SceneSpec { size: 16, train: 8, val: 1, test: 1 }).unwrap();
    let data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    let cfg = small_config().with(|c| {
        c.sampling.batch_rays = 128;
        c.optimiser.lr = 1e-2;
    });
    let probe = Trainer::draw_batch(&data, 512, Draw::CENTRES, &mut Rng::new(5));
    for seed in 0..4 {
        let mut tr = Trainer::new(cfg.clone(), data.scene, 1, seed).unwrap();
        let (_, c0, f0, _) = tr.gradients(&probe, 1);
        for i in 0..60 {
            tr.train_step(&data, i as f64 / 60.0);
        }
        let (_, c1, f1, _) = tr.gradients(&probe, 1);
        println!("seed {seed}: coarse {c0:.1} -> {c1:.1}, fine {f0:.1} -> {f1:.1} (summed squared error)");
        assert!(c1 < 0.6 * c0, "seed {seed}: coarse network did not learn ({c0} -> {c1})");
        assert!(f1 < 0.6 * f0, "seed {seed}: fine network did not learn ({f0} -> {f1})");
    }
}

#[test]
fn non_finite_steps_are_skipped_and_never_reach_the_weights() {
    let d = support::TestDir::new("train-nan");
    write_blender(&d, SceneSpec { size: 16, train: 4, val: 1, test: 1 }).unwrap();
    let good = load(&d, Split::Train, LoadOptions::default()).unwrap();
    let mut bad = good.clone();
    for v in &mut bad.views {
        v.rgb.iter_mut().step_by(7).for_each(|p| *p = [f32::NAN, f32::INFINITY, 0.5]);
    }
    let cfg = small_config().with(|c| c.sampling.batch_rays = 128);
    let mut tr = Trainer::new(cfg, good.scene, 1, 2).unwrap();
    tr.train_step(&good, 0.0);
    let (params, adam_before) = (tr.field.params.clone(), tr.to_bytes().unwrap());
    for _ in 0..3 {
        let st = tr.train_step(&bad, 0.1);
        assert!(st.skipped && !st.loss.is_finite(), "{st:?}");
    }
    assert_eq!(tr.skipped, 3);
    assert_eq!(tr.field.params, params, "a skipped step changed the weights");
    // optimiser state is untouched too: only the step counter moved
    let mut back = Trainer::from_bytes(&adam_before).unwrap();
    back.step = tr.step;
    back.skipped = tr.skipped;
    assert_eq!(back.to_bytes().unwrap(), tr.to_bytes().unwrap());
    let st = tr.train_step(&good, 0.2);
    assert!(!st.skipped && st.loss.is_finite());
    assert_ne!(tr.field.params, params);
}

#[test]
fn pixels_a_mask_leaves_out_are_never_drawn_nor_scored() {
    let d = support::TestDir::new("train-mask");
    write_blender(&d, SceneSpec { size: 16, train: 4, val: 1, test: 1 }).unwrap();
    let mut data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    // every 7th pixel poisoned and masked out: a step that drew one would be skipped
    for v in &mut data.views {
        v.rgb.iter_mut().step_by(7).for_each(|p| *p = [f32::NAN, f32::INFINITY, 0.5]);
        v.mask = (0..v.rgb.len()).map(|i| i % 7 != 0).collect();
    }
    let cfg = small_config().with(|c| c.sampling.batch_rays = 512);
    let mut tr = Trainer::new(cfg, data.scene, 1, 2).unwrap();
    for k in 0..4 {
        let st = tr.train_step(&data, 0.1 * k as f64);
        assert!(!st.skipped && st.loss.is_finite(), "{st:?}");
    }
    let batch = Trainer::draw_batch(&data, 4096, Draw::CENTRES, &mut Rng::new(5));
    assert_eq!(batch.len(), 4096);
    assert!(batch.iter().all(|s| s.rgb.iter().all(|c| c.is_finite())));
    // scored on the kept pixels alone: a render equal to them where they are kept scores 100 dB
    let mut v = data.views[0].clone();
    v.rgb.iter_mut().step_by(7).for_each(|p| *p = [1.0, 0.0, 1.0]);
    let r = Rendered {
        width: v.camera.width,
        height: v.camera.height,
        rgb: v.rgb.iter().enumerate().map(|(i, p)| if v.kept(i) { *p } else { [0.0; 3] }).collect(),
        depth: vec![0.0; v.rgb.len()],
        opacity: vec![1.0; v.rgb.len()],
        secs_per_ray: 0.0,
        samples_per_ray: 0.0,
    };
    let s = score_rendered(&r, &v);
    assert_eq!(s.psnr, 100.0);
    v.mask.clear();
    assert!(score_rendered(&r, &v).psnr < 20.0);
    // with every pixel masked out, training refuses the data and says why
    for v in &mut data.views {
        v.mask.iter_mut().for_each(|k| *k = false);
    }
    let e = data.check_rays().unwrap_err().to_string();
    assert!(e.contains("masks leave 0 of"), "{e}");
}

#[test]
fn the_occupancy_grid_clears_empty_space_and_the_model_carries_it() {
    let d = support::TestDir::new("grid-test");
    write_blender(&d, SceneSpec { size: 24, train: 12, val: 1, test: 1 }).unwrap();
    let data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    let val = load(&d, Split::Val, LoadOptions::default()).unwrap();
    let cfg = small_config().with(|c| {
        c.sampling.batch_rays = 256;
        c.optimiser.lr = 1e-2;
        c.sampling.n_coarse = 48;
        c.sampling.n_fine = None;
        c.grid.res = NonZeroU16::new(16);
        c.grid.warmup = 40;
        c.grid.every = 8;
    });
    let mut tr = Trainer::new(cfg, data.scene, 1, 1).unwrap();
    let first = tr.train_step(&data, 0.0);
    assert_eq!(first.samples, first.rays * 48, "before warm-up every sample counts");
    let mut last = first;
    for i in 0..160 {
        last = tr.train_step(&data, i as f64 / 160.0);
    }
    let grid = tr.sampler.occupancy.as_ref().unwrap();
    let occ = grid.occupied_fraction();
    let per_ray = last.samples as f64 / last.rays as f64;
    println!(
        "occupied {:.1} %, {per_ray:.1} of 48 samples per ray, loss {:.4} -> {:.4}",
        100.0 * occ,
        first.loss,
        last.loss
    );
    assert!(occ > 0.01 && occ < 0.6, "occupied fraction {occ}");
    assert!(per_ray < 0.6 * 48.0, "{per_ray} samples per ray");
    assert!(last.loss < 0.5 * first.loss);
    // checkpoints keep the grid
    let back = Trainer::from_bytes(&tr.to_bytes().unwrap()).unwrap();
    assert_eq!(back.sampler.occupancy, tr.sampler.occupancy);
    // the model file carries the grid (format version 2), no second network,
    // and renders the validation view well
    let calib = Trainer::draw_batch(&data, 512, Draw::CENTRES, &mut Rng::new(3));
    let bytes = trainer_model(&tr, &calib, Prune::Off).to_bytes().unwrap();
    assert_eq!(u16::from_le_bytes([bytes[4], bytes[5]]), 2);
    let m = Model::from_bytes(&bytes).unwrap();
    assert!(m.fine.is_none());
    assert_eq!(m.grid.unwrap().bits, &grid.bits[..]);
    let (_, s) = score_view(&m, RenderOptions::from_model(&m), &val.views[0]).unwrap();
    let white = vec![[1.0f32; 3]; val.views[0].rgb.len()];
    let base = nerf_train::metrics::psnr(&white, &val.views[0].rgb);
    println!("validation PSNR {:.2} dB (all-white baseline {base:.2} dB)", s.psnr);
    assert!(s.psnr > base + 3.0);
}

#[test]
fn jittered_rays_cross_their_own_pixel_anywhere_and_unjittered_ones_its_centre() {
    let d = support::TestDir::new("jitter-test");
    write_blender(&d, SceneSpec { size: 16, train: 1, val: 1, test: 1 }).unwrap();
    let mut data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    // each pixel's colour names the pixel, so a ray can be traced back to it
    let v = &mut data.views[0];
    let w = v.camera.width as usize;
    for (k, c) in v.rgb.iter_mut().enumerate() {
        *c = [(k % w) as f32, (k / w) as f32, 0.0];
    }
    let cam = data.views[0].camera;
    // where a ray crosses the image plane, in pixels from the top-left corner
    let crossing = |s: &nerf_train::train::Sample| {
        let d = cam.rotation.transpose() * s.ray.viewdir;
        (cam.cx + cam.fx * d.x / -d.z, cam.cy - cam.fy * d.y / -d.z)
    };
    for jitter in [false, true] {
        let how = Draw { jitter, ..Draw::CENTRES };
        let batch = Trainer::draw_batch(&data, 2000, how, &mut Rng::new(11));
        let mut fracs = Vec::new();
        for s in &batch {
            let (u, v) = crossing(s);
            let (fu, fv) = (u - s.rgb[0], v - s.rgb[1]);
            assert!(
                (-1e-3..1.001).contains(&fu) && (-1e-3..1.001).contains(&fv),
                "ray at ({u}, {v}) of pixel {:?}",
                s.rgb
            );
            fracs.extend([fu, fv]);
        }
        let (lo, hi) = fracs.iter().fold((f32::MAX, f32::MIN), |(a, b), &f| (a.min(f), b.max(f)));
        if jitter {
            let mean = fracs.iter().sum::<f32>() / fracs.len() as f32;
            assert!(lo < 0.02 && hi > 0.98 && (mean - 0.5).abs() < 0.02, "offsets {lo}..{hi}, mean {mean}");
        } else {
            assert!(lo > 0.499 && hi < 0.501, "centre rays at offsets {lo}..{hi}");
        }
    }
}

/// Rays through pixel centres, a share `random` of them on a random background.
fn bg(random: f32) -> Draw {
    Draw { random_background: random, ..Draw::CENTRES }
}

#[test]
fn random_backgrounds_recomposite_a_share_of_pixels_by_their_alpha_and_leave_opaque_photos_alone() {
    let d = support::TestDir::new("bg-test");
    write_blender(&d, SceneSpec { size: 16, train: 4, val: 1, test: 1 }).unwrap();
    let data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    // the Blender renders keep their alpha: a transparent background around an opaque object
    let a = &data.views[0].alpha;
    assert_eq!(a.len(), data.views[0].rgb.len());
    assert!(a.contains(&0.0) && a.contains(&1.0), "alpha of the synthetic render: {a:?}");
    // a transparent pixel shows the ray's background, whatever it is
    let mut clear = data.clone();
    for v in &mut clear.views {
        v.alpha.fill(0.0);
        v.rgb.fill([1.0; 3]);
    }
    let batch = Trainer::draw_batch(&clear, 256, bg(1.0), &mut Rng::new(7));
    assert_eq!(batch.len(), 256);
    for s in &batch {
        assert!(s.bg.iter().all(|c| (0.0..1.0).contains(c)), "{:?}", s.bg);
        assert!((0..3).all(|c| (s.rgb[c] - s.bg[c]).abs() < 1e-6), "{:?} on {:?}", s.rgb, s.bg);
    }
    let reds: Vec<f32> = batch.iter().map(|s| s.bg[0]).collect();
    assert!(reds.iter().any(|&r| r < 0.1) && reds.iter().any(|&r| r > 0.9), "backgrounds do not vary");
    // an opaque pixel keeps its colour on any background
    let mut solid = data.clone();
    for v in &mut solid.views {
        v.alpha.fill(1.0);
        v.rgb.fill([0.25, 0.5, 0.75]);
    }
    for s in Trainer::draw_batch(&solid, 64, bg(1.0), &mut Rng::new(8)) {
        assert_eq!(s.rgb, [0.25, 0.5, 0.75]);
    }
    // without the option, or for photos without an alpha channel, rays keep the scene's white
    let mut opaque = clear.clone();
    opaque.views.iter_mut().for_each(|v| v.alpha.clear());
    for (set, random) in [(&clear, 0.0), (&opaque, 1.0)] {
        for s in Trainer::draw_batch(set, 64, bg(random), &mut Rng::new(9)) {
            assert_eq!((s.rgb, s.bg), ([1.0; 3], [1.0; 3]));
        }
    }
    // a share of the rays: about that share of transparent pixels leaves white
    let batch = Trainer::draw_batch(&clear, 4000, bg(0.25), &mut Rng::new(10));
    let random = batch.iter().filter(|s| s.bg != [1.0; 3]).count();
    assert!((900..1100).contains(&random), "{random} of 4000 rays on a random background at a share of 0.25");
    assert!(batch.iter().all(|s| s.rgb == s.bg), "a transparent pixel shows its ray's background");
}

#[test]
fn clear_opacity_is_the_rendered_opacity_over_transparent_pixels_only() {
    let d = support::TestDir::new("clear-test");
    write_blender(&d, SceneSpec { size: 16, train: 1, val: 1, test: 1 }).unwrap();
    let view = load(&d, Split::Val, LoadOptions::default()).unwrap().views.remove(0);
    let clear = view.alpha.iter().filter(|&&a| a == 0.0).count();
    assert!(clear > 0 && clear < view.alpha.len(), "the render has transparent and covered pixels");
    // haze of 0.25 on the transparent pixels, an opaque object elsewhere
    let r = Rendered {
        width: view.camera.width,
        height: view.camera.height,
        rgb: view.rgb.clone(),
        depth: vec![4.0; view.rgb.len()],
        opacity: view.alpha.iter().map(|&a| if a == 0.0 { 0.25 } else { 1.0 }).collect(),
        secs_per_ray: 0.0,
        samples_per_ray: 0.0,
    };
    assert_eq!(score_rendered(&r, &view).clear_opacity, Some(0.25));
    // photos without alpha have no transparent pixels to judge
    let opaque = View { alpha: Vec::new(), ..view };
    assert_eq!(score_rendered(&r, &opaque).clear_opacity, None);
}

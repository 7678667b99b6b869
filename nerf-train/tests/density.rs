//! The field's density on tiny data: where a fresh network starts, the
//! optical-depth penalty that empties free space, a field without density
//! growing back, an unbounded scene's thin start, gradients scaled near
//! the cameras, and samples behind an opaque stretch left out of the
//! backward pass.

mod support;

use nerf_infer::format::Scene;
use nerf_train::config::TrainConfig;
use nerf_train::dataset::synthetic::{write_blender, write_colmap, ColmapText, SceneSpec};
use nerf_train::dataset::{load, LoadOptions, Split};
use nerf_train::train::{Draw, Sample, Trainer};
use nerf_train::util::rng::Rng;
use std::num::{NonZeroU16, NonZeroU8};
use support::small_config;

/// The density at 200 random points of the normalised cube of a fresh
/// trainer of `cfg` over `scene`, of each of its networks (coarse, then
/// fine if any).
fn initial_densities(
    cfg: &nerf_train::config::TrainConfig,
    scene: nerf_infer::format::Scene,
    seed: u64,
) -> Vec<Vec<f32>> {
    densities(&Trainer::new(cfg.clone(), scene, 1, seed).unwrap(), seed)
}

/// The density at 200 random points (drawn with `seed`) of the
/// normalised cube, of each of `tr`'s networks (coarse, then fine if any).
fn densities(tr: &Trainer, seed: u64) -> Vec<Vec<f32>> {
    let mut rng = Rng::new(seed);
    let pts: Vec<[f32; 3]> = (0..200).map(|_| [0; 3].map(|_: i32| rng.f32() * 2.0 - 1.0)).collect();
    let nets = [Some(tr.coarse_params()), tr.fine_params()];
    nets.into_iter()
        .flatten()
        .map(|p| {
            let mut acts = nerf_train::mlp::Acts::default();
            tr.mlp().forward(p, &pts, &[[0.0, 0.0, 1.0]], false, &mut acts);
            acts.sigma[..pts.len()].iter().map(|s| s.max(0.0)).collect()
        })
        .collect()
}

#[test]
fn the_optical_depth_penalty_empties_the_space_the_photos_leave_free() {
    let d = support::TestDir::new("density-l1-test");
    write_blender(&d, SceneSpec { size: 16, train: 8, val: 1, test: 1 }).unwrap();
    let data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    let mean_density = |density_l1: f32| {
        let cfg = small_config().with(|c| {
            c.sampling.batch_rays = 128;
            c.optimiser.lr = 1e-2;
            c.loss.density_l1 = density_l1;
        });
        let mut tr = Trainer::new(cfg, data.scene, 1, 3).unwrap();
        let (first, last) = support::loss_before_and_after(&mut tr, &data, 80);
        let sigma = densities(&tr, 7).concat();
        let mean = sigma.iter().sum::<f32>() / sigma.len() as f32;
        println!("density_l1 {density_l1}: loss {first:.4} -> {last:.4}, mean density {mean:.3}");
        (mean, first, last)
    };
    let (free, ..) = mean_density(0.0);
    let (penalised, first, last) = mean_density(0.1);
    assert!(penalised < 0.5 * free, "mean density {penalised} with the penalty, {free} without");
    // and the colours still train
    assert!(last < 0.7 * first, "loss {first} -> {last}");
}

#[test]
fn a_field_left_without_density_anywhere_grows_back() {
    let d = support::TestDir::new("empty-field-test");
    write_blender(&d, SceneSpec { size: 16, train: 8, val: 1, test: 1 }).unwrap();
    let data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    let cfg = small_config().with(|c| {
        c.sampling.batch_rays = 128;
        c.sampling.n_fine = None;
        c.optimiser.lr = 1e-2;
    });
    let mut tr = Trainer::new(cfg, data.scene, 1, 5).unwrap();
    // as a few large first steps can leave it: σ < 0 at every point (the
    // density head's weights at zero, its bias below zero)
    let (w, b) = tr.mlp().density_head();
    tr.field.params[w].fill(0.0);
    tr.field.params[b] = -0.5;
    assert!(densities(&tr, 7).concat().iter().all(|&s| s == 0.0));
    let (first, last) = support::loss_before_and_after(&mut tr, &data, 80);
    let sigma = densities(&tr, 7).concat();
    let dense = sigma.iter().filter(|&&s| s > 0.0).count();
    println!("loss {first:.4} -> {last:.4}; {dense} of {} points with density", sigma.len());
    assert!(dense > 0 && last < 0.8 * first, "loss {first} -> {last}, {dense} points with density");
}

#[test]
fn an_unbounded_scene_starts_thin_and_even_so_light_reaches_beyond_its_bounds() {
    let bounded = nerf_infer::format::Scene::blender(1.1, 0.2, 1000.0);
    let unbounded =
        nerf_infer::format::Scene { unbounded: Some(nerf_infer::format::Unbounded { linear_until: 2.0 }), ..bounded };
    let diagonal = 2.2 * 3f32.sqrt();
    // the default (one network) and `fast` (coarse and fine)
    for cfg in [nerf_train::config::TrainConfig::default(), nerf_train::config::TrainConfig::fast()] {
        let nets = 1 + cfg.sampling.n_fine.is_some() as usize;
        for seed in 0..4 {
            let even = initial_densities(&cfg, unbounded, seed);
            let fogs = initial_densities(&cfg, bounded, seed);
            assert_eq!((even.len(), fogs.len()), (nets, nets));
            for (sigma, fog) in even.iter().zip(&fogs) {
                // the same density everywhere, whatever the seed
                assert!(sigma.iter().all(|&s| s == sigma[0]), "seed {seed}: {:?}", &sigma[..4]);
                // the bounds' diagonal absorbs under a third of the light
                let depth = sigma[0] * diagonal;
                assert!(depth > 0.0 && (-depth).exp() > 0.67, "seed {seed}: optical depth {depth}");
                // a bounded scene starts as a fog to carve (seed-dependent, dense)
                let mean = fog.iter().sum::<f32>() / fog.len() as f32;
                assert!(fog.iter().any(|&s| s != fog[0]) && mean * diagonal > 1.0, "seed {seed}: mean σ {mean}");
            }
        }
    }
}

/// The Euclidean norm of a gradient.
fn norm(g: &[f32]) -> f64 {
    g.iter().map(|&x| (x as f64).powi(2)).sum::<f64>().sqrt()
}

/// The gradient over `probe` of a fresh run (seed 3) of `cfg` on `scene`
/// with `loss.near_gradient` at `d0`, the batch in one chunk (one sum, the
/// same at every call).
fn near_gradient(cfg: &TrainConfig, scene: Scene, probe: &[Sample], d0: f32) -> Vec<f32> {
    let cfg = cfg.clone().with(|c| {
        c.sampling.chunk_rays = probe.len();
        c.loss.near_gradient = d0;
    });
    Trainer::new(cfg, scene, 1, 3).unwrap().gradients(probe, 1).0
}

#[test]
fn gradients_shrink_only_within_the_near_gradient_distance_of_the_camera() {
    let object = support::TestDir::new("near-gradient-test");
    write_blender(&object, SceneSpec { size: 16, train: 4, val: 1, test: 1 }).unwrap();
    let room = support::TestDir::new("near-gradient-room-test");
    write_colmap(&room, SceneSpec { size: 16, train: 6, val: 1, test: 0 }, ColmapText::Binary, true).unwrap();
    // an object scene's stratified samples, and an unbounded scene's placed by a proposal grid
    let one = small_config().with(|c| c.sampling.n_fine = None);
    let proposed = one.clone().with(|c| c.sampling.proposal_res = NonZeroU16::new(16));
    for (dir, cfg) in [(&object, one), (&room, proposed)] {
        let data = load(dir, Split::Train, LoadOptions::default()).unwrap();
        assert_eq!(data.scene.unbounded.is_some(), cfg.sampling.proposal_res.is_some());
        let probe = Trainer::draw_batch(&data, 256, Draw::CENTRES, &mut Rng::new(5));
        let (near, far) = (data.scene.near, data.scene.far);
        let off = near_gradient(&cfg, data.scene, &probe, 0.0);
        assert!(near > 0.0 && norm(&off) > 0.0);
        // every sample lies beyond the near plane: a distance inside it changes nothing
        assert_eq!(near_gradient(&cfg, data.scene, &probe, 0.5 * near), off);
        // a hundred times the far plane: every sample's gradient shrinks by (d/d₀)² ≤ 10⁻⁴
        let all = near_gradient(&cfg, data.scene, &probe, 100.0 * far);
        assert!(norm(&all) < 1e-2 * norm(&off), "{} against {}", norm(&all), norm(&off));
        // half way: the nearer samples shrink, the farther keep theirs
        let half = near_gradient(&cfg, data.scene, &probe, 0.5 * (near + far));
        assert!(half != off && norm(&half) > norm(&all), "{} against {}", norm(&half), norm(&all));
    }
}

#[test]
fn samples_behind_half_the_light_leave_the_backward_pass() {
    let d = support::TestDir::new("backward-transmittance-test");
    write_blender(&d, SceneSpec { size: 16, train: 8, val: 1, test: 1 }).unwrap();
    let data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    let small = TrainConfig::features().with(|c| {
        (c.model.depth, c.model.width, c.model.view_width) = (2, 32, 16);
        (c.features.levels, c.features.log2_table, c.features.max_res) = (NonZeroU8::new(4), 10, 32);
        c.sampling.n_coarse = 48;
        c.sampling.batch_rays = 128;
    });
    // a field with surfaces: 40 steps fitted to the photos
    let mut tr = Trainer::new(small.clone(), data.scene, 1, 3).unwrap();
    support::loss_before_and_after(&mut tr, &data, 40);
    let probe = Trainer::draw_batch(&data, 256, Draw::CENTRES, &mut Rng::new(5));
    // the probe in one chunk, the same field under each transmittance
    let mut gradient = |t: f32| {
        tr.cfg = small.clone().with(|c| (c.sampling.chunk_rays, c.loss.backward_transmittance) = (probe.len(), t));
        tr.gradients(&probe, 1).0
    };
    let dist = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(&x, &y)| ((x - y) as f64).powi(2)).sum::<f64>().sqrt();
    let all = gradient(0.0);
    assert!(norm(&all) > 0.0);
    assert_eq!(gradient(0.0), all);
    // the samples behind half of the light carry a share of the gradient
    let half = gradient(0.5);
    assert!(dist(&half, &all) > 1e-2 * norm(&all), "{} against {}", dist(&half, &all), norm(&all));
    // and a step leaves them out of its backward pass, beside those without gradient
    let mut keeping = tr.clone();
    keeping.cfg.loss.backward_transmittance = 0.0;
    let (cut, kept) = (tr.train_step(&data, 0.5), keeping.train_step(&data, 0.5));
    assert_eq!(cut.samples, kept.samples);
    assert!(cut.backward_samples < kept.backward_samples, "{} against {}", cut.backward_samples, kept.backward_samples);
}

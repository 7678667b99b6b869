//! The trainer's f32 forward pass (`nerf_train::mlp::Mlp::forward`) and the
//! renderer's f32 evaluation (`nerf_infer::network::Block`) of the model
//! exported from the same parameters give the same densities and colours:
//! the network, the encoding and the feature grid are one function in both
//! crates. They differ only by the order of each layer's sums (the
//! trainer's matrix products against the renderer's register tiles), so
//! the bound is a few f32 roundings of the largest term.

mod support;

use nerf_infer::format::Scheme;
use nerf_infer::network::{BlockF32, F32};
use nerf_infer::Model;
use nerf_train::config::TrainConfig;
use nerf_train::export::{trainer_model, Prune};
use nerf_train::mlp::Acts;
use nerf_train::path::orbit_rays;
use nerf_train::train::Trainer;
use support::unit_scene;

/// Largest |trainer − renderer| over positions on and around the scene
/// box and three view directions, for densities and for colours, with the
/// largest |density| seen.
fn differences(cfg: TrainConfig, seed: u64) -> (f32, f32, f32) {
    let scene = unit_scene();
    let tr = Trainer::new(cfg, scene, 1, seed).unwrap();
    let owned = trainer_model(&tr, &orbit_rays(&scene, 2, 6), Prune::Off);
    let bytes = owned.to_bytes().unwrap();
    let model = Model::from_bytes(&bytes).unwrap();
    assert_eq!(model.scheme(), Scheme::F32);
    let (mlp, params) = (tr.mlp(), tr.coarse_params());
    let net = &model.coarse;
    let mut block = Box::<BlockF32<8>>::default();
    let mut acts = Acts::default();
    let (mut d_sigma, mut d_rgb, mut sigma_max) = (0f32, 0f32, 0f32);
    for (r, dir) in [[0.0f32, 0.6, -0.8], [1.0, 0.0, 0.0], [-0.36, 0.48, 0.8]].into_iter().enumerate() {
        // 8 samples of one ray: normalised positions across [-1.2, 1.2]³
        let pos: Vec<[f32; 3]> = (0..8)
            .map(|k| {
                let u = (k as f32 + 0.5) / 8.0 * 2.4 - 1.2;
                [u, 0.7 * u.sin() + 0.1 * r as f32, 0.5 - u * 0.3]
            })
            .collect();
        mlp.forward(params, &pos, &[dir], true, &mut acts);
        block.prepare_ray::<F32>(&model, net, dir);
        block.eval_density::<F32>(&model, net, &pos, false);
        block.eval_colour::<F32>(&model, net, &(0..8).collect::<Vec<_>>());
        for k in 0..8 {
            sigma_max = sigma_max.max(acts.sigma[k].abs());
            d_sigma = d_sigma.max((acts.sigma[k] - block.sigma[k]).abs());
            for c in 0..3 {
                d_rgb = d_rgb.max((acts.rgb[3 * k + c] - block.rgb[k][c]).abs());
            }
        }
    }
    (d_sigma, d_rgb, sigma_max)
}

#[test]
fn the_trainers_forward_is_the_renderers_f32_evaluation() {
    let configs = [
        ("fast (frequency encoding, view branch)", TrainConfig::fast()),
        ("features (feature grid, 2x64)", TrainConfig::features()),
        ("grid (occupancy grid, 4x64)", TrainConfig::grid()),
    ];
    for (name, cfg) in configs {
        for seed in [1, 2] {
            let (ds, drgb, smax) = differences(cfg.clone(), seed);
            eprintln!("{name} seed {seed}: |Δσ| {ds:.2e} of |σ| up to {smax:.2}, |Δrgb| {drgb:.2e}");
            assert!(smax > 0.01, "{name}: densities to compare");
            assert!(ds <= 1e-5 * smax.max(1.0), "{name} seed {seed}: density differs by {ds} (|σ| up to {smax})");
            assert!(drgb <= 1e-6, "{name} seed {seed}: colour differs by {drgb}");
        }
    }
}

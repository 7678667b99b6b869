//! Each fixed-point stage against the f32 path, with stated tolerances:
//! encoding (in nerf-infer's unit tests), the MLP (one layer and whole)
//! and full rays, including edge cases; alpha and transmittance are
//! nerf-infer's own tests (`nerf-infer/tests/compositing.rs`).

mod support;

use nerf_infer::encoding::NPOS_FRAC;
use nerf_infer::format::Scheme;
use nerf_infer::network::{BlockF32, BlockFixed, F32, W16, W8};
use nerf_infer::Orbit;
use nerf_infer::{Model, RayRenderer, RenderOptions, RendererF32, RendererFixed, ScratchF32, ScratchFixed};
use nerf_train::config::TrainConfig;
use nerf_train::export::{quantise, quantise_with, random_model, ActBits, Quantisation};
use support::*;

/// Tolerance tiers, in the units of each stage's output.
mod tol {
    /// Density σ: relative to the largest |σ| seen, plus two Q10 steps.
    pub const SIGMA_REL: f32 = 0.01;
    /// Colour after the sigmoid: absolute.
    pub const RGB: f32 = 4e-3;
}

fn models(cfg: &TrainConfig, seed: u64) -> (Vec<u8>, Vec<u8>, Vec<u8>) {
    let f = random_model(cfg, unit_scene(), seed, 6.0).unwrap().to_bytes().unwrap();
    let (q16, q8) = {
        let m = Model::from_bytes(&f).unwrap();
        (quantise(&m, Scheme::I16).unwrap().to_bytes().unwrap(), quantise(&m, Scheme::I8).unwrap().to_bytes().unwrap())
    };
    (f, q16, q8)
}

/// Positions exactly representable in Q24, inside and around the bounds.
fn positions(n: usize, seed: u32) -> Vec<[i32; 3]> {
    (0..n as u32)
        .map(|i| {
            let h = |k: u32| nerf_infer::sampling::hash32(seed ^ (i * 3 + k));
            std::array::from_fn(|c| ((h(c as u32) as i32) >> 6).clamp(-(3 << 23), 3 << 23))
        })
        .collect()
}

fn compare_mlp(cfg: &TrainConfig, scheme: Scheme, sigma_tol: f32, rgb_tol: f32) {
    let f = random_model(cfg, unit_scene(), 11, 6.0).unwrap().to_bytes().unwrap();
    let q = quantise(&Model::from_bytes(&f).unwrap(), scheme).unwrap().to_bytes().unwrap();
    let (mf, mq) = (Model::from_bytes(&f).unwrap(), Model::from_bytes(&q).unwrap());
    let mut bf = Box::<BlockF32<8>>::default();
    let mut bq = Box::<BlockFixed<8>>::default();
    let dir = [0.0f32, 0.6, -0.8];
    let dir_q = dir.map(|v| (v * (1 << NPOS_FRAC) as f32).round() as i32);
    let (nf, nq) = (mf.final_network(), mq.final_network());
    bf.prepare_ray::<F32>(
        &mf,
        nf,
        [dir_q[0] as f32 / 16777216.0, dir_q[1] as f32 / 16777216.0, dir_q[2] as f32 / 16777216.0],
    );
    let mut sig_max = 0.0f32;
    let mut errs = (0.0f32, 0.0f32);
    for chunk in positions(400, 5).chunks(8) {
        let pf: Vec<[f32; 3]> = chunk.iter().map(|p| p.map(|v| v as f32 / (1 << NPOS_FRAC) as f32)).collect();
        let all: Vec<usize> = (0..chunk.len()).collect();
        bf.eval_density::<F32>(&mf, nf, &pf, false);
        bf.eval_colour::<F32>(&mf, nf, &all);
        match scheme {
            Scheme::I16 => {
                bq.prepare_ray::<W16>(&mq, nq, dir_q);
                bq.eval_density::<W16>(&mq, nq, chunk, false);
                bq.eval_colour::<W16>(&mq, nq, &all);
            }
            _ => {
                bq.prepare_ray::<W8>(&mq, nq, dir_q);
                bq.eval_density::<W8>(&mq, nq, chunk, false);
                bq.eval_colour::<W8>(&mq, nq, &all);
            }
        }
        for k in 0..chunk.len() {
            sig_max = sig_max.max(bf.sigma[k].abs());
            errs.0 = errs.0.max((bf.sigma[k] - bq.sigma[k] as f32 / 1024.0).abs());
            for c in 0..3 {
                errs.1 = errs.1.max((bf.rgb[k][c] - bq.rgb[k][c] as f32 / 32768.0).abs());
            }
        }
    }
    println!(
        "{scheme:?} {}x{}: max |Δσ| = {:.4} (max |σ| {sig_max:.2}), max |Δrgb| = {:.5}",
        cfg.model.depth, cfg.model.width, errs.0, errs.1
    );
    assert!(sig_max > 1.0, "test model has no density");
    assert!(errs.0 <= sigma_tol * sig_max + 2.0 / 1024.0, "σ error {} over {}·{sig_max}", errs.0, sigma_tol);
    assert!(errs.1 <= rgb_tol, "colour error {} over {rgb_tol}", errs.1);
}

#[test]
fn one_dense_layer_then_heads_int16() {
    // depth 1: a single hidden layer between the encoding and the heads
    let cfg = small_config().with(|c| {
        c.model.depth = 1;
        c.model.width = 48;
        c.model.skips = vec![];
        c.model.view_dependent = false;
        c.sampling.n_fine = None;
    });
    compare_mlp(&cfg, Scheme::I16, tol::SIGMA_REL, tol::RGB);
}

#[test]
fn whole_mlp_int16_small_and_fast_preset() {
    compare_mlp(&small_config(), Scheme::I16, tol::SIGMA_REL, tol::RGB);
    compare_mlp(&TrainConfig::fast(), Scheme::I16, tol::SIGMA_REL, tol::RGB);
}

#[test]
fn whole_mlp_int8_within_its_own_tier() {
    // int8 weights: one weight step is 1/127 of a channel's range.
    compare_mlp(&small_config(), Scheme::I8, 0.08, 0.04);
}

#[test]
fn activation_width_must_fit_the_scheme() {
    let f = random_model(&small_config(), unit_scene(), 3, 6.0).unwrap().to_bytes().unwrap();
    let mf = Model::from_bytes(&f).unwrap();
    assert!(quantise_with(&mf, &Quantisation::new(Scheme::I16).with_act_bits(ActBits::A8)).is_err());
    // a model claiming 8-bit activations with int16 weights is refused
    let mut m16 = quantise_with(&mf, &Quantisation::new(Scheme::I16)).unwrap();
    m16.coarse.act_bits = 8;
    assert_eq!(m16.to_bytes().unwrap_err(), nerf_infer::Error::InvalidTopology("unsupported activation width"));
    let m8 = quantise_with(&mf, &Quantisation::new(Scheme::I8).with_act_bits(ActBits::A8)).unwrap().to_bytes().unwrap();
    assert_eq!(Model::from_bytes(&m8).unwrap().coarse.act_bits, 8);
}

#[test]
fn full_rays_fixed_against_f32_and_degenerate_rays() {
    let (f, q16, _) = models(&small_config(), 3);
    let (mf, mq) = (Model::from_bytes(&f).unwrap(), Model::from_bytes(&q16).unwrap());
    let rf = RendererF32::new(&mf, RenderOptions::from_model(&mf)).unwrap();
    let rq = RendererFixed::new(&mq, RenderOptions::from_model(&mq)).unwrap();
    let (mut sf, mut sq) = (Box::<ScratchF32>::default(), Box::<ScratchFixed>::default());
    let cam = Orbit::new(&mf.scene, None).camera(0.3, 24, 24).unwrap();
    let mut worst = 0.0f32;
    for y in 0..24 {
        for x in 0..24 {
            let (o, d) = cam.ray(x, y);
            let a = rf.render_ray(o, d, (x, y), &mut sf);
            let b = rq.render_ray(o, d, (x, y), &mut sq).to_pixel();
            for c in 0..3 {
                worst = worst.max((a.rgb[c] - b.rgb[c]).abs());
            }
            assert!((mf.scene.near..=mf.scene.far).contains(&b.depth));
        }
    }
    println!("worst |Δrgb| over a 24×24 view: {worst:.5}");
    assert!(worst < 0.02);
    // degenerate rays render as background at far, in both paths
    for (o, d) in [
        (glam::Vec3::ZERO, glam::Vec3::ZERO),
        (glam::Vec3::NAN, glam::Vec3::X),
        (glam::Vec3::ZERO, glam::Vec3::new(f32::INFINITY, 0.0, 0.0)),
    ] {
        let a = rf.render_ray(o, d, (0, 0), &mut sf);
        let b = rq.render_ray(o, d, (0, 0), &mut sq).to_pixel();
        assert_eq!((a.rgb, a.opacity, a.depth), ([1.0; 3], 0.0, mf.scene.far));
        assert_eq!((b.rgb, b.opacity, b.depth), ([1.0; 3], 0.0, mf.scene.far));
    }
}

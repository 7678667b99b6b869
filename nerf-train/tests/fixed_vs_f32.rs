//! The fixed-point path against the f32 reference on whole renders.

mod support;

use nerf_infer::Orbit;
use nerf_infer::{Model, Scheme};
use nerf_train::export::{quantise, random_model};
use support::*;

#[test]
fn int16_render_of_a_random_model_is_within_40_db_of_f32() {
    for (seed, cfg) in [(1, small_config()), (2, nerf_train::config::TrainConfig::fast())] {
        let f32_bytes = random_model(&cfg, unit_scene(), seed, 8.0).unwrap().to_bytes().unwrap();
        let m32 = Model::from_bytes(&f32_bytes).unwrap();
        let q_bytes = quantise(&m32, Scheme::I16).unwrap().to_bytes().unwrap();
        let m16 = Model::from_bytes(&q_bytes).unwrap();
        for turn in [0.1, 0.6] {
            let cam = Orbit::new(&m32.scene, None).camera(turn, 32, 32).unwrap();
            let a = render(&m32, &cam);
            let b = render(&m16, &cam);
            let mean: f64 = a.iter().map(|c| c[0] as f64).sum::<f64>() / a.len() as f64;
            let var: f64 = a.iter().map(|c| (c[0] as f64 - mean).powi(2)).sum::<f64>() / a.len() as f64;
            println!("mean {mean:.3} std {:.3}", var.sqrt());
            assert!(var.sqrt() > 0.05, "the random model renders a flat image");
            let p = psnr(&a, &b);
            println!("seed {seed} view {turn}: PSNR(int16 fixed vs f32) = {p:.2} dB");
            assert!(p >= 40.0, "PSNR {p:.2} dB < 40 dB");
        }
    }
}

/// An unbounded scene: rays run past the bounds to `far`, positions are
/// contracted into the grid and samples spaced out with distance; the
/// fixed-point path contracts and spaces them in integers and stays as
/// close to f32 as in a bounded scene.
#[test]
fn int16_render_of_an_unbounded_random_model_is_within_40_db_of_f32() {
    let unbounded = Some(nerf_infer::format::Unbounded { linear_until: 5.0 });
    let scene =
        nerf_infer::format::Scene { near: 0.5, far: 5000.0, white_background: false, unbounded, ..unit_scene() };
    let bounded = nerf_infer::format::Scene { near: 0.5, far: 6.0, white_background: false, ..unit_scene() };
    for seed in [3, 4] {
        let f32_bytes = random_model(&small_config(), scene, seed, 8.0).unwrap().to_bytes().unwrap();
        let m32 = Model::from_bytes(&f32_bytes).unwrap();
        assert_eq!(m32.format_version(), 5);
        let q_bytes = quantise(&m32, Scheme::I16).unwrap().to_bytes().unwrap();
        let m16 = Model::from_bytes(&q_bytes).unwrap();
        let b_bytes = random_model(&small_config(), bounded, seed, 8.0).unwrap().to_bytes().unwrap();
        let mb = Model::from_bytes(&b_bytes).unwrap();
        for turn in [0.2, 0.7] {
            let cam = Orbit::new(&m32.scene, None).camera(turn, 32, 32).unwrap();
            let (a, b) = (render(&m32, &cam), render(&m16, &cam));
            let p = psnr(&a, &b);
            println!("seed {seed} view {turn}: PSNR(int16 fixed vs f32) = {p:.2} dB");
            assert!(p >= 40.0, "PSNR {p:.2} dB < 40 dB");
            // the same weights in the bounded scene see other positions
            let other = psnr(&a, &render(&mb, &cam));
            assert!(other < 30.0, "contraction changed little: {other:.2} dB");
        }
    }
}

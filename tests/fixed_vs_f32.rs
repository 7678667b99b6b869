//! The fixed-point path against the f32 reference on whole renders.

mod support;

use nerf_infer::{Model, Scheme};
use nerf_train::export::{orbit_camera, quantise, random_model};
use support::*;

#[test]
fn int16_render_of_a_random_model_is_within_40_db_of_f32() {
    for (seed, cfg) in [(1, small_config()), (2, nerf_train::config::TrainConfig::fast())] {
        let f32_bytes = random_model(&cfg, unit_scene(), seed, 8.0).to_bytes().unwrap();
        let m32 = Model::from_bytes(&f32_bytes).unwrap();
        let q_bytes = quantise(&m32, Scheme::I16).unwrap().to_bytes().unwrap();
        let m16 = Model::from_bytes(&q_bytes).unwrap();
        for turn in [0.1, 0.6] {
            let cam = orbit_camera(&m32.scene, turn, 32, 32);
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

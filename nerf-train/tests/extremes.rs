//! Numerical extremes, both numeric paths: models whose density is zero,
//! huge or negative everywhere, whose weights are all zero or at the ends of
//! their type, scenes with a tiny or a very long depth range, and hostile
//! rays (axis-parallel, grazing a bounding plane or edge, starting inside
//! the bounds, far outside, tiny or huge directions, NaN and infinities).
//! Every render must be finite with colour and opacity in [0, 1] and depth
//! in [near, far] (far for an empty ray), or the model/options must be
//! refused with a typed error. The compositor's, the encoding's, the
//! samplers', the scene's and the camera's own extremes are nerf-infer's
//! tests (`nerf-infer/tests/compositing.rs`, `entry_points.rs`).

mod support;

use glam::Vec3;
use nerf_infer::format::{Scene, Scheme};
use nerf_infer::sampling::hash32;
use nerf_infer::Orbit;
use nerf_infer::{Error, Model, Pixel, RayRenderer, RenderOptions, RendererF32, RendererFixed};
use nerf_infer::{ScratchF32, ScratchFixed};
use nerf_train::config::TrainConfig;
use nerf_train::export::{quantise, quantise_with, random_model, ActBits, OwnedModel, Quantisation};
use std::num::NonZeroU8;
use support::{small_config, unit_scene};

/// What a model's weights are set to after random initialisation.
#[derive(Clone, Copy, Debug)]
enum Weights {
    /// He-uniform random weights, as trained models look.
    Random,
    /// Density head bias `b` (the rest random): 0-ish, huge or negative σ.
    SigmaBias(f32),
    /// Every weight and bias zero.
    AllZero,
    /// Every weight ±`w`, signs pseudo-random, and bias 0: for large `w`
    /// activations overflow to ±∞ and meet (∞ − ∞ = NaN).
    Every(f32),
}

fn sigma_layer(m: &OwnedModel) -> usize {
    m.topology.depth as usize
}

fn set_f32(bytes: &mut [u8], v: f32) {
    for c in bytes.chunks_exact_mut(4) {
        c.copy_from_slice(&v.to_le_bytes());
    }
}

/// An f32 model with `weights` applied to both networks.
fn f32_model(cfg: &TrainConfig, scene: Scene, weights: Weights) -> OwnedModel {
    let mut m = random_model(cfg, scene, 5, 4.0).unwrap();
    let si = sigma_layer(&m);
    for net in std::iter::once(&mut m.coarse).chain(m.fine.as_mut()) {
        for (i, l) in net.layers.iter_mut().enumerate() {
            match weights {
                Weights::Random => {}
                Weights::SigmaBias(b) if i == si => {
                    set_f32(&mut l.bias, b);
                    l.act_max = l.act_max.max(b.abs());
                }
                Weights::SigmaBias(_) => {}
                Weights::AllZero => {
                    set_f32(&mut l.weights, 0.0);
                    set_f32(&mut l.bias, 0.0);
                }
                Weights::Every(w) => {
                    for (k, c) in l.weights.chunks_exact_mut(4).enumerate() {
                        c.copy_from_slice(&if hash32(k as u32) & 1 == 0 { w } else { -w }.to_le_bytes());
                    }
                    set_f32(&mut l.bias, 0.0);
                    l.act_max = 1e4;
                }
            }
        }
    }
    // a feature grid's table takes the same extremes as the weights
    if let (Some((_, table)), Weights::Every(w)) = (m.features.as_mut(), weights) {
        for (k, c) in table.chunks_exact_mut(4).enumerate() {
            c.copy_from_slice(&if hash32(k as u32 ^ 0xF) & 1 == 0 { w } else { -w }.to_le_bytes());
        }
    }
    m
}

/// Overwrites every weight of a quantised model with the largest (`max`)
/// or smallest value of its integer type.
fn saturate_weights(m: &mut OwnedModel, max: bool) {
    for net in std::iter::once(&mut m.coarse).chain(m.fine.as_mut()) {
        let pattern: &[u8] = match (net.scheme, max) {
            (Scheme::I8, true) => &[0x7F],
            (Scheme::I8, false) => &[0x80],
            (_, true) => &[0xFF, 0x7F],
            (_, false) => &[0x00, 0x80],
        };
        for l in &mut net.layers {
            for c in l.weights.chunks_exact_mut(pattern.len()) {
                c.copy_from_slice(pattern);
            }
        }
    }
}

/// Rays in world space for `scene`: camera rays and hostile ones.
fn rays(scene: &Scene) -> Vec<(Vec3, Vec3)> {
    let lo = Vec3::from(scene.bounds_min);
    let hi = Vec3::from(scene.bounds_max);
    let c = 0.5 * (lo + hi);
    let h = 0.5 * (hi - lo);
    let back = c + Vec3::new(0.0, 0.0, h.z + 0.5 * (scene.near + scene.far));
    let cam = Orbit::new(scene, None).camera(0.1, 5, 5).unwrap();
    let mut out: Vec<_> = [(0, 0), (2, 2), (4, 1)].iter().map(|&(x, y)| cam.ray(x, y)).collect();
    out.extend([
        (c, Vec3::X),                                           // from the centre, inside the bounds
        (c + 0.5 * h, Vec3::new(1.0, 1.0, 1.0)),                // inside, diagonal
        (back, Vec3::NEG_Z),                                    // axis-parallel through the middle
        (back + Vec3::new(h.x, 0.0, 0.0), Vec3::NEG_Z),         // in the bounding plane x = max
        (back + Vec3::new(-h.x, -h.y, 0.0), Vec3::NEG_Z),       // along an edge of the bounds
        (back + Vec3::new(h.x, h.y, 0.0) * 0.999, Vec3::NEG_Z), // just inside a corner column
        (back + Vec3::new(0.0, 3.0 * h.y, 0.0), Vec3::NEG_Z),   // misses
        (c + Vec3::new(1e6, 0.0, 0.0), Vec3::NEG_X),            // origin far outside
        (back, Vec3::new(1e-30, 0.0, -1e-30)),                  // tiny direction
        (back, Vec3::new(1e30, 1e30, -1e30)),                   // huge direction
        (back, Vec3::new(f32::MIN_POSITIVE, 0.0, -1.0)),        // subnormal-adjacent component
        (Vec3::NAN, Vec3::NEG_Z),
        (back, Vec3::new(0.0, f32::NAN, -1.0)),
        (back, Vec3::new(0.0, 0.0, f32::NEG_INFINITY)),
        (Vec3::splat(f32::INFINITY), Vec3::NEG_ONE),
        (back, Vec3::ZERO),
    ]);
    out
}

fn option_sets(m: &Model<'_>) -> Vec<RenderOptions> {
    let fine = |n: usize| if m.fine.is_some() { n } else { 0 };
    vec![
        RenderOptions::from_model(m),
        RenderOptions { coarse: 2, fine: 0, early_stop: 0.0, seed: None },
        RenderOptions { coarse: 256, fine: fine(256), early_stop: 0.0, seed: Some(3) },
        RenderOptions { coarse: nerf_infer::format::MAX_MARCH, fine: 0, early_stop: 0.0, seed: Some(5) },
        RenderOptions { coarse: 3, fine: fine(1), early_stop: 0.999, seed: Some(u32::MAX) },
    ]
}

fn check_pixel(p: Pixel, scene: &Scene, what: &str) {
    let unit = |v: f32| (0.0..=1.0).contains(&v);
    assert!(p.rgb.iter().all(|&c| unit(c)) && unit(p.opacity), "{what}: {p:?}");
    // depth is the expected t over the samples: within [near, far]; the
    // fixed path's Q16 rounding may put it one step outside near.
    let slack = 2.0 / 65536.0;
    assert!(p.depth >= scene.near - slack && p.depth <= scene.far + slack, "{what}: depth out of range: {p:?}");
    if p.opacity == 0.0 {
        assert!((p.depth - scene.far).abs() <= slack, "{what}: an empty ray has depth far: {p:?}");
        let bg = scene.background();
        assert!(
            p.rgb.iter().all(|c| (c - bg).abs() <= 1.0 / 32768.0),
            "{what}: an empty ray shows the background: {p:?}"
        );
    }
}

/// Renders every ray with every option set on `bytes`' numeric path;
/// returns how many renders ran (0 if the model was refused).
fn render_all(bytes: &[u8], what: &str) -> usize {
    let m = match Model::from_bytes(bytes) {
        Ok(m) => m,
        Err(e) => panic!("{what}: a valid model was refused: {e}"),
    };
    let mut n = 0;
    let (mut sf, mut sq) = (Box::<ScratchF32<3>>::default(), Box::<ScratchFixed<3>>::default());
    for opts in option_sets(&m) {
        for (k, (o, d)) in rays(&m.scene).into_iter().enumerate() {
            let pixel = (k as u32, 7);
            let p = if m.scheme() == Scheme::F32 {
                RendererF32::new(&m, opts).unwrap().render_ray(o, d, pixel, &mut sf)
            } else {
                match RendererFixed::new(&m, opts) {
                    Ok(r) => r.render_ray(o, d, pixel, &mut sq).to_pixel(),
                    // int8 weights at their extremes may not fit the i32
                    // accumulator: the renderer proves headroom or refuses.
                    Err(Error::InvalidScale(_)) => return 0,
                    Err(e) => panic!("{what}: {e}"),
                }
            };
            check_pixel(p, &m.scene, &format!("{what}, {opts:?}, ray {k} ({o}, {d})"));
            n += 1;
        }
    }
    n
}

fn scenes() -> Vec<(&'static str, Scene)> {
    let unit = unit_scene();
    vec![
        ("unit", unit),
        // far at the fixed-point range limit, camera-to-bounds distance large
        ("long", Scene { near: 0.0, far: 30000.0, ..unit }),
        // a tiny scene: normalisation scales positions by 10^3
        ("tiny", Scene { bounds_min: [-1e-3; 3], bounds_max: [1e-3; 3], near: 1e-3, far: 2e-2, ..unit }),
        ("black", Scene { white_background: false, ..unit }),
    ]
}

fn feature_grid_config() -> TrainConfig {
    // a learned feature grid: 3 levels (dense, dense, hashed) beside γ(x)
    small_config().with(|c| {
        c.sampling.n_fine = None;
        c.features.levels = NonZeroU8::new(3);
        c.features.log2_table = 9;
        c.features.min_res = 2;
        c.features.max_res = 40;
    })
}

fn high_freq_config() -> TrainConfig {
    // the highest frequencies the format allows, no view branch
    small_config().with(|c| {
        c.model.pos_freqs = 16;
        c.model.dir_freqs = 16;
        c.model.view_dependent = false;
        c.sampling.n_fine = None;
    })
}

#[test]
fn extreme_densities_and_weights_render_in_range_on_both_paths() {
    let variants = [
        Weights::Random,
        Weights::SigmaBias(-1e6), // negative raw density everywhere: empty
        Weights::SigmaBias(1e6),  // huge density everywhere: opaque at the first sample
        Weights::AllZero,         // σ = 0 everywhere, colour 0.5
        Weights::Every(1e30),
        Weights::Every(-3e38),
    ];
    let mut renders = 0;
    let configs = [("small", small_config()), ("L=16", high_freq_config()), ("features", feature_grid_config())];
    for (cfg_name, cfg) in configs {
        for (scene_name, scene) in scenes() {
            for w in variants {
                let what = format!("{cfg_name} {scene_name} {w:?}");
                let f = f32_model(&cfg, scene, w).to_bytes().unwrap();
                renders += render_all(&f, &format!("{what} f32"));
                let mf = Model::from_bytes(&f).unwrap();
                for (scheme, act_bits) in
                    [(Scheme::I16, ActBits::A16), (Scheme::I8, ActBits::A16), (Scheme::I8, ActBits::A8)]
                {
                    match quantise_with(&mf, &Quantisation::new(scheme).with_act_bits(act_bits)) {
                        Ok(q) => {
                            renders +=
                                render_all(&q.to_bytes().unwrap(), &format!("{what} {scheme:?}/{}", act_bits.bits()))
                        }
                        // weights beyond any scale the format can hold are refused at export
                        Err(e) => assert!(matches!(w, Weights::Every(_)), "{what} {scheme:?}: {e}"),
                    }
                }
            }
        }
    }
    println!("{renders} renders in range");
    assert!(renders > 3000);
}

#[test]
fn integer_weights_at_the_ends_of_their_type_saturate_or_are_refused() {
    let f = f32_model(&small_config(), unit_scene(), Weights::Random).to_bytes().unwrap();
    let mf = Model::from_bytes(&f).unwrap();
    let mut rendered = Vec::new();
    for scheme in [Scheme::I16, Scheme::I8] {
        for max in [true, false] {
            let mut q = quantise(&mf, scheme).unwrap();
            saturate_weights(&mut q, max);
            let n =
                render_all(&q.to_bytes().unwrap(), &format!("{scheme:?} weights all {}", ["min", "max"][max as usize]));
            rendered.push((scheme, max, n));
        }
    }
    println!("{rendered:?}");
    // int16 weights accumulate in i64 and always render
    assert!(rendered.iter().filter(|r| r.0 == Scheme::I16).all(|r| r.2 > 0));
}

#[test]
fn huge_density_is_opaque_at_the_first_sample_and_negative_density_is_empty() {
    let scene = unit_scene();
    let cfg = small_config().with(|c| c.sampling.n_fine = None);
    let (o, d) = (Vec3::new(0.0, 0.0, 4.0), Vec3::NEG_Z); // enters the bounds at t = 3
    for (bias, opaque) in [(1e6f32, true), (-1e6, false)] {
        let f = f32_model(&cfg, scene, Weights::SigmaBias(bias)).to_bytes().unwrap();
        let mf = Model::from_bytes(&f).unwrap();
        let q = quantise(&mf, Scheme::I16).unwrap().to_bytes().unwrap();
        let mq = Model::from_bytes(&q).unwrap();
        let pf = RendererF32::new(&mf, RenderOptions::from_model(&mf)).unwrap().render_ray(
            o,
            d,
            (0, 0),
            &mut Box::<ScratchF32>::default(),
        );
        let pq = RendererFixed::new(&mq, RenderOptions::from_model(&mq))
            .unwrap()
            .render_ray(o, d, (0, 0), &mut Box::<ScratchFixed>::default())
            .to_pixel();
        for p in [pf, pq] {
            if opaque {
                assert_eq!(p.opacity, 1.0, "{p:?}");
                assert!((p.depth - 3.0).abs() < 1e-3, "first sample at the bounds' entry: {p:?}");
            } else {
                assert_eq!((p.opacity, p.rgb, p.depth), (0.0, [1.0; 3], scene.far), "{p:?}");
            }
        }
    }
}

//! f32 export: a trained run's networks, grids and calibration as an f32
//! model, and random models for benchmarks and tests.

use super::*;

pub(super) fn f32_bytes(v: impl IntoIterator<Item = f32>) -> Vec<u8> {
    v.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// The f32 network of a parameter vector laid out by `mlp`.
pub fn f32_network(mlp: &Mlp, params: &[f32], act_max: &[f32]) -> OwnedNetwork {
    let layers = mlp
        .slots
        .iter()
        .enumerate()
        .map(|(i, s)| OwnedLayer {
            in_dim: s.din as u16,
            out_dim: s.dout as u16,
            act_max: act_max.get(i).copied().unwrap_or(0.0),
            weights: f32_bytes(params[s.w..s.b].iter().copied()),
            bias: f32_bytes(params[s.b..s.b + s.dout].iter().copied()),
            scales: Vec::new(),
            requant: Vec::new(),
        })
        .collect();
    OwnedNetwork { scheme: Scheme::F32, act_bits: 32, layers, precise: None }
}

/// Fractional bits for raw coordinates whose magnitude reaches `max_abs`
/// (with 5 % headroom), in `0..=14`.
pub fn raw_frac_bits_for(max_abs: f32) -> u8 {
    frac_bits_for(max_abs, 14)
}

/// Most fractional bits (≤ `cap`) that keep `max_abs` (with 5 % headroom)
/// inside i16.
pub(super) fn frac_bits_for(max_abs: f32, cap: u8) -> u8 {
    let m = (max_abs.abs() * 1.05).max(1e-3) as f64;
    (32767.0 / m).log2().floor().clamp(0.0, cap as f64) as u8
}

/// The f32 model of a run (of its parameters' average when it keeps one,
/// [`Trainer::averaged`]), with activation ranges from `calibration` rays
/// (drawn from the training views).
/// `prune` says which never-active neurons are removed (see [`Prune`]).
pub fn trainer_model(tr: &Trainer, calibration: &[crate::train::Sample], prune: Prune) -> OwnedModel {
    let tr = &*tr.averaged();
    let mlp = tr.mlp();
    let cal = tr.calibrate(calibration);
    let mut encoding = tr.cfg.encoding();
    encoding.raw_frac_bits = raw_frac_bits_for(cal.max_pos);
    let t = tr.cfg.topology();
    let coarse = f32_network(mlp, tr.coarse_params(), &cal.max_c);
    let coarse = prune_network(&t, &encoding, &coarse, &cal.active_c, prune);
    let fine = tr.fine_params().map(|p| {
        let net = f32_network(mlp, p, cal.max_f.as_deref().unwrap_or(&[]));
        prune_network(&t, &encoding, &net, cal.active_f.as_deref().unwrap_or(&[]), prune)
    });
    OwnedModel {
        scene: tr.scene,
        encoding,
        topology: t,
        samples: tr.cfg.samples(),
        meta: Meta { train_downscale: tr.downscale as u16, iterations: tr.step as u32 },
        coarse,
        fine,
        grid: tr.sampler.occupancy.as_ref().map(|g| (g.res, g.bits.clone())),
        features: mlp
            .features
            .as_ref()
            .map(|f| (f.clone(), f32_bytes(tr.field.params[mlp.table..mlp.n_params].iter().copied()))),
        capture: None,
        narrow: None,
        orbit: None,
        footprint: tr.footprint().filter(|_| tr.scene.ndc.is_none()),
        proposal: tr.sampler.proposal.as_ref().map(|g| {
            let (log_min, log_step, codes) = g.codes();
            (format::Proposal { res: g.res, log_min, log_step, codes: &[] }, codes)
        }),
    }
}

/// A model with random weights for tests and benchmarks: He-uniform
/// weights (PyTorch's default scaled by √6, so activations keep their
/// magnitude through the layers and the image has structure), the density
/// head further scaled by `sigma_gain`; activation ranges calibrated on
/// rays of an orbit around the scene (twice those with a feature grid,
/// whose random table is noise); feature-grid values uniform in ±0.5.
/// Fails, naming the field, if `cfg` does not pass
/// [`TrainConfig::validate`](crate::config::TrainConfig::validate).
pub fn random_model(
    cfg: &crate::config::TrainConfig,
    scene: Scene,
    seed: u64,
    sigma_gain: f32,
) -> crate::error::Result<OwnedModel> {
    let mut tr = Trainer::new(cfg.clone(), scene, 1, seed)?;
    let mlp = tr.mlp().clone();
    let si = sigma_layer(&mlp.topo);
    let nets = if cfg.sampling.n_fine.is_some() { 2 } else { 1 };
    for k in 0..nets {
        let off = k * mlp.n_params;
        // the random density head of every scene (an unbounded scene's
        // trainer starts with an even density, no head to scale)
        let init = mlp.init(crate::train::network_seed(seed, k));
        tr.field.params[off..off + mlp.n_params].copy_from_slice(&init);
        for (i, s) in mlp.slots.iter().enumerate() {
            let gain = if i == si { 6f32.sqrt() * sigma_gain } else { 6f32.sqrt() };
            for v in &mut tr.field.params[off + s.w..off + s.b] {
                *v *= gain;
            }
        }
    }
    // feature values of the size trained grids reach (init is ±1e-4)
    let mut rng = crate::util::rng::Rng::new(seed ^ crate::util::rng::stream::RANDOM_TABLE);
    for v in &mut tr.field.params[mlp.table..mlp.n_params] {
        *v = rng.f32() - 0.5;
    }
    let rays = crate::path::orbit_rays(&scene, 8, 24);
    let mut m = trainer_model(&tr, &rays, Prune::Off);
    if m.features.is_some() {
        // a random table is noise: points between the calibration rays
        // reach beyond the calibrated activation ranges (seen: one pixel of
        // a test view off by 0.64 in int16), so give them 2× headroom
        for l in &mut m.coarse.layers {
            l.act_max *= 2.0;
        }
    }
    Ok(m)
}

//! `--max-bytes`: a candidate's model size at the chosen weight bits, and
//! the candidate shrunk (grid, table, samples) until it fits.

use super::*;
use std::num::NonZeroU16;

/// The fixed-point model file's size for configuration `cfg` on `scene`:
/// a model of that shape with random weights, exported as `nerf fit`
/// exports a trained one (an upper bound: training can only prune).
pub(super) fn model_bytes(cfg: &TrainConfig, scene: nerf_infer::format::Scene, bits: Scheme) -> CmdResult<usize> {
    let mut twin = random_model(cfg, scene, 0, 1.0)?;
    // the records a trained model may carry, at their largest (varints): the size is then an upper bound
    twin.meta.iterations = u32::MAX;
    twin.meta.train_downscale = u16::MAX;
    twin.capture = Some(nerf_infer::format::Capture {
        holdout: 100_000,
        views: u32::MAX,
        held_out_crc: u32::MAX,
        framing: nerf_infer::format::Framing::Unbounded,
        lens: true,
    });
    // an orbit record has a fixed size; forward-facing scenes have none
    if scene.ndc.is_none() {
        let orbit = nerf_infer::format::FittedOrbit {
            centre: [0.0; 3],
            up: [0.0, 0.0, 1.0],
            radius: 1.0,
            height: 0.0,
            fov_x: 1.0,
            azimuth: 0.0,
        };
        twin.orbit = Some(orbit);
    }
    let f = twin.to_bytes()?;
    let m = nerf_infer::Model::from_bytes(&f)?;
    let q = quantise(&m, bits)?;
    Ok(q.to_bytes()?.len())
}

/// A configuration shrunk to fit a budget, what it gave up ("feature table
/// 2^15 -> 2^10 entries per level") and its model's size in bytes.
pub(super) type Shrunk = (TrainConfig, Vec<String>, usize);

/// `cfg` shrunk until its model fits `max` bytes, in this order, each
/// step only as far as needed: the feature table halved down to 2¹⁰
/// entries per level ([`TABLE_FLOOR_LOG2`]), the occupancy grid coarsened
/// down to 32³, the table halved down to 2⁸, the grid coarsened down to
/// 16³. Returns the configuration, what it gave up, and its size, or
/// (`Ok(Err)`) the smallest size if it cannot fit.
pub(super) fn fit_budget(
    cfg: &TrainConfig,
    scene: nerf_infer::format::Scene,
    bits: Scheme,
    max: usize,
) -> CmdResult<Result<Shrunk, usize>> {
    let mut c = cfg.clone();
    let mut bytes = model_bytes(&c, scene, bits)?;
    for (table_floor, grid_floor) in [(TABLE_FLOOR_LOG2, 32), (8, 16)] {
        while bytes > max && c.features.levels.is_some() && c.features.log2_table > table_floor {
            c.features.log2_table -= 1;
            bytes = model_bytes(&c, scene, bits)?;
        }
        while let Some(res) = c.grid.res.filter(|r| bytes > max && r.get() > grid_floor) {
            c.grid.res = NonZeroU16::new(res.get() / 2);
            bytes = model_bytes(&c, scene, bits)?;
        }
    }
    if bytes > max {
        return Ok(Err(bytes));
    }
    let mut gave = Vec::new();
    if c.features.log2_table != cfg.features.log2_table {
        gave.push(format!(
            "feature table 2^{} -> 2^{} entries per level",
            cfg.features.log2_table, c.features.log2_table
        ));
    }
    if let (Some(from), Some(to)) = (cfg.grid.res, c.grid.res) {
        if from != to {
            gave.push(format!("occupancy grid {from}^3 -> {to}^3"));
        }
    }
    Ok(Ok((c, gave, bytes)))
}

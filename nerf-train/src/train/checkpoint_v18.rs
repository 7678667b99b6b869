//! The version 18 checkpoint's layout: the run's whole state in postcard,
//! field after field, read into this build's [`Trainer`]. Its
//! configuration is the sections as that version laid them out
//! ([`ConfigV18`]): the per-photo settings sat in `optimiser` and `loss`.

use super::*;
use crate::config::{
    FeatureConfig, GridConfig, LossConfig, ModelConfig, OptimiserConfig, PerPhotoConfig, SamplingConfig,
};
use crate::optim::adam::Adam;
use crate::sampling::occupancy::OccupancyGrid;
use serde::Deserialize;
#[cfg(test)]
use serde::Serialize;

/// [`TrainConfig`] as a version 18 checkpoint lays it out in postcard.
#[derive(Deserialize)]
#[cfg_attr(test, derive(Serialize))]
pub(super) struct ConfigV18 {
    model: ModelConfig,
    features: FeatureConfig,
    sampling: SamplingConfig,
    grid: GridConfig,
    optimiser: OptimiserV18,
    loss: LossV18,
}

/// [`OptimiserConfig`] then the pose corrections' learning rate (postcard
/// writes a struct's fields one after the other, a nested one's inline).
#[derive(Deserialize)]
#[cfg_attr(test, derive(Serialize))]
struct OptimiserV18 {
    optimiser: OptimiserConfig,
    pose_lr: f32,
}

/// [`LossConfig`]'s fields of that version then the per-photo
/// corrections' switches.
#[derive(Deserialize)]
#[cfg_attr(test, derive(Serialize))]
struct LossV18 {
    distortion: f32,
    density_l1: f32,
    near_gradient: f32,
    appearance: bool,
    pose_refine: bool,
}

impl From<ConfigV18> for TrainConfig {
    fn from(c: ConfigV18) -> Self {
        let (o, l) = (c.optimiser, c.loss);
        TrainConfig {
            model: c.model,
            features: c.features,
            sampling: c.sampling,
            grid: c.grid,
            optimiser: o.optimiser,
            loss: LossConfig {
                distortion: l.distortion,
                density_l1: l.density_l1,
                near_gradient: l.near_gradient,
                // samples behind an opaque stretch kept, as that version did
                backward_transmittance: 0.0,
            },
            per_photo: PerPhotoConfig { appearance: l.appearance, pose_refine: l.pose_refine, pose_lr: o.pose_lr },
        }
    }
}

/// A configuration as a version 18 checkpoint held it, for the tests that write one.
#[cfg(test)]
impl From<&TrainConfig> for ConfigV18 {
    fn from(c: &TrainConfig) -> Self {
        let p = &c.per_photo;
        ConfigV18 {
            model: c.model.clone(),
            features: c.features.clone(),
            sampling: c.sampling.clone(),
            grid: c.grid.clone(),
            optimiser: OptimiserV18 { optimiser: c.optimiser.clone(), pose_lr: p.pose_lr },
            loss: LossV18 {
                distortion: c.loss.distortion,
                density_l1: c.loss.density_l1,
                near_gradient: c.loss.near_gradient,
                appearance: p.appearance,
                pose_refine: p.pose_refine,
            },
        }
    }
}

/// The scene as a checkpoint holds it: [`Scene`] in the model format's
/// encoding, then its unbounded space, which that encoding leaves to a
/// model's own field (`#[serde(with = "scene_in_full")]` on a version 18
/// checkpoint's scene).
pub(super) mod scene_in_full {
    use nerf_infer::format::{Scene, Unbounded};
    use serde::{Deserialize, Deserializer};
    #[cfg(test)]
    use serde::{Serialize, Serializer};

    /// Writes `scene` and `scene.unbounded` (as a version 18 checkpoint did).
    #[cfg(test)]
    pub fn serialize<S: Serializer>(scene: &Scene, s: S) -> Result<S::Ok, S::Error> {
        (scene, scene.unbounded).serialize(s)
    }

    /// Reads what [`serialize`] writes.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Scene, D::Error> {
        let (mut scene, unbounded): (Scene, Option<Unbounded>) = Deserialize::deserialize(d)?;
        scene.unbounded = unbounded;
        Ok(scene)
    }
}

/// A version 18 checkpoint's payload: the state's fields in this order,
/// in postcard (the types as this build defines them, but the
/// configuration's, whose layout [`ConfigV18`] keeps).
#[derive(Deserialize)]
#[cfg_attr(test, derive(Serialize))]
pub(super) struct V18 {
    cfg: ConfigV18,
    #[serde(with = "scene_in_full")]
    scene: Scene,
    downscale: u32,
    params: Vec<f32>,
    adam: Adam,
    step: u64,
    elapsed: f64,
    seed: u64,
    skipped: u64,
    grid: Option<OccupancyGrid>,
    data: String,
    pixel: f32,
    ema: Vec<f32>,
    proposal: Option<ProposalGrid>,
    appearance: Option<Appearance>,
    poses: Option<Poses>,
}

impl TryFrom<V18> for Trainer {
    type Error = crate::error::Error;

    /// The run a version 18 checkpoint holds; refused as an inconsistent
    /// `cfg` where its configuration is not a valid one.
    fn try_from(v: V18) -> Result<Self, Self::Error> {
        let cfg: TrainConfig = v.cfg.into();
        Ok(Trainer {
            field: super::checkpoint::restored_field(&cfg, v.params, v.adam, v.ema)?,
            cfg,
            scene: v.scene,
            downscale: v.downscale,
            step: v.step,
            elapsed: v.elapsed,
            seed: v.seed,
            skipped: v.skipped,
            sampler: Sampler { occupancy: v.grid, proposal: v.proposal },
            data: v.data,
            pixel: v.pixel,
            appearance: v.appearance,
            poses: v.poses,
            pool: GradPool::default(),
        })
    }
}

/// A run as a version 18 checkpoint held it, for the tests that write one.
#[cfg(test)]
impl From<&Trainer> for V18 {
    fn from(t: &Trainer) -> Self {
        let t = t.clone();
        V18 {
            cfg: (&t.cfg).into(),
            scene: t.scene,
            downscale: t.downscale,
            params: t.field.params,
            adam: t.field.adam,
            step: t.step,
            elapsed: t.elapsed,
            seed: t.seed,
            skipped: t.skipped,
            grid: t.sampler.occupancy,
            data: t.data,
            pixel: t.pixel,
            ema: t.field.ema,
            proposal: t.sampler.proposal,
            appearance: t.appearance,
            poses: t.poses,
        }
    }
}

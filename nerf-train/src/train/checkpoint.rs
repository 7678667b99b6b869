//! The checkpoint container: the run's state in postcard, framed as a
//! model file is (`nerf_infer::format::frame`: magic, version, length,
//! CRC-32) under its own magic.

use super::*;
use crate::error::Error;
use nerf_infer::format::{frame, unframe};
use nerf_infer::Error as FormatError;

/// The first bytes of a checkpoint file (`nerf_infer::format::CHECKPOINT_MAGIC`).
pub const CHECKPOINT_MAGIC: &[u8; 8] = &nerf_infer::format::CHECKPOINT_MAGIC;

/// The checkpoint format [`Trainer::to_bytes`] writes and reads.
pub const CHECKPOINT_VERSION: u16 = 18;

/// The scene as a checkpoint holds it: [`Scene`] in the model format's
/// encoding, then its unbounded space, which that encoding leaves to a
/// model's own field (`#[serde(with = "scene_in_full")]` on
/// [`Trainer::scene`]).
pub(super) mod scene_in_full {
    use nerf_infer::format::{Scene, Unbounded};
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// Writes `scene` and `scene.unbounded`.
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

/// How many of a run's `params` parameters are a feature grid's table: the
/// last ones (a run with a feature grid has one network), none without one.
pub(super) fn table_values(net: &Mlp, params: usize) -> usize {
    if net.features.is_some() {
        params - net.table
    } else {
        0
    }
}

impl Trainer {
    /// Serialises the run for a checkpoint: [`CHECKPOINT_MAGIC`], the
    /// format version (u16 LE), the payload's length (u32 LE) and CRC-32
    /// (u32 LE), then the payload (postcard). Fails with
    /// [`Error::Checkpoint`] for a state of 4 GiB or more.
    pub fn to_bytes(&self) -> Result<Vec<u8>, Error> {
        let payload = postcard::to_stdvec(self).map_err(|e| Error::Checkpoint(format!("cannot encode: {e}")))?;
        frame(CHECKPOINT_MAGIC, CHECKPOINT_VERSION, &payload).map_err(|e| Error::Checkpoint(e.to_string()))
    }

    /// Restores a run from [`Trainer::to_bytes`]; fails with
    /// [`Error::Checkpoint`] saying why: a header, length or checksum that
    /// does not match (a damaged or foreign file, or another checkpoint
    /// version), or a state that is inconsistent (parameters that its
    /// configuration does not lay out).
    pub fn from_bytes(b: &[u8]) -> Result<Self, Error> {
        let bad = |m: &str| Error::Checkpoint(m.to_string());
        let payload = match unframe(b, CHECKPOINT_MAGIC, CHECKPOINT_VERSION, CHECKPOINT_VERSION) {
            Ok((_, payload)) => payload,
            Err(FormatError::BadMagic) => return Err(bad("not a checkpoint (no NERFCKPT header)")),
            Err(FormatError::UnsupportedVersion(v)) => {
                return Err(Error::Checkpoint(format!(
                    "checkpoint version {v}, this build reads version {CHECKPOINT_VERSION} (written by another build)"
                )))
            }
            Err(_) => return Err(bad("truncated or damaged (its length or checksum does not match)")),
        };
        let t: Self = postcard::from_bytes(payload).map_err(|e| Error::Checkpoint(format!("cannot decode: {e}")))?;
        let grid_ok = match &t.grid {
            None => t.cfg.grid.res == 0,
            Some(g) => g.res == t.cfg.grid.res && g.view().is_valid() && g.density.len() == (g.res as usize).pow(3),
        };
        let proposal_ok = match &t.proposal {
            None => t.cfg.sampling.proposal_res == 0,
            Some(p) => {
                let n = (p.res as usize).pow(3);
                p.res > 0
                    && p.res == t.cfg.sampling.proposal_res
                    && p.log_sigma.len() == n
                    && p.adam.m.len() == n
                    && p.adam.v.len() == n
                    && p.adam.steps.len() == n
            }
        };
        let appearance_ok = match &t.appearance {
            None => true,
            Some(a) => t.cfg.loss.appearance && a.is_consistent(),
        };
        let poses_ok = match &t.poses {
            None => true,
            Some(p) => t.cfg.loss.pose_refine && p.is_consistent(),
        };
        let nets = if t.cfg.sampling.n_fine > 0 { 2 } else { 1 };
        let sizes_ok = proposal_ok
            && appearance_ok
            && poses_ok
            && t.cfg.validate().is_ok()
            && t.pixel.is_finite()
            && t.pixel >= 0.0
            && t.params.len() == t.mlp().n_params * nets
            && t.params.len() == t.adam.m.len()
            && t.params.len() == t.adam.v.len()
            && t.adam.steps.len() == table_values(&t.mlp(), t.params.len())
            && (t.ema.is_empty() || (t.cfg.optimiser.ema_decay > 0.0 && t.ema.len() == t.params.len()));
        match sizes_ok && grid_ok {
            true => Ok(t),
            false => {
                Err(bad("its state is inconsistent (parameters, grids or configuration that do not fit together)"))
            }
        }
    }
}

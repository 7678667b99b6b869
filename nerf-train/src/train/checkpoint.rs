//! The checkpoint container: the run's state framed as a model file is
//! (`nerf_infer::format::frame`: magic, version, length, CRC-32) under its
//! own magic.
//!
//! Version 19 holds the state as named sections, one per field of
//! [`Trainer`] (each in postcard; its sampler's two grids are the `grid`
//! and `proposal` sections), the configuration among them as JSON
//! with its fields named: a field added to the trainer or its
//! configuration leaves earlier checkpoints readable. Reading one that
//! lacks a field takes the value [`ABSENT_MEANS`] gives it (what builds
//! before the field did), or refuses the checkpoint naming the field; a
//! field this build does not know (a newer build's) is refused by name.
//! Version 18, the whole state in postcard, is still read, through its
//! own layout.

use super::checkpoint_v18::V18;
use super::*;
use crate::error::{CheckpointError, Error};
use crate::optim::adam::Adam;
use nerf_infer::format::{frame, unframe};
use nerf_infer::Error as FormatError;
use serde::de::DeserializeOwned;
use serde::Serialize;
use serde_json::Value;

/// The first bytes of a checkpoint file (`nerf_infer::format::CHECKPOINT_MAGIC`).
pub const CHECKPOINT_MAGIC: &[u8; 8] = &nerf_infer::format::CHECKPOINT_MAGIC;

/// The checkpoint format [`Trainer::to_bytes`] writes: named sections.
pub const CHECKPOINT_VERSION: u16 = 19;

/// The earliest checkpoint format [`Trainer::from_bytes`] reads: 18, the
/// run's state in postcard, read through its own layout (the fields'
/// types as this build defines them).
pub const CHECKPOINT_VERSION_MIN: u16 = 18;

/// Fields an earlier build's checkpoint may lack, by name (a section of
/// the state, or `cfg.SECTION.FIELD` of its configuration), each with the
/// value (as JSON) that means what builds before it did. A field added to
/// [`Trainer`] or [`TrainConfig`] gets a line here when such a value
/// exists; without one, checkpoints that lack it are refused, naming it.
pub const ABSENT_MEANS: &[(&str, &str)] = &[
    // every sample with a gradient went through the backward pass
    ("cfg.loss.backward_transmittance", "0"),
];

impl Trainer {
    /// Serialises the run for a checkpoint: [`CHECKPOINT_MAGIC`], the
    /// format version (u16 LE), the payload's length (u32 LE) and CRC-32
    /// (u32 LE), then the payload (postcard). Fails with
    /// [`Error::Checkpoint`] for a state of 4 GiB or more.
    pub fn to_bytes(&self) -> Result<Vec<u8>, Error> {
        let mut w = Sections::default();
        let cfg = serde_json::to_string(&self.cfg).map_err(CheckpointError::EncodeConfig)?;
        w.put("cfg", &cfg)?;
        w.put("scene", &(&self.scene, self.scene.unbounded))?;
        w.put("downscale", &self.downscale)?;
        w.put("params", &self.field.params)?;
        w.put("adam", &self.field.adam)?;
        w.put("step", &self.step)?;
        w.put("elapsed", &self.elapsed)?;
        w.put("seed", &self.seed)?;
        w.put("skipped", &self.skipped)?;
        w.put("grid", &self.sampler.occupancy)?;
        w.put("data", &self.data)?;
        w.put("pixel", &self.pixel)?;
        w.put("ema", &self.field.ema)?;
        w.put("proposal", &self.sampler.proposal)?;
        w.put("appearance", &self.appearance)?;
        w.put("poses", &self.poses)?;
        let payload = postcard::to_stdvec(&w.0).map_err(CheckpointError::Encode)?;
        Ok(frame(CHECKPOINT_MAGIC, CHECKPOINT_VERSION, &payload).map_err(CheckpointError::Frame)?)
    }

    /// Restores a run from [`Trainer::to_bytes`]; fails with
    /// [`Error::Checkpoint`] saying why: a header, length or checksum that
    /// does not match (a damaged or foreign file, or another checkpoint
    /// version), or a state that is inconsistent (parameters that its
    /// configuration does not lay out).
    pub fn from_bytes(b: &[u8]) -> Result<Self, Error> {
        let (version, payload) = match unframe(b, CHECKPOINT_MAGIC, CHECKPOINT_VERSION_MIN, CHECKPOINT_VERSION) {
            Ok(read) => read,
            Err(FormatError::BadMagic) => return Err(CheckpointError::NotACheckpoint.into()),
            Err(FormatError::UnsupportedVersion(found)) => {
                let (min, max) = (CHECKPOINT_VERSION_MIN, CHECKPOINT_VERSION);
                return Err(CheckpointError::Version { found, min, max }.into());
            }
            Err(e) => return Err(CheckpointError::Damaged(e).into()),
        };
        let t: Self = match version {
            CHECKPOINT_VERSION_MIN => {
                let v: V18 = postcard::from_bytes(payload).map_err(CheckpointError::Decode)?;
                v.try_into()?
            }
            _ => Self::from_sections(payload, ABSENT_MEANS)?,
        };
        match t.inconsistent_part() {
            None => Ok(t),
            Some(part) => Err(CheckpointError::Inconsistent { part }.into()),
        }
    }

    /// The first part of a restored state that does not fit the rest
    /// (`grid`, `proposal`, `appearance`, `poses`, `pixel`,
    /// `params`, `adam`, `ema`), or `None` when all fit.
    fn inconsistent_part(&self) -> Option<&'static str> {
        let t = self;
        let grid_ok = match &t.sampler.occupancy {
            None => t.cfg.grid.res.is_none(),
            Some(g) => {
                t.cfg.grid.res.is_some_and(|r| r.get() == g.res)
                    && g.view().is_valid()
                    && g.density.len() == (g.res as usize).pow(3)
            }
        };
        let proposal_ok = match &t.sampler.proposal {
            None => t.cfg.sampling.proposal_res.is_none(),
            Some(p) => {
                let n = (p.res as usize).pow(3);
                t.cfg.sampling.proposal_res.is_some_and(|r| r.get() == p.res)
                    && p.log_sigma.len() == n
                    && p.adam.m.len() == n
                    && p.adam.v.len() == n
                    && p.adam.steps.len() == n
            }
        };
        let appearance_ok = match &t.appearance {
            None => true,
            Some(a) => t.cfg.per_photo.appearance && a.is_consistent(),
        };
        let poses_ok = match &t.poses {
            None => true,
            Some(p) => t.cfg.per_photo.pose_refine && p.is_consistent(),
        };
        let parts = [("grid", grid_ok), ("proposal", proposal_ok), ("appearance", appearance_ok), ("poses", poses_ok)];
        if let Some(&(part, _)) = parts.iter().find(|p| !p.1) {
            return Some(part);
        }
        // the configuration was validated by restored_field, before the network's layout was read from it
        let (field, nets) = (&t.field, if t.cfg.sampling.n_fine.is_some() { 2 } else { 1 });
        let parts = [
            ("pixel", t.pixel.is_finite() && t.pixel >= 0.0),
            ("params", field.params.len() == field.net.n_params * nets),
            (
                "adam",
                field.params.len() == field.adam.m.len()
                    && field.params.len() == field.adam.v.len()
                    && field.adam.steps.len() == Field::table_values(&field.net, field.params.len()),
            ),
            ("ema", field.ema.is_empty() || (t.cfg.optimiser.ema_decay > 0.0 && field.ema.len() == field.params.len())),
        ];
        parts.iter().find(|p| !p.1).map(|p| p.0)
    }
}

/// A restored run's field: its networks' shape is laid out from its
/// configuration, which must be a valid one (refused as an inconsistent
/// `cfg` otherwise); the parameters' sizes are checked against it after.
pub(super) fn restored_field(cfg: &TrainConfig, params: Vec<f32>, adam: Adam, ema: Vec<f32>) -> Result<Field, Error> {
    if cfg.validate().is_err() {
        return Err(CheckpointError::Inconsistent { part: "cfg" }.into());
    }
    Ok(Field { net: cfg.mlp(), params, adam, ema })
}

/// A checkpoint's sections: (name, postcard bytes), in the order written.
#[derive(Default)]
struct Sections(Vec<(String, Vec<u8>)>);

impl Sections {
    fn put<T: Serialize>(&mut self, name: &str, v: &T) -> Result<(), Error> {
        let bytes = postcard::to_stdvec(v)
            .map_err(|source| CheckpointError::EncodeSection { name: name.to_string(), source })?;
        self.0.push((name.to_string(), bytes));
        Ok(())
    }
}

/// Reads sections by name, each once, giving absent ones the value `absent` names.
struct SectionReader<'a> {
    sections: std::collections::BTreeMap<String, Vec<u8>>,
    absent: &'a [(&'a str, &'a str)],
}

impl SectionReader<'_> {
    fn take<T: DeserializeOwned>(&mut self, name: &str) -> Result<T, Error> {
        let owned = || name.to_string();
        match self.sections.remove(name) {
            Some(bytes) => postcard::from_bytes(&bytes)
                .map_err(|source| CheckpointError::DecodeSection { name: owned(), source }.into()),
            None => match self.absent.iter().find(|(n, _)| *n == name) {
                Some((_, json)) => serde_json::from_str(json)
                    .map_err(|source| CheckpointError::AbsentSection { name: owned(), source }.into()),
                None => Err(lacks(name)),
            },
        }
    }

    /// Refuses sections nobody took: a newer build's fields.
    fn finish(self) -> Result<(), Error> {
        match self.sections.keys().next() {
            Some(name) => Err(unknown(name)),
            None => Ok(()),
        }
    }
}

/// The error for a checkpoint without field `name`.
fn lacks(name: &str) -> Error {
    CheckpointError::Missing { name: name.to_string() }.into()
}

/// The error for a checkpoint with field `name` this build does not know.
fn unknown(name: &str) -> Error {
    CheckpointError::Unknown { name: name.to_string() }.into()
}

/// `found` (a checkpoint's configuration as JSON) with every field `like`
/// (this build's) has, at every depth: absent ones from `absent` (under
/// `cfg.PATH`) or refused, unknown ones refused, each named by its path.
fn complete(found: &mut Value, like: &Value, path: &str, absent: &[(&str, &str)]) -> Result<(), Error> {
    let (Some(found), Some(like)) = (found.as_object_mut(), like.as_object()) else { return Ok(()) };
    if let Some(k) = found.keys().find(|k| !like.contains_key(*k)) {
        return Err(unknown(&format!("{path}.{k}")));
    }
    for (k, v) in like {
        let name = format!("{path}.{k}");
        match found.get_mut(k) {
            Some(f) => complete(f, v, &name, absent)?,
            None => {
                let (_, json) = absent.iter().find(|(n, _)| *n == name).ok_or_else(|| lacks(&name))?;
                let value = serde_json::from_str(json)
                    .map_err(|source| CheckpointError::AbsentField { name: name.clone(), source })?;
                found.insert(k.clone(), value);
            }
        }
    }
    Ok(())
}

impl Trainer {
    /// The state of a version 19 checkpoint's payload; absent fields as
    /// `absent` ([`ABSENT_MEANS`]) says.
    pub(super) fn from_sections(payload: &[u8], absent: &[(&str, &str)]) -> Result<Self, Error> {
        let sections: Vec<(String, Vec<u8>)> = postcard::from_bytes(payload).map_err(CheckpointError::Decode)?;
        let mut r = SectionReader { sections: sections.into_iter().collect(), absent };
        let cfg: String = r.take("cfg")?;
        let bad_cfg = CheckpointError::DecodeConfig;
        let mut cfg: Value = serde_json::from_str(&cfg).map_err(bad_cfg)?;
        crate::config::json::moved_fields_placed(&mut cfg);
        let like = serde_json::to_value(TrainConfig::default()).map_err(bad_cfg)?;
        complete(&mut cfg, &like, "cfg", absent)?;
        let (mut scene, unbounded): (Scene, Option<nerf_infer::format::Unbounded>) = r.take("scene")?;
        scene.unbounded = unbounded;
        let cfg: TrainConfig = serde_json::from_value(cfg).map_err(bad_cfg)?;
        let t = Trainer {
            field: restored_field(&cfg, r.take("params")?, r.take("adam")?, r.take("ema")?)?,
            cfg,
            scene,
            downscale: r.take("downscale")?,
            step: r.take("step")?,
            elapsed: r.take("elapsed")?,
            seed: r.take("seed")?,
            skipped: r.take("skipped")?,
            sampler: Sampler { occupancy: r.take("grid")?, proposal: r.take("proposal")? },
            data: r.take("data")?,
            pixel: r.take("pixel")?,
            appearance: r.take("appearance")?,
            poses: r.take("poses")?,
            pool: GradPool::default(),
        };
        r.finish()?;
        Ok(t)
    }
}

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
use crate::error::Error;
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
pub const ABSENT_MEANS: &[(&str, &str)] = &[];

impl Trainer {
    /// Serialises the run for a checkpoint: [`CHECKPOINT_MAGIC`], the
    /// format version (u16 LE), the payload's length (u32 LE) and CRC-32
    /// (u32 LE), then the payload (postcard). Fails with
    /// [`Error::Checkpoint`] for a state of 4 GiB or more.
    pub fn to_bytes(&self) -> Result<Vec<u8>, Error> {
        let mut w = Sections::default();
        let cfg = serde_json::to_string(&self.cfg).map_err(|e| Error::Checkpoint(format!("cannot encode: {e}")))?;
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
        let payload = postcard::to_stdvec(&w.0).map_err(|e| Error::Checkpoint(format!("cannot encode: {e}")))?;
        frame(CHECKPOINT_MAGIC, CHECKPOINT_VERSION, &payload).map_err(|e| Error::Checkpoint(e.to_string()))
    }

    /// Restores a run from [`Trainer::to_bytes`]; fails with
    /// [`Error::Checkpoint`] saying why: a header, length or checksum that
    /// does not match (a damaged or foreign file, or another checkpoint
    /// version), or a state that is inconsistent (parameters that its
    /// configuration does not lay out).
    pub fn from_bytes(b: &[u8]) -> Result<Self, Error> {
        let bad = |m: &str| Error::Checkpoint(m.to_string());
        let (version, payload) = match unframe(b, CHECKPOINT_MAGIC, CHECKPOINT_VERSION_MIN, CHECKPOINT_VERSION) {
            Ok(read) => read,
            Err(FormatError::BadMagic) => return Err(bad("not a checkpoint (no NERFCKPT header)")),
            Err(FormatError::UnsupportedVersion(v)) => {
                return Err(Error::Checkpoint(format!(
                    "checkpoint version {v}, this build reads versions {CHECKPOINT_VERSION_MIN} to \
                     {CHECKPOINT_VERSION} (written by another build)"
                )))
            }
            Err(_) => return Err(bad("truncated or damaged (its length or checksum does not match)")),
        };
        let t: Self = match version {
            CHECKPOINT_VERSION_MIN => {
                let v: V18 =
                    postcard::from_bytes(payload).map_err(|e| Error::Checkpoint(format!("cannot decode: {e}")))?;
                v.into()
            }
            _ => Self::from_sections(payload, ABSENT_MEANS)?,
        };
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
        let field = &t.field;
        let nets = if t.cfg.sampling.n_fine.is_some() { 2 } else { 1 };
        let sizes_ok = proposal_ok
            && appearance_ok
            && poses_ok
            && t.cfg.validate().is_ok()
            && t.pixel.is_finite()
            && t.pixel >= 0.0
            && field.params.len() == field.net.n_params * nets
            && field.params.len() == field.adam.m.len()
            && field.params.len() == field.adam.v.len()
            && field.adam.steps.len() == Field::table_values(&field.net, field.params.len())
            && (field.ema.is_empty() || (t.cfg.optimiser.ema_decay > 0.0 && field.ema.len() == field.params.len()));
        match sizes_ok && grid_ok {
            true => Ok(t),
            false => {
                Err(bad("its state is inconsistent (parameters, grids or configuration that do not fit together)"))
            }
        }
    }
}

/// A checkpoint's sections: (name, postcard bytes), in the order written.
#[derive(Default)]
struct Sections(Vec<(String, Vec<u8>)>);

impl Sections {
    fn put<T: Serialize>(&mut self, name: &str, v: &T) -> Result<(), Error> {
        let bytes = postcard::to_stdvec(v).map_err(|e| Error::Checkpoint(format!("cannot encode its {name}: {e}")))?;
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
        let cannot = |e: &dyn std::fmt::Display| Error::Checkpoint(format!("its {name} cannot be decoded: {e}"));
        match self.sections.remove(name) {
            Some(bytes) => postcard::from_bytes(&bytes).map_err(|e| cannot(&e)),
            None => match self.absent.iter().find(|(n, _)| *n == name) {
                Some((_, json)) => serde_json::from_str(json).map_err(|e| cannot(&e)),
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
    Error::Checkpoint(format!(
        "it has no {name} (written by an earlier build, before this build's {name} existed, and no value of it \
         means what that build did): start the run over with --force"
    ))
}

/// The error for a checkpoint with field `name` this build does not know.
fn unknown(name: &str) -> Error {
    Error::Checkpoint(format!("it holds {name}, which this build does not know (written by a newer build)"))
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
                let value = serde_json::from_str(json).map_err(|e| Error::Checkpoint(format!("{name}: {e}")))?;
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
        let sections: Vec<(String, Vec<u8>)> =
            postcard::from_bytes(payload).map_err(|e| Error::Checkpoint(format!("cannot decode: {e}")))?;
        let mut r = SectionReader { sections: sections.into_iter().collect(), absent };
        let cfg: String = r.take("cfg")?;
        let bad_cfg = |e: serde_json::Error| Error::Checkpoint(format!("its cfg cannot be decoded: {e}"));
        let mut cfg: Value = serde_json::from_str(&cfg).map_err(bad_cfg)?;
        crate::config::json::moved_fields_placed(&mut cfg);
        let like = serde_json::to_value(TrainConfig::default()).map_err(bad_cfg)?;
        complete(&mut cfg, &like, "cfg", absent)?;
        let (mut scene, unbounded): (Scene, Option<nerf_infer::format::Unbounded>) = r.take("scene")?;
        scene.unbounded = unbounded;
        let cfg: TrainConfig = serde_json::from_value(cfg).map_err(bad_cfg)?;
        let t = Trainer {
            field: Field { net: cfg.mlp(), params: r.take("params")?, adam: r.take("adam")?, ema: r.take("ema")? },
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

//! The checkpoint container: a header (magic, version, length, CRC-32)
//! before the run's state in postcard.

use super::*;

/// The first bytes of a checkpoint file.
pub const CHECKPOINT_MAGIC: &[u8; 8] = b"NERFCKPT";

/// The checkpoint format [`Trainer::to_bytes`] writes and reads.
pub const CHECKPOINT_VERSION: u16 = 11;

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
    /// format version (u16 LE), the payload's length (u64 LE) and CRC-32
    /// (u32 LE), then the payload (postcard).
    pub fn to_bytes(&self) -> Vec<u8> {
        let payload = postcard::to_stdvec(self).expect("trainer state serialises");
        let mut out = Vec::with_capacity(payload.len() + 22);
        out.extend_from_slice(CHECKPOINT_MAGIC);
        out.extend_from_slice(&CHECKPOINT_VERSION.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(&nerf_infer::format::crc32(&payload).to_le_bytes());
        out.extend_from_slice(&payload);
        out
    }

    /// Restores a run from [`Trainer::to_bytes`]; `None` if the header,
    /// length or checksum do not match (a damaged or foreign file) or the
    /// state is inconsistent (parameters that its configuration does not lay out).
    pub fn from_bytes(b: &[u8]) -> Option<Self> {
        let (head, payload) = b.split_at_checked(22)?;
        let version = u16::from_le_bytes([head[8], head[9]]);
        let len = u64::from_le_bytes(head[10..18].try_into().ok()?);
        let crc = u32::from_le_bytes(head[18..22].try_into().ok()?);
        let whole = &head[..8] == CHECKPOINT_MAGIC && version == CHECKPOINT_VERSION && len == payload.len() as u64;
        if !whole || nerf_infer::format::crc32(payload) != crc {
            return None;
        }
        let t: Self = postcard::from_bytes(payload).ok()?;
        let grid_ok = match &t.grid {
            None => t.cfg.grid_res == 0,
            Some(g) => g.res == t.cfg.grid_res && g.view().is_valid() && g.density.len() == (g.res as usize).pow(3),
        };
        let proposal_ok = match &t.proposal {
            None => t.cfg.proposal_res == 0,
            Some(p) => {
                let n = (p.res as usize).pow(3);
                p.res > 0
                    && p.res == t.cfg.proposal_res
                    && p.log_sigma.len() == n
                    && p.adam.m.len() == n
                    && p.adam.v.len() == n
                    && p.adam.steps.len() == n
            }
        };
        let nets = if t.cfg.n_fine > 0 { 2 } else { 1 };
        let sizes_ok = proposal_ok
            && t.cfg.validate().is_ok()
            && t.pixel.is_finite()
            && t.pixel >= 0.0
            && t.params.len() == t.mlp().n_params * nets
            && t.params.len() == t.adam.m.len()
            && t.params.len() == t.adam.v.len()
            && t.adam.steps.len() == table_values(&t.mlp(), t.params.len())
            && (t.ema.is_empty() || (t.cfg.ema_decay > 0.0 && t.ema.len() == t.params.len()));
        (sizes_ok && grid_ok).then_some(t)
    }
}

//! The model file format (versions 1 to 10). The full layout is in `FORMAT.md`.
//!
//! A model is a 14-byte header followed by a postcard payload:
//!
//! | offset | size | field                                   |
//! |--------|------|-----------------------------------------|
//! | 0      | 4    | magic `b"NERF"`                          |
//! | 4      | 2    | format version, u16 little-endian (1–10) |
//! | 6      | 4    | payload length in bytes, u32 LE         |
//! | 10     | 4    | CRC-32 (IEEE) of the payload, u32 LE    |
//! | 14     | n    | payload: [`Model`] in postcard encoding |
//!
//! Version 2 appends one field, the optional occupancy grid; version 3
//! another, the optional learned feature grid ([`FeatureGrid`]); version 4
//! the optional record of the training capture's split ([`Capture`]);
//! version 5 unbounded space ([`Unbounded`]); version 6 the parts of an
//! int8 model kept at 16 bits ([`Precise`]); version 7 a feature table
//! stored as 8- or 4-bit codebook indices ([`NarrowTable`]); version 8 the
//! density heads at 16 bits ([`PreciseDensity`]); version 9 the orbit fitted
//! to the training cameras ([`FittedOrbit`]); version 10 the features
//! averaged over each sample's pixel footprint ([`Footprint`]). A model is
//! written as the oldest version that holds it (no footprint: 9; no fitted orbit: 8; no 16-bit density head: 7; no narrow
//! table either: 6; no 16-bit parts
//! either: 5; not
//! unbounded either: 4; no capture record
//! either: 3; no feature grid either: 2; no occupancy grid and no pruned
//! layer either: 1), byte for byte what earlier builds wrote, so older readers
//! keep reading it.
//!
//! Tensors are borrowed from the blob ([`Model::from_bytes`] never copies or
//! allocates), so a model can live in flash. Multi-byte tensor elements are
//! little-endian and read without alignment requirements.

mod header;
mod layers;
#[cfg(feature = "alloc")]
pub mod owned;
mod records;
mod validate;

#[cfg(feature = "alloc")]
pub use header::frame;
use header::{check_header, Padded};
pub use header::{crc32, unframe, FRAME_FIELDS_LEN};
pub use layers::{
    expected_shape, prunable, pruned_shape, sigma_layer, Layer, Network, Precise, PreciseDensity, PreciseNet,
};
pub use records::{
    CameraConvention, Capture, Encoding, FittedOrbit, Footprint, Framing, Meta, Ndc, Samples, Scene, Scheme, Topology,
    Unbounded,
};

use crate::error::{Error, Result};
pub use crate::features::{FeatureGrid, NarrowTable};
pub use crate::occupancy::Occupancy;
pub use crate::proposal::Proposal;
use serde::{Deserialize, Serialize};

pub use crate::limits::{
    max_coarse, CHECKPOINT_MAGIC, FORMAT_VERSION, FORMAT_VERSION_NO_CAPTURE, FORMAT_VERSION_NO_DENSITY16,
    FORMAT_VERSION_NO_FEATURES, FORMAT_VERSION_NO_FOOTPRINT, FORMAT_VERSION_NO_GRID, FORMAT_VERSION_NO_NARROW,
    FORMAT_VERSION_NO_ORBIT, FORMAT_VERSION_NO_PRECISE, FORMAT_VERSION_NO_PROPOSAL, FORMAT_VERSION_NO_UNBOUNDED,
    HEADER_LEN, MAGIC, MAX_COARSE, MAX_FINE, MAX_FREQS, MAX_INPUT, MAX_LAYERS, MAX_MARCH, MAX_WIDTH,
};
pub use crate::tensor::{read_f32, read_i16, read_i32};

/// A decoded model, borrowing its tensors from the blob.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Model<'a> {
    /// Scene bounds, near/far, background, camera convention.
    pub scene: Scene,
    /// Positional encoding.
    pub encoding: Encoding,
    /// Network shape (both networks share it).
    pub topology: Topology,
    /// Default sample counts.
    pub samples: Samples,
    /// Provenance.
    pub meta: Meta,
    /// The coarse network (the only one when `fine` is `None`).
    #[serde(borrow)]
    pub coarse: Network<'a>,
    /// The fine network evaluated on coarse + importance samples.
    #[serde(borrow)]
    pub fine: Option<Network<'a>>,
    /// Occupancy grid (format version 2): samples in clear cells are
    /// skipped by both numeric paths. (Version 2 also lets trunk and view
    /// layers be narrower than the topology: pruned neurons.)
    #[serde(borrow)]
    pub grid: Option<Occupancy<'a>>,
    /// Learned feature grid (format version 3): its values follow γ(x) in
    /// the trunk's input (`encoding.grid_dim` of them).
    #[serde(borrow)]
    pub features: Option<FeatureGrid<'a>>,
    /// How the training capture was split and framed (format version 4;
    /// `None` for datasets with their own split files, such as Blender's).
    pub capture: Option<Capture>,
    /// Unbounded space (format version 5), the same as `scene.unbounded`.
    pub unbounded: Option<Unbounded>,
    /// The parts of the networks kept at 16 bits (format version 6), the
    /// same as each network's `precise`.
    #[serde(borrow)]
    pub precise: Option<Precise<'a>>,
    /// The feature table's values as 8- or 4-bit codebook indices (format
    /// version 7), the same as `features.narrow`.
    #[serde(borrow)]
    pub narrow: Option<NarrowTable<'a>>,
    /// The density heads at 16 bits (format version 8), the same as each
    /// network's `precise.density` (and `precise`'s); only beside `precise`.
    #[serde(borrow)]
    pub precise_density: Option<PreciseDensity<'a>>,
    /// The orbit fitted to the training cameras (format version 9), for
    /// videos and viewers; `None`: the scene's own.
    pub orbit: Option<FittedOrbit>,
    /// Features averaged over each sample's pixel footprint (format
    /// version 10).
    pub footprint: Option<Footprint>,
    /// The proposal grid that places the network's samples (format
    /// version 11; [`crate::proposal`]): `samples.coarse` stratified
    /// samples composite it, and the network is evaluated at
    /// `samples.fine` samples drawn from its weights and the last stratified one.
    #[serde(borrow)]
    pub proposal: Option<Proposal<'a>>,
}

impl<'a> Model<'a> {
    /// Decodes and validates a model from `bytes` without copying or allocating.
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self> {
        let (version, payload) = check_header(bytes)?;
        let absent = (FORMAT_VERSION - version) as usize;
        let mut de = postcard::Deserializer::from_flavor(Padded { rest: payload, absent });
        let mut model = Model::deserialize(&mut de).map_err(|_| Error::Decode)?;
        de.finalize().map_err(|_| Error::Decode)?;
        model.encoding.grid_dim = model.features.as_ref().map_or(0, |f| f.dim() as u8);
        model.scene.unbounded = model.unbounded;
        if let Some(f) = &mut model.features {
            f.narrow = model.narrow;
        }
        if let (Some(p), Some(d)) = (&mut model.precise, model.precise_density) {
            p.coarse.density = Some(d.coarse);
            if let Some(f) = &mut p.fine {
                f.density = d.fine;
            }
        }
        if let Some(p) = model.precise {
            model.coarse.precise = Some(p.coarse);
            if let Some(f) = &mut model.fine {
                f.precise = p.fine;
            }
        }
        model.validate()?;
        if version == FORMAT_VERSION_NO_GRID && model.is_pruned() {
            return Err(Error::InvalidTopology("pruned layers need format version 2"));
        }
        Ok(model)
    }

    /// The network that produces the final colour (fine if present).
    pub fn final_network(&self) -> &Network<'a> {
        self.fine.as_ref().unwrap_or(&self.coarse)
    }

    /// Numeric scheme of the model (both networks share it).
    pub fn scheme(&self) -> Scheme {
        self.coarse.scheme
    }

    /// True if a network has a layer narrower than the topology (pruned).
    pub fn is_pruned(&self) -> bool {
        let (t, e) = (&self.topology, &self.encoding);
        core::iter::once(&self.coarse)
            .chain(self.fine.as_ref())
            .any(|n| n.layers.iter().enumerate().any(|(i, l)| l.out_dim as usize != expected_shape(t, e, i).1))
    }

    /// Tensor bytes the model would have without pruning (16-bit parts
    /// included).
    pub fn unpruned_tensor_bytes(&self) -> usize {
        let (t, e) = (&self.topology, &self.encoding);
        let per_layer = |n: &Network<'_>, i: usize| {
            let (din, dout) = expected_shape(t, e, i);
            let b = n.scheme.weight_bytes();
            din * dout * b + 4 * dout + if n.scheme.is_fixed() { 12 * dout } else { 0 }
        };
        // 16-bit parts at the topology's widths
        let precise = |n: &Network<'_>| {
            n.precise.map_or(0, |p| {
                let (din, _) = expected_shape(t, e, n.layers.len() - 1);
                let dirs = if p.view_dirs.is_empty() { 0 } else { e.dir_dim() * t.view_width as usize * 2 };
                let density = p.density.map_or(0, |_| expected_shape(t, e, sigma_layer(t)).0 * 2 + 16);
                dirs + p.colour.map_or(0, |_| din * 3 * 2 + 3 * 16) + density
            })
        };
        core::iter::once(&self.coarse)
            .chain(self.fine.as_ref())
            .map(|n| (0..n.layers.len()).map(|i| per_layer(n, i)).sum::<usize>() + precise(n))
            .sum()
    }

    /// The format version this model is written as: 11 with a proposal
    /// grid, 10 with a pixel footprint, 9 with a fitted orbit,
    /// 8 with 16-bit density heads, 7 with a narrow feature table, 6 with 16-bit parts, 5 with
    /// unbounded space, 4 with a capture record, 3 with a feature grid, 2
    /// with an occupancy grid or pruned layers, else 1.
    pub fn format_version(&self) -> u16 {
        if self.proposal.is_some() {
            FORMAT_VERSION
        } else if self.footprint.is_some() {
            FORMAT_VERSION_NO_PROPOSAL
        } else if self.orbit.is_some() {
            FORMAT_VERSION_NO_FOOTPRINT
        } else if self.precise_density.is_some() {
            FORMAT_VERSION_NO_ORBIT
        } else if self.narrow.is_some() {
            FORMAT_VERSION_NO_DENSITY16
        } else if self.precise.is_some() {
            FORMAT_VERSION_NO_NARROW
        } else if self.unbounded.is_some() {
            FORMAT_VERSION_NO_PRECISE
        } else if self.capture.is_some() {
            FORMAT_VERSION_NO_UNBOUNDED
        } else if self.features.is_some() {
            FORMAT_VERSION_NO_CAPTURE
        } else if self.grid.is_some() || self.is_pruned() {
            FORMAT_VERSION_NO_FEATURES
        } else {
            FORMAT_VERSION_NO_GRID
        }
    }

    /// Bytes of the occupancy bits (0 without a grid).
    pub fn grid_bytes(&self) -> usize {
        self.grid.map_or(0, |g| g.bits.len())
    }

    /// Bytes of the feature grid's table and codebook (0 without a grid).
    pub fn feature_bytes(&self) -> usize {
        self.features.as_ref().map_or(0, |f| f.table.len() + f.narrow.map_or(0, |n| n.codebook.len()))
    }

    /// Total bytes of all tensors (weights, biases, scales, requant, and the
    /// 16-bit parts).
    pub fn tensor_bytes(&self) -> usize {
        core::iter::once(&self.coarse)
            .chain(self.fine.as_ref())
            .flat_map(|n| n.layers.iter())
            .map(|l| l.weights.len() + l.bias.len() + l.scales.len() + l.requant.len())
            .sum::<usize>()
            + self
                .precise
                .iter()
                .flat_map(|p| core::iter::once(p.coarse).chain(p.fine))
                .map(|p| p.bytes())
                .sum::<usize>()
    }
}

/// Encodes a model (header + postcard payload) into a new byte vector.
#[cfg(feature = "alloc")]
pub fn to_bytes(model: &Model<'_>) -> Result<alloc::vec::Vec<u8>> {
    model.validate()?;
    encode(model)
}

/// [`to_bytes`] without the validation (tests write invalid models with it).
#[cfg(feature = "alloc")]
fn encode(model: &Model<'_>) -> Result<alloc::vec::Vec<u8>> {
    let mut payload = postcard::to_allocvec(model).map_err(|_| Error::Decode)?;
    // older versions are the same encoding without the trailing `None` bytes
    let absent = (FORMAT_VERSION - model.format_version()) as usize;
    payload.truncate(payload.len() - absent);
    frame(&MAGIC, model.format_version(), &payload)
}

#[cfg(test)]
mod tests;

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
mod records;
mod validate;

pub use header::crc32;
use header::{check_header, Padded};
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
    max_coarse, FORMAT_VERSION, FORMAT_VERSION_NO_CAPTURE, FORMAT_VERSION_NO_DENSITY16, FORMAT_VERSION_NO_FEATURES,
    FORMAT_VERSION_NO_FOOTPRINT, FORMAT_VERSION_NO_GRID, FORMAT_VERSION_NO_NARROW, FORMAT_VERSION_NO_ORBIT,
    FORMAT_VERSION_NO_PRECISE, FORMAT_VERSION_NO_PROPOSAL, FORMAT_VERSION_NO_UNBOUNDED, HEADER_LEN, MAGIC, MAX_COARSE,
    MAX_FINE, MAX_FREQS, MAX_INPUT, MAX_LAYERS, MAX_MARCH, MAX_WIDTH,
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
    let mut out = alloc::vec::Vec::with_capacity(HEADER_LEN + payload.len());
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&model.format_version().to_le_bytes());
    out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    out.extend_from_slice(&crc32(&payload).to_le_bytes());
    out.extend_from_slice(&payload);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc32_matches_zlib() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
    }

    #[test]
    fn header_errors_are_typed() {
        assert_eq!(Model::from_bytes(b"NE").unwrap_err(), Error::Truncated);
        assert_eq!(Model::from_bytes(b"XXXXXXXXXXXXXXXXXX").unwrap_err(), Error::BadMagic);
        let mut h = [0u8; 14];
        h[..4].copy_from_slice(&MAGIC);
        let newer = FORMAT_VERSION + 1;
        h[4..6].copy_from_slice(&newer.to_le_bytes());
        assert_eq!(Model::from_bytes(&h).unwrap_err(), Error::UnsupportedVersion(newer));
    }

    /// A capture record makes a version-4 file that decodes to the same
    /// model; without one the file is the version it was before, and an
    /// invalid record is refused.
    #[cfg(feature = "alloc")]
    #[test]
    fn capture_record_is_version_4() {
        let golden = include_bytes!("../../tests/data/golden.nerf");
        let mut m = Model::from_bytes(golden).unwrap();
        assert_eq!(to_bytes(&m).unwrap(), golden);
        let c = Capture { holdout: 8, views: 71, held_out_crc: 0xdead_beef, framing: Framing::Unbounded, lens: true };
        m.capture = Some(c);
        let bytes = to_bytes(&m).unwrap();
        assert_eq!(u16::from_le_bytes([bytes[4], bytes[5]]), 4);
        assert_eq!(Model::from_bytes(&bytes).unwrap(), m);
        m.capture = Some(Capture { holdout: 0, ..c });
        assert!(matches!(Model::from_bytes(&encode(&m).unwrap()), Err(Error::InvalidScene(_))));
    }

    /// A fitted orbit makes a version-9 file that decodes to the same model;
    /// a version-8 file without one re-encodes byte for byte; an orbit out
    /// of range, or in a forward-facing scene, is refused.
    #[cfg(feature = "alloc")]
    #[test]
    fn a_fitted_orbit_is_version_9_and_checked() {
        let golden = include_bytes!("../../tests/data/golden8_density.nerf");
        let mut m = Model::from_bytes(golden).unwrap();
        assert_eq!(m.format_version(), FORMAT_VERSION_NO_ORBIT);
        assert_eq!(to_bytes(&m).unwrap(), golden);
        let o = FittedOrbit {
            centre: [0.1, -0.2, 0.3],
            up: [0.0, 0.6, 0.8],
            radius: 1.5,
            height: 0.4,
            fov_x: 0.9,
            azimuth: -2.0,
        };
        m.orbit = Some(o);
        let bytes = to_bytes(&m).unwrap();
        assert_eq!(u16::from_le_bytes([bytes[4], bytes[5]]), 9);
        assert_eq!(bytes.len(), golden.len() + 1 + 10 * 4, "one tag byte and ten f32");
        assert_eq!(Model::from_bytes(&bytes).unwrap(), m);
        let refused = |o: FittedOrbit| {
            let bad = Model { orbit: Some(o), ..m.clone() };
            matches!(Model::from_bytes(&encode(&bad).unwrap()), Err(Error::InvalidScene(_)))
        };
        assert!(refused(FittedOrbit { up: [0.0, 0.0, 2.0], ..o }));
        assert!(refused(FittedOrbit { radius: 0.0, ..o }));
        assert!(refused(FittedOrbit { height: 151.0, ..o }));
        assert!(refused(FittedOrbit { fov_x: 3.2, ..o }));
        assert!(refused(FittedOrbit { centre: [f32::NAN, 0.0, 0.0], ..o }));
        assert!(refused(FittedOrbit { azimuth: 3.2, ..o }));
        let mut ndc = m.clone();
        ndc.scene.ndc = Some(Ndc { focal: 50.0, width: 64.0, height: 48.0 });
        assert!(matches!(ndc.validate(), Err(Error::InvalidScene(s)) if s.contains("NDC")));
    }

    /// 16-bit parts make a version-6 file that re-encodes byte for byte;
    /// parts of the wrong shape, in an f32 model, or differing between the
    /// model and its networks are refused.
    #[cfg(feature = "alloc")]
    #[test]
    fn precise_parts_are_version_6_and_checked() {
        let blob = include_bytes!("../../tests/data/golden8_precise.nerf");
        let m = Model::from_bytes(blob).unwrap();
        assert_eq!(m.format_version(), 6);
        assert_eq!(to_bytes(&m).unwrap(), blob);
        let p = m.precise.unwrap();
        assert_eq!(m.coarse.precise, Some(p.coarse));
        assert!(!p.coarse.view_dirs.is_empty() && p.coarse.colour.is_some());
        let refused = |m: &Model<'_>| Model::from_bytes(&encode(m).unwrap()).unwrap_err();
        // direction rows one element short
        let short = &p.coarse.view_dirs[..p.coarse.view_dirs.len() - 2];
        let mut bad = m.clone();
        bad.precise = Some(Precise { coarse: PreciseNet { view_dirs: short, ..p.coarse }, ..p });
        assert!(matches!(refused(&bad), Error::TensorLength(_)));
        // a colour head of the wrong width
        let mut narrow = p.coarse.colour.unwrap();
        narrow.in_dim -= 1;
        bad.precise = Some(Precise { coarse: PreciseNet { colour: Some(narrow), ..p.coarse }, ..p });
        assert!(matches!(refused(&bad), Error::LayerShape(_)));
        // a fine network's parts missing
        bad.precise = Some(Precise { fine: None, ..p });
        assert!(matches!(refused(&bad), Error::InvalidTopology(_)));
        // an f32 model
        let mut f = m.clone();
        f.coarse.scheme = Scheme::F32;
        assert!(matches!(f.validate(), Err(Error::InvalidTopology(s)) if s.contains("f32")));
    }

    /// A 16-bit density head makes a version-8 file that re-encodes byte
    /// for byte and reads back into the networks; a head of the wrong
    /// shape or length, one without the other 16-bit parts, or one that
    /// differs from the networks' is refused.
    #[cfg(feature = "alloc")]
    #[test]
    fn a_16_bit_density_head_is_version_8_and_checked() {
        let blob = include_bytes!("../../tests/data/golden8_density.nerf");
        let m = Model::from_bytes(blob).unwrap();
        assert_eq!(m.format_version(), 8);
        assert_eq!(to_bytes(&m).unwrap(), blob);
        let d = m.precise_density.unwrap();
        assert_eq!(m.coarse.precise.and_then(|p| p.density), Some(d.coarse));
        assert_eq!((d.coarse.out_dim, d.coarse.in_dim), (1, m.coarse.layers[sigma_layer(&m.topology)].in_dim));
        assert_eq!(m.fine.as_ref().and_then(|f| f.precise?.density), d.fine);
        let refused = |m: &Model<'_>| Model::from_bytes(&encode(m).unwrap()).unwrap_err();
        fn with<'a>(m: &Model<'a>, coarse: Layer<'a>) -> Model<'a> {
            let mut bad = m.clone();
            let (d, p) = (m.precise_density.unwrap(), m.precise.unwrap());
            bad.precise_density = Some(PreciseDensity { coarse, ..d });
            bad.precise = Some(Precise { coarse: PreciseNet { density: Some(coarse), ..p.coarse }, ..p });
            bad
        }
        // one weight short, one input too many
        let short = Layer { weights: &d.coarse.weights[..d.coarse.weights.len() - 2], ..d.coarse };
        assert!(matches!(refused(&with(&m, short)), Error::TensorLength(_)));
        let wide = Layer { in_dim: d.coarse.in_dim + 1, ..d.coarse };
        assert!(matches!(refused(&with(&m, wide)), Error::LayerShape(_)));
        // without the other 16-bit parts
        let mut bad = m.clone();
        bad.precise = None;
        assert!(matches!(refused(&bad), Error::InvalidTopology(_)));
        // the record and the networks disagree
        let mut bad = m.clone();
        bad.precise_density = None;
        assert!(matches!(bad.validate(), Err(Error::InvalidTopology(_))));
        // a crafted file with too few layers is refused, not read past its end
        let mut bad = m.clone();
        bad.coarse.layers.truncate(1);
        assert!(Model::from_bytes(&encode(&bad).unwrap()).is_err());
        // the version-7 reader's view of it: older files still read
        let old = Model::from_bytes(include_bytes!("../../tests/data/golden8_precise.nerf")).unwrap();
        assert!(old.precise_density.is_none() && old.coarse.precise.unwrap().density.is_none());
    }

    /// Without the `feature-grid` feature a model with a feature grid is
    /// refused before anything else is checked; with it, this one (whose
    /// layer 0 lacks the grid's inputs) fails on that instead.
    #[cfg(feature = "alloc")]
    #[test]
    fn feature_grid_models_need_the_feature() {
        let table = [0u8; 8 * 2 * 2]; // 1 cell: 8 vertices of 2 i16
        let mut m = Model::from_bytes(include_bytes!("../../tests/data/golden.nerf")).unwrap();
        let resolutions = heapless::Vec::from_slice(&[1]).unwrap();
        m.features =
            Some(FeatureGrid { width: 2, log2_table: 3, frac_bits: 8, resolutions, table: &table, narrow: None });
        let e = Model::from_bytes(&encode(&m).unwrap()).unwrap_err();
        if cfg!(feature = "feature-grid") {
            assert_eq!(e, Error::LayerShape(0));
        } else {
            assert!(matches!(e, Error::Capacity(s) if s.contains("feature-grid")), "{e:?}");
        }
    }

    /// A narrow feature table makes a version-7 model. Files whose table,
    /// codebook or bits disagree, with codes but no grid, or with codes in
    /// an f32 model are refused with `InvalidEncoding` (a valid one round
    /// trips in the workspace's tests/features.rs).
    #[cfg(feature = "alloc")]
    #[test]
    fn narrow_tables_are_version_7_and_checked() {
        let table = [0u8; 8 * 2 / 2]; // 1 cell: 8 vertices of 2 4-bit indices
        let codebook = [0u8; 16 * 2];
        let narrow = NarrowTable { bits: 4, codebook: &codebook };
        let mut m = Model::from_bytes(include_bytes!("../../tests/data/golden8.nerf")).unwrap();
        let resolutions = heapless::Vec::from_slice(&[1]).unwrap();
        let grid =
            FeatureGrid { width: 2, log2_table: 3, frac_bits: 8, resolutions, table: &table, narrow: Some(narrow) };
        m.features = Some(grid.clone());
        m.narrow = Some(narrow);
        assert_eq!(m.format_version(), 7);
        let decoded = |m: &Model<'_>| Model::from_bytes(&encode(m).unwrap()).map(|_| ());
        // consistent: the checks pass the table and fail later on layer 0's missing grid inputs
        if !cfg!(feature = "feature-grid") {
            return;
        }
        assert_eq!(decoded(&m), Err(Error::LayerShape(0)));
        let invalid = |m: &Model<'_>| matches!(decoded(m), Err(Error::InvalidEncoding(_)));
        for bits in [0, 5, 8, 16, 255] {
            let other = NarrowTable { bits, ..narrow };
            let bad = Model {
                narrow: Some(other),
                features: Some(FeatureGrid { narrow: Some(other), ..grid.clone() }),
                ..m.clone()
            };
            assert!(invalid(&bad), "{bits} bits");
        }
        let short = NarrowTable { codebook: &codebook[2..], ..narrow };
        let bad = Model {
            narrow: Some(short),
            features: Some(FeatureGrid { narrow: Some(short), ..grid.clone() }),
            ..m.clone()
        };
        assert!(invalid(&bad));
        let bad = Model { features: Some(FeatureGrid { table: &table[1..], ..grid.clone() }), ..m.clone() };
        assert!(invalid(&bad));
        let bad = Model { features: None, ..m.clone() };
        assert!(invalid(&bad));
        let mut f = m.clone();
        f.coarse.scheme = Scheme::F32;
        assert!(matches!(f.validate(), Err(Error::InvalidEncoding(s)) if s.contains("f32")));
    }
}

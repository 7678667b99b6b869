//! The owned model (with the `alloc` feature): a mirror of [`Model`] whose
//! tensors a program builds and edits (the exporter, tests that make
//! models), written by the same serialiser and validation as every model
//! file ([`to_bytes`]).

use super::{
    to_bytes, Capture, Encoding, FeatureGrid, FittedOrbit, Footprint, Layer, Meta, Model, NarrowTable, Network,
    Occupancy, Precise, PreciseDensity, PreciseNet, Proposal, Samples, Scene, Scheme, Topology, MAX_LAYERS,
};
use crate::error::Error;
use alloc::vec::Vec;

/// A layer owning its tensor bytes (see [`Layer`]).
#[derive(Clone, Debug, PartialEq)]
pub struct OwnedLayer {
    /// Input width.
    pub in_dim: u16,
    /// Output width.
    pub out_dim: u16,
    /// Largest |output| on calibration rays.
    pub act_max: f32,
    /// Weight bytes.
    pub weights: Vec<u8>,
    /// Bias bytes.
    pub bias: Vec<u8>,
    /// Scale bytes.
    pub scales: Vec<u8>,
    /// Requantisation bytes.
    pub requant: Vec<u8>,
}

/// A network owning its layers.
#[derive(Clone, Debug, PartialEq)]
pub struct OwnedNetwork {
    /// Weight scheme.
    pub scheme: Scheme,
    /// Activation bits.
    pub act_bits: u8,
    /// Layers.
    pub layers: Vec<OwnedLayer>,
    /// The parts kept at 16 bits (format version 6; the density head: 8).
    pub precise: Option<OwnedPrecise>,
}

/// A network's 16-bit parts, owned (see [`PreciseNet`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OwnedPrecise {
    /// The view layer's direction rows, i16 LE (empty: none).
    pub view_dirs: Vec<u8>,
    /// The colour head with i16 weights.
    pub colour: Option<OwnedLayer>,
    /// The density head with i16 weights (format version 8).
    pub density: Option<OwnedLayer>,
}

impl OwnedLayer {
    fn view(&self) -> Layer<'_> {
        Layer {
            in_dim: self.in_dim,
            out_dim: self.out_dim,
            act_max: self.act_max,
            weights: &self.weights,
            bias: &self.bias,
            scales: &self.scales,
            requant: &self.requant,
        }
    }

    fn from_view(l: &Layer<'_>) -> Self {
        OwnedLayer {
            in_dim: l.in_dim,
            out_dim: l.out_dim,
            act_max: l.act_max,
            weights: l.weights.to_vec(),
            bias: l.bias.to_vec(),
            scales: l.scales.to_vec(),
            requant: l.requant.to_vec(),
        }
    }
}

impl OwnedPrecise {
    fn view(&self) -> PreciseNet<'_> {
        PreciseNet {
            view_dirs: &self.view_dirs,
            colour: self.colour.as_ref().map(OwnedLayer::view),
            density: self.density.as_ref().map(OwnedLayer::view),
        }
    }

    fn from_view(p: &PreciseNet<'_>) -> Self {
        Self {
            view_dirs: p.view_dirs.to_vec(),
            colour: p.colour.as_ref().map(OwnedLayer::from_view),
            density: p.density.as_ref().map(OwnedLayer::from_view),
        }
    }
}

/// A model owning its tensors; [`OwnedModel::to_bytes`] writes the file.
#[derive(Clone, Debug, PartialEq)]
pub struct OwnedModel {
    /// Scene.
    pub scene: Scene,
    /// Encoding.
    pub encoding: Encoding,
    /// Topology.
    pub topology: Topology,
    /// Default samples.
    pub samples: Samples,
    /// Provenance.
    pub meta: Meta,
    /// Coarse network.
    pub coarse: OwnedNetwork,
    /// Fine network.
    pub fine: Option<OwnedNetwork>,
    /// Occupancy grid: cells per axis and the bits (format version 2).
    pub grid: Option<(u16, Vec<u8>)>,
    /// Learned feature grid (format version 3): its shape (`table` empty)
    /// and the table bytes (f32 LE, or i16 LE in quantised models).
    pub features: Option<(FeatureGrid<'static>, Vec<u8>)>,
    /// How the training capture was split and framed (format version 4).
    pub capture: Option<Capture>,
    /// The feature table's index bits and codebook bytes when its values
    /// are codebook indices (format version 7, [`NarrowTable`]).
    pub narrow: Option<(u8, Vec<u8>)>,
    /// The orbit fitted to the training cameras (format version 9).
    pub orbit: Option<FittedOrbit>,
    /// Features averaged over each sample's pixel footprint (format
    /// version 10).
    pub footprint: Option<Footprint>,
    /// The proposal grid (format version 11): its shape and scale
    /// (`codes` empty) and the codes.
    pub proposal: Option<(Proposal<'static>, Vec<u8>)>,
}

impl OwnedNetwork {
    fn view(&self) -> Network<'_> {
        let mut layers = heapless::Vec::new();
        for l in &self.layers {
            let _ = layers.push(l.view());
        }
        let precise = self.precise.as_ref().map(OwnedPrecise::view);
        Network { scheme: self.scheme, act_bits: self.act_bits, layers, precise }
    }

    fn from_view(n: &Network<'_>) -> Self {
        let layers = n.layers.iter().map(OwnedLayer::from_view).collect();
        let precise = n.precise.as_ref().map(OwnedPrecise::from_view);
        Self { scheme: n.scheme, act_bits: n.act_bits, layers, precise }
    }
}

impl OwnedModel {
    /// The file bytes (validated by the same code that loads them).
    pub fn to_bytes(&self) -> Result<Vec<u8>, Error> {
        if self.coarse.layers.len() > MAX_LAYERS {
            return Err(Error::Capacity("more than 24 layers"));
        }
        let narrow = self.narrow.as_ref().map(|(bits, codebook)| NarrowTable { bits: *bits, codebook });
        let m = Model {
            scene: self.scene,
            encoding: self.encoding,
            topology: self.topology,
            samples: self.samples,
            meta: self.meta,
            coarse: self.coarse.view(),
            fine: self.fine.as_ref().map(|f| f.view()),
            grid: self.grid.as_ref().map(|(res, bits)| Occupancy { res: *res, bits }),
            features: self.features.as_ref().map(|(f, t)| FeatureGrid { narrow, ..f.with_table(t) }),
            capture: self.capture,
            unbounded: self.scene.unbounded,
            precise: self.coarse.precise.as_ref().map(|p| Precise {
                coarse: p.view(),
                fine: self.fine.as_ref().and_then(|f| f.precise.as_ref()).map(OwnedPrecise::view),
            }),
            narrow,
            precise_density: self.coarse.precise.as_ref().and_then(|p| p.density.as_ref()).map(|d| PreciseDensity {
                coarse: d.view(),
                fine: self.fine.as_ref().and_then(|f| f.precise.as_ref()?.density.as_ref()).map(OwnedLayer::view),
            }),
            orbit: self.orbit,
            footprint: self.footprint,
            proposal: self.proposal.as_ref().map(|(p, codes)| Proposal { codes, ..*p }),
        };
        to_bytes(&m)
    }

    /// An owned copy of a decoded model.
    pub fn from_model(m: &Model<'_>) -> Self {
        Self {
            scene: m.scene,
            encoding: m.encoding,
            topology: m.topology,
            samples: m.samples,
            meta: m.meta,
            coarse: OwnedNetwork::from_view(&m.coarse),
            fine: m.fine.as_ref().map(OwnedNetwork::from_view),
            grid: m.grid.map(|g| (g.res, g.bits.to_vec())),
            features: m.features.as_ref().map(|f| (f.with_table(&[]), f.table.to_vec())),
            capture: m.capture,
            narrow: m.narrow.map(|n| (n.bits, n.codebook.to_vec())),
            orbit: m.orbit,
            footprint: m.footprint,
            proposal: m.proposal.map(|p| (Proposal { codes: &[], ..p }, p.codes.to_vec())),
        }
    }
}

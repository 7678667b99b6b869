//! A network's dense layers as stored, and the shapes a topology implies.

use super::records::{Encoding, Scheme, Topology};
use crate::fixed::Requant;
use crate::limits::MAX_LAYERS;
use crate::tensor::{read_f32, read_i32};
use serde::{Deserialize, Serialize};

/// One dense layer `y = W·x + b`. Activation follows from its position.
///
/// * `weights`: `in_dim · out_dim` elements, input-major (`[in][out]`:
///   element `(j, c)` at index `j·out_dim + c`), f32/i16/i8 little-endian.
/// * `bias`: `out_dim` elements, f32 for [`Scheme::F32`], otherwise i32 in
///   accumulator units (real bias = `bias[c] · scales[c]`).
/// * `scales`: integer schemes only, `out_dim` f32: real accumulator value
///   = integer accumulator · `scales[c]`.
/// * `requant`: integer schemes only, `out_dim` pairs (i32 multiplier, i32
///   shift) of [`Requant`] mapping the accumulator to the output format.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct Layer<'a> {
    /// Input width.
    pub in_dim: u16,
    /// Output width.
    pub out_dim: u16,
    /// Largest |output| seen on calibration rays (0 = not measured).
    pub act_max: f32,
    /// Weight tensor bytes.
    #[serde(borrow)]
    pub weights: &'a [u8],
    /// Bias tensor bytes.
    #[serde(borrow)]
    pub bias: &'a [u8],
    /// Per-output accumulator scales (integer schemes), f32 LE.
    #[serde(borrow)]
    pub scales: &'a [u8],
    /// Per-output requantisation constants (integer schemes), 2 × i32 LE.
    #[serde(borrow)]
    pub requant: &'a [u8],
}

impl Layer<'_> {
    /// Real-valued scale of output channel `c` (integer schemes).
    pub fn scale(&self, c: usize) -> f32 {
        read_f32(self.scales, c)
    }
    /// Requantisation constants of output channel `c` (integer schemes).
    #[inline(always)]
    pub fn requant(&self, c: usize) -> Requant {
        Requant { multiplier: read_i32(self.requant, 2 * c), shift: read_i32(self.requant, 2 * c + 1) }
    }
}

/// One MLP: the trunk, the density head and the colour head(s).
///
/// Layer order: trunk `0..depth`; density head (`width → 1`, ReLU applied
/// at compositing); then either feature (`width → width`, linear), view
/// (`width + dir_dim → view_width`, ReLU, input `[feature, γ(d)]`) and
/// colour (`view_width → 3`, sigmoid), or colour (`width → 3`, sigmoid).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Network<'a> {
    /// Numeric scheme of every layer's weights.
    pub scheme: Scheme,
    /// Activation width in bits: 32 for f32; 16 for int16 weights; 16 or 8
    /// for int8 weights (8: hidden ReLU outputs in `[0, 255]`, the linear
    /// feature layer in `[−127, 127]`; the encoding stays 16-bit).
    pub act_bits: u8,
    /// The layers, in the order documented above.
    #[serde(borrow)]
    pub layers: heapless::Vec<Layer<'a>, MAX_LAYERS>,
    /// The parts kept at 16 bits ([`PreciseNet`], format version 6). Not
    /// stored here: set from [`Model::precise`](super::Model::precise) when
    /// a model is decoded.
    #[serde(skip)]
    pub precise: Option<PreciseNet<'a>>,
}

/// Index of the density head.
pub const fn sigma_layer(t: &Topology) -> usize {
    t.depth as usize
}

/// Input and output width of layer `i` of a network with this shape.
pub fn expected_shape(t: &Topology, e: &Encoding, i: usize) -> (usize, usize) {
    let w = t.width as usize;
    let d = t.depth as usize;
    if i < d {
        let din = if i == 0 {
            e.pos_dim()
        } else if t.is_skip(i) {
            w + e.pos_dim()
        } else {
            w
        };
        return (din, w);
    }
    match (i - d, t.view_dependent) {
        (0, _) => (w, 1),
        (1, true) => (w, w),
        (2, true) => (w + e.dir_dim(), t.view_width as usize),
        (3, true) => (t.view_width as usize, 3),
        (1, false) => (w, 3),
        _ => (0, 0),
    }
}

/// Whether layer `i` may be narrower than the topology says: trunk layers
/// and the view layer (ReLU outputs, pruned at export when never active).
pub const fn prunable(t: &Topology, i: usize) -> bool {
    i < t.depth as usize || (t.view_dependent && i == t.depth as usize + 2)
}

/// Input and output width layer `i` must have given the widths of the
/// layers before it (format version 2: pruned layers are narrower).
/// Output: the layer's own `out_dim` for prunable layers (checked to be in
/// `1..=` the topology's width by the reader), the topology's otherwise.
pub fn pruned_shape(t: &Topology, e: &Encoding, layers: &[Layer<'_>], i: usize) -> (usize, usize) {
    let d = t.depth as usize;
    let out = |k: usize| layers.get(k).map_or(0, |l| l.out_dim as usize);
    let dout = if prunable(t, i) { out(i) } else { expected_shape(t, e, i).1 };
    if i < d {
        let din = if i == 0 {
            e.pos_dim()
        } else if t.is_skip(i) {
            out(i - 1) + e.pos_dim()
        } else {
            out(i - 1)
        };
        return (din, dout);
    }
    let trunk = out(d - 1);
    let din = match (i - d, t.view_dependent) {
        (0, _) | (1, _) => trunk,
        (2, true) => out(d + 1) + e.dir_dim(),
        (3, true) => out(d + 2),
        _ => 0,
    };
    (din, dout)
}

/// The parts of an integer model's networks kept at 16 bits (format
/// version 6): the two where 8-bit weights cost the most PSNR and the
/// least time at 16 bits; the density head joins them from version 8
/// ([`PreciseDensity`]).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct Precise<'a> {
    /// The coarse network's.
    #[serde(borrow)]
    pub coarse: PreciseNet<'a>,
    /// The fine network's, present iff the model has a fine network.
    #[serde(borrow)]
    pub fine: Option<PreciseNet<'a>>,
}

/// One network's 16-bit parts ([`Precise`]).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct PreciseNet<'a> {
    /// The view layer's direction rows, `dir_dim × out_dim` i16 LE,
    /// input-major, or empty (the layer's own rows then). The direction is
    /// the same for every sample of a ray, so these rows are summed once
    /// per ray: row `j` of channel `c` holds `w[j][c]` in steps of
    /// 2^−[`PreciseNet::SHIFT`] of the layer's weight step, and the per-ray
    /// start of channel `c`'s sum is `bias[c] + round(Σ_j γ(d)[j] · w[j][c]
    /// / 2^SHIFT)` (ties up). The layer's own tensor still holds the rows at
    /// its precision; renderers of version 6 read these instead.
    #[serde(borrow)]
    pub view_dirs: &'a [u8],
    /// The colour head with i16 weights (its own bias, scales and
    /// requantisation, quantised as in an int16 model), used instead of the
    /// network's last layer; `None`: that layer.
    #[serde(borrow)]
    pub colour: Option<Layer<'a>>,
    /// The density head with i16 weights (format version 8, quantised as
    /// in an int16 model), used instead of the network's density head;
    /// `None`: that layer. Not stored here: set from
    /// [`Model::precise_density`](super::Model::precise_density) when a
    /// model is decoded.
    #[serde(skip)]
    pub density: Option<Layer<'a>>,
}

/// The density heads of an integer model kept at 16 bits (format version
/// 8): in an int8 model, 8-bit density weights cost the most PSNR of any
/// layer once training has sharpened the density (docs/EXPERIMENTS.md),
/// and the head is one output wide.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct PreciseDensity<'a> {
    /// The coarse network's.
    #[serde(borrow)]
    pub coarse: Layer<'a>,
    /// The fine network's, present iff the model has a fine network.
    #[serde(borrow)]
    pub fine: Option<Layer<'a>>,
}

impl PreciseNet<'_> {
    /// Fraction bits of the stored direction rows below the layer's weight
    /// step: 8, so int8 rows (±127 steps) become ±32512.
    pub const SHIFT: u32 = 8;

    /// Tensor bytes held.
    pub fn bytes(&self) -> usize {
        let layer = |l: Layer<'_>| l.weights.len() + l.bias.len() + l.scales.len() + l.requant.len();
        self.view_dirs.len() + self.colour.map_or(0, layer) + self.density.map_or(0, layer)
    }
}

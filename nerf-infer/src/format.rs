//! The model file format (versions 1 to 5). The full layout is in `FORMAT.md`.
//!
//! A model is a 14-byte header followed by a postcard payload:
//!
//! | offset | size | field                                   |
//! |--------|------|-----------------------------------------|
//! | 0      | 4    | magic `b"NERF"`                          |
//! | 4      | 2    | format version, u16 little-endian (1–5)  |
//! | 6      | 4    | payload length in bytes, u32 LE         |
//! | 10     | 4    | CRC-32 (IEEE) of the payload, u32 LE    |
//! | 14     | n    | payload: [`Model`] in postcard encoding |
//!
//! Version 2 appends one field, the optional occupancy grid; version 3
//! another, the optional learned feature grid ([`FeatureGrid`]); version 4
//! the optional record of the training capture's split ([`Capture`]);
//! version 5 unbounded space ([`Unbounded`]). A model is written as the
//! oldest version that holds it (not unbounded: 4; no capture record
//! either: 3; no feature grid either: 2; no occupancy grid and no pruned
//! layer either: 1), byte for byte what earlier builds wrote, so older readers
//! keep reading it.
//!
//! Tensors are borrowed from the blob ([`Model::from_bytes`] never copies or
//! allocates), so a model can live in flash. Multi-byte tensor elements are
//! little-endian and read without alignment requirements.

use crate::error::{Error, Result};
pub use crate::features::FeatureGrid;
use crate::fixed::Requant;
pub use crate::occupancy::Occupancy;
use serde::{Deserialize, Serialize};

pub use crate::limits::{
    FORMAT_VERSION, FORMAT_VERSION_NO_CAPTURE, FORMAT_VERSION_NO_FEATURES, FORMAT_VERSION_NO_GRID,
    FORMAT_VERSION_NO_UNBOUNDED, HEADER_LEN, MAGIC, MAX_COARSE, MAX_FINE, MAX_FREQS, MAX_INPUT, MAX_LAYERS, MAX_WIDTH,
};
pub use crate::tensor::{read_f32, read_i32};

/// Numeric scheme of a network's weights.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    /// f32 weights and biases; rendered by the f32 path.
    F32,
    /// int16 weights with per-output-channel scales; i64 accumulation.
    I16,
    /// int8 weights with per-output-channel scales; i32 accumulation.
    I8,
}

impl Scheme {
    /// Bytes per weight element.
    pub const fn weight_bytes(self) -> usize {
        match self {
            Scheme::F32 => 4,
            Scheme::I16 => 2,
            Scheme::I8 => 1,
        }
    }
    /// Weight bits (32, 16 or 8).
    pub const fn bits(self) -> u32 {
        self.weight_bytes() as u32 * 8
    }
    /// True for the integer schemes rendered by the fixed-point path.
    pub const fn is_fixed(self) -> bool {
        !matches!(self, Scheme::F32)
    }
}

/// Camera convention of the poses the model was trained with.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraConvention {
    /// OpenGL/Blender: camera looks down −z, +y up, +x right.
    OpenGl,
}

/// Normalised-device-coordinate ray space of forward-facing (LLFF) scenes.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct Ndc {
    /// Focal length of the training cameras, in pixels.
    pub focal: f32,
    /// Training image width in pixels.
    pub width: f32,
    /// Training image height in pixels.
    pub height: f32,
}

/// Where the scene is and how rays see it.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct Scene {
    /// Axis-aligned bounds of the content, world units (NDC units if `ndc`).
    pub bounds_min: [f32; 3],
    /// Upper corner of the bounds; each component > `bounds_min`.
    pub bounds_max: [f32; 3],
    /// Near plane distance along the ray parameter `t` (units of `|d|`, `d.z = −1` in camera space).
    pub near: f32,
    /// Far plane distance, > `near`.
    pub far: f32,
    /// Composite on white (true, Blender) or black (false).
    pub white_background: bool,
    /// Pose convention.
    pub convention: CameraConvention,
    /// Rays are mapped to NDC before sampling (forward-facing scenes).
    pub ndc: Option<Ndc>,
    /// Space beyond the bounds is contracted into a shell around them
    /// (format version 5). Not stored here: set from [`Model::unbounded`]
    /// when a model is decoded.
    #[serde(skip)]
    pub unbounded: Option<Unbounded>,
}

/// Unbounded space (mip-NeRF 360's contraction, with the max norm): a
/// normalised position `u` (bounds ↦ `[−1, 1]³`) with `m = ‖u‖∞` enters the
/// grid and the network as `u/2` when `m ≤ 1` and as `u/m · (1 − 1/(2m))`
/// beyond, so all of space fits `[−1, 1]³` and the bounds fill its inner
/// half. Rays are not clipped to the bounds; samples are spaced evenly in
/// `t` up to [`Unbounded::linear_until`] and evenly in `1/t` beyond it, up
/// to the scene's `far`.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct Unbounded {
    /// Ray parameter `T` (units of `t`, > 0, below `far`) where the sample
    /// spacing turns from even in `t` to even in `1/t`: a sample at `s ∈
    /// [0, 1)` sits at `t = 2Ts` below `s = 1/2` and at `T/(2(1 − s))` above.
    pub linear_until: f32,
}

/// Positional encoding parameters (NeRF eq. 4): per coordinate p,
/// `γ(p) = (p, sin(2⁰πp), cos(2⁰πp), …, sin(2^{L−1}πp), cos(2^{L−1}πp))`.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Encoding {
    /// Frequencies `L` for positions (0..=16; 0 disables the encoding).
    pub pos_freqs: u8,
    /// Frequencies `L` for view directions (0..=16).
    pub dir_freqs: u8,
    /// Whether the raw coordinate is included before the sin/cos features.
    pub include_input: bool,
    /// Fixed path: raw positions enter the first layer as i16 with this many
    /// fractional bits (0..=15). Ignored by the f32 path.
    pub raw_frac_bits: u8,
    /// Values of the learned feature grid appended to γ(x) (`levels ×
    /// width` of [`Model::features`], 0 without one). Not stored: set from
    /// the feature grid when a model is decoded.
    #[serde(skip)]
    pub grid_dim: u8,
}

impl Encoding {
    /// Width of the encoded position: γ(x), then the feature grid's values.
    pub const fn pos_dim(&self) -> usize {
        self.gamma_dim() + self.grid_dim as usize
    }
    /// Width of γ(x) alone.
    pub const fn gamma_dim(&self) -> usize {
        3 * (self.include_input as usize + 2 * self.pos_freqs as usize)
    }
    /// Width of the encoded direction.
    pub const fn dir_dim(&self) -> usize {
        3 * (self.include_input as usize + 2 * self.dir_freqs as usize)
    }
}

/// The MLP's shape (NeRF fig. 7, configurable).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Topology {
    /// Trunk layers (each `width` wide, ReLU), ≥ 1.
    pub depth: u8,
    /// Trunk width (1..=256).
    pub width: u16,
    /// Bit `i` set: trunk layer `i` (≥ 1) takes `[γ(x), h]` as input.
    pub skip_mask: u16,
    /// View-dependent colour branch (feature layer + view layer) on or off.
    pub view_dependent: bool,
    /// Width of the view layer (1..=256); ignored without the branch.
    pub view_width: u16,
}

impl Topology {
    /// Number of layers a network of this topology has.
    pub const fn layer_count(&self) -> usize {
        self.depth as usize + if self.view_dependent { 4 } else { 2 }
    }
    /// Whether trunk layer `i` takes the encoded position as extra input.
    pub const fn is_skip(&self, i: usize) -> bool {
        i > 0 && i < 16 && self.skip_mask & (1 << i) != 0
    }
}

/// Default sample counts per ray.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Samples {
    /// Stratified samples evaluated by the coarse network (2..=256).
    pub coarse: u16,
    /// Importance samples added for the fine network (0..=256; 0: no fine pass).
    pub fine: u16,
}

/// Provenance recorded by the trainer.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Meta {
    /// Dataset downscale factor used for training (1 = full resolution).
    pub train_downscale: u16,
    /// Training iterations run.
    pub iterations: u32,
}

/// How the scene's frame was chosen when the capture was loaded for training.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Framing {
    /// Given by the capture's own files (bounds or an `aabb` in them).
    Files,
    /// Fitted: a box around what the cameras look at.
    Object,
    /// Forward-facing: NDC rays.
    Forward,
    /// Fitted: a box holding the cameras and their surroundings.
    Unbounded,
}

/// How the training capture was split and framed (format version 4), so
/// that evaluation and rendering load the capture as training did and
/// score only views the model never saw.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Capture {
    /// Every `holdout`-th view in capture order (0, N, 2N, …) was held out
    /// of training (1..=100 000; LLFF, COLMAP, instant-ngp).
    pub holdout: u32,
    /// Views in the whole capture, training and held out.
    pub views: u32,
    /// CRC-32 ([`crc32`]) of the held-out views' names (image file stems),
    /// each followed by `\n`, in capture order.
    pub held_out_crc: u32,
    /// How the scene's frame was chosen.
    pub framing: Framing,
    /// Rays followed the photos' lens distortion (false: treated as pinholes).
    pub lens: bool,
}

impl Capture {
    /// Largest valid [`Capture::holdout`].
    pub const MAX_HOLDOUT: u32 = 100_000;
}

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
}

/// Index of the density head.
pub const fn sigma_layer(t: &Topology) -> usize {
    t.depth as usize
}

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
}

/// An older version's payload read as the newest: the payload, then one
/// `0` byte (postcard's `None`) for each field appended since. Tensors are
/// borrowed from the payload; the padding only ever holds `None` tags.
struct Padded<'a> {
    rest: &'a [u8],
    absent: usize,
}

impl<'a> postcard::de_flavors::Flavor<'a> for Padded<'a> {
    type Remainder = ();
    type Source = &'a [u8];

    fn pop(&mut self) -> postcard::Result<u8> {
        if let Some((&b, rest)) = self.rest.split_first() {
            self.rest = rest;
            Ok(b)
        } else if self.absent > 0 {
            self.absent -= 1;
            Ok(0)
        } else {
            Err(postcard::Error::DeserializeUnexpectedEnd)
        }
    }

    fn try_take_n(&mut self, ct: usize) -> postcard::Result<&'a [u8]> {
        if ct > self.rest.len() {
            return Err(postcard::Error::DeserializeUnexpectedEnd);
        }
        let (taken, rest) = self.rest.split_at(ct);
        self.rest = rest;
        Ok(taken)
    }

    /// The payload must be exactly its version's encoding: no bytes left,
    /// every appended field read as absent.
    fn finalize(self) -> postcard::Result<()> {
        if self.rest.is_empty() && self.absent == 0 {
            Ok(())
        } else {
            Err(postcard::Error::DeserializeBadEncoding)
        }
    }
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

    /// Tensor bytes the model would have without pruning.
    pub fn unpruned_tensor_bytes(&self) -> usize {
        let (t, e) = (&self.topology, &self.encoding);
        let per_layer = |n: &Network<'_>, i: usize| {
            let (din, dout) = expected_shape(t, e, i);
            let b = n.scheme.weight_bytes();
            din * dout * b + 4 * dout + if n.scheme.is_fixed() { 12 * dout } else { 0 }
        };
        core::iter::once(&self.coarse)
            .chain(self.fine.as_ref())
            .map(|n| (0..n.layers.len()).map(|i| per_layer(n, i)).sum::<usize>())
            .sum()
    }

    /// The format version this model is written as: 5 with unbounded
    /// space, 4 with a capture record, 3 with a feature grid, 2 with an
    /// occupancy grid or pruned layers, else 1.
    pub fn format_version(&self) -> u16 {
        if self.unbounded.is_some() {
            FORMAT_VERSION
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

    /// Bytes of the feature grid's table (0 without one).
    pub fn feature_bytes(&self) -> usize {
        self.features.as_ref().map_or(0, |f| f.table.len())
    }

    /// Total bytes of all tensors (weights, biases, scales, requant).
    pub fn tensor_bytes(&self) -> usize {
        core::iter::once(&self.coarse)
            .chain(self.fine.as_ref())
            .flat_map(|n| n.layers.iter())
            .map(|l| l.weights.len() + l.bias.len() + l.scales.len() + l.requant.len())
            .sum()
    }

    /// Checks every field; called by [`Model::from_bytes`].
    pub fn validate(&self) -> Result<()> {
        let s = &self.scene;
        let finite3 = |v: &[f32; 3]| v.iter().all(|x| x.is_finite());
        if !finite3(&s.bounds_min) || !finite3(&s.bounds_max) {
            return Err(Error::InvalidScene("bounds are not finite"));
        }
        if (0..3).any(|i| s.bounds_min[i] >= s.bounds_max[i]) {
            return Err(Error::InvalidScene("bounds_min is not below bounds_max"));
        }
        if !(s.near.is_finite() && s.far.is_finite() && s.near >= 0.0 && s.near < s.far) {
            return Err(Error::InvalidScene("need finite 0 <= near < far"));
        }
        if s.far > 30000.0 {
            return Err(Error::InvalidScene("far exceeds the fixed-point range (30000)"));
        }
        if s.unbounded != self.unbounded {
            return Err(Error::InvalidScene("scene.unbounded differs from the model's unbounded field"));
        }
        if let Some(u) = s.unbounded {
            if s.ndc.is_some() || !(u.linear_until.is_finite() && u.linear_until > 0.0 && u.linear_until < s.far) {
                return Err(Error::InvalidScene("unbounded space needs 0 < linear_until < far and no NDC"));
            }
        }
        if let Some(n) = s.ndc {
            let finite = n.focal.is_finite() && n.width.is_finite() && n.height.is_finite();
            if !(finite && n.focal > 0.0 && n.width >= 1.0 && n.height >= 1.0) {
                return Err(Error::InvalidScene("NDC parameters"));
            }
        }
        let e = &self.encoding;
        if e.pos_freqs as usize > MAX_FREQS || e.dir_freqs as usize > MAX_FREQS {
            return Err(Error::InvalidEncoding("more than 16 frequencies"));
        }
        if e.raw_frac_bits > 15 {
            return Err(Error::InvalidEncoding("raw_frac_bits above 15"));
        }
        if e.pos_dim() == 0 || (self.topology.view_dependent && e.dir_dim() == 0) {
            return Err(Error::InvalidEncoding("empty encoding"));
        }
        let t = &self.topology;
        if t.depth == 0 || t.width == 0 || (t.view_dependent && t.view_width == 0) {
            return Err(Error::InvalidTopology("zero depth or width"));
        }
        if t.width as usize > MAX_WIDTH || t.view_width as usize > MAX_WIDTH {
            return Err(Error::Capacity("layer width above 256"));
        }
        if t.layer_count() > MAX_LAYERS {
            return Err(Error::Capacity("more than 24 layers"));
        }
        if t.skip_mask & 1 != 0 || (t.depth < 16 && t.skip_mask >> t.depth != 0) {
            return Err(Error::InvalidTopology("skip mask names a layer outside 1..depth"));
        }
        let sm = &self.samples;
        if sm.coarse < 2 || sm.coarse as usize > MAX_COARSE || sm.fine as usize > MAX_FINE {
            return Err(Error::InvalidSamples);
        }
        if (sm.fine > 0) != self.fine.is_some() {
            return Err(Error::InvalidTopology("fine samples without a fine network or vice versa"));
        }
        if self.grid.is_some_and(|g| !g.is_valid()) {
            return Err(Error::InvalidTopology("occupancy grid resolution or length"));
        }
        if self.features.is_some() && !cfg!(feature = "feature-grid") {
            return Err(Error::Capacity("feature grid (nerf-infer built without its `feature-grid` feature)"));
        }
        let elem = if self.scheme().is_fixed() { 2 } else { 4 };
        if self.features.as_ref().is_some_and(|f| !f.is_valid(elem)) {
            return Err(Error::InvalidEncoding("feature grid shape, range or table length"));
        }
        if self.encoding.grid_dim as usize != self.features.as_ref().map_or(0, |f| f.dim()) {
            return Err(Error::InvalidEncoding("grid_dim does not match the feature grid"));
        }
        if self.capture.is_some_and(|c| c.holdout == 0 || c.holdout > Capture::MAX_HOLDOUT || c.views == 0) {
            return Err(Error::InvalidScene("capture record: holdout outside 1..=100000 or no views"));
        }
        self.validate_network(&self.coarse)?;
        if let Some(f) = &self.fine {
            if f.scheme != self.coarse.scheme {
                return Err(Error::MixedScheme(0));
            }
            self.validate_network(f)?;
        }
        Ok(())
    }

    fn validate_network(&self, n: &Network<'_>) -> Result<()> {
        let t = &self.topology;
        let e = &self.encoding;
        if n.layers.len() != t.layer_count() {
            return Err(Error::InvalidTopology("layer count does not match the topology"));
        }
        let act_ok = match n.scheme {
            Scheme::F32 => n.act_bits == 32,
            Scheme::I16 => n.act_bits == 16,
            Scheme::I8 => n.act_bits == 16 || n.act_bits == 8,
        };
        if !act_ok {
            return Err(Error::InvalidTopology("unsupported activation width"));
        }
        for (i, l) in n.layers.iter().enumerate() {
            let (din, dout) = pruned_shape(t, e, &n.layers, i);
            let idx = i as u8;
            let full = expected_shape(t, e, i).1;
            if l.in_dim as usize != din || l.out_dim as usize != dout || dout == 0 || dout > full {
                return Err(Error::LayerShape(idx));
            }
            if !(l.act_max.is_finite() && l.act_max >= 0.0) {
                return Err(Error::InvalidScale(idx));
            }
            let elems = din * dout;
            if l.weights.len() != elems * n.scheme.weight_bytes() || l.bias.len() != 4 * dout {
                return Err(Error::TensorLength(idx));
            }
            if n.scheme.is_fixed() {
                if din > 512 {
                    return Err(Error::Capacity("fixed-point layer input above 512"));
                }
                if l.scales.len() != 4 * dout || l.requant.len() != 8 * dout {
                    return Err(Error::TensorLength(idx));
                }
                for c in 0..dout {
                    let sc = l.scale(c);
                    if !(sc.is_finite() && sc > 0.0 && l.requant(c).is_valid()) {
                        return Err(Error::InvalidScale(idx));
                    }
                }
            } else {
                if !l.scales.is_empty() || !l.requant.is_empty() {
                    return Err(Error::TensorLength(idx));
                }
                let all_finite = (0..elems).all(|k| read_f32(l.weights, k).is_finite())
                    && (0..dout).all(|k| read_f32(l.bias, k).is_finite());
                if !all_finite {
                    return Err(Error::InvalidScale(idx));
                }
            }
        }
        Ok(())
    }
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

/// Checks magic, version, length and checksum; returns the version and the payload.
fn check_header(bytes: &[u8]) -> Result<(u16, &[u8])> {
    if bytes.len() < 4 {
        return Err(Error::Truncated);
    }
    if bytes[0..4] != MAGIC {
        return Err(Error::BadMagic);
    }
    if bytes.len() < HEADER_LEN {
        return Err(Error::Truncated);
    }
    let version = u16::from_le_bytes([bytes[4], bytes[5]]);
    if !(FORMAT_VERSION_NO_GRID..=FORMAT_VERSION).contains(&version) {
        return Err(Error::UnsupportedVersion(version));
    }
    let len = u32::from_le_bytes([bytes[6], bytes[7], bytes[8], bytes[9]]) as usize;
    let crc = u32::from_le_bytes([bytes[10], bytes[11], bytes[12], bytes[13]]);
    let rest = &bytes[HEADER_LEN..];
    if rest.len() < len {
        return Err(Error::Truncated);
    }
    if rest.len() > len {
        return Err(Error::TrailingBytes);
    }
    if crc32(rest) != crc {
        return Err(Error::ChecksumMismatch);
    }
    Ok((version, rest))
}

static CRC_TABLE: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
            k += 1;
        }
        t[i] = c;
        i += 1;
    }
    t
};

/// CRC-32 (IEEE 802.3, reflected, as zlib's `crc32`).
pub fn crc32(data: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in data {
        c = CRC_TABLE[((c ^ b as u32) & 0xFF) as usize] ^ (c >> 8);
    }
    !c
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
        h[4] = 9;
        assert_eq!(Model::from_bytes(&h).unwrap_err(), Error::UnsupportedVersion(9));
    }

    /// A capture record makes a version-4 file that decodes to the same
    /// model; without one the file is the version it was before, and an
    /// invalid record is refused.
    #[cfg(feature = "alloc")]
    #[test]
    fn capture_record_is_version_4() {
        let golden = include_bytes!("../tests/data/golden.nerf");
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

    /// Without the `feature-grid` feature a model with a feature grid is
    /// refused before anything else is checked; with it, this one (whose
    /// layer 0 lacks the grid's inputs) fails on that instead.
    #[cfg(feature = "alloc")]
    #[test]
    fn feature_grid_models_need_the_feature() {
        let table = [0u8; 8 * 2 * 2]; // 1 cell: 8 vertices of 2 i16
        let mut m = Model::from_bytes(include_bytes!("../tests/data/golden.nerf")).unwrap();
        let resolutions = heapless::Vec::from_slice(&[1]).unwrap();
        m.features = Some(FeatureGrid { width: 2, log2_table: 3, frac_bits: 8, resolutions, table: &table });
        let e = Model::from_bytes(&encode(&m).unwrap()).unwrap_err();
        if cfg!(feature = "feature-grid") {
            assert_eq!(e, Error::LayerShape(0));
        } else {
            assert!(matches!(e, Error::Capacity(s) if s.contains("feature-grid")), "{e:?}");
        }
    }
}

//! The NeRF MLP in f32 with a hand-written backward pass.
//!
//! Parameters are one flat `Vec<f32>` per network, layer after layer, each
//! layer as its weights `[in][out]` (input-major, the model format's layout)
//! followed by its bias `[out]`. Layer order and shapes come from
//! [`nerf_infer::format::expected_shape`], so the trainer and the kernel
//! cannot disagree on them.
//!
//! With a learned feature grid ([`Mlp::with_features`]) its table follows
//! the layers in the parameter vector (level, entry, value: the model
//! format's order) and its values follow γ(x) in the trunk's input.
//!
//! Forward and backward work on a chunk of `S` samples belonging to `R`
//! rays with `S/R` consecutive samples per ray (the view direction is per
//! ray). Matrix products go through [`crate::util::gemm::matmul`].
//!
//! Files: this one holds the network's layout and initialisation;
//! `features.rs` the feature grid's lookups and table gradients, `forward.rs`
//! and `backward.rs` the two passes, `retain.rs` the samples dropped
//! between them.

use crate::util::gemm::{matmul, View};
use nerf_infer::camera::FOOTPRINT_POINTS;
use nerf_infer::encoding::encode_f32;
use nerf_infer::features::{Corners, FeatureGrid};
use nerf_infer::format::{expected_shape, Encoding, Topology};
use nerf_infer::per_width;
use rayon::prelude::*;

mod backward;
mod features;
mod forward;
mod position;
pub mod retain;

/// Where one layer's tensors sit in the flat parameter vector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LayerSlot {
    /// Input width.
    pub din: usize,
    /// Output width.
    pub dout: usize,
    /// Offset of the weights (`din·dout` values, `[in][out]`).
    pub w: usize,
    /// Offset of the bias (`dout` values).
    pub b: usize,
}

/// Shape of one network and its parameter layout.
#[derive(Clone, Debug, PartialEq)]
pub struct Mlp {
    /// Network shape.
    pub topo: Topology,
    /// Positional encoding.
    pub enc: Encoding,
    /// Layer tensors in the flat parameter vector.
    pub slots: Vec<LayerSlot>,
    /// The feature grid's shape (its `table` empty: the values are
    /// parameters from [`Mlp::table`] on).
    pub features: Option<FeatureGrid<'static>>,
    /// Offset of the feature grid's table (= the layers' parameter count).
    pub table: usize,
    /// Total parameter count.
    pub n_params: usize,
}

/// The feature-grid part of one chunk's backward pass, for
/// [`Mlp::scatter_table`]: the corners of each sample and level and the
/// gradient of the grid values.
#[derive(Clone, Debug, Default)]
pub struct GridGrad {
    corners: Vec<Corners>,
    dgf: Vec<f32>,
    s: usize,
}

/// Forward activations of a chunk, kept for the backward pass.
#[derive(Clone, Debug, Default)]
pub struct Acts {
    s: usize,
    /// Feature-grid points per sample: 1, or [`FOOTPRINT_POINTS`] with a pixel footprint
    /// ([`Mlp::encode_footprint`]); `corners` and the backward's `dgf` hold `S·k` points.
    k: usize,
    r: usize,
    enc: Vec<f32>,
    /// Feature-grid values per sample (`S × grid_dim`, the footprint's
    /// mean with one) and the corners of their `S·k` points, level after
    /// level (`levels × S·k`: the scatter reads one level at a time).
    gf: Vec<f32>,
    corners: Vec<Corners>,
    dgf: Vec<f32>,
    dgf_part: Vec<f32>,
    denc: Vec<f32>,
    h: Vec<Vec<f32>>,
    /// Raw density per sample (before ReLU).
    pub sigma: Vec<f32>,
    feat: Vec<f32>,
    dirpart: Vec<f32>,
    view: Vec<f32>,
    /// Colour per sample in `[0, 1]`, 3 per sample.
    pub rgb: Vec<f32>,
    // backward scratch
    dh: Vec<f32>,
    dtmp: Vec<f32>,
    dview: Vec<f32>,
    dray: Vec<f32>,
    /// With [`Acts::keep_input_gradient`]: the backward pass's gradient of
    /// γ(x) (`S × gamma_dim`), for [`Mlp::position_gradient`].
    denc_in: Option<Vec<f32>>,
    /// With it, the gradient of γ(d), the view directions' encoding (`R × dir_dim`).
    ddir_in: Vec<f32>,
}

impl Acts {
    /// Whether the next backward passes keep the gradient of the encoded
    /// positions γ(x) ([`Mlp::position_gradient`] reads it); off by default.
    pub fn keep_input_gradient(&mut self, on: bool) {
        self.denc_in = on.then(|| self.denc_in.take().unwrap_or_default());
    }
}

fn resize(v: &mut Vec<f32>, n: usize) {
    v.resize(n, 0.0);
}

impl Mlp {
    /// The layout for a topology and encoding.
    pub fn new(topo: Topology, enc: Encoding) -> Self {
        let mut slots = Vec::new();
        let mut off = 0;
        for i in 0..topo.layer_count() {
            let (din, dout) = expected_shape(&topo, &enc, i);
            slots.push(LayerSlot { din, dout, w: off, b: off + din * dout });
            off += din * dout + dout;
        }
        Self { topo, enc, slots, features: None, table: off, n_params: off }
    }

    /// The same network with a learned feature grid of shape `f` (its
    /// `table` is ignored) in front of the trunk; `enc.grid_dim` must be
    /// `f.dim()`.
    ///
    /// # Panics
    /// If `f`'s values per point (`levels × width`) are not `enc.grid_dim`.
    pub fn with_features(mut self, f: Option<FeatureGrid<'static>>) -> Self {
        if let Some(mut f) = f {
            assert_eq!(self.enc.grid_dim as usize, f.dim(), "encoding.grid_dim");
            f.table = &[];
            self.n_params = self.table + f.values();
            self.features = Some(f);
        }
        self
    }

    /// Width of the encoded position.
    pub fn pos_dim(&self) -> usize {
        self.enc.pos_dim()
    }

    /// Width of γ(x), the part of the encoded position before the grid values.
    fn gamma_dim(&self) -> usize {
        self.enc.gamma_dim()
    }

    /// Initial feature-grid values: uniform in ±`FEATURE_INIT` (instant-ngp's).
    pub const FEATURE_INIT: f32 = 1e-4;

    fn sigma_idx(&self) -> usize {
        self.topo.depth as usize
    }

    /// Initial parameters: PyTorch's default for `nn.Linear`, weights and
    /// biases uniform in `±1/√in`, from a seeded generator — except the
    /// density bias, set to [`Mlp::SIGMA_BIAS_INIT`].
    ///
    /// Why: trunk activations are ReLU outputs that vary little around their
    /// mean at initialisation, so a random density head is often negative
    /// at every point; the compositor's ReLU then passes no gradient and the
    /// network never starts (seen: a coarse network dead from step 0 while
    /// the fine one trained). A positive start makes space semi-opaque
    /// everywhere and lets the loss carve out the empty parts.
    pub fn init(&self, seed: u64) -> Vec<f32> {
        let mut rng = crate::util::rng::Rng::new(seed);
        let mut p = vec![0.0; self.n_params];
        for s in &self.slots {
            let bound = 1.0 / (s.din as f32).sqrt();
            for v in &mut p[s.w..s.b + s.dout] {
                *v = (rng.f32() * 2.0 - 1.0) * bound;
            }
        }
        let s = self.slots[self.sigma_idx()];
        p[s.b] = Self::SIGMA_BIAS_INIT;
        for v in &mut p[self.table..] {
            *v = (rng.f32() * 2.0 - 1.0) * Self::FEATURE_INIT;
        }
        p
    }

    /// Initial density bias of bounded scenes (σ in 1/world units before
    /// the ReLU): with the σ head's weights at ±1/√width on activations of
    /// order 1, this keeps σ > 0 at nearly every point at the start.
    pub const SIGMA_BIAS_INIT: f32 = 1.0;

    /// [`Mlp::init`] with the density head's weights at zero and its bias
    /// at `sigma` (1/world units, > 0): the network starts with the same
    /// density `sigma` at every point, whatever the seed, and the head's
    /// weights learn from the first step (their gradient is the trunk's
    /// activations times the density's).
    pub fn init_uniform_density(&self, seed: u64, sigma: f32) -> Vec<f32> {
        debug_assert!(sigma > 0.0 && sigma.is_finite(), "{sigma}");
        let mut p = self.init(seed);
        let (w, b) = self.density_head();
        p[w].fill(0.0);
        p[b] = sigma;
        p
    }

    /// Where the density head sits in the parameters: the range of its
    /// weights (one per trunk output) and the index of its bias.
    pub fn density_head(&self) -> (std::ops::Range<usize>, usize) {
        let s = self.slots[self.sigma_idx()];
        (s.w..s.w + s.din * s.dout, s.b)
    }

    /// Multiply-accumulates of one forward evaluation (per sample), with
    /// the view layer's direction part counted per sample.
    pub fn macs_per_sample(&self) -> usize {
        self.slots.iter().map(|s| s.din * s.dout).sum()
    }
}

#[cfg(test)]
mod tests;

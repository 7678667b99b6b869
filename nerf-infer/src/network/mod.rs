//! The NeRF MLP evaluated on a block of up to `B` samples of one ray,
//! written once over its numbers ([`Numbers`]: f32, or the fixed-point
//! formats) and a layer kernel ([`LayerKernel`]: f32 weights, int16 or
//! int8 weights).
//!
//! The walk: encode the positions (γ and the learned features); the trunk,
//! each layer into the other of two activation buffers (skip layers read
//! the encoding again); the density head. Then, for the samples that need
//! a colour only, the feature layer (linear), the view layer (ReLU) and the
//! colour head. The direction part of the view layer is the same for every
//! sample of a ray, so [`Block::prepare_ray`] folds it into a per-ray start
//! of the view layer's sums.
//!
//! Fixed-point path: i16 activations; [`Scheme::I16`] weights accumulate in
//! i64, [`Scheme::I8`] weights in i32 (overflow excluded when a renderer is
//! made, see [`check_i8_headroom`]); one [`crate::fixed::Requant`] per
//! output channel.
//!
//! [`Scheme::I16`]: crate::format::Scheme::I16
//! [`Scheme::I8`]: crate::format::Scheme::I8

mod float;
mod int;

pub use crate::layer::{IntWeight, OUTPUT_TILE, W16, W8};
pub use float::ViewBias;
pub use int::{check_i8_headroom, FixedAcc};

use crate::format::{sigma_layer, Layer, Model, Network};
use crate::limits::{MAX_FEATURES, MAX_FREQS, MAX_WIDTH};

/// Longest encoded position or direction: `3 + 6·16` plus the feature
/// grid's values.
pub const ENC_MAX: usize = 3 + 6 * MAX_FREQS + MAX_FEATURES;

/// The f32 numbers: f32 activations, positions in normalised coordinates,
/// raw density, colour in `[0, 1]`.
#[derive(Clone, Copy, Debug)]
pub struct F32;

/// The fixed-point numbers: i16 activations at per-layer scales, positions
/// and directions in Q24, density in Q10, colour in Q15.
#[derive(Clone, Copy, Debug)]
pub struct Fixed;

/// The number formats of a network evaluation.
pub trait Numbers: Sized + Copy {
    /// Activation (f32; i16).
    type X: Copy + Default;
    /// Normalised position or unit direction (`[f32; 3]`; `[i32; 3]` Q24).
    type Pos: Copy + Default;
    /// Raw density head output (f32; i32 Q10).
    type Sigma: Copy + Default;
    /// Colour; its default is black (`[f32; 3]` in `[0, 1]`; `[u16; 3]` Q15).
    type Rgb: Copy + Default;
    /// Accumulators kept beside the activations for `B` samples (none for
    /// f32, which accumulates in place), and the per-ray start of the view
    /// layer's sums.
    type Acc<const B: usize>: Clone + Default;
    /// Encodes each position (γ, then the feature grid's values) into the
    /// same row of `enc`; returns the encoded width.
    fn encode_rows(model: &Model<'_>, pos: &[Self::Pos], enc: &mut [[Self::X; ENC_MAX]]) -> usize;
    /// γ of a unit direction into `out`; returns its width.
    fn encode_dir(model: &Model<'_>, dir: Self::Pos, out: &mut [Self::X; ENC_MAX]) -> usize;
}

/// How a hidden layer ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Act {
    /// ReLU.
    Relu,
    /// None (the feature layer), saturated to the activation's range.
    Linear,
}

/// The inputs of a dense layer: the encoding (`enc`, its first `pd`
/// values; trunk input and skip layers) and the previous layer's output.
pub struct Inputs<'i, X, const N: usize> {
    /// `(rows, width)` of the encoding, read by weight rows `0..width`.
    pub enc: Option<(&'i [[X; ENC_MAX]], usize)>,
    /// `(rows, width)` of the previous layer, read by the rows after the
    /// encoding's.
    pub prev: Option<(&'i [[X; N]], usize)>,
}

/// A dense layer's arithmetic in the numbers `N`: f32 weights for
/// [`F32`]; int16 ([`W16`]) or int8 ([`W8`]) weights for [`Fixed`].
pub trait LayerKernel<N: Numbers> {
    /// `out[s] = act(start + Σ inputs[s] · W)` for the first `n` samples,
    /// `start` being the bias, or with `view` the per-ray start that
    /// [`LayerKernel::fold_view`] left in `acc`.
    #[allow(clippy::too_many_arguments)]
    fn dense<const B: usize>(
        net: &Network<'_>,
        l: &Layer<'_>,
        view: bool,
        inputs: Inputs<'_, N::X, MAX_WIDTH>,
        n: usize,
        acc: &mut N::Acc<B>,
        out: &mut [[N::X; MAX_WIDTH]],
        act: Act,
    );
    /// The density head on the trunk's first `w` outputs.
    fn sigma_head<const B: usize>(
        l: &Layer<'_>,
        trunk: &[[N::X; MAX_WIDTH]],
        w: usize,
        n: usize,
        acc: &mut N::Acc<B>,
        sigma: &mut [N::Sigma; B],
    );
    /// The colour head (then the sigmoid) on the first `dim` values of `input`.
    fn rgb_head<const B: usize>(
        l: &Layer<'_>,
        input: &[[N::X; MAX_WIDTH]],
        dim: usize,
        n: usize,
        acc: &mut N::Acc<B>,
        rgb: &mut [N::Rgb; B],
    );
    /// `view[c] = bias[c] + Σ_j dir[j] · W[w + j][c]` into `acc`: the
    /// direction's part of the view layer `l` (the first `w` rows are the
    /// feature layer's).
    fn fold_view<const B: usize>(l: &Layer<'_>, dir: &[N::X; ENC_MAX], nd: usize, w: usize, acc: &mut N::Acc<B>);
}

/// Per-block buffers of a network evaluation on `B` samples (f32: about
/// `B` · 2.4 KiB + 1 KiB; fixed point: `B` · 4.7 KiB + 2 KiB).
#[derive(Clone)]
pub struct Block<N: Numbers, const B: usize> {
    enc: [[N::X; ENC_MAX]; B],
    h: [[N::X; MAX_WIDTH]; B],
    g: [[N::X; MAX_WIDTH]; B],
    acc: N::Acc<B>,
    /// Raw density head output per sample.
    pub sigma: [N::Sigma; B],
    /// Colour `j` of the last [`Block::eval_colour`].
    pub rgb: [N::Rgb; B],
}

/// The f32 block.
pub type BlockF32<const B: usize> = Block<F32, B>;
/// The fixed-point block (int16 and int8 weights).
pub type BlockFixed<const B: usize> = Block<Fixed, B>;

impl<N: Numbers, const B: usize> Default for Block<N, B> {
    fn default() -> Self {
        Self {
            enc: [[N::X::default(); ENC_MAX]; B],
            h: [[N::X::default(); MAX_WIDTH]; B],
            g: [[N::X::default(); MAX_WIDTH]; B],
            acc: N::Acc::default(),
            sigma: [N::Sigma::default(); B],
            rgb: [N::Rgb::default(); B],
        }
    }
}

/// Whether the trunk of a `depth`-layer network ends in `h` (layers
/// alternate `h`, `g`, `h`, … starting with `h`).
fn trunk_in_h(depth: u8) -> bool {
    depth % 2 == 1
}

/// Moves the first `width` values of rows `rows` (ascending, `rows[j] ≥ j`)
/// to the front of `buf`, row `rows[j]` to row `j` (a forward copy).
fn gather_rows<X: Copy>(buf: &mut [[X; MAX_WIDTH]], rows: &[usize], width: usize) {
    for (j, &k) in rows.iter().enumerate() {
        if k != j {
            let (to, from) = buf.split_at_mut(k);
            to[j][..width].copy_from_slice(&from[0][..width]);
        }
    }
}

impl<N: Numbers, const B: usize> Block<N, B> {
    /// Per-ray setup of network `net`: folds the encoded unit direction
    /// `viewdir` into the view layer. No-op without the view branch.
    pub fn prepare_ray<K: LayerKernel<N>>(&mut self, model: &Model<'_>, net: &Network<'_>, viewdir: N::Pos) {
        let t = &model.topology;
        if !t.view_dependent {
            return;
        }
        let l = &net.layers[sigma_layer(t) + 2];
        let mut dir = [N::X::default(); ENC_MAX];
        let nd = N::encode_dir(model, viewdir, &mut dir);
        let w = l.in_dim as usize - nd; // the feature layer's width
        K::fold_view::<B>(l, &dir, nd, w, &mut self.acc);
    }

    /// The trunk and density head at positions `pos` (≤ `B`): fills
    /// `sigma` and keeps the trunk's output for [`Block::eval_colour`].
    pub fn eval_density<K: LayerKernel<N>>(&mut self, model: &Model<'_>, net: &Network<'_>, pos: &[N::Pos]) {
        let n = pos.len();
        let t = &model.topology;
        let Self { enc, h, g, acc, sigma, .. } = self;
        let pd = N::encode_rows(model, pos, enc);
        let layers = &net.layers;
        // layer widths come from the layers: pruned ones are narrower
        let width = |k: usize| layers[k].out_dim as usize;
        let first = Inputs { enc: Some((&*enc, pd)), prev: None };
        K::dense::<B>(net, &layers[0], false, first, n, acc, h, Act::Relu);
        let mut in_h = true;
        for (i, l) in layers.iter().enumerate().take(t.depth as usize).skip(1) {
            let (src, dst) = if in_h { (&*h, &mut *g) } else { (&*g, &mut *h) };
            let inputs = Inputs { enc: t.is_skip(i).then_some((&*enc, pd)), prev: Some((src, width(i - 1))) };
            K::dense::<B>(net, l, false, inputs, n, acc, dst, Act::Relu);
            in_h = !in_h;
        }
        debug_assert_eq!(in_h, trunk_in_h(t.depth));
        let trunk = if in_h { &*h } else { &*g };
        let si = sigma_layer(t);
        K::sigma_head::<B>(&layers[si], trunk, width(si - 1), n, acc, sigma);
    }

    /// The colour branch for samples `rows` (ascending, each < the count
    /// given to the last [`Block::eval_density`]): `rgb[j]` is the colour
    /// of sample `rows[j]`. Samples whose weight is zero need none.
    pub fn eval_colour<K: LayerKernel<N>>(&mut self, model: &Model<'_>, net: &Network<'_>, rows: &[usize]) {
        let n = rows.len();
        let t = &model.topology;
        let Self { h, g, acc, rgb, .. } = self;
        let (trunk, spare) = if trunk_in_h(t.depth) { (h, g) } else { (g, h) };
        let layers = &net.layers;
        let width = |k: usize| layers[k].out_dim as usize;
        let si = sigma_layer(t);
        let w = width(si - 1);
        gather_rows(trunk, rows, w);
        let (dim, head) = if t.view_dependent {
            let feature = Inputs { enc: None, prev: Some((&*trunk, w)) };
            K::dense::<B>(net, &layers[si + 1], false, feature, n, acc, spare, Act::Linear);
            let with_view = Inputs { enc: None, prev: Some((&*spare, width(si + 1))) };
            K::dense::<B>(net, &layers[si + 2], true, with_view, n, acc, trunk, Act::Relu);
            (width(si + 2), &layers[si + 3])
        } else {
            (w, &layers[si + 1])
        };
        K::rgb_head::<B>(head, trunk, dim, n, acc, rgb);
    }
}

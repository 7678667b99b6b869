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

mod contract;
mod float;
mod int;

pub use crate::layer::{IntWeight, OUTPUT_TILE, W16, W8};
pub use contract::{Act, Fixed, Inputs, LayerKernel, Numbers, ENC_MAX, F32};
pub use float::ViewBias;
pub use int::{check_i8_headroom, FixedAcc};

use crate::format::{sigma_layer, Model, Network};
use crate::limits::FOOTPRINT_POINTS;
use crate::limits::MAX_WIDTH;
use crate::tensor::Zero;

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
    /// The footprint points of each position given to
    /// [`Block::eval_density`] with `foot` (written by the caller).
    pub foot: [[N::Pos; FOOTPRINT_POINTS]; B],
}

/// The f32 block.
pub type BlockF32<const B: usize> = Block<F32, B>;
/// The fixed-point block (int16 and int8 weights).
pub type BlockFixed<const B: usize> = Block<Fixed, B>;

impl<N: Numbers, const B: usize> Default for Block<N, B> {
    fn default() -> Self {
        Self::new()
    }
}

impl<N: Numbers, const B: usize> Block<N, B> {
    /// A block of zeros (a `const fn`: a block can be a `static`'s part).
    pub const fn new() -> Self {
        Self {
            enc: Zero::ZERO,
            h: Zero::ZERO,
            g: Zero::ZERO,
            acc: <N::Acc<B> as Zero>::ZERO,
            sigma: Zero::ZERO,
            rgb: Zero::ZERO,
            foot: Zero::ZERO,
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
        let rows16 = net.precise.map_or(&[][..], |p| p.view_dirs);
        K::fold_view::<B>(l, rows16, &dir, nd, w, &mut self.acc);
    }

    /// The trunk and density head at positions `pos` (≤ `B`), with `foot`
    /// the feature grid's values averaged over the points in
    /// [`Block::foot`] for each ([`crate::format::Footprint`]): fills
    /// `sigma` and keeps the trunk's output for [`Block::eval_colour`].
    pub fn eval_density<K: LayerKernel<N>>(
        &mut self,
        model: &Model<'_>,
        net: &Network<'_>,
        pos: &[N::Pos],
        foot: bool,
    ) {
        let n = pos.len();
        let t = &model.topology;
        let Self { enc, h, g, acc, sigma, foot: points, .. } = self;
        let pd = N::encode_rows(model, pos, foot.then_some(&points[..n]), enc);
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
        let head16 = net.precise.and_then(|p| p.density);
        K::sigma_head::<B>(&layers[si], head16.as_ref(), trunk, width(si - 1), n, acc, sigma);
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
        let head16 = net.precise.and_then(|p| p.colour);
        K::rgb_head::<B>(head, head16.as_ref(), trunk, dim, n, acc, rgb);
    }
}

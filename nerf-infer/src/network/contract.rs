//! What the network walk needs from a numeric path: its number formats
//! ([`Numbers`]) and a dense layer's arithmetic in them ([`LayerKernel`]).

use crate::format::{Layer, Model, Network};
use crate::limits::FOOTPRINT_POINTS;
use crate::limits::{MAX_FEATURES, MAX_FREQS, MAX_WIDTH};
use crate::tensor::Zero;

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
    type X: Copy + Default + Zero;
    /// Normalised position or unit direction (`[f32; 3]`; `[i32; 3]` Q24).
    type Pos: Copy + Default + Zero;
    /// Raw density head output (f32; i32 Q10).
    type Sigma: Copy + Default + Zero;
    /// Colour; its default is black (`[f32; 3]` in `[0, 1]`; `[u16; 3]` Q15).
    type Rgb: Copy + Default + Zero;
    /// Accumulators kept beside the activations for `B` samples (none for
    /// f32, which accumulates in place), and the per-ray start of the view
    /// layer's sums.
    type Acc<const B: usize>: Clone + Default + Zero;
    /// Encodes each position (γ, then the feature grid's values, or with
    /// `foot` their mean over the position's footprint points) into
    /// the same row of `enc`; returns the encoded width.
    fn encode_rows(
        model: &Model<'_>,
        pos: &[Self::Pos],
        foot: Option<&[[Self::Pos; FOOTPRINT_POINTS]]>,
        enc: &mut [[Self::X; ENC_MAX]],
    ) -> usize;
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
/// [`F32`]; int16 ([`W16`](crate::layer::W16)) or int8 ([`W8`](crate::layer::W8)) weights for [`Fixed`].
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
    /// The density head on the trunk's first `w` outputs: `l`, or `head16`
    /// when given (the 16-bit density head of an integer model of format 8,
    /// [`crate::format::PreciseNet::density`]).
    #[allow(clippy::too_many_arguments)]
    fn sigma_head<const B: usize>(
        l: &Layer<'_>,
        head16: Option<&Layer<'_>>,
        trunk: &[[N::X; MAX_WIDTH]],
        w: usize,
        n: usize,
        acc: &mut N::Acc<B>,
        sigma: &mut [N::Sigma; B],
    );
    /// The colour head (then the sigmoid) on the first `dim` values of
    /// `input`: `l`, or `head16` when given (the 16-bit colour head of an
    /// integer model of format 6, [`crate::format::PreciseNet`]).
    #[allow(clippy::too_many_arguments)]
    fn rgb_head<const B: usize>(
        l: &Layer<'_>,
        head16: Option<&Layer<'_>>,
        input: &[[N::X; MAX_WIDTH]],
        dim: usize,
        n: usize,
        acc: &mut N::Acc<B>,
        rgb: &mut [N::Rgb; B],
    );
    /// `view[c] = bias[c] + Σ_j dir[j] · W[w + j][c]` into `acc`: the
    /// direction's part of the view layer `l` (the first `w` rows are the
    /// feature layer's), or with `rows16` non-empty (integer models of
    /// format 6) `bias[c] + round(Σ_j dir[j] · rows16[j][c] / 2^8)`
    /// ([`crate::format::PreciseNet`]).
    fn fold_view<const B: usize>(
        l: &Layer<'_>,
        rows16: &[u8],
        dir: &[N::X; ENC_MAX],
        nd: usize,
        w: usize,
        acc: &mut N::Acc<B>,
    );
}

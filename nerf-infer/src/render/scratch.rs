//! The working memory of a render, owned by the caller.

use super::path::NumericPath;
use crate::format::{MAX_COARSE, MAX_FINE};
use crate::network::Block;

/// Working memory of a renderer on path `P` for blocks of `B` samples:
/// f32 about 5 KiB + `B` · 2.4 KiB (≈ 25 KiB for the default `B = 8`);
/// fixed point about 7 KiB + `B` · 4.7 KiB + 2 KiB (≈ 47 KiB for `B = 8`,
/// ≈ 14 KiB for `B = 1`).
#[derive(Clone)]
pub struct Scratch<P: NumericPath, const B: usize = 8> {
    pub(super) t_coarse: [P::T; MAX_COARSE],
    pub(super) w_coarse: [P::W; MAX_COARSE],
    pub(super) cdf: [P::Cdf; MAX_COARSE],
    pub(super) t_fine: [P::T; MAX_FINE],
    pub(super) t_all: [P::T; MAX_COARSE + MAX_FINE],
    pub(super) block: Block<P, B>,
    /// Network evaluations performed since creation (for samples/ray).
    pub evaluations: u64,
}

impl<P: NumericPath, const B: usize> Default for Scratch<P, B> {
    fn default() -> Self {
        Self {
            t_coarse: [P::T::default(); MAX_COARSE],
            w_coarse: [P::W::default(); MAX_COARSE],
            cdf: [P::Cdf::default(); MAX_COARSE],
            t_fine: [P::T::default(); MAX_FINE],
            t_all: [P::T::default(); MAX_COARSE + MAX_FINE],
            block: Block::default(),
            evaluations: 0,
        }
    }
}

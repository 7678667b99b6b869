//! The working memory of a render, owned by the caller.

use super::path::NumericPath;
use crate::format::{MAX_COARSE, MAX_FINE, MAX_MARCH};
use crate::network::Block;
use crate::tensor::Zero;

/// Working memory of a renderer on path `P` for blocks of `B` samples:
/// f32 about 5 KiB + `B` · 2.4 KiB (≈ 25 KiB for the default `B = 8`);
/// fixed point about 7 KiB + `B` · 4.7 KiB + 2 KiB (≈ 47 KiB for `B = 8`,
/// ≈ 14 KiB for `B = 1`).
#[derive(Clone)]
pub struct Scratch<P: NumericPath, const B: usize = 1> {
    /// Sample positions `t`: up to [`MAX_MARCH`] in a one-pass render; a
    /// two-pass render splits it into the coarse, the fine and the merged
    /// samples ([`two_pass`]).
    pub(super) t: [P::T; MAX_MARCH],
    pub(super) w_coarse: [P::W; MAX_COARSE],
    pub(super) cdf: [P::Cdf; MAX_COARSE],
    pub(super) block: Block<P, B>,
    /// Network evaluations performed since creation (for samples/ray).
    pub evaluations: u64,
}

/// The sample buffers of a two-pass render, borrowed from one scratch.
pub(super) struct TwoPass<'s, T> {
    /// Coarse samples, up to [`MAX_COARSE`].
    pub coarse: &'s mut [T],
    /// Importance samples, up to [`MAX_FINE`].
    pub fine: &'s mut [T],
    /// Coarse and importance samples merged, up to their sum.
    pub all: &'s mut [T],
}

// a two-pass render's coarse, fine and merged samples fit the one buffer
const _: () = assert!(MAX_MARCH >= 2 * (MAX_COARSE + MAX_FINE));

/// A scratch's sample buffer split for a two-pass render.
pub(super) fn two_pass<T>(t: &mut [T; MAX_MARCH]) -> TwoPass<'_, T> {
    let (coarse, rest) = t.split_at_mut(MAX_COARSE);
    let (fine, all) = rest.split_at_mut(MAX_FINE);
    TwoPass { coarse, fine, all }
}

impl<P: NumericPath, const B: usize> Scratch<P, B> {
    /// Zeroed working memory. A `const fn`, so a scratch can be a
    /// `static` (in a `Mutex`, or a `static mut` the program hands out
    /// once) instead of a stack value:
    ///
    /// ```
    /// use core::cell::RefCell;
    /// use nerf_infer::ScratchFixed;
    /// use std::sync::Mutex;
    /// static SCRATCH: Mutex<RefCell<ScratchFixed<1>>> = Mutex::new(RefCell::new(ScratchFixed::new()));
    /// # let _ = &SCRATCH;
    /// ```
    pub const fn new() -> Self {
        Self { t: Zero::ZERO, w_coarse: Zero::ZERO, cdf: Zero::ZERO, block: Block::new(), evaluations: 0 }
    }
}

impl<P: NumericPath, const B: usize> Default for Scratch<P, B> {
    fn default() -> Self {
        Self::new()
    }
}

//! AVX2 kernels (x86-64: with `std`, in every build, run where the CPU has
//! AVX2; without, built when the target enables `avx2`): the int8 layer
//! and its requantiser, the f32 layer, the encoding's sine, and width-2
//! feature-grid lookups. Each matches its portable reference bit for bit. Each entry
//! point takes an [`Avx2`] token, the proof that the CPU has AVX2.

mod features;
mod float;
mod layer;
mod sine;

pub(crate) use features::features_w2;
pub(crate) use float::accumulate_f32;
pub(crate) use layer::{accumulate_i8, live_pairs, requant_i32};
pub(crate) use sine::sin_turns_q15_x8;

/// Proof that the CPU running this code has AVX2: made only by
/// [`Avx2::new`], which checks.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx2(());

impl Avx2 {
    /// The token, if the CPU has AVX2.
    #[inline]
    pub(crate) fn new() -> Option<Self> {
        super::has_avx2().then_some(Avx2(()))
    }
}

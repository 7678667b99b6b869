//! The portable f32 dense-layer kernel ([`crate::layer::accumulate`])
//! compiled for AVX2: the same operations in the same order on wider
//! registers (no fused multiply-add, which would round differently), so
//! the same bits.

#![allow(unsafe_code)]

use crate::format::{Layer, MAX_WIDTH};
use crate::layer::{accumulate, Input, MacF32};

/// `out[s][c] += Σ_j x.rows[s][j] · W[x.row0 + j][c]` for `s < x.n` and
/// every output `c` of `l`, an f32 layer.
#[inline]
pub(crate) fn accumulate_f32<const N: usize>(
    _: super::Avx2,
    l: &Layer<'_>,
    x: Input<'_, f32, N>,
    out: &mut [[f32; MAX_WIDTH]],
) {
    // SAFETY: the token proves the CPU has AVX2.
    unsafe { accumulate_avx2(l, x, out) }
}

#[target_feature(enable = "avx2")]
fn accumulate_avx2<const N: usize>(l: &Layer<'_>, x: Input<'_, f32, N>, out: &mut [[f32; MAX_WIDTH]]) {
    // (inline(always): its loops are compiled here, for AVX2)
    accumulate::<MacF32, N>(l, 0, x, out);
}

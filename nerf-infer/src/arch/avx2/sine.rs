//! The encoding's sine on AVX2, 8 phases per register.

#![allow(unsafe_code)]

use core::arch::x86_64::*;

use crate::fixed::SIN_TABLE;

/// [`crate::fixed::sin_turns_q15`] of the phases in whole groups of 8
/// (bit-identical: the same table, interpolation and rounding in integer
/// lanes); returns how many it wrote (`phases.len()` rounded down to 8).
pub(crate) fn sin_turns_q15_x8(_: super::Avx2, phases: &[u32], out: &mut [i16]) -> usize {
    let n = phases.len().min(out.len()) / 8 * 8;
    for (p, o) in phases[..n].chunks_exact(8).zip(out[..n].chunks_exact_mut(8)) {
        // SAFETY: the token proves the CPU has AVX2.
        unsafe { sin8(p, o) };
    }
    n
}

#[target_feature(enable = "avx2")]
fn sin8(phases: &[u32], out: &mut [i16]) {
    let one = |v: i32| _mm256_set1_epi32(v);
    // SAFETY: `phases` is 8 u32 (32 bytes) long.
    let ph = unsafe { _mm256_loadu_si256(phases[..8].as_ptr().cast()) };
    let quadrant = _mm256_srli_epi32::<30>(ph);
    let within = _mm256_and_si256(ph, one(0x3FFF_FFFF));
    // quadrants 1 and 3 mirror: sin(π/2 + a) = sin(π/2 − a)
    let mirror = _mm256_cmpeq_epi32(_mm256_and_si256(quadrant, one(1)), one(1));
    let pos = _mm256_blendv_epi8(within, _mm256_sub_epi32(one(1 << 30), within), mirror);
    let idx = _mm256_srli_epi32::<22>(pos); // 0..=256
    let frac = _mm256_and_si256(pos, one(0x3F_FFFF));
    let next = _mm256_min_epu32(_mm256_add_epi32(idx, one(1)), one(256));
    // SAFETY: every index is in 0..=256, inside the 257-entry table.
    let (a, b) = unsafe {
        (_mm256_i32gather_epi32::<4>(SIN_TABLE.as_ptr(), idx), _mm256_i32gather_epi32::<4>(SIN_TABLE.as_ptr(), next))
    };
    // (b − a) · frac >> 22: the table rises, so b − a ≥ 0 (< 2²³) and the
    // product (< 2⁴⁵) is exact in the u64 lanes, even and odd lanes apart
    let d = _mm256_sub_epi32(b, a);
    let even = _mm256_srli_epi64::<22>(_mm256_mul_epu32(d, frac));
    let odd = _mm256_srli_epi64::<22>(_mm256_mul_epu32(_mm256_srli_epi64::<32>(d), _mm256_srli_epi64::<32>(frac)));
    let step = _mm256_blend_epi32::<0b1010_1010>(even, _mm256_slli_epi64::<32>(odd));
    // Q30 in [0, 2³⁰], rounded to Q15 and capped, negated in quadrants 2, 3
    let v = _mm256_add_epi32(a, step);
    let q = _mm256_min_epi32(_mm256_srli_epi32::<15>(_mm256_add_epi32(v, one(1 << 14))), one(32767));
    let neg = _mm256_cmpgt_epi32(quadrant, one(1));
    let q = _mm256_sub_epi32(_mm256_xor_si256(q, neg), neg);
    let packed = _mm256_permute4x64_epi64::<0b1000>(_mm256_packs_epi32(q, q));
    // SAFETY: `out` is 8 i16 (16 bytes) long.
    unsafe { _mm_storeu_si128(out[..8].as_mut_ptr().cast(), _mm256_castsi256_si128(packed)) };
}

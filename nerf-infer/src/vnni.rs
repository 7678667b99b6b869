//! The int8-weight layer kernel on x86-64 CPUs with AVX-512 VNNI (built when
//! the target enables `avx512bw` and `avx512vnni`, e.g. `-C
//! target-cpu=native` on such a CPU; elsewhere the portable kernel runs).
//!
//! `vpdpwssd` multiplies 32 pairs of i16 and adds each pair's two products
//! to one of 16 i32 accumulators: 32 multiply-accumulates per instruction,
//! against 16 for an f32 multiply and add. Two weight rows `ja`, `jb` (i8,
//! sign-extended to i16) are interleaved so each i32 lane holds the pair
//! `(W[ja][c], W[jb][c])`, and the inputs `(x[ja], x[jb])` are broadcast as
//! one i32. Rows whose input is zero for every sample of the tile (ReLU)
//! are skipped before pairing. Integer sums are exact, and the load-time
//! headroom check (`check_i8_headroom`) bounds every partial sum, so the
//! result is bit-identical to the portable kernel's.
#![allow(unsafe_code)]

use core::arch::x86_64::*;

use crate::format::MAX_WIDTH;

/// Samples per register tile: 8 samples × 32 outputs is 16 accumulator
/// registers, leaving room for the weights.
const TILE_S: usize = 8;
/// Outputs per register tile.
const TILE_C: usize = 32;

/// Output channel (within a 32-wide tile) of lane `i` of the `lo` / `hi`
/// accumulator: `unpack{lo,hi}_epi16` work within 128-bit lanes.
const fn channel(i: usize, hi: bool) -> usize {
    8 * (i / 4) + i % 4 + if hi { 4 } else { 0 }
}

/// 32 int8 weights of row `j` from column `c0`, sign-extended to i16.
#[inline]
#[target_feature(enable = "avx512f,avx512bw")]
fn row_i16(weights: &[u8], od: usize, j: usize, c0: usize) -> __m512i {
    let w = &weights[j * od + c0..j * od + c0 + TILE_C];
    // SAFETY: `w` is exactly 32 bytes (the slice above is bounds-checked);
    // the load is unaligned.
    let v = unsafe { _mm256_loadu_si256(w.as_ptr().cast()) };
    _mm512_cvtepi8_epi16(v)
}

/// `out[s][c] += Σ_j input[s][j] · W[row0 + j][c]` for the first `n`
/// samples and the outputs `0..od − od % 32` (the caller finishes the rest),
/// int8 weights `weights` with `od` outputs per row, i32 accumulators.
#[inline]
pub(crate) fn accumulate_i8<const N: usize>(
    weights: &[u8],
    od: usize,
    row0: usize,
    input: &[[i16; N]],
    in_dim: usize,
    n: usize,
    out: &mut [[i32; MAX_WIDTH]],
) {
    // SAFETY: this module is only compiled when the build enables
    // avx512f, avx512bw and avx512vnni for the whole crate.
    unsafe { accumulate_i8_vnni(weights, od, row0, input, in_dim, n, out) }
}

#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
fn accumulate_i8_vnni<const N: usize>(
    weights: &[u8],
    od: usize,
    row0: usize,
    input: &[[i16; N]],
    in_dim: usize,
    n: usize,
    out: &mut [[i32; MAX_WIDTH]],
) {
    let pairs = in_dim.div_ceil(2);
    let mut s0 = 0;
    while s0 < n {
        let sn = (n - s0).min(TILE_S);
        // a short tile repeats its last sample; those results are dropped
        let rows: [&[i16; N]; TILE_S] = core::array::from_fn(|s| &input[s0 + s.min(sn - 1)]);
        // inputs (2p, 2p + 1) of sample s as one i32, the low half first
        let pair_x = |p: usize, s: usize| -> i32 {
            let lo = rows[s][2 * p] as u16 as u32;
            let hi = if 2 * p + 1 < in_dim { rows[s][2 * p + 1] as u16 as u32 } else { 0 };
            (lo | hi << 16) as i32
        };
        let mut c0 = 0;
        while c0 + TILE_C <= od {
            let mut lo = [_mm512_setzero_si512(); TILE_S];
            let mut hi = [_mm512_setzero_si512(); TILE_S];
            for p in 0..pairs {
                let xs: [i32; TILE_S] = core::array::from_fn(|s| pair_x(p, s));
                if xs.iter().all(|&x| x == 0) {
                    continue; // ReLU zeros for the whole tile
                }
                let ja = row0 + 2 * p;
                // an odd last input pairs its row with itself (input 0)
                let jb = if 2 * p + 1 < in_dim { ja + 1 } else { ja };
                let wa = row_i16(weights, od, ja, c0);
                let wb = row_i16(weights, od, jb, c0);
                let w_lo = _mm512_unpacklo_epi16(wa, wb);
                let w_hi = _mm512_unpackhi_epi16(wa, wb);
                for s in 0..TILE_S {
                    let xp = _mm512_set1_epi32(xs[s]);
                    lo[s] = _mm512_dpwssd_epi32(lo[s], xp, w_lo);
                    hi[s] = _mm512_dpwssd_epi32(hi[s], xp, w_hi);
                }
            }
            for s in 0..sn {
                let (mut l, mut h) = ([0i32; 16], [0i32; 16]);
                // SAFETY: each array holds exactly the 64 bytes stored.
                unsafe {
                    _mm512_storeu_si512(l.as_mut_ptr().cast(), lo[s]);
                    _mm512_storeu_si512(h.as_mut_ptr().cast(), hi[s]);
                }
                let row = &mut out[s0 + s][c0..c0 + TILE_C];
                for i in 0..16 {
                    row[channel(i, false)] = row[channel(i, false)].wrapping_add(l[i]);
                    row[channel(i, true)] = row[channel(i, true)].wrapping_add(h[i]);
                }
            }
            c0 += TILE_C;
        }
        s0 += TILE_S;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_map_to_every_channel_once() {
        let mut seen = [0; TILE_C];
        for i in 0..16 {
            seen[channel(i, false)] += 1;
            seen[channel(i, true)] += 1;
        }
        assert!(seen.iter().all(|&k| k == 1));
    }
}

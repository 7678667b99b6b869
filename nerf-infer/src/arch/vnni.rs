//! The int8-weight layer kernel and its requantiser on x86-64 CPUs with
//! AVX-512 VNNI (with `std`, in every x86-64 build, run where the CPU has
//! `avx512f`, `avx512bw` and `avx512vnni`; without, built when the target
//! enables `avx512bw` and `avx512vnni`). Each entry point takes a [`Vnni`]
//! token, the proof that the CPU has them.
//!
//! `vpdpwssd` multiplies 32 pairs of i16 and adds each pair's two products
//! to one of 16 i32 accumulators: 32 multiply-accumulates per instruction,
//! against 16 for an f32 multiply and add. Two weight rows `ja`, `jb` (i8,
//! sign-extended to i16) are interleaved so each i32 lane holds the pair
//! `(W[ja][c], W[jb][c])`, and the inputs `(x[ja], x[jb])` of adjacent rows
//! `jb = ja + 1` are broadcast as one i32. Pairs whose inputs are zero for
//! every sample of the 8-sample tile (ReLU) are skipped; the live pairs are
//! gathered once per tile and reused for every 32-wide output tile.
//! Integer sums are exact, and the load-time
//! headroom check (`check_i8_headroom`) bounds every partial sum, so the
//! result is bit-identical to the portable kernel's.
#![allow(unsafe_code)]

use core::arch::x86_64::*;
use core::mem::MaybeUninit;

use crate::format::{Layer, MAX_INPUT, MAX_WIDTH};
use crate::layer::{requant_rows, Input, W8};

use super::avx2::Avx2;

/// Proof that the CPU running this code has AVX-512 F, BW and VNNI (and
/// AVX2): made only by [`Vnni::new`], which checks.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Vnni(Avx2);

impl Vnni {
    /// The token, if the CPU has the instructions.
    #[inline]
    pub(crate) fn new() -> Option<Self> {
        Avx2::new().filter(|_| super::has_vnni()).map(Vnni)
    }

    /// The AVX2 token this one implies.
    #[inline]
    pub(crate) fn avx2(self) -> Avx2 {
        self.0
    }
}

/// Samples per register tile: 8 samples × 32 outputs is 16 accumulator
/// registers, leaving room for the weights.
const TILE_S: usize = 8;
/// Outputs per register tile.
const TILE_C: usize = 32;
/// Most input pairs of a layer.
const MAX_PAIRS: usize = MAX_INPUT.div_ceil(2);

/// Output channel (within a 32-wide tile) of lane `i` of the `lo` / `hi`
/// accumulator: `unpack{lo,hi}_epi16` work within 128-bit lanes.
const fn channel(i: usize, hi: bool) -> usize {
    8 * (i / 4) + i % 4 + if hi { 4 } else { 0 }
}

/// `_mm512_permutex2var_epi32(lo, PERM[h], hi)` lists channels
/// `16h..16h + 16` in order (index `i` is lane `i` of `lo`, `16 + i` of `hi`).
const PERM: [[i32; 16]; 2] = {
    let mut p = [[0; 16]; 2];
    let mut i = 0;
    while i < 16 {
        let c = channel(i, false);
        p[c / 16][c % 16] = i as i32;
        let c = channel(i, true);
        p[c / 16][c % 16] = 16 + i as i32;
        i += 1;
    }
    p
};

/// 32 int8 weights of row `j` from column `c0`, sign-extended to i16.
#[inline]
#[target_feature(enable = "avx512f,avx512bw")]
fn row_i16(weights: &[u8], od: usize, j: usize, c0: usize) -> __m512i {
    let w = &weights[j * od + c0..j * od + c0 + TILE_C];
    // SAFETY: `w` is exactly 32 bytes (the slice above is bounds-checked);
    // the load is unaligned.
    _mm512_cvtepi8_epi16(unsafe { _mm256_loadu_si256(w.as_ptr().cast()) })
}

/// `out[s][c] += Σ_j x.rows[s][j] · W[x.row0 + j][c]` for the first `x.n`
/// samples and the outputs `0..od − od % 32` of `l`, an int8 layer with
/// `od` outputs (the caller finishes the rest), i32 accumulators.
#[inline]
pub(crate) fn accumulate_i8<const N: usize>(
    _: Vnni,
    l: &Layer<'_>,
    x: Input<'_, i16, N>,
    out: &mut [[i32; MAX_WIDTH]],
) {
    // SAFETY: the token proves the CPU has avx512f, avx512bw and avx512vnni.
    unsafe { accumulate_i8_vnni(l.weights, l.out_dim as usize, x, out) }
}

/// `s` as initialised values.
///
/// # Safety
/// Every element of `s` has been written.
unsafe fn slice_assume_init<T>(s: &[MaybeUninit<T>]) -> &[T] {
    // SAFETY: MaybeUninit<T> has T's layout; the caller vouches for the values.
    unsafe { &*(s as *const [MaybeUninit<T>] as *const [T]) }
}

#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
fn accumulate_i8_vnni<const N: usize>(weights: &[u8], od: usize, x: Input<'_, i16, N>, out: &mut [[i32; MAX_WIDTH]]) {
    let Input { rows: input, row0, width: in_dim, n } = x;
    // SAFETY: each row of PERM is exactly 64 bytes; unaligned loads.
    let perm = PERM.map(|row| unsafe { _mm512_loadu_si512(row.as_ptr().cast()) });
    // Per tile: the input pairs (2p, 2p + 1) that are non-zero for some
    // sample (ReLU zeros skipped), and each sample's pair as one i32, the
    // low half first; built once, used for every 32-wide output tile.
    let mut live_p = [0u16; MAX_PAIRS];
    // only the first `live` of a tile are written, then read: left
    // uninitialised, since zeroing its 6 KiB per call costs about 5 % of a render
    let mut live_x = [MaybeUninit::<[i32; TILE_S]>::uninit(); MAX_PAIRS];
    let mut s0 = 0;
    while s0 < n {
        let sn = (n - s0).min(TILE_S);
        // a short tile repeats its last sample; those results are dropped
        let rows: [&[i16; N]; TILE_S] = core::array::from_fn(|s| &input[s0 + s.min(sn - 1)]);
        // the live pairs (as the AVX2 kernel finds them; an odd last input
        // is a pair of its own), then each sample's values of those only
        let tile = &input[s0..s0 + sn];
        let mut live = super::avx2::live_pairs(tile, in_dim, &mut live_p);
        if in_dim % 2 == 1 {
            live_p[live] = (in_dim / 2) as u16;
            live += tile.iter().any(|r| r[in_dim - 1] != 0) as usize;
        }
        for (xs, &p) in live_x.iter_mut().zip(&live_p[..live]) {
            let p = p as usize;
            xs.write(core::array::from_fn(|s| {
                let r = rows[s];
                let hi = if 2 * p + 1 < in_dim { r[2 * p + 1] as u16 as u32 } else { 0 };
                (r[2 * p] as u16 as u32 | hi << 16) as i32
            }));
        }
        // SAFETY: the loop above wrote the first `live` entries.
        let live_x: &[[i32; TILE_S]] = unsafe { slice_assume_init(&live_x[..live]) };
        let mut c0 = 0;
        while c0 + TILE_C <= od {
            let mut lo = [_mm512_setzero_si512(); TILE_S];
            let mut hi = [_mm512_setzero_si512(); TILE_S];
            for (&p, xs) in live_p[..live].iter().zip(live_x) {
                let ja = row0 + 2 * p as usize;
                // an odd last input pairs its row with itself (input 0)
                let jb = if 2 * p as usize + 1 < in_dim { ja + 1 } else { ja };
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
                let row = &mut out[s0 + s][c0..c0 + TILE_C];
                for (half, &idx) in perm.iter().enumerate() {
                    let dst = &mut row[16 * half..16 * half + 16];
                    let add = _mm512_permutex2var_epi32(lo[s], idx, hi[s]);
                    // SAFETY: `dst` is exactly 16 i32 (bounds-checked slice);
                    // unaligned load and store.
                    unsafe {
                        let old = _mm512_loadu_si512(dst.as_ptr().cast());
                        _mm512_storeu_si512(dst.as_mut_ptr().cast(), _mm512_add_epi32(old, add));
                    }
                }
            }
            c0 += TILE_C;
        }
        s0 += TILE_S;
    }
}

/// `out[s][c] = clamp((acc[s][c] · m_c + 2^(n_c − 1)) >> n_c, lo, hi)` for
/// `s < n` and every output `c` of `l`: [`crate::fixed::Requant::apply`]
/// on i32 accumulators, eight channels per register in 64-bit lanes
/// (AVX-512 has the arithmetic shift and the 64-bit clamp AVX2 lacks),
/// the last `od % 8` channels one by one.
pub(crate) fn requant_i32(
    _: Vnni,
    l: &Layer<'_>,
    n: usize,
    acc: &[[i32; MAX_WIDTH]],
    out: &mut [[i16; MAX_WIDTH]],
    bounds: (i16, i16),
) {
    // SAFETY: the token proves the CPU has avx512f and avx512bw.
    unsafe { requant_avx512(l, n, acc, out, bounds) }
}

#[target_feature(enable = "avx512f,avx512bw")]
fn requant_avx512(
    l: &Layer<'_>,
    n: usize,
    acc: &[[i32; MAX_WIDTH]],
    out: &mut [[i16; MAX_WIDTH]],
    (lo, hi): (i16, i16),
) {
    let (rq, od) = (l.requant, l.out_dim as usize);
    let (lov, hiv) = (_mm512_set1_epi64(lo as i64), _mm512_set1_epi64(hi as i64));
    let mut c0 = 0;
    while c0 + 8 <= od {
        // channel c's (multiplier, shift) pair as one 64-bit lane: the
        // multiply reads the low half, the shift is the high half
        let f = &rq[8 * c0..8 * c0 + 64];
        // SAFETY: `f` is 64 bytes long; unaligned load.
        let m = unsafe { _mm512_loadu_si512(f.as_ptr().cast()) };
        // n = (31 + shift) & 63 with the shift taken as u32, as `apply`
        let bits = _mm512_and_si512(
            _mm512_add_epi64(_mm512_srli_epi64::<32>(m), _mm512_set1_epi64(31)),
            _mm512_set1_epi64(63),
        );
        let round = _mm512_srli_epi64::<1>(_mm512_sllv_epi64(_mm512_set1_epi64(1), bits));
        for (a, o) in acc[..n].iter().zip(out[..n].iter_mut()) {
            let src = &a[c0..c0 + 8];
            // SAFETY: `src` is 8 i32 (32 bytes) long; unaligned load.
            let x = _mm512_cvtepi32_epi64(unsafe { _mm256_loadu_si256(src.as_ptr().cast()) });
            // |acc · m| < 2⁶² and round ≤ 2⁶¹: the sum fits an i64
            let p = _mm512_add_epi64(_mm512_mul_epi32(x, m), round);
            let q = _mm512_min_epi64(_mm512_max_epi64(_mm512_srav_epi64(p, bits), lov), hiv);
            let dst = &mut o[c0..c0 + 8];
            // SAFETY: `dst` is 8 i16 (16 bytes) long; the clamped lanes fit
            // i16, so truncating them is exact; unaligned store.
            unsafe { _mm_storeu_si128(dst.as_mut_ptr().cast(), _mm512_cvtepi64_epi16(q)) };
        }
        c0 += 8;
    }
    requant_rows::<W8>(l, c0, n, acc, out, (lo, hi));
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

//! The int8 layer kernel on AVX2 (x86-64 without AVX-512 VNNI).
//!
//! `vpmaddwd` multiplies 16 i16 pairs and adds each pair into one of 8 i32
//! lanes: with the weights of rows `j` and `j + 1` interleaved and
//! sign-extended to i16 (`[W[j][c], W[j+1][c]]` for 8 outputs `c`), and the
//! inputs `x[j], x[j+1]` of one sample broadcast as an i32, one instruction
//! does 16 multiply-accumulates for 8 outputs. Up to 8 samples share each
//! interleaved weight register; input pairs that are zero for all of them
//! (ReLU) are skipped. Integer sums are exact and, with the accumulator
//! headroom checked at load ([`crate::network::check_i8_headroom`]), never
//! overflow, so the result equals the portable kernel's bit for bit.

#![allow(unsafe_code)]

use core::arch::x86_64::*;
use core::mem::MaybeUninit;

use crate::fixed::Requant;
use crate::format::{read_i32, MAX_INPUT, MAX_WIDTH};

/// Samples per register tile.
const TILE_S: usize = 8;
/// Outputs per register (8 i32 lanes).
const TILE_C: usize = 8;
const MAX_PAIRS: usize = MAX_INPUT.div_ceil(2);

/// Interleaved weights of rows `ja` and `jb` for outputs `c0..c0 + 8`,
/// sign-extended to i16.
#[inline]
#[target_feature(enable = "avx2")]
fn pair_weights(weights: &[u8], od: usize, ja: usize, jb: usize, c0: usize) -> __m256i {
    let a = &weights[ja * od + c0..ja * od + c0 + TILE_C];
    let b = &weights[jb * od + c0..jb * od + c0 + TILE_C];
    // SAFETY: both slices are 8 bytes long (checked by the indexing above).
    let (a, b) = unsafe { (_mm_loadl_epi64(a.as_ptr().cast()), _mm_loadl_epi64(b.as_ptr().cast())) };
    _mm256_cvtepi8_epi16(_mm_unpacklo_epi8(a, b))
}

/// [`pair_weights`] for the last `od - c0 < 8` outputs, the missing ones 0.
#[inline]
#[target_feature(enable = "avx2")]
fn pair_weights_tail(weights: &[u8], od: usize, ja: usize, jb: usize, c0: usize) -> __m256i {
    let (mut a, mut b) = ([0u8; TILE_C], [0u8; TILE_C]);
    a[..od - c0].copy_from_slice(&weights[ja * od + c0..(ja + 1) * od]);
    b[..od - c0].copy_from_slice(&weights[jb * od + c0..(jb + 1) * od]);
    let (a, b) = (_mm_set1_epi64x(i64::from_le_bytes(a)), _mm_set1_epi64x(i64::from_le_bytes(b)));
    _mm256_cvtepi8_epi16(_mm_unpacklo_epi8(a, b))
}

/// `out[s][c] += Σ_j input[s][j] · W[row0 + j][c]` for `s < n` and every
/// output `c < od`, `W` being int8 `weights` with `od` outputs per row.
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
    let mut live_p = [0u16; MAX_PAIRS];
    // written up to the live count before each use (no 5 KiB zeroing per call)
    let mut live_x = [MaybeUninit::<[i32; TILE_S]>::uninit(); MAX_PAIRS];
    let mut s0 = 0;
    while s0 < n {
        let sn = (n - s0).min(TILE_S);
        let rows = &input[s0..s0 + sn];
        // the input pairs of each sample, keeping only the pairs that are
        // non-zero for some sample
        let mut live = 0;
        for p in 0..in_dim.div_ceil(2) {
            let mut xs = [0i32; TILE_S];
            for (x, r) in xs.iter_mut().zip(rows) {
                *x = pair(r, p, in_dim);
            }
            live_p[live] = p as u16;
            live_x[live] = MaybeUninit::new(xs);
            live += xs.iter().any(|&x| x != 0) as usize;
        }
        // SAFETY: entries 0..live were written in the loop above.
        let x: &[[i32; TILE_S]] = unsafe { core::slice::from_raw_parts(live_x.as_ptr().cast(), live) };
        let (p, out) = (&live_p[..live], &mut out[s0..s0 + sn]);
        // SAFETY: this module is compiled only with AVX2 enabled.
        unsafe {
            match sn {
                1 => tile::<1>(weights, od, row0, in_dim, p, x, out),
                2 => tile::<2>(weights, od, row0, in_dim, p, x, out),
                3 => tile::<3>(weights, od, row0, in_dim, p, x, out),
                4 => tile::<4>(weights, od, row0, in_dim, p, x, out),
                5 => tile::<5>(weights, od, row0, in_dim, p, x, out),
                6 => tile::<6>(weights, od, row0, in_dim, p, x, out),
                7 => tile::<7>(weights, od, row0, in_dim, p, x, out),
                _ => tile::<8>(weights, od, row0, in_dim, p, x, out),
            }
        }
        s0 += TILE_S;
    }
}

/// Inputs `2p` (low half) and `2p + 1` (high half, 0 past `in_dim`) of a
/// sample as one i32.
#[inline(always)]
fn pair<const N: usize>(r: &[i16; N], p: usize, in_dim: usize) -> i32 {
    let hi = if 2 * p + 1 < in_dim { r[2 * p + 1] as u16 as u32 } else { 0 };
    (r[2 * p] as u16 as u32 | hi << 16) as i32
}

/// One tile of `S` samples over all `od` outputs, 8 at a time, summing the
/// input pairs `live_p` whose values per sample are `live_x`.
#[target_feature(enable = "avx2")]
fn tile<const S: usize>(
    weights: &[u8],
    od: usize,
    row0: usize,
    in_dim: usize,
    live_p: &[u16],
    live_x: &[[i32; TILE_S]],
    out: &mut [[i32; MAX_WIDTH]],
) {
    // rows `ja`, `jb` of input pair `p`
    let rows = |p: u16| {
        let ja = row0 + 2 * p as usize;
        (ja, if 2 * p as usize + 1 < in_dim { ja + 1 } else { ja })
    };
    let mut c0 = 0;
    while c0 + TILE_C <= od {
        let acc = sums::<S>(live_p, live_x, |p| {
            let (ja, jb) = rows(p);
            pair_weights(weights, od, ja, jb, c0)
        });
        for (a, row) in acc.iter().zip(out.iter_mut()) {
            let dst = &mut row[c0..c0 + TILE_C];
            // SAFETY: `dst` is 8 i32 long.
            unsafe {
                let old = _mm256_loadu_si256(dst.as_ptr().cast());
                _mm256_storeu_si256(dst.as_mut_ptr().cast(), _mm256_add_epi32(old, *a));
            }
        }
        c0 += TILE_C;
    }
    if c0 < od {
        // a pruned width off the 8 grain: one short group
        let acc = sums::<S>(live_p, live_x, |p| {
            let (ja, jb) = rows(p);
            pair_weights_tail(weights, od, ja, jb, c0)
        });
        for (a, row) in acc.iter().zip(out.iter_mut()) {
            let mut sum = [0i32; TILE_C];
            // SAFETY: `sum` is 8 i32 long.
            unsafe { _mm256_storeu_si256(sum.as_mut_ptr().cast(), *a) };
            for (o, x) in row[c0..od].iter_mut().zip(sum) {
                *o += x;
            }
        }
    }
}

/// `Σ_p madd(x_s[p], w(p))` over the live pairs, for each of `S` samples.
#[inline(always)]
fn sums<const S: usize>(live_p: &[u16], live_x: &[[i32; TILE_S]], w: impl Fn(u16) -> __m256i) -> [__m256i; S] {
    // SAFETY: only called from `tile`, which requires AVX2.
    unsafe {
        let mut acc = [_mm256_setzero_si256(); S];
        for (&p, xs) in live_p.iter().zip(live_x) {
            let w = w(p);
            for s in 0..S {
                acc[s] = _mm256_add_epi32(acc[s], _mm256_madd_epi16(_mm256_set1_epi32(xs[s]), w));
            }
        }
        acc
    }
}

/// `out[s][c] = clamp((acc[s][c] · m_c + 2^(n_c − 1)) >> n_c, lo, hi)` for
/// `s < n`, `c < od`: [`crate::fixed::Requant::apply`] on i32 accumulators
/// (`rq` holds the layer's multiplier and shift pairs), four channels per
/// register in 64-bit lanes.
pub(crate) fn requant_i32(
    rq: &[u8],
    od: usize,
    n: usize,
    acc: &[[i32; MAX_WIDTH]],
    out: &mut [[i16; MAX_WIDTH]],
    (lo, hi): (i16, i16),
) {
    // SAFETY: this module is compiled only with AVX2 enabled.
    unsafe { requant_avx2(rq, od, n, acc, out, (lo, hi)) }
}

#[target_feature(enable = "avx2")]
fn requant_avx2(
    rq: &[u8],
    od: usize,
    n: usize,
    acc: &[[i32; MAX_WIDTH]],
    out: &mut [[i16; MAX_WIDTH]],
    (lo, hi): (i16, i16),
) {
    let factor = |c: usize| Requant { multiplier: read_i32(rq, 2 * c), shift: read_i32(rq, 2 * c + 1) };
    let (lov, hiv) = (_mm256_set1_epi64x(lo as i64), _mm256_set1_epi64x(hi as i64));
    // the low 32 bits of the four 64-bit lanes, in order
    let low_halves = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
    let mut c0 = 0;
    while c0 + 4 <= od {
        let f: [Requant; 4] = core::array::from_fn(|k| factor(c0 + k));
        let bits = f.map(|r| (31 + r.shift) as u32 & 63);
        let m = _mm256_setr_epi64x(
            f[0].multiplier as i64,
            f[1].multiplier as i64,
            f[2].multiplier as i64,
            f[3].multiplier as i64,
        );
        let round = bits.map(|b| (1i64 << b) >> 1);
        let round = _mm256_setr_epi64x(round[0], round[1], round[2], round[3]);
        let bits = _mm256_setr_epi64x(bits[0] as i64, bits[1] as i64, bits[2] as i64, bits[3] as i64);
        for (a, o) in acc[..n].iter().zip(out[..n].iter_mut()) {
            let src = &a[c0..c0 + 4];
            // SAFETY: `src` is 4 i32 (16 bytes) long.
            let x = _mm256_cvtepi32_epi64(unsafe { _mm_loadu_si128(src.as_ptr().cast()) });
            // |acc · m| < 2⁶², plus the rounding term < 2⁶³: exact in i64
            let p = _mm256_add_epi64(_mm256_mul_epi32(x, m), round);
            // arithmetic shift from a logical one: ¬((¬p) >> n) for p < 0
            let sign = _mm256_cmpgt_epi64(_mm256_setzero_si256(), p);
            let q = _mm256_xor_si256(_mm256_srlv_epi64(_mm256_xor_si256(p, sign), bits), sign);
            let q = _mm256_blendv_epi8(q, lov, _mm256_cmpgt_epi64(lov, q));
            let q = _mm256_blendv_epi8(q, hiv, _mm256_cmpgt_epi64(q, hiv));
            let q = _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(q, low_halves));
            let q = _mm_packs_epi32(q, q);
            let dst = &mut o[c0..c0 + 4];
            // SAFETY: `dst` is 4 i16 (8 bytes) long.
            unsafe { _mm_storel_epi64(dst.as_mut_ptr().cast(), q) };
        }
        c0 += 4;
    }
    for c in c0..od {
        let r = factor(c);
        for (a, o) in acc[..n].iter().zip(out[..n].iter_mut()) {
            o[c] = r.apply(a[c] as i64).clamp(lo as i64, hi as i64) as i16;
        }
    }
}

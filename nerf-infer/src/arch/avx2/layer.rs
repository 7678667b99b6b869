//! The int8 layer kernel on AVX2 (used where the CPU lacks AVX-512 VNNI).
//!
//! `vpmaddwd` multiplies 16 i16 pairs and adds each pair into one of 8 i32
//! lanes: with the weights of rows `j` and `j + 1` interleaved and
//! sign-extended to i16 (`[W[j][c], W[j+1][c]]` for 8 outputs `c`), and the
//! inputs `x[j], x[j+1]` of one sample broadcast as an i32, one instruction
//! does 16 multiply-accumulates for 8 outputs. Up to 8 samples share each
//! interleaved weight register; input pairs that are zero for all of them
//! (ReLU) are skipped. Integer sums are exact and, with the accumulator
//! headroom checked when a renderer is made, never
//! overflow, so the result equals the portable kernel's bit for bit.

#![allow(unsafe_code)]

use core::arch::x86_64::*;

use crate::format::{Layer, MAX_INPUT, MAX_WIDTH};
use crate::layer::{requant_rows, Input, W8};

/// Samples per register tile.
const TILE_S: usize = 8;
/// Outputs per register (8 i32 lanes).
const TILE_C: usize = 8;
const MAX_PAIRS: usize = MAX_INPUT / 2;

/// Interleaved weights of rows `ja` and `jb` for outputs `c0..c0 + 8`,
/// sign-extended to i16; `jb = None` pairs row `ja` with zeros.
///
/// # Safety
/// AVX2, and `(j + 1) · od ≤ weights.len()` and `c0 + 8 ≤ od` for both rows.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn pair_weights(weights: &[u8], od: usize, ja: usize, jb: Option<usize>, c0: usize) -> __m256i {
    debug_assert!(c0 + TILE_C <= od && (ja.max(jb.unwrap_or(0)) + 1) * od <= weights.len());
    // SAFETY: both 8-byte reads are inside `weights` (the contract above).
    let a = unsafe { _mm_loadl_epi64(weights.as_ptr().add(ja * od + c0).cast()) };
    let b = match jb {
        // SAFETY: as for `a`.
        Some(jb) => unsafe { _mm_loadl_epi64(weights.as_ptr().add(jb * od + c0).cast()) },
        None => _mm_setzero_si128(),
    };
    _mm256_cvtepi8_epi16(_mm_unpacklo_epi8(a, b))
}

/// [`pair_weights`] for the last `od - c0 < 8` outputs, the missing ones 0.
#[inline]
#[target_feature(enable = "avx2")]
fn pair_weights_tail(weights: &[u8], od: usize, ja: usize, jb: Option<usize>, c0: usize) -> __m256i {
    let (mut a, mut b) = ([0u8; TILE_C], [0u8; TILE_C]);
    // byte by byte: a copy of a run this short would call memcpy
    for (k, (a, b)) in a.iter_mut().zip(b.iter_mut()).enumerate().take(od - c0) {
        *a = weights[ja * od + c0 + k];
        *b = jb.map_or(0, |jb| weights[jb * od + c0 + k]);
    }
    let (a, b) = (_mm_set1_epi64x(i64::from_le_bytes(a)), _mm_set1_epi64x(i64::from_le_bytes(b)));
    _mm256_cvtepi8_epi16(_mm_unpacklo_epi8(a, b))
}

/// `out[s][c] += Σ_j x.rows[s][j] · W[x.row0 + j][c]` for `s < x.n` and
/// every output `c` of `l`, an int8 layer.
#[inline]
pub(crate) fn accumulate_i8<const N: usize>(
    _: super::Avx2,
    l: &Layer<'_>,
    x: Input<'_, i16, N>,
    out: &mut [[i32; MAX_WIDTH]],
) {
    let Input { rows: input, row0, width: in_dim, n } = x;
    let (weights, od) = (l.weights, l.out_dim as usize);
    // every weight the tiles read is in rows row0 .. row0 + in_dim
    assert!((row0 + in_dim) * od <= weights.len() && in_dim <= N);
    let mut live_p = [0u16; MAX_PAIRS];
    let mut s0 = 0;
    while s0 < n {
        let sn = (n - s0).min(TILE_S);
        let rows = &input[s0..s0 + sn];
        // the pairs of inputs (2p, 2p + 1) non-zero for some sample, 8 at a
        // time from one OR of the rows; an odd last input goes alone
        // SAFETY: the token proves the CPU has AVX2.
        let live = unsafe { live_pairs(rows, in_dim, &mut live_p) };
        let odd = in_dim % 2 == 1 && rows.iter().any(|r| r[in_dim - 1] != 0);
        let (p, out) = (&live_p[..live], &mut out[s0..s0 + sn]);
        // SAFETY: the token proves the CPU has AVX2.
        unsafe {
            match sn {
                1 => tile::<1, N>(weights, od, row0, in_dim, p, odd, rows, out),
                2 => tile::<2, N>(weights, od, row0, in_dim, p, odd, rows, out),
                3 => tile::<3, N>(weights, od, row0, in_dim, p, odd, rows, out),
                4 => tile::<4, N>(weights, od, row0, in_dim, p, odd, rows, out),
                5 => tile::<5, N>(weights, od, row0, in_dim, p, odd, rows, out),
                6 => tile::<6, N>(weights, od, row0, in_dim, p, odd, rows, out),
                7 => tile::<7, N>(weights, od, row0, in_dim, p, odd, rows, out),
                _ => tile::<8, N>(weights, od, row0, in_dim, p, odd, rows, out),
            }
        }
        s0 += TILE_S;
    }
}

/// Writes to `live_p` the pairs `p < in_dim / 2` (inputs `2p`, `2p + 1`)
/// that are non-zero in some row, in order, 8 at a time from one OR of the
/// rows and the last few one by one; returns their count. (The VNNI
/// kernel finds its live pairs with it too.)
#[target_feature(enable = "avx2")]
pub(crate) fn live_pairs<const N: usize>(rows: &[[i16; N]], in_dim: usize, live_p: &mut [u16]) -> usize {
    let mut live = 0;
    for k in 0..in_dim / 16 {
        let mut v = _mm256_setzero_si256();
        for r in rows {
            let x = &r[16 * k..16 * k + 16];
            // SAFETY: `x` is 16 i16 (32 bytes) long.
            v = _mm256_or_si256(v, unsafe { _mm256_loadu_si256(x.as_ptr().cast()) });
        }
        let zero = _mm256_cmpeq_epi32(v, _mm256_setzero_si256());
        let mut m = !_mm256_movemask_ps(_mm256_castsi256_ps(zero)) as u32 & 0xFF;
        while m != 0 {
            live_p[live] = (8 * k + m.trailing_zeros() as usize) as u16;
            live += 1;
            m &= m - 1;
        }
    }
    for p in in_dim / 16 * 8..in_dim / 2 {
        live_p[live] = p as u16;
        live += rows.iter().any(|r| r[2 * p] | r[2 * p + 1] != 0) as usize;
    }
    live
}

/// One tile of `S` samples (`rows`) over all `od` outputs, 8 at a time,
/// summing the input pairs `live_p` (each `< in_dim / 2`) and, if `odd`,
/// the odd last input.
#[allow(clippy::too_many_arguments)]
#[target_feature(enable = "avx2")]
fn tile<const S: usize, const N: usize>(
    weights: &[u8],
    od: usize,
    row0: usize,
    in_dim: usize,
    live_p: &[u16],
    odd: bool,
    rows: &[[i16; N]],
    out: &mut [[i32; MAX_WIDTH]],
) {
    let rows: &[[i16; N]; S] = rows.try_into().expect("S rows");
    let mut c0 = 0;
    while c0 + TILE_C <= od {
        let acc = group::<S, N, false>(weights, od, row0, in_dim, live_p, odd, rows, c0);
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
        let acc = group::<S, N, true>(weights, od, row0, in_dim, live_p, odd, rows, c0);
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

/// The sums of one group of 8 outputs from `c0` (fewer if `TAIL`) for `S`
/// samples.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn group<const S: usize, const N: usize, const TAIL: bool>(
    weights: &[u8],
    od: usize,
    row0: usize,
    in_dim: usize,
    live_p: &[u16],
    odd: bool,
    rows: &[[i16; N]; S],
    c0: usize,
) -> [__m256i; S] {
    // SAFETY: only called from `tile`, which requires AVX2, with rows
    // row0 .. row0 + in_dim of `weights` present (asserted in
    // `accumulate_i8`) and, unless TAIL, c0 + 8 ≤ od.
    unsafe {
        let weights_of = |ja: usize, jb: Option<usize>| {
            if TAIL {
                pair_weights_tail(weights, od, ja, jb, c0)
            } else {
                pair_weights(weights, od, ja, jb, c0)
            }
        };
        let mut acc = [_mm256_setzero_si256(); S];
        for &p in live_p {
            let j = 2 * p as usize;
            let w = weights_of(row0 + j, Some(row0 + j + 1));
            debug_assert!(j + 1 < in_dim && in_dim <= N);
            for s in 0..S {
                // inputs j and j + 1 as one little-endian i32 (low half j):
                // one broadcast load. SAFETY: j + 1 < in_dim ≤ N.
                let x = core::ptr::read_unaligned(rows[s].as_ptr().add(j).cast::<i32>());
                acc[s] = _mm256_add_epi32(acc[s], _mm256_madd_epi16(_mm256_set1_epi32(x), w));
            }
        }
        if odd {
            let j = in_dim - 1;
            let w = weights_of(row0 + j, None);
            for s in 0..S {
                let x = _mm256_set1_epi32(rows[s][j] as u16 as i32);
                acc[s] = _mm256_add_epi32(acc[s], _mm256_madd_epi16(x, w));
            }
        }
        acc
    }
}

/// `out[s][c] = clamp((acc[s][c] · m_c + 2^(n_c − 1)) >> n_c, lo, hi)` for
/// `s < n` and every output `c` of `l`: [`crate::fixed::Requant::apply`]
/// on i32 accumulators, four channels per register in 64-bit lanes.
pub(crate) fn requant_i32(
    _: super::Avx2,
    l: &Layer<'_>,
    n: usize,
    acc: &[[i32; MAX_WIDTH]],
    out: &mut [[i16; MAX_WIDTH]],
    (lo, hi): (i16, i16),
) {
    // SAFETY: the token proves the CPU has AVX2.
    unsafe { requant_avx2(l, n, acc, out, (lo, hi)) }
}

#[target_feature(enable = "avx2")]
fn requant_avx2(l: &Layer<'_>, n: usize, acc: &[[i32; MAX_WIDTH]], out: &mut [[i16; MAX_WIDTH]], (lo, hi): (i16, i16)) {
    let (rq, od) = (l.requant, l.out_dim as usize);
    let (lov, hiv) = (_mm256_set1_epi64x(lo as i64), _mm256_set1_epi64x(hi as i64));
    let (lo4, hi4) = (_mm_set1_epi32(lo as i32), _mm_set1_epi32(hi as i32));
    // the low 32 bits of the four 64-bit lanes, in order
    let low_halves = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
    let mut c0 = 0;
    while c0 + 4 <= od {
        // channel c's (multiplier, shift) pair as one 64-bit lane: the
        // multiply reads the low half, the shift is the high half
        let f = &rq[8 * c0..8 * c0 + 32];
        // SAFETY: `f` is 32 bytes long.
        let m = unsafe { _mm256_loadu_si256(f.as_ptr().cast()) };
        // (31 + shift) & 63 with the shift taken as u32: 2³² vanishes mod 64
        let bits = _mm256_and_si256(
            _mm256_add_epi64(_mm256_srli_epi64::<32>(m), _mm256_set1_epi64x(31)),
            _mm256_set1_epi64x(63),
        );
        // an arithmetic shift from a logical one: with |acc · m| < 2⁶², the
        // sum acc · m + 2⁶² + round lies in [0, 2⁶⁴) (as u64), and since
        // 2⁶² is a multiple of 2ⁿ (n ≤ 62), shifting it right by n and
        // taking 2⁶²⁻ⁿ off again is ⌊(acc · m + round) / 2ⁿ⌋ exactly
        let round = _mm256_srli_epi64::<1>(_mm256_sllv_epi64(_mm256_set1_epi64x(1), bits));
        let bias = _mm256_set1_epi64x(1 << 62);
        let add = _mm256_add_epi64(round, bias);
        let sub = _mm256_srlv_epi64(bias, bits);
        // with every shift ≥ 0 (n ≥ 31) the result fits an i32 (|acc · m|
        // < 2⁶²), so the clamp can wait until the lanes are narrowed
        let narrow = (c0..c0 + 4).all(|c| l.requant(c).shift >= 0);
        for (a, o) in acc[..n].iter().zip(out[..n].iter_mut()) {
            let src = &a[c0..c0 + 4];
            // SAFETY: `src` is 4 i32 (16 bytes) long.
            let x = _mm256_cvtepi32_epi64(unsafe { _mm_loadu_si128(src.as_ptr().cast()) });
            let p = _mm256_add_epi64(_mm256_mul_epi32(x, m), add);
            let q = _mm256_sub_epi64(_mm256_srlv_epi64(p, bits), sub);
            let q = if narrow {
                let q = _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(q, low_halves));
                _mm_min_epi32(_mm_max_epi32(q, lo4), hi4)
            } else {
                let q = _mm256_blendv_epi8(q, lov, _mm256_cmpgt_epi64(lov, q));
                let q = _mm256_blendv_epi8(q, hiv, _mm256_cmpgt_epi64(q, hiv));
                _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(q, low_halves))
            };
            let q = _mm_packs_epi32(q, q);
            let dst = &mut o[c0..c0 + 4];
            // SAFETY: `dst` is 4 i16 (8 bytes) long.
            unsafe { _mm_storel_epi64(dst.as_mut_ptr().cast(), q) };
        }
        c0 += 4;
    }
    requant_rows::<W8>(l, c0, n, acc, out, (lo, hi));
}

//! The int8 layer kernel on WebAssembly's 128-bit SIMD.
//!
//! `i32x4.dot_i16x8_s` multiplies 8 i16 pairs and adds each pair into one
//! of 4 i32 lanes (the 128-bit `vpmaddwd`, as in `avx2::accumulate_i8`):
//! with the weights of rows `j` and `j + 1` interleaved and sign-extended
//! to i16 (`[W[j][c], W[j+1][c]]` for 4 outputs `c`), and the inputs
//! `x[j], x[j+1]` of one sample splatted as an i32, one instruction does
//! 8 multiply-accumulates. A tile is up to 4 samples × 16 outputs; pairs of
//! inputs that are zero for every sample of the tile (ReLU) are skipped.
//! Integer sums are exact and, with the accumulator headroom checked when
//! a renderer is made, never overflow, so the result equals the portable
//! kernel's bit for bit.

use core::arch::wasm32::*;

use crate::format::{Layer, MAX_INPUT, MAX_WIDTH};
use crate::layer::Input;

/// Samples per tile.
const TILE_S: usize = 4;
/// Outputs per tile (four registers of 4 i32 lanes).
const TILE_C: usize = 16;
const MAX_PAIRS: usize = MAX_INPUT.div_ceil(2);

/// Bytes `at..at + 16` of `w` as a register, missing bytes (past the end)
/// zero.
#[inline(always)]
fn load16(w: &[u8], at: usize) -> v128 {
    let word = |k: usize| -> u64 {
        match w.get(at + k..at + k + 8) {
            Some(b) => u64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]),
            // byte by byte: a copy of a run this short would call memcpy
            None => (0..8).fold(0, |v, i| v | (w.get(at + k + i).copied().unwrap_or(0) as u64) << (8 * i)),
        }
    };
    u64x2(word(0), word(8))
}

/// `out[s][c] += Σ_j x.rows[s][j] · W[x.row0 + j][c]` for `s < x.n` and
/// every output `c` of `l`, an int8 layer.
#[inline]
pub(crate) fn accumulate_i8<const N: usize>(l: &Layer<'_>, x: Input<'_, i16, N>, out: &mut [[i32; MAX_WIDTH]]) {
    let Input { rows: input, row0, width: in_dim, n } = x;
    let (weights, od) = (l.weights, l.out_dim as usize);
    assert!((row0 + in_dim) * od <= weights.len() && in_dim <= N);
    let pairs = in_dim.div_ceil(2);
    let mut live = [0u16; MAX_PAIRS];
    // each sample's inputs (2p, 2p + 1) as the i32 the interleaved weights multiply by
    let mut xs = [[0i32; MAX_PAIRS]; TILE_S];
    let mut s0 = 0;
    while s0 < n {
        let sn = (n - s0).min(TILE_S);
        let rows = &input[s0..s0 + sn];
        // the pairs non-zero for some sample; an odd last input goes alone
        let mut nl = 0;
        for p in 0..pairs {
            let (j, b) = (2 * p, (2 * p + 1 < in_dim) as usize);
            live[nl] = p as u16;
            let mut any = false;
            for (x, r) in xs.iter_mut().zip(rows) {
                let v = r[j] as u16 as u32 | (r[j + b] as u16 as u32 * b as u32) << 16;
                x[p] = v as i32;
                any |= v != 0;
            }
            nl += any as usize;
        }
        let mut c0 = 0;
        while c0 < od {
            let cw = (od - c0).min(TILE_C);
            let mut acc = [[i32x4_splat(0); 4]; TILE_S];
            for (a, o) in acc.iter_mut().zip(&out[s0..s0 + sn]) {
                let mut v = [0i32; TILE_C];
                v[..cw].copy_from_slice(&o[c0..c0 + cw]);
                *a = core::array::from_fn(|q| i32x4(v[4 * q], v[4 * q + 1], v[4 * q + 2], v[4 * q + 3]));
            }
            for &p in &live[..nl] {
                let ja = row0 + 2 * p as usize;
                let a = load16(weights, ja * od + c0);
                let b = if 2 * p as usize + 1 < in_dim { load16(weights, (ja + 1) * od + c0) } else { i32x4_splat(0) };
                // a0 b0 a1 b1 …, as i16: four registers of 4 outputs each
                let lo = i8x16_shuffle::<0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23>(a, b);
                let hi = i8x16_shuffle::<8, 24, 9, 25, 10, 26, 11, 27, 12, 28, 13, 29, 14, 30, 15, 31>(a, b);
                let w = [
                    i16x8_extend_low_i8x16(lo),
                    i16x8_extend_high_i8x16(lo),
                    i16x8_extend_low_i8x16(hi),
                    i16x8_extend_high_i8x16(hi),
                ];
                for (acc, x) in acc[..sn].iter_mut().zip(&xs) {
                    let xv = i32x4_splat(x[p as usize]);
                    for q in 0..4 {
                        acc[q] = i32x4_add(acc[q], i32x4_dot_i16x8(w[q], xv));
                    }
                }
            }
            for (a, o) in acc.iter().zip(&mut out[s0..s0 + sn]) {
                let mut v = [0i32; TILE_C];
                for (q, r) in a.iter().enumerate() {
                    v[4 * q..4 * q + 4].copy_from_slice(&[
                        i32x4_extract_lane::<0>(*r),
                        i32x4_extract_lane::<1>(*r),
                        i32x4_extract_lane::<2>(*r),
                        i32x4_extract_lane::<3>(*r),
                    ]);
                }
                o[c0..c0 + cw].copy_from_slice(&v[..cw]);
            }
            c0 += TILE_C;
        }
        s0 += TILE_S;
    }
}

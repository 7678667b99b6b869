//! Architecture-specific kernels and the one place that picks them.
//!
//! Each kernel here implements a contract that a portable reference in the
//! crate also implements, bit for bit:
//!
//! | contract | portable reference | x86-64 AVX2 | x86-64 AVX-512 VNNI | wasm32 SIMD128 |
//! |---|---|---|---|---|
//! | int8 dense layer (`acc += x·W`) | [`crate::layer::accumulate`] | `avx2::accumulate_i8` | `vnni::accumulate_i8` (32-wide tiles) | `wasm::accumulate_i8` |
//! | requantisation of i32 accumulators | [`crate::layer::requant_rows`] | `avx2::requant_i32` | `vnni::requant_i32` | (portable) |
//! | sine of phases, Q15 | [`crate::fixed::sin_turns_q15`] | `avx2::sin_turns_q15_x8` | (AVX2) | (portable) |
//! | width-2 feature-grid lookups | [`FeatureGrid::encode_fixed`] | `avx2::features_w2` | (AVX2) | (portable) |
//!
//! The choice is made at compile time from the target features the build
//! enables (`-C target-cpu=native`, or `x86-64-v3` for AVX2); without them
//! every contract runs its portable reference, as on Cortex-M. wasm32 with
//! `simd128` (which the browser viewer is built with) has its own int8
//! layer; its tests run in the browser (`tests/web.rs`: the page's frames
//! against the host's, bit for bit), the others here.
//! Portable code never calls into this module's submodules; the rest of the
//! crate calls the functions and the [`IntKernel`] trait below. The tests at
//! the end run every implementation built against its reference.
//!
//! To add an architecture: a folder beside `avx2/` with the kernels it
//! speeds up, a `cfg` arm in the functions below, and a line in the tests'
//! list.

#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[cfg_attr(all(target_feature = "avx512bw", target_feature = "avx512vnni"), allow(dead_code))]
mod avx2;
#[cfg(all(target_arch = "x86_64", target_feature = "avx512bw", target_feature = "avx512vnni"))]
mod vnni;
#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
mod wasm;

use crate::camera::FOOTPRINT_POINTS;
use crate::features::FeatureGrid;
use crate::fixed::sin_turns_q15;
use crate::format::{Layer, MAX_WIDTH};
use crate::layer::{accumulate, requant_rows, Input, IntWeight, W16, W8};

/// Whether the AVX2 int8 kernels are built (and AVX-512 VNNI is not).
const AVX2_ONLY: bool = cfg!(all(
    target_arch = "x86_64",
    target_feature = "avx2",
    not(all(target_feature = "avx512bw", target_feature = "avx512vnni"))
));

/// Whether the wasm SIMD128 int8 kernel is built.
const WASM_SIMD: bool = cfg!(all(target_arch = "wasm32", target_feature = "simd128"));

/// The dense-layer kernels of an integer weight type, as built for this
/// target.
pub trait IntKernel: IntWeight + Sized {
    /// Whether [`IntKernel::accumulate_wide`] also takes layers narrower
    /// than the portable tile (the colour head) faster than scalar dot
    /// products.
    const WIDE_TAKES_NARROW: bool = false;
    /// `acc[s][c] += Σ_j x.rows[s][j] · W[x.row0 + j][c]` for the first
    /// `x.n` samples and every output of a layer at least
    /// [`crate::layer::TILE_C`] wide (or any width if
    /// [`IntKernel::WIDE_TAKES_NARROW`]); the portable kernel by default.
    #[inline]
    fn accumulate_wide<const N: usize>(l: &Layer<'_>, x: Input<'_, i16, N>, acc: &mut [[Self::A; MAX_WIDTH]]) {
        accumulate::<Self, N>(l, 0, x, acc);
    }
    /// `out[s][c] = clamp(requantised acc[s][c], lo, hi)` for the first `n`
    /// samples and every output of `l`; the portable loop by default.
    #[inline]
    fn requant_rows(
        l: &Layer<'_>,
        n: usize,
        acc: &[[Self::A; MAX_WIDTH]],
        out: &mut [[i16; MAX_WIDTH]],
        bounds: (i16, i16),
    ) {
        requant_rows::<Self>(l, 0, n, acc, out, bounds);
    }
}

/// int16 weights: the portable kernels everywhere (i64 sums auto-vectorise).
impl IntKernel for W16 {}

/// int8 weights: VNNI for whole 32-wide tiles (the portable loop for the
/// rest), else AVX2 `vpmaddwd` 8 outputs at a time (a short last group
/// padded), else portable.
impl IntKernel for W8 {
    const WIDE_TAKES_NARROW: bool = AVX2_ONLY || WASM_SIMD;
    #[inline]
    fn accumulate_wide<const N: usize>(l: &Layer<'_>, x: Input<'_, i16, N>, acc: &mut [[i32; MAX_WIDTH]]) {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx512bw", target_feature = "avx512vnni"))]
        {
            vnni::accumulate_i8(l, x, acc);
            let od = l.out_dim as usize;
            accumulate::<W8, N>(l, od - od % crate::layer::TILE_C, x, acc);
        }
        #[cfg(all(
            target_arch = "x86_64",
            target_feature = "avx2",
            not(all(target_feature = "avx512bw", target_feature = "avx512vnni"))
        ))]
        avx2::accumulate_i8(l, x, acc);
        #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
        wasm::accumulate_i8(l, x, acc);
        #[cfg(not(any(
            all(target_arch = "x86_64", target_feature = "avx2"),
            all(target_arch = "wasm32", target_feature = "simd128")
        )))]
        accumulate::<W8, N>(l, 0, x, acc);
    }
    #[inline]
    fn requant_rows(l: &Layer<'_>, n: usize, acc: &[[i32; MAX_WIDTH]], out: &mut [[i16; MAX_WIDTH]], b: (i16, i16)) {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx512bw", target_feature = "avx512vnni"))]
        vnni::requant_i32(l, n, acc, out, b);
        #[cfg(all(
            target_arch = "x86_64",
            target_feature = "avx2",
            not(all(target_feature = "avx512bw", target_feature = "avx512vnni"))
        ))]
        avx2::requant_i32(l, n, acc, out, b);
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
        requant_rows::<W8>(l, 0, n, acc, out, b);
    }
}

/// [`sin_turns_q15`] of every phase in `phases` into `out` (same length),
/// bit for bit; with AVX2, 8 at a time.
#[inline]
pub fn sin_turns_q15_slice(phases: &[u32], out: &mut [i16]) {
    debug_assert_eq!(phases.len(), out.len());
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    let done = avx2::sin_turns_q15_x8(phases, out);
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    let done = 0;
    for (o, &ph) in out[done..].iter_mut().zip(&phases[done..]) {
        *o = sin_turns_q15(ph);
    }
}

/// [`FeatureGrid::encode_fixed`] at every position of `pos`, into
/// `out[s][at..at + g.dim()]` (bit for bit; with AVX2, width-2 grids take
/// 8 levels per register, i16 or narrow tables).
#[inline]
pub fn feature_rows<const N: usize>(g: &FeatureGrid<'_>, pos: &[[i32; 3]], out: &mut [[i16; N]], at: usize) {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    if g.width == 2 {
        avx2::features_w2(g, pos, out, at);
        return;
    }
    for (p, o) in pos.iter().zip(out.iter_mut()) {
        g.encode_fixed(*p, &mut o[at..at + g.dim()]);
    }
}

/// The mean of [`FeatureGrid::encode_fixed`] over each row's three
/// footprint points in `foot`, into `out[s][at..at + g.dim()]`: the three
/// i16 features summed in i32, divided by 3 and rounded to the nearest,
/// `⌊(2Σ + 3)/6⌋` (the lookups as [`feature_rows`] makes them, up to 16 rows'
/// points per call).
#[inline]
pub fn feature_rows_mean<const N: usize>(
    g: &FeatureGrid<'_>,
    foot: &[[[i32; 3]; FOOTPRINT_POINTS]],
    out: &mut [[i16; N]],
    at: usize,
) {
    const ROWS: usize = 16;
    const _: () = assert!(FOOTPRINT_POINTS == 3);
    let dim = g.dim();
    let mut lookups = [[0i16; crate::limits::MAX_FEATURES]; FOOTPRINT_POINTS * ROWS];
    for (pts, rows) in foot.chunks(ROWS).zip(out.chunks_mut(ROWS)) {
        feature_rows(g, pts.as_flattened(), &mut lookups, 0);
        for (q, o) in lookups.chunks_exact(FOOTPRINT_POINTS).zip(rows.iter_mut().take(pts.len())) {
            for (j, v) in o[at..at + dim].iter_mut().enumerate() {
                let sum = q[0][j] as i32 + q[1][j] as i32 + q[2][j] as i32;
                *v = (2 * sum + 3).div_euclid(6) as i16;
            }
        }
    }
}

#[cfg(test)]
mod tests;

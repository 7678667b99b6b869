//! Architecture-specific kernels and the one place that picks them, and
//! [`prefetch`], a hint that changes no value (so it has no reference).
//!
//! Each kernel here implements a contract that a portable reference in the
//! crate also implements, bit for bit:
//!
//! | contract | portable reference | x86-64 AVX2 | x86-64 AVX-512 VNNI | wasm32 SIMD128 |
//! |---|---|---|---|---|
//! | f32 dense layer (`acc += x·W`) | [`crate::layer::accumulate`] | `avx2::accumulate_f32` (the same loop for AVX2) | (AVX2) | (portable) |
//! | int8 dense layer (`acc += x·W`) | [`crate::layer::accumulate`] | `avx2::accumulate_i8` | `vnni::accumulate_i8` (32-wide tiles) | `wasm::accumulate_i8` |
//! | requantisation of i32 accumulators | [`crate::layer::requant_rows`] | `avx2::requant_i32` | `vnni::requant_i32` | (portable) |
//! | sine of phases, Q15 | [`crate::fixed::sin_turns_q15`] | `avx2::sin_turns_q15_x8` | (AVX2) | (portable) |
//! | width-2 feature-grid lookups | [`FeatureGrid::encode_fixed`] | `avx2::features_w2` | (AVX2) | (portable) |
//!
//! The choice is made once per process, at first use ([`kernels`]): with
//! the `std` feature, x86-64 builds carry the AVX2 and AVX-512 VNNI
//! kernels whatever the build's target features, and pick the best the
//! CPU has (`is_x86_feature_detected!`), so a plain `cargo build` of a
//! program that depends on this crate gets them. Without `std` the choice
//! is made at compile time from the target features the build enables
//! (`RUSTFLAGS="-C target-cpu=native"`, or `-C target-cpu=x86-64-v3` for
//! AVX2, `-C target-feature=+avx512bw,+avx512vnni` for VNNI); without them
//! every contract runs its portable reference, as on Cortex-M. wasm32 with
//! `simd128` (`RUSTFLAGS="-C target-feature=+simd128"`, as the browser
//! viewer is built) has its own int8 layer; its tests run in the browser
//! (`tests/web.rs`: the page's frames against the host's, bit for bit), the
//! others here. Every kernel gives the same bits, so the pixels do not
//! depend on the kernels chosen ([`use_kernels`] chooses others, for
//! benchmarks and tests).
//!
//! Portable code never calls into this module's submodules; the rest of the
//! crate calls the functions and the [`IntKernel`] trait below. The tests at
//! the end run every implementation the build carries and the CPU runs
//! against its reference.
//!
//! To add an architecture: a folder beside `avx2/` with the kernels it
//! speeds up and a token type that proves the CPU has them, a
//! [`Kernels`] variant and its detection, an arm in the functions below,
//! and a line in the tests' list.

#[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
mod avx2;
#[cfg(all(
    target_arch = "x86_64",
    any(feature = "std", all(target_feature = "avx512bw", target_feature = "avx512vnni"))
))]
mod vnni;
#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
mod wasm;

use core::sync::atomic::{AtomicU8, Ordering};

use crate::features::FeatureGrid;
use crate::fixed::sin_turns_q15;
use crate::format::{Layer, MAX_WIDTH};
use crate::layer::{accumulate, requant_rows, Input, IntWeight, MacF32, W16, W8};
use crate::limits::FOOTPRINT_POINTS;

/// A set of SIMD kernels for the contracts of this module.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernels {
    /// The portable references (any target).
    Portable,
    /// x86-64 AVX2: the int8 layer, its requantiser, the sine and width-2
    /// feature lookups.
    Avx2,
    /// x86-64 AVX-512 VNNI (with `avx512f` and `avx512bw`) for the int8
    /// layer and its requantiser, AVX2 for the rest.
    Avx512Vnni,
    /// wasm32 SIMD128: the int8 layer.
    Simd128,
}

impl Kernels {
    /// Every set, best last.
    pub const ALL: [Kernels; 4] = [Kernels::Portable, Kernels::Simd128, Kernels::Avx2, Kernels::Avx512Vnni];

    /// Whether this build carries the set and the CPU running it has the
    /// instructions it needs.
    pub fn available(self) -> bool {
        match self {
            Kernels::Portable => true,
            Kernels::Avx2 => has_avx2(),
            Kernels::Avx512Vnni => has_vnni(),
            Kernels::Simd128 => cfg!(all(target_arch = "wasm32", target_feature = "simd128")),
        }
    }

    /// The best set [`Kernels::available`].
    pub fn best() -> Kernels {
        *Kernels::ALL.iter().rev().find(|k| k.available()).unwrap_or(&Kernels::Portable)
    }
}

/// A hint that element `i` of `data` is about to be read: on x86-64 a
/// prefetch into every cache level (`prefetcht0`, part of the baseline
/// SSE), nothing elsewhere or for an index past the end. It changes no
/// value, only when the memory arrives: for gathers whose addresses are
/// known a few samples ahead (the feature grid's corners).
#[inline(always)]
#[allow(unsafe_code)]
pub fn prefetch<T>(data: &[T], i: usize) {
    #[cfg(target_arch = "x86_64")]
    if i < data.len() {
        use core::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: a prefetch neither faults nor writes; the address is inside `data`
        unsafe { _mm_prefetch::<_MM_HINT_T0>(data.as_ptr().add(i).cast::<i8>()) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (data, i);
}

/// Whether the AVX2 kernels are built and the CPU has AVX2.
#[inline]
fn has_avx2() -> bool {
    #[cfg(all(target_arch = "x86_64", feature = "std"))]
    return std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(all(target_arch = "x86_64", feature = "std")))]
    return cfg!(all(target_arch = "x86_64", target_feature = "avx2"));
}

/// Whether the VNNI kernels are built and the CPU has what they need.
#[inline]
fn has_vnni() -> bool {
    #[cfg(all(target_arch = "x86_64", feature = "std"))]
    return std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512bw")
        && std::arch::is_x86_feature_detected!("avx512vnni")
        && has_avx2();
    #[cfg(not(all(target_arch = "x86_64", feature = "std")))]
    return cfg!(all(target_arch = "x86_64", target_feature = "avx512bw", target_feature = "avx512vnni"));
}

/// The kernels in use plus one; 0 until the first call of [`kernels`].
static IN_USE: AtomicU8 = AtomicU8::new(0);

/// The kernels this process runs: [`Kernels::best`], picked at the first
/// call (one CPU feature check per process), unless [`use_kernels`] chose
/// others.
#[inline]
pub fn kernels() -> Kernels {
    match IN_USE.load(Ordering::Relaxed) {
        0 => {
            let k = Kernels::best();
            IN_USE.store(k as u8 + 1, Ordering::Relaxed);
            k
        }
        k => Kernels::ALL.into_iter().find(|&v| v as u8 + 1 == k).unwrap_or(Kernels::Portable),
    }
}

/// Runs `k` from now on, in every thread, in place of [`kernels`]' choice;
/// returns `false` (and changes nothing) if `k` is not
/// [`Kernels::available`]. The pixels are the same whichever runs: this
/// is for timing one against another and for tests.
pub fn use_kernels(k: Kernels) -> bool {
    if k.available() {
        IN_USE.store(k as u8 + 1, Ordering::Relaxed);
    }
    k.available()
}

/// The kernels of one call, with the proof that the CPU has them.
#[derive(Clone, Copy)]
enum Active {
    Portable,
    #[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
    Avx2(avx2::Avx2),
    #[cfg(all(
        target_arch = "x86_64",
        any(feature = "std", all(target_feature = "avx512bw", target_feature = "avx512vnni"))
    ))]
    Vnni(vnni::Vnni),
    #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
    Simd128,
}

/// [`kernels`] as an [`Active`] set.
#[inline]
fn active() -> Active {
    match kernels() {
        #[cfg(all(
            target_arch = "x86_64",
            any(feature = "std", all(target_feature = "avx512bw", target_feature = "avx512vnni"))
        ))]
        Kernels::Avx512Vnni => vnni::Vnni::new().map_or(Active::Portable, Active::Vnni),
        #[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
        Kernels::Avx2 => avx2::Avx2::new().map_or(Active::Portable, Active::Avx2),
        #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
        Kernels::Simd128 => Active::Simd128,
        _ => Active::Portable,
    }
}

/// The dense-layer kernels of an integer weight type.
pub trait IntKernel: IntWeight + Sized {
    /// Whether [`IntKernel::accumulate_wide`] also takes layers narrower
    /// than the portable tile (the colour head) faster than scalar dot
    /// products, with the kernels in use.
    #[inline]
    fn wide_takes_narrow() -> bool {
        false
    }
    /// `acc[s][c] += Σ_j x.rows[s][j] · W[x.row0 + j][c]` for the first
    /// `x.n` samples and every output of a layer at least
    /// [`crate::layer::TILE_C`] wide (or any width if
    /// [`IntKernel::wide_takes_narrow`]); the portable kernel by default.
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
/// padded), else SIMD128, else portable.
impl IntKernel for W8 {
    #[inline]
    fn wide_takes_narrow() -> bool {
        match active() {
            #[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
            Active::Avx2(_) => true,
            #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
            Active::Simd128 => true,
            _ => false,
        }
    }
    #[inline]
    fn accumulate_wide<const N: usize>(l: &Layer<'_>, x: Input<'_, i16, N>, acc: &mut [[i32; MAX_WIDTH]]) {
        match active() {
            #[cfg(all(
                target_arch = "x86_64",
                any(feature = "std", all(target_feature = "avx512bw", target_feature = "avx512vnni"))
            ))]
            Active::Vnni(k) => {
                vnni::accumulate_i8(k, l, x, acc);
                let od = l.out_dim as usize;
                accumulate::<W8, N>(l, od - od % crate::layer::TILE_C, x, acc);
            }
            #[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
            Active::Avx2(k) => avx2::accumulate_i8(k, l, x, acc),
            #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
            Active::Simd128 => wasm::accumulate_i8(l, x, acc),
            Active::Portable => accumulate::<W8, N>(l, 0, x, acc),
        }
    }
    #[inline]
    fn requant_rows(l: &Layer<'_>, n: usize, acc: &[[i32; MAX_WIDTH]], out: &mut [[i16; MAX_WIDTH]], b: (i16, i16)) {
        match active() {
            #[cfg(all(
                target_arch = "x86_64",
                any(feature = "std", all(target_feature = "avx512bw", target_feature = "avx512vnni"))
            ))]
            Active::Vnni(k) => vnni::requant_i32(k, l, n, acc, out, b),
            #[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
            Active::Avx2(k) => avx2::requant_i32(k, l, n, acc, out, b),
            _ => requant_rows::<W8>(l, 0, n, acc, out, b),
        }
    }
}

/// The AVX2 token of the kernels in use, if they include AVX2 (the VNNI
/// set does).
#[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
#[inline]
fn avx2_in_use() -> Option<avx2::Avx2> {
    match active() {
        Active::Avx2(k) => Some(k),
        #[cfg(any(feature = "std", all(target_feature = "avx512bw", target_feature = "avx512vnni")))]
        Active::Vnni(k) => Some(k.avx2()),
        _ => None,
    }
}

/// [`accumulate`] of an f32 layer from its first output: `out[s][c] +=
/// Σ_j x.rows[s][j] · W[x.row0 + j][c]`, bit for bit; with AVX2, the same
/// loop on 8-lane registers.
#[inline]
pub fn accumulate_f32<const N: usize>(l: &Layer<'_>, x: Input<'_, f32, N>, out: &mut [[f32; MAX_WIDTH]]) {
    #[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
    if let Some(k) = avx2_in_use() {
        return avx2::accumulate_f32(k, l, x, out);
    }
    accumulate::<MacF32, N>(l, 0, x, out);
}

/// [`sin_turns_q15`] of every phase in `phases` into `out` (same length),
/// bit for bit; with AVX2, 8 at a time.
#[inline]
pub fn sin_turns_q15_slice(phases: &[u32], out: &mut [i16]) {
    debug_assert_eq!(phases.len(), out.len());
    #[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
    let done = avx2_in_use().map_or(0, |k| avx2::sin_turns_q15_x8(k, phases, out));
    #[cfg(not(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2"))))]
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
    #[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
    if let (2, Some(k)) = (g.width, avx2_in_use()) {
        avx2::features_w2(k, g, pos, out, at);
        return;
    }
    for (p, o) in pos.iter().zip(out.iter_mut()) {
        g.encode_fixed(*p, &mut o[at..at + g.dim()]);
    }
}

/// The mean of [`FeatureGrid::encode_fixed`] over each row's three
/// footprint points in `foot`, into `out[s][at..at + g.dim()]`: the three
/// i16 features summed in i32, divided by 3 and rounded to the nearest,
/// `⌊(2Σ + 3)/6⌋` (the lookups as [`feature_rows`] makes them, up to 8
/// rows' points per call).
#[inline]
pub fn feature_rows_mean<const N: usize>(
    g: &FeatureGrid<'_>,
    foot: &[[[i32; 3]; FOOTPRINT_POINTS]],
    out: &mut [[i16; N]],
    at: usize,
) {
    // the lookups' buffer is zeroed at every call: as wide as the features need (16 for 8 levels of 2)
    if g.dim() <= 16 {
        rows_mean::<N, 16>(g, foot, out, at)
    } else {
        rows_mean::<N, { crate::limits::MAX_FEATURES }>(g, foot, out, at)
    }
}

/// [`feature_rows_mean`] with lookups of `W ≥ g.dim()` values a row.
#[inline]
fn rows_mean<const N: usize, const W: usize>(
    g: &FeatureGrid<'_>,
    foot: &[[[i32; 3]; FOOTPRINT_POINTS]],
    out: &mut [[i16; N]],
    at: usize,
) {
    const ROWS: usize = 8;
    const _: () = assert!(FOOTPRINT_POINTS == 3);
    let dim = g.dim();
    let mut lookups = [[0i16; W]; FOOTPRINT_POINTS * ROWS];
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

//! The dense layer's portable kernels, the reference every
//! architecture-specific kernel in [`crate::arch`] matches bit for bit.
//!
//! Dense layers are computed in input-major "axpy" form: for each input `j`,
//! its weight row (all outputs) is loaded once and added, scaled by the
//! input, to each sample's accumulator. Zero inputs (ReLU) are skipped,
//! which changes no result. Weights are stored input-major
//! (`W[j][c]` at `j · out_dim + c`), little-endian: f32, i16 or i8.

use crate::format::{Layer, MAX_WIDTH};

/// Element arithmetic of a dense layer: input activations `X`, decoded
/// weights `Wd`, accumulators `A` (f32; or exact integers).
pub trait Mac {
    /// Input activation type.
    type X: Copy + Default + PartialEq;
    /// Weight decoded from its bytes.
    type Wd: Copy + Default;
    /// Accumulator type.
    type A: Copy + Default;
    /// Bytes per stored weight.
    const BYTES: usize;
    /// Decodes one little-endian weight.
    fn decode(b: &[u8]) -> Self::Wd;
    /// `acc += x · w`.
    fn mac(acc: &mut Self::A, x: Self::X, w: Self::Wd);
}

/// f32 activations and weights.
pub struct MacF32;

impl Mac for MacF32 {
    type X = f32;
    type Wd = f32;
    type A = f32;
    const BYTES: usize = 4;
    #[inline(always)]
    fn decode(b: &[u8]) -> f32 {
        f32::from_le_bytes([b[0], b[1], b[2], b[3]])
    }
    #[inline(always)]
    fn mac(acc: &mut f32, x: f32, w: f32) {
        *acc += x * w;
    }
}

/// Samples per register tile.
pub const TILE_S: usize = 4;
/// Outputs per register tile.
pub const TILE_C: usize = 32;

/// Outputs per register tile of both kernels: a layer whose width is a
/// multiple of this runs only whole tiles (the remainder takes a slower
/// loop), so pruning at export keeps widths on this grain by default.
pub const OUTPUT_TILE: usize = TILE_C;

/// The input of a dense layer: `rows[s][..width]` for the first `n`
/// samples, multiplied by the layer's weight rows `row0..row0 + width`.
#[derive(Clone, Copy, Debug)]
pub struct Input<'i, X, const N: usize> {
    /// One row of values per sample.
    pub rows: &'i [[X; N]],
    /// The first weight row the values meet.
    pub row0: usize,
    /// Values per sample.
    pub width: usize,
    /// Samples.
    pub n: usize,
}

/// `out[s][c] += Σ_j x.rows[s][j] · W[x.row0 + j][c]` for the first `x.n`
/// samples and the outputs `c ≥ c_start` of layer `l`.
///
/// Register-tiled: a tile of 4 samples × 32 outputs stays in registers
/// while the inputs stream past, each weight row segment loaded once for 4
/// samples. Inputs that are zero for the whole tile (ReLU) are skipped. Per
/// output the sum runs over `j` in ascending order, so results do not depend
/// on the tiling.
#[inline(always)]
pub fn accumulate<M: Mac, const N: usize>(
    l: &Layer<'_>,
    c_start: usize,
    x: Input<'_, M::X, N>,
    out: &mut [[M::A; MAX_WIDTH]],
) {
    tiles::<M, N>(l.weights, l.out_dim as usize, c_start, x.row0, x.rows, x.width, x.n, out);
}

/// [`accumulate`] on the layer's weight bytes with `od` outputs per row.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn tiles<M: Mac, const N: usize>(
    weights: &[u8],
    od: usize,
    c_start: usize,
    row0: usize,
    input: &[[M::X; N]],
    in_dim: usize,
    n: usize,
    out: &mut [[M::A; MAX_WIDTH]],
) {
    let zero = M::X::default();
    let mut s0 = 0;
    while s0 < n {
        let sn = (n - s0).min(TILE_S);
        let rows = &input[s0..s0 + sn];
        let mut c0 = c_start;
        while c0 + TILE_C <= od {
            let mut acc = [[M::A::default(); TILE_C]; TILE_S];
            for s in 0..sn {
                acc[s].copy_from_slice(&out[s0 + s][c0..c0 + TILE_C]);
            }
            let [a0, a1, a2, a3] = &mut acc;
            for j in 0..in_dim {
                let x0 = rows[0][j];
                let x1 = if sn > 1 { rows[1][j] } else { zero };
                let x2 = if sn > 2 { rows[2][j] } else { zero };
                let x3 = if sn > 3 { rows[3][j] } else { zero };
                if x0 == zero && x1 == zero && x2 == zero && x3 == zero {
                    continue;
                }
                let base = ((row0 + j) * od + c0) * M::BYTES;
                let wrow = &weights[base..base + TILE_C * M::BYTES];
                for k in 0..TILE_C {
                    let w = M::decode(&wrow[k * M::BYTES..(k + 1) * M::BYTES]);
                    M::mac(&mut a0[k], x0, w);
                    M::mac(&mut a1[k], x1, w);
                    M::mac(&mut a2[k], x2, w);
                    M::mac(&mut a3[k], x3, w);
                }
            }
            for s in 0..sn {
                out[s0 + s][c0..c0 + TILE_C].copy_from_slice(&acc[s]);
            }
            c0 += TILE_C;
        }
        if c0 < od {
            for s in 0..sn {
                for j in 0..in_dim {
                    let x = rows[s][j];
                    if x == zero {
                        continue;
                    }
                    let base = ((row0 + j) * od) * M::BYTES;
                    for c in c0..od {
                        let w = M::decode(&weights[base + c * M::BYTES..base + (c + 1) * M::BYTES]);
                        M::mac(&mut out[s0 + s][c], x, w);
                    }
                }
            }
        }
        s0 += TILE_S;
    }
}

/// Integer weight element types of the fixed-point path: a [`Mac`] on i16
/// inputs and exact i32 products, whose accumulator holds exact sums (i64
/// for int16 weights; i32 for int8 weights, overflow excluded when a
/// renderer is made).
pub trait IntWeight: Mac<X = i16, A: core::ops::AddAssign + Into<i64>> {
    /// `a · w` in the accumulator type (`w` is the weight's bytes).
    fn mul(a: i16, w: &[u8]) -> Self::A;
    /// A bias or partial sum (checked at load to fit the accumulator).
    fn from_i64(b: i64) -> Self::A;
    /// Picks this type's accumulator buffer.
    fn pick<'a, const B: usize>(
        a64: &'a mut [[i64; MAX_WIDTH]; B],
        a32: &'a mut [[i32; MAX_WIDTH]; B],
    ) -> &'a mut [[Self::A; MAX_WIDTH]; B];
}

/// int16 weights, i64 accumulation.
pub struct W16;
/// int8 weights, i32 accumulation.
pub struct W8;

impl Mac for W16 {
    type X = i16;
    type Wd = i16;
    type A = i64;
    const BYTES: usize = 2;
    #[inline(always)]
    fn decode(b: &[u8]) -> i16 {
        i16::from_le_bytes([b[0], b[1]])
    }
    #[inline(always)]
    fn mac(acc: &mut i64, x: i16, w: i16) {
        // exact either way; the product's width picks the instruction:
        // `smlalbb` (16 × 16 + 64) from the 32-bit product on DSP cores,
        // `smlal` (32 × 32 + 64) from the 64-bit one elsewhere
        if cfg!(arm_dsp) {
            *acc += (x as i32 * w as i32) as i64;
        } else {
            *acc += x as i64 * w as i64;
        }
    }
}

impl IntWeight for W16 {
    #[inline(always)]
    fn mul(a: i16, w: &[u8]) -> i64 {
        a as i64 * i16::from_le_bytes([w[0], w[1]]) as i64
    }
    fn from_i64(b: i64) -> i64 {
        b
    }
    fn pick<'a, const B: usize>(
        a64: &'a mut [[i64; MAX_WIDTH]; B],
        _: &'a mut [[i32; MAX_WIDTH]; B],
    ) -> &'a mut [[i64; MAX_WIDTH]; B] {
        a64
    }
}

impl Mac for W8 {
    type X = i16;
    type Wd = i32;
    type A = i32;
    const BYTES: usize = 1;
    #[inline(always)]
    fn decode(b: &[u8]) -> i32 {
        b[0] as i8 as i32
    }
    #[inline(always)]
    fn mac(acc: &mut i32, x: i16, w: i32) {
        *acc += x as i32 * w;
    }
}

impl IntWeight for W8 {
    #[inline(always)]
    fn mul(a: i16, w: &[u8]) -> i32 {
        a as i32 * w[0] as i8 as i32
    }
    fn from_i64(b: i64) -> i32 {
        b as i32
    }
    fn pick<'a, const B: usize>(
        _: &'a mut [[i64; MAX_WIDTH]; B],
        a32: &'a mut [[i32; MAX_WIDTH]; B],
    ) -> &'a mut [[i32; MAX_WIDTH]; B] {
        a32
    }
}

/// `out[s][c] = clamp(requantised acc[s][c], lo, hi)` for the first `n`
/// samples and the outputs `c ≥ c_start` of `l`: the portable requantiser.
#[inline]
pub fn requant_rows<W: IntWeight>(
    l: &Layer<'_>,
    c_start: usize,
    n: usize,
    acc: &[[W::A; MAX_WIDTH]],
    out: &mut [[i16; MAX_WIDTH]],
    (lo, hi): (i16, i16),
) {
    // output-major: each channel's multiplier and shift are read once
    for c in c_start..l.out_dim as usize {
        let r = l.requant(c);
        for (a, o) in acc[..n].iter().zip(out[..n].iter_mut()) {
            o[c] = r.apply(a[c].into()).clamp(lo as i64, hi as i64) as i16;
        }
    }
}

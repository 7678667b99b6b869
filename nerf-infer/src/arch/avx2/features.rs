//! Feature-grid lookups of width-2 grids on AVX2, 8 levels per register:
//! i16 tables, and narrow tables whose codebook values are gathered per
//! lane (each lane a level with its own codebook).

#![allow(unsafe_code)]

use core::arch::x86_64::*;

use crate::features::{FeatureGrid, NarrowTable};

/// Per-lane constants of up to 8 levels of a width-2 feature grid (lanes
/// past the last level look up entry 0 and are not written).
struct LevelLanes {
    /// Cells per axis.
    res: [i32; 8],
    /// Index contributions of the y and z vertex coordinates: the dense
    /// strides `N+1, (N+1)²` or the hash primes.
    mul_y: [i32; 8],
    mul_z: [i32; 8],
    /// All ones in dense lanes (entries add), 0 in hashed ones (entries XOR).
    dense: [i32; 8],
    /// The table mask of hashed lanes.
    mask: [i32; 8],
    /// First entry of the level in the table.
    base: [i32; 8],
    /// Narrow tables: the level's first code in the codebook (`l·2^bits`).
    code: [i32; 8],
}

/// [`FeatureGrid::encode_fixed`] of a width-2 grid at every position of
/// `pos`, into `out[s][at..at + g.dim()]`: 8 levels per register, the same
/// integer steps in lanes (bit-identical), the 8 corners read with gathers.
pub(crate) fn features_w2<const N: usize>(
    _: super::Avx2,
    g: &FeatureGrid<'_>,
    pos: &[[i32; 3]],
    out: &mut [[i16; N]],
    at: usize,
) {
    // the gathers below read, for e < entries(l): entry `base + e` of 4
    // bytes (i16), or the aligned 4-byte word holding its indices and the
    // aligned words holding its codes (narrow)
    // (a valid grid's table and codebook have exactly the lengths they need,
    // a narrow table in whole words, and its entry indices fit an i32)
    assert!(g.width == 2 && g.is_valid(2) && at + g.dim() <= N && pos.len() <= out.len());
    let bits = g.narrow.map_or(0, |n| n.bits);
    // a table past the caches: log2 of an entry's bytes, to prefetch the corners ahead
    let entry_shift = (g.table.len() > PREFETCH_ABOVE).then_some(match bits {
        0 => 2,
        8 => 1,
        _ => 0,
    });
    let mut base = 0;
    for l0 in (0..g.levels()).step_by(8) {
        let k = (g.levels() - l0).min(8);
        let mut c = LevelLanes {
            res: [1; 8],
            mul_y: [0; 8],
            mul_z: [0; 8],
            dense: [0; 8],
            mask: [0; 8],
            base: [0; 8],
            code: [0; 8],
        };
        for j in 0..k {
            let res = g.resolutions[l0 + j];
            let (mul, dense) = g.lattice(res);
            c.res[j] = res as i32;
            (c.mul_y[j], c.mul_z[j]) = (mul[1] as i32, mul[2] as i32);
            c.dense[j] = if dense { -1 } else { 0 };
            c.mask[j] = ((1u32 << g.log2_table) - 1) as i32;
            c.base[j] = base as i32;
            c.code[j] = ((l0 + j) << bits) as i32;
            base += g.entries(l0 + j);
        }
        for (i, (p, o)) in pos.iter().zip(out.iter_mut()).enumerate() {
            if let (Some(shift), Some(next)) = (entry_shift, pos.get(i + AHEAD)) {
                // SAFETY: the token proves the CPU has AVX2; a prefetch reads nothing.
                unsafe { prefetch8(g.table, shift, &c, *next) };
            }
            // SAFETY: the token proves the CPU has AVX2; every
            // lane's entry is below its level's count (hashed: masked;
            // dense: < (N+1)³), so each read is inside the table, and each
            // code inside the codebook (lengths asserted above).
            unsafe { levels8(g.table, g.narrow, &c, *p, &mut o[at + 2 * l0..at + 2 * (l0 + k)]) };
        }
    }
}

/// Table bytes above which the corners of the position [`AHEAD`] ahead are
/// prefetched while one is looked up: the lookups of a table of 0.8 MiB
/// (lego's at 100×100) or 3.4 MiB lose more to the prefetches'
/// instructions than they gain, those of 6.1 MiB (lego's at 800×800 with
/// 8-bit indices) and 12.3 MiB (with i16 values) gain
/// (docs/EXPERIMENTS.md, `examples/lookup_cost`).
const PREFETCH_ABOVE: usize = 4 << 20;

/// Positions ahead of the one looked up whose corners are prefetched: the
/// next sample's first footprint point, or the third sample ahead.
const AHEAD: usize = 3;

/// Prefetches the table's cache lines of the corners of `p` at the lower
/// x vertex in every lane (the upper x vertex's entry is the next one, in
/// the same line unless the lower one ends a line); an entry is
/// `1 << entry_shift` bytes (4: i16 values, 2: 8-bit indices, 1: 4-bit
/// ones).
///
/// # Safety
/// AVX2.
#[target_feature(enable = "avx2")]
unsafe fn prefetch8(table: &[u8], entry_shift: u32, c: &LevelLanes, p: [i32; 3]) {
    let (parts, _) = cells(c, p);
    let lanes = entry_lanes(c);
    let mut idx = [[0i32; 8]; 4];
    for (k, row) in idx.iter_mut().enumerate() {
        // corners 0, 2, 4, 6: the lower x vertex
        let e = corner_entry(lanes, &parts, 2 * k);
        // SAFETY: `row` is 8 i32 (32 bytes) long.
        unsafe { _mm256_storeu_si256(row.as_mut_ptr().cast(), e) };
    }
    for row in &idx {
        for &e in row {
            crate::arch::prefetch(table, (e as usize) << entry_shift);
        }
    }
}

// the shifts below are those of the Q24 position (u·N in Q25, fractions Q15)
const _: () = assert!(crate::fixed::NPOS_FRAC == 24);

/// Per axis, the index contributions (the cell's vertex times the axis's
/// multiplier) and the Q15 weights of the lower and upper vertex of the
/// cell of `p`, in each lane's level.
#[target_feature(enable = "avx2")]
#[inline]
fn cells(c: &LevelLanes, p: [i32; 3]) -> ([[__m256i; 2]; 3], [[__m256i; 2]; 3]) {
    let one = |v: i32| _mm256_set1_epi32(v);
    // SAFETY: each array is 8 i32 (32 bytes) long.
    let ld = |a: &[i32; 8]| unsafe { _mm256_loadu_si256(a.as_ptr().cast()) };
    let res = ld(&c.res);
    let (res_odd, res_m1) = (_mm256_srli_epi64::<32>(res), _mm256_sub_epi32(res, one(1)));
    let (mut cell, mut w) = ([_mm256_setzero_si256(); 3], [[_mm256_setzero_si256(); 2]; 3]);
    for a in 0..3 {
        // u·2²⁵ in [0, 2²⁵], x = u·N in Q25 (< 2³⁷) in u64 lanes, even and odd levels apart
        let u = one(p[a].clamp(-(1 << 24), 1 << 24) + (1 << 24));
        let (even, odd) = (_mm256_mul_epu32(u, res), _mm256_mul_epu32(u, res_odd));
        let i = _mm256_blend_epi32::<0b1010_1010>(
            _mm256_srli_epi64::<25>(even),
            _mm256_slli_epi64::<32>(_mm256_srli_epi64::<25>(odd)),
        );
        let i = _mm256_min_epu32(i, res_m1);
        // x − i·2²⁵ is in [0, 2²⁵], so its low 32 bits (wrapping) are exact
        let x_lo = _mm256_blend_epi32::<0b1010_1010>(even, _mm256_slli_epi64::<32>(odd));
        let rem = _mm256_sub_epi32(x_lo, _mm256_slli_epi32::<25>(i));
        let f = _mm256_srli_epi32::<10>(_mm256_add_epi32(rem, one(1 << 9)));
        cell[a] = i;
        w[a] = [_mm256_sub_epi32(one(1 << 15), f), f];
    }
    // x multiplier 1 in either lattice (FeatureGrid::lattice)
    let up = |v: __m256i| _mm256_add_epi32(v, one(1));
    let times = |v: __m256i, m: __m256i| [_mm256_mullo_epi32(v, m), _mm256_mullo_epi32(up(v), m)];
    let parts = [[cell[0], up(cell[0])], times(cell[1], ld(&c.mul_y)), times(cell[2], ld(&c.mul_z))];
    (parts, w)
}

/// [`LevelLanes`]' `dense`, `mask` and `base` in registers, for [`corner_entry`].
#[target_feature(enable = "avx2")]
#[inline]
fn entry_lanes(c: &LevelLanes) -> [__m256i; 3] {
    // SAFETY: each array is 8 i32 (32 bytes) long.
    [&c.dense, &c.mask, &c.base].map(|a| unsafe { _mm256_loadu_si256(a.as_ptr().cast()) })
}

/// The entry of corner `k` (bit 0: upper x vertex, bit 1: y, bit 2: z) of
/// a cell's index contributions `parts` ([`cells`]) in each lane's level:
/// their sum in dense levels, their masked XOR in hashed ones, from the
/// level's first entry (`[dense, mask, base]` from [`entry_lanes`]).
#[target_feature(enable = "avx2")]
#[inline]
fn corner_entry([dense, mask, base]: [__m256i; 3], parts: &[[__m256i; 2]; 3], k: usize) -> __m256i {
    let (x, y, z) = (parts[0][k & 1], parts[1][(k >> 1) & 1], parts[2][k >> 2]);
    let sum = _mm256_add_epi32(_mm256_add_epi32(x, y), z);
    let hash = _mm256_and_si256(_mm256_xor_si256(_mm256_xor_si256(x, y), z), mask);
    _mm256_add_epi32(base, _mm256_blendv_epi8(hash, sum, dense))
}

/// Up to 8 levels (`out.len() / 2`) of one position; see [`features_w2`].
///
/// # Safety
/// AVX2, and every lane's entry `base + e` below the table's entries: for
/// an i16 table (`narrow` none) `4·(base + e + 1) ≤ table.len()`; for a
/// narrow one the table padded to whole words and the codebook holding
/// `2^bits` codes for each lane's level (as [`FeatureGrid::is_valid`]
/// checks them).
#[target_feature(enable = "avx2")]
unsafe fn levels8(table: &[u8], narrow: Option<NarrowTable<'_>>, c: &LevelLanes, p: [i32; 3], out: &mut [i16]) {
    let one = |v: i32| _mm256_set1_epi32(v);
    // SAFETY: each array is 8 i32 (32 bytes) long.
    let ld = |a: &[i32; 8]| unsafe { _mm256_loadu_si256(a.as_ptr().cast()) };
    let (parts, w) = cells(c, p);
    // Q30 products of the x and y factors (≤ 2³⁰, exact)
    let wxy: [__m256i; 4] = core::array::from_fn(|k| _mm256_mullo_epi32(w[0][k & 1], w[1][k >> 1]));
    let (lanes, code) = (entry_lanes(c), ld(&c.code));
    let (mut acc0, mut acc1) = (_mm256_setzero_si256(), _mm256_setzero_si256());
    for k in 0..8 {
        let (wxy, wz) = (wxy[k & 3], w[2][k >> 2]);
        // round(wxy·wz / 2³⁰) as in the scalar path, in i32: with
        // wxy = hi·2¹⁵ + lo, ⌊(wxy·wz + 2²⁹)/2³⁰⌋ = ⌊(hi·wz + ⌊(lo·wz + 2²⁹)/2¹⁵⌋)/2¹⁵⌋
        let (hi, lo) = (_mm256_srli_epi32::<15>(wxy), _mm256_and_si256(wxy, one(0x7FFF)));
        let low = _mm256_srli_epi32::<15>(_mm256_add_epi32(_mm256_mullo_epi32(lo, wz), one(1 << 29)));
        let wc = _mm256_srli_epi32::<15>(_mm256_add_epi32(_mm256_mullo_epi32(hi, wz), low));
        let idx = corner_entry(lanes, &parts, k);
        let (v0, v1) = match narrow {
            None => {
                // SAFETY: the caller's contract; each entry is 4 bytes (2 × i16 LE).
                let v = unsafe { _mm256_i32gather_epi32::<4>(table.as_ptr().cast(), idx) };
                (_mm256_srai_epi32::<16>(_mm256_slli_epi32::<16>(v)), _mm256_srai_epi32::<16>(v))
            }
            // SAFETY: the caller's contract (entries and codes in bounds, whole words).
            Some(n) => unsafe { narrow_pair(table, n.codebook, n.bits, code, idx) },
        };
        acc0 = _mm256_add_epi32(acc0, _mm256_mullo_epi32(wc, v0));
        acc1 = _mm256_add_epi32(acc1, _mm256_mullo_epi32(wc, v1));
    }
    // round to the output step and saturate to i16, level-major pairs
    let r = |a: __m256i| _mm256_srai_epi32::<15>(_mm256_add_epi32(a, one(1 << 14)));
    let (r0, r1) = (r(acc0), r(acc1));
    let packed = _mm256_packs_epi32(_mm256_unpacklo_epi32(r0, r1), _mm256_unpackhi_epi32(r0, r1));
    let mut all = [0i16; 16];
    // SAFETY: `all` is 16 i16 (32 bytes) long.
    unsafe { _mm256_storeu_si256(all.as_mut_ptr().cast(), packed) };
    out.copy_from_slice(&all[..out.len()]);
}

/// The two values of entry `idx` of a narrow width-2 table in each lane,
/// sign-extended to i32: its two indices from the aligned 4-byte word that
/// holds them (8 bits: 2 bytes at `2·idx`; 4 bits: the low and high nibble
/// of byte `idx`), then each index's code from the aligned word of the
/// codebook that holds code `code + q` (its low half when even).
///
/// # Safety
/// AVX2; `table` padded to whole words and covering every lane's entry;
/// `codebook` holding code `code + 2^bits − 1` of every lane.
#[target_feature(enable = "avx2")]
unsafe fn narrow_pair(table: &[u8], codebook: &[u8], bits: u8, code: __m256i, idx: __m256i) -> (__m256i, __m256i) {
    let one = |v: i32| _mm256_set1_epi32(v);
    let (word, shift, q_mask, q_step) = if bits == 8 {
        (_mm256_srli_epi32::<1>(idx), _mm256_slli_epi32::<4>(_mm256_and_si256(idx, one(1))), one(0xFF), 8)
    } else {
        (_mm256_srli_epi32::<2>(idx), _mm256_slli_epi32::<3>(_mm256_and_si256(idx, one(3))), one(0xF), 4)
    };
    // SAFETY: the caller's contract: the word holding each lane's entry is in the table.
    let w = unsafe { _mm256_i32gather_epi32::<4>(table.as_ptr().cast(), word) };
    let q = _mm256_srlv_epi32(w, shift);
    let q0 = _mm256_and_si256(q, q_mask);
    let q1 = _mm256_and_si256(_mm256_srlv_epi32(q, _mm256_set1_epi32(q_step)), q_mask);
    let code_of = |q: __m256i| {
        let k = _mm256_add_epi32(code, q);
        // SAFETY: the caller's contract: code k's word is in the codebook.
        let w = unsafe { _mm256_i32gather_epi32::<4>(codebook.as_ptr().cast(), _mm256_srli_epi32::<1>(k)) };
        // an even code is the word's low half: moved up before the sign-extending shift
        let up = _mm256_xor_si256(_mm256_slli_epi32::<4>(_mm256_and_si256(k, one(1))), one(16));
        _mm256_srai_epi32::<16>(_mm256_sllv_epi32(w, up))
    };
    (code_of(q0), code_of(q1))
}

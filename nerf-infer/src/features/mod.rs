//! Learned multiresolution feature grid (instant-ngp's encoding, Müller et
//! al. 2022), f32 and fixed point: appended to γ(x) as extra inputs of the
//! trunk.
//!
//! Level `l` is a lattice of `N_l` cells per axis over the scene bounds
//! (vertices `0..=N_l`). A normalised position `p ∈ [−1, 1]³` maps to
//! `u = (p + 1)/2` (clamped to `[0, 1]`), `x = u·N_l`; the 8 vertices of
//! the cell holding `x` are looked up in the level's table of
//! `2^log2_table` entries (`width` values each) — directly (`i + (N+1)·(j +
//! (N+1)·k)`) when the lattice fits, else through instant-ngp's spatial
//! hash `(i ⊕ 2654435761·j ⊕ 805459861·k) mod 2^log2_table` — and blended
//! trilinearly. Output: `levels × width` values, level-major.
//!
//! Table values: f32 in f32 models; i16 with `frac_bits` fractional bits in
//! fixed-point models, or (format version 7, [`NarrowTable`]) 8- or 4-bit
//! indices into a per-level codebook of such i16 values. The
//! fixed path computes the cell and the Q15 trilinear weights from the Q24
//! position with integers only, and its features come out as i16 with
//! `frac_bits` fractional bits.

use crate::fixed::NPOS_FRAC;
use crate::fixed::{sat_i16, shr_round_i64};
use crate::limits::FOOTPRINT_POINTS;
use crate::tensor::read_f32;
use serde::{Deserialize, Serialize};

pub use crate::limits::{MAX_FEATURES, MAX_LEVELS, MAX_LOG2_TABLE, MAX_RES};

/// A decoded feature grid, borrowing its table from the model blob.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct FeatureGrid<'a> {
    /// Values per table entry (1..=8).
    pub width: u8,
    /// Most entries per level: `2^log2_table` (1..=22); see [`FeatureGrid::entries`].
    pub log2_table: u8,
    /// Fixed-point models: fractional bits of the i16 table values and of
    /// the features (0..=15). 0 in f32 models.
    pub frac_bits: u8,
    /// Cells per axis of each level, coarse to fine (1..=4096).
    pub resolutions: heapless::Vec<u16, MAX_LEVELS>,
    /// [`FeatureGrid::values`] values, level then entry then value (level
    /// `l` from entry [`FeatureGrid::offset`]`(l)`): f32 LE (f32 models),
    /// i16 LE (fixed-point models), or packed as `narrow` says.
    #[serde(borrow)]
    pub table: &'a [u8],
    /// Fixed-point models: the table's values in fewer than 16 bits. Not
    /// part of this record's encoding: the model carries it (format
    /// version 7) and [`crate::Model::from_bytes`] copies it here.
    #[serde(skip)]
    pub narrow: Option<NarrowTable<'a>>,
}

/// A fixed-point table stored in fewer than 16 bits per value (format
/// version 7): each value is an index `q` into its level's codebook of
/// `2^bits` i16 values in Q`frac_bits`, so a level's values can sit where
/// its values are dense (most near zero) rather than on an even grid.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct NarrowTable<'a> {
    /// Bits per stored index: 8 (one per byte) or 4 (two per byte, value
    /// `2m` in the low nibble of byte `m`, `2m + 1` in the high one). The
    /// table is padded with zero bytes to whole 4-byte words, so that a
    /// reader may load the aligned word that holds an entry.
    pub bits: u8,
    /// `levels × 2^bits` i16 LE: level `l`'s value for index `q` at
    /// element `l·2^bits + q`.
    #[serde(borrow)]
    pub codebook: &'a [u8],
}

impl NarrowTable<'_> {
    /// Bytes of a table of `values` values, padded to whole 4-byte words.
    pub fn bytes(&self, values: usize) -> usize {
        (values * self.bits as usize).div_ceil(32) * 4
    }

    /// Value `k` of `table`, in level `l`'s codebook: an i16 in
    /// Q`frac_bits`.
    #[inline(always)]
    pub fn value(&self, table: &[u8], l: usize, k: usize) -> i32 {
        debug_assert!(matches!(self.bits, 4 | 8), "{} bits", self.bits);
        let q = if self.bits == 8 { table[k] } else { (table[k / 2] >> (4 * (k & 1))) & 0xF } as usize;
        let e = 2 * ((l << self.bits) + q);
        i16::from_le_bytes([self.codebook[e], self.codebook[e + 1]]) as i32
    }

    /// Checks the bits and that the codebook holds `2^bits` values for
    /// each of `levels` levels.
    pub fn is_valid(&self, levels: usize) -> bool {
        matches!(self.bits, 4 | 8) && self.codebook.len() == 2 * (levels << self.bits)
    }
}

/// The 8 table entries and trilinear weights of one level at one point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Corners {
    /// Entry index within the level, corner `c` = `(c & 1, c >> 1 & 1, c >> 2)`.
    pub entry: [u32; 8],
    /// Trilinear weight of each corner (they sum to 1).
    pub weight: [f32; 8],
}

/// Runs `$body` with `$W` a constant equal to the feature width `$w`
/// (1..=8, [`FeatureGrid::is_valid`](crate::features::FeatureGrid::is_valid); panics on any other), so that loops
/// over an entry's values are compiled once per width, fixed-size:
/// `per_width!(g.width as usize, W => f::<W>(...))`.
#[macro_export]
macro_rules! per_width {
    ($w:expr, $W:ident => $body:expr) => {
        $crate::per_width!(@arms $w, $W, $body, 1 2 3 4 5 6 7 8)
    };
    (@arms $w:expr, $W:ident, $body:expr, $($n:literal)*) => {
        match $w {
            $($n => {
                const $W: usize = $n;
                $body
            })*
            w => panic!("feature width {w}: 1 to 8"),
        }
    };
}

impl Corners {
    /// `out = Σ weight[c] · value(entry)` over the 8 corners, where the
    /// level's entries start at `base` and hold `out.len()` values each
    /// (`value(k)`: element `k` of the table). Shared by the f32 kernel and
    /// the trainer, so both blend in the same order. `out` holds at most 8
    /// values (the widths [`FeatureGrid::is_valid`] allows); the sums are
    /// kept in registers and written once.
    #[inline]
    pub fn blend(&self, base: usize, width: usize, value: impl Fn(usize) -> f32, out: &mut [f32]) {
        // one copy per number of values, so that the sums and the final
        // write are fixed-size moves
        if !out.is_empty() {
            crate::per_width!(out.len(), N => self.blend_n::<N>(base, width, value, out));
        }
    }

    /// [`Corners::blend`] of `N` values per entry.
    #[inline(always)]
    fn blend_n<const N: usize>(&self, base: usize, width: usize, value: impl Fn(usize) -> f32, out: &mut [f32]) {
        let mut acc = [0.0f32; N];
        for k in 0..8 {
            let e = (base + self.entry[k] as usize) * width;
            for (j, v) in acc.iter_mut().enumerate() {
                *v += self.weight[k] * value(e + j);
            }
        }
        out.copy_from_slice(&acc);
    }
}

impl FeatureGrid<'_> {
    /// This grid's shape with `table` as its table (i16 or f32 values, no
    /// codebook).
    pub fn with_table<'t>(&self, table: &'t [u8]) -> FeatureGrid<'t> {
        FeatureGrid {
            width: self.width,
            log2_table: self.log2_table,
            frac_bits: self.frac_bits,
            resolutions: self.resolutions.clone(),
            table,
            narrow: None,
        }
    }
}

impl FeatureGrid<'_> {
    /// Number of levels.
    pub fn levels(&self) -> usize {
        self.resolutions.len()
    }
    /// Values the grid appends to γ(x): `levels × width`.
    pub fn dim(&self) -> usize {
        self.levels() * self.width as usize
    }
    /// Entries of level `l`: one per vertex, `(N + 1)³`, when that fits
    /// `2^log2_table` (a dense level), else `2^log2_table` (hashed).
    pub fn entries(&self, l: usize) -> usize {
        let n = self.resolutions[l] as u64 + 1;
        (n * n * n).min(1 << self.log2_table) as usize
    }
    /// First entry of level `l` in the table (the entries of the levels before it).
    pub fn offset(&self, l: usize) -> usize {
        (0..l).map(|k| self.entries(k)).sum()
    }
    /// Table elements (values) in all levels.
    pub fn values(&self) -> usize {
        self.offset(self.levels()) * self.width as usize
    }

    /// Bytes of the table: `values()` elements of `elem_bytes` bytes (4:
    /// f32, 2: i16), or as packed by `narrow`.
    pub fn table_bytes(&self, elem_bytes: usize) -> usize {
        match &self.narrow {
            Some(n) => n.bytes(self.values()),
            None => self.values() * elem_bytes,
        }
    }

    /// Checks ranges, the narrow packing if any, and that the table holds
    /// [`FeatureGrid::table_bytes`] bytes.
    pub fn is_valid(&self, elem_bytes: usize) -> bool {
        let shape_ok = (1..=8).contains(&self.width)
            && (1..=MAX_LOG2_TABLE).contains(&self.log2_table)
            && self.frac_bits <= 15
            && !self.resolutions.is_empty()
            && self.dim() <= MAX_FEATURES
            && self.resolutions.iter().all(|&r| (1..=MAX_RES).contains(&r))
            && self.narrow.as_ref().is_none_or(|n| n.is_valid(self.levels()));
        shape_ok && self.table.len() == self.table_bytes(elem_bytes)
    }

    /// Entry of vertex `(i, j, k)` of a level with `res` cells per axis:
    /// dense when the `(res + 1)³` vertices fit the table, else hashed.
    #[inline]
    pub fn entry(&self, res: u16, v: [u32; 3]) -> u32 {
        let (parts, dense, mask) = self.axis_parts(res, v);
        combine(parts[0][0], parts[1][0], parts[2][0], dense, mask)
    }

    /// Per axis, the index contributions of the cell's lower and upper
    /// vertex (`cell[a]` and `cell[a] + 1`): dense strides `1, N+1, (N+1)²`
    /// or the hash primes; whether the level is dense; the table mask.
    #[inline(always)]
    fn axis_parts(&self, res: u16, cell: [u32; 3]) -> ([[u32; 2]; 3], bool, u32) {
        let (mul, dense) = self.lattice(res);
        let parts = [0, 1, 2].map(|a| [cell[a].wrapping_mul(mul[a]), (cell[a] + 1).wrapping_mul(mul[a])]);
        (parts, dense, (1u32 << self.log2_table) - 1)
    }

    /// Index multipliers of a level with `res` cells per axis: the dense
    /// strides `1, N+1, (N+1)²` when its `(N+1)³` vertices fit the table, else
    /// the hash primes; and whether it is dense.
    #[inline(always)]
    pub(crate) fn lattice(&self, res: u16) -> ([u32; 3], bool) {
        let n = res as u32 + 1;
        let dense = (n as u64).pow(3) <= 1u64 << self.log2_table;
        (if dense { [1, n, n * n] } else { [1, 2_654_435_761, 805_459_861] }, dense)
    }

    /// Corners and weights of level `l` at the normalised position `p`
    /// (f32 path and trainer). Non-finite coordinates count as 0.
    pub fn corners_f32(&self, l: usize, p: [f32; 3]) -> Corners {
        let res = self.resolutions[l];
        let mut cell = [0u32; 3];
        let mut w = [[0.0f32; 2]; 3];
        for a in 0..3 {
            let v = if p[a].is_finite() { p[a] } else { 0.0 };
            let x = ((v + 1.0) * 0.5).clamp(0.0, 1.0) * res as f32;
            // x ≥ 0: the conversion truncates, which is the floor here
            let i = (x as u32).min(res as u32 - 1);
            cell[a] = i;
            let f = x - i as f32;
            w[a] = [1.0 - f, f];
        }
        let (parts, dense, mask) = self.axis_parts(res, cell);
        let mut out = Corners::default();
        for c in 0..8 {
            let (bx, by, bz) = (c & 1, (c >> 1) & 1, c >> 2);
            out.entry[c] = combine(parts[0][bx], parts[1][by], parts[2][bz], dense, mask);
            out.weight[c] = w[0][bx] * w[1][by] * w[2][bz];
        }
        out
    }

    /// The `dim()` features at the normalised position `p` (f32 table).
    pub fn encode_f32(&self, p: [f32; 3], out: &mut [f32]) {
        let w = self.width as usize;
        let mut base = 0;
        for l in 0..self.levels() {
            let c = self.corners_f32(l, p);
            c.blend(base, w, |k| read_f32(self.table, k), &mut out[l * w..(l + 1) * w]);
            base += self.entries(l);
        }
    }

    /// The mean of [`FeatureGrid::encode_f32`] over the footprint points
    /// `pts` (summed in their order, then divided by their count), into
    /// `out` (`dim()` values).
    pub fn encode_f32_mean(&self, pts: &[[f32; 3]; FOOTPRINT_POINTS], out: &mut [f32]) {
        let mut one = [0.0f32; MAX_FEATURES];
        out.fill(0.0);
        for p in pts {
            self.encode_f32(*p, &mut one);
            out.iter_mut().zip(&one).for_each(|(o, v)| *o += v);
        }
        out.iter_mut().for_each(|o| *o /= FOOTPRINT_POINTS as f32);
    }

    /// The `dim()` features at the Q24 normalised position `p` (i16 table,
    /// or a [`NarrowTable`]'s indices of i16 values), as i16 with
    /// `frac_bits` fractional bits. Integer only: the cell and the fractions
    /// (rounded to Q15) come from `u·N` in Q25, each corner weight is the
    /// product of three Q15 factors rounded once to Q15, the
    /// blend is summed in i32 and rounded once. No overflow: the weights are
    /// ≥ 0 and sum to at most 2¹⁵ + 4 (4 roundings up of ½ beyond the exact
    /// sum 2¹⁵), so |Σ w·t| ≤ (2¹⁵ + 4)·2¹⁵ < 2³¹. Error against the exact
    /// blend at the exact position: at most `0.5 + 7·max|t|/2¹⁵` output
    /// steps (fractions: `3·2⁻¹⁶·2·max|t|`; weights: `8·2⁻¹⁶·max|t|`).
    pub fn encode_fixed(&self, p: [i32; 3], out: &mut [i16]) {
        const ONE: i32 = 1 << 15;
        let w = self.width as usize;
        let one = 1i64 << NPOS_FRAC;
        let mut base = 0;
        for l in 0..self.levels() {
            let res = self.resolutions[l];
            let mut cell = [0u32; 3];
            let mut wt = [[0i32; 2]; 3];
            for a in 0..3 {
                // u·2²⁵ in [0, 2²⁵], then x = u·N in Q25 (< 2³⁷)
                let u = (p[a] as i64).clamp(-one, one) + one;
                let x = u * res as i64;
                let i = ((x >> (NPOS_FRAC + 1)) as u32).min(res as u32 - 1);
                cell[a] = i;
                let sh = NPOS_FRAC + 1 - 15;
                let f = ((x - ((i as i64) << (NPOS_FRAC + 1)) + (1 << (sh - 1))) >> sh) as i32;
                wt[a] = [ONE - f, f];
            }
            // Q30 products of two factors ≤ 2¹⁵ (exact in i32), then Q45 in i64
            let wxy: [i32; 4] = core::array::from_fn(|k| wt[0][k & 1] * wt[1][k >> 1]);
            let (parts, dense, mask) = self.axis_parts(res, cell);
            // corner c = (c & 1, c >> 1 & 1, c >> 2): weights, then entries
            // (the dense/hashed choice made once for all 8)
            let wc: [i32; 8] =
                core::array::from_fn(|c| ((wxy[c & 3] as i64 * wt[2][c >> 2] as i64 + (1 << 29)) >> 30) as i32);
            let at = |c: usize| (parts[0][c & 1], parts[1][(c >> 1) & 1], parts[2][c >> 2]);
            let entry: [u32; 8] = if dense {
                core::array::from_fn(|c| combine(at(c).0, at(c).1, at(c).2, true, mask))
            } else {
                core::array::from_fn(|c| combine(at(c).0, at(c).1, at(c).2, false, mask))
            };
            let mut acc = [0i32; 8];
            match &self.narrow {
                Some(n) => {
                    for c in 0..8 {
                        let e = (base + entry[c] as usize) * w;
                        for (j, a) in acc[..w].iter_mut().enumerate() {
                            *a += wc[c] * n.value(self.table, l, e + j);
                        }
                    }
                }
                None => self.blend_i16(base, w, &entry, &wc, &mut acc),
            }
            for j in 0..w {
                out[l * w + j] = sat_i16(shr_round_i64(acc[j] as i64, 15));
            }
            base += self.entries(l);
        }
    }

    /// `acc[j] += Σ_c wc[c] · value(entry[c], j)` over an i16 table.
    #[inline(always)]
    fn blend_i16(&self, base: usize, w: usize, entry: &[u32; 8], wc: &[i32; 8], acc: &mut [i32; 8]) {
        for c in 0..8 {
            let (wc, e) = (wc[c], (base + entry[c] as usize) * w);
            if w == 2 {
                // the common width: one 4-byte read per corner
                let b = &self.table[2 * e..2 * e + 4];
                acc[0] += wc * i16::from_le_bytes([b[0], b[1]]) as i32;
                acc[1] += wc * i16::from_le_bytes([b[2], b[3]]) as i32;
                continue;
            }
            let vals = &self.table[2 * e..2 * (e + w)];
            for (a, b) in acc[..w].iter_mut().zip(vals.chunks_exact(2)) {
                *a += wc * i16::from_le_bytes([b[0], b[1]]) as i32;
            }
        }
    }
}

/// A vertex's entry from its axis contributions: their sum (dense levels)
/// or their XOR masked to the table (hashed levels).
#[inline(always)]
fn combine(x: u32, y: u32, z: u32, dense: bool, mask: u32) -> u32 {
    if dense {
        x + y + z
    } else {
        (x ^ y ^ z) & mask
    }
}

/// Resolutions of a geometric series of `levels` lattices from `min` to
/// `max` cells per axis (instant-ngp's `N_l = ⌊N_min·b^l⌋`).
pub fn geometric_resolutions(levels: usize, min: u16, max: u16) -> heapless::Vec<u16, MAX_LEVELS> {
    let mut out = heapless::Vec::new();
    let levels = levels.clamp(1, MAX_LEVELS);
    let b =
        if levels > 1 { libm::exp((libm::log(max as f64) - libm::log(min as f64)) / (levels - 1) as f64) } else { 1.0 };
    for l in 0..levels {
        let r = libm::floor(min as f64 * libm::pow(b, l as f64) + 1e-6) as u16;
        let _ = out.push(r.clamp(1, MAX_RES));
    }
    out
}

#[cfg(test)]
mod tests;

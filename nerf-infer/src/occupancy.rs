//! Empty-space skipping: an occupancy bit grid over the scene bounds.
//!
//! The grid splits the normalised bounds `[−1, 1]³` into `res³` equal
//! cells; a clear bit means the trainer found no density worth rendering
//! anywhere in that cell, so both numeric paths skip every sample that
//! falls in it (its weight is taken as 0, the network is not evaluated).
//! Cell `(x, y, z)` is bit `x + res·(y + res·z)`, stored in byte `i / 8` at
//! bit `i % 8` (least significant first).

use serde::{Deserialize, Serialize};

/// Largest grid resolution (cells per axis) a model may carry.
pub const MAX_GRID_RES: u16 = 256;

/// Occupancy bits over the normalised scene bounds, borrowed from the blob.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Occupancy<'a> {
    /// Cells per axis, `1..=256`.
    pub res: u16,
    /// `ceil(res³ / 8)` bytes of occupancy bits (layout in the module doc).
    #[serde(borrow)]
    pub bits: &'a [u8],
}

/// Bytes of the bit array of a `res³` grid.
pub const fn grid_bytes(res: u16) -> usize {
    let r = res as usize;
    (r * r * r).div_ceil(8)
}

impl<'a> Occupancy<'a> {
    /// True if `res` is in range and `bits` has exactly [`grid_bytes`] bytes.
    pub fn is_valid(&self) -> bool {
        (1..=MAX_GRID_RES).contains(&self.res) && self.bits.len() == grid_bytes(self.res)
    }

    /// Whether cell number `i` (layout in the module doc) is occupied.
    #[inline(always)]
    pub fn cell(&self, i: usize) -> bool {
        self.bits.get(i >> 3).is_some_and(|b| b >> (i & 7) & 1 != 0)
    }

    /// Calls `f` with the coordinates `[x, y, z]` (each in `0..res`) of
    /// every occupied cell, in index order: the set bits found a byte at a
    /// time, the coordinates stepped from the byte's first cell (divisions
    /// once per non-zero byte, not per cell). Bits past the last cell are
    /// ignored; a grid of `res` 0 has no cells.
    pub fn for_each_occupied(&self, mut f: impl FnMut([usize; 3])) {
        let r = self.res as usize;
        let n = r * r * r;
        if n == 0 {
            return;
        }
        for (b, &byte) in self.bits.iter().enumerate() {
            // most bytes are 0: only the set bits cost anything
            if byte == 0 {
                continue;
            }
            let first = 8 * b;
            let (mut at, mut c) = (first, [first % r, (first / r) % r, first / (r * r)]);
            let mut rest = byte;
            while rest != 0 {
                let i = first + rest.trailing_zeros() as usize;
                rest &= rest - 1;
                if i >= n {
                    return;
                }
                // step the coordinates from cell `at` to cell `i`
                while at < i {
                    let step = (i - at).min(r - c[0]);
                    (at, c[0]) = (at + step, c[0] + step);
                    if c[0] == r {
                        c[0] = 0;
                        c[1] += 1;
                        if c[1] == r {
                            c[1] = 0;
                            c[2] += 1;
                        }
                    }
                }
                f(c);
            }
        }
    }

    /// Number of occupied cells.
    pub fn occupied_cells(&self) -> usize {
        let mut n = 0;
        self.for_each_occupied(|_| n += 1);
        n
    }

    /// Whether the cell holding normalised position `p` (f32, bounds ↦
    /// `[−1, 1]³`) is occupied. Positions outside the bounds (and NaN)
    /// read the nearest edge cell.
    #[inline(always)]
    pub fn at_f32(&self, p: [f32; 3]) -> bool {
        self.cell(self.index(self.cell_f32(p)))
    }

    /// The cell `(x, y, z)` holding normalised position `p` (f32), each
    /// coordinate in `0..res` (outside the bounds: the nearest edge cell;
    /// NaN: 0). Non-decreasing in each coordinate of `p`.
    #[inline(always)]
    pub fn cell_f32(&self, p: [f32; 3]) -> [usize; 3] {
        let r = self.res as i32;
        let half = 0.5 * self.res as f32;
        p.map(|x| (((x + 1.0) * half) as i32).clamp(0, r - 1) as usize)
    }

    /// [`Occupancy::cell_f32`] for a position in Q`frac` fixed point.
    #[inline(always)]
    pub fn cell_fixed(&self, p: [i32; 3], frac: u32) -> [usize; 3] {
        let r = self.res as i64;
        let one = 1i64 << frac;
        p.map(|x| (((x as i64 + one) * r) >> (frac + 1)).clamp(0, r - 1) as usize)
    }

    /// Cell number of cell `(x, y, z)` (layout in the module doc).
    #[inline(always)]
    pub fn index(&self, c: [usize; 3]) -> usize {
        c[0] + self.res as usize * (c[1] + self.res as usize * c[2])
    }

    /// [`Occupancy::at_f32`] for a position in Q`frac` fixed point (the
    /// fixed path's Q24): integer arithmetic only.
    #[inline(always)]
    pub fn at_fixed(&self, p: [i32; 3], frac: u32) -> bool {
        self.cell(self.index(self.cell_fixed(p, frac)))
    }
}

/// Coarse cells per axis of a [`CoarseOccupancy`], at most.
pub const COARSE_RES: usize = 16;

/// A coarse level over an [`Occupancy`] grid, so a march can rule out a
/// run of samples with one test instead of one per sample
/// ([`CoarseOccupancy::box_is_empty`]).
///
/// Fine cell coordinate `c` falls in coarse coordinate `c >> shift`, the
/// smallest shift that leaves at most [`COARSE_RES`] coarse cells per axis
/// (4 fine cells per coarse cell at `res = 64`); a coarse cell is set if
/// any of its fine cells is occupied. 512 bytes, built from the grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CoarseOccupancy {
    /// Fine cells per axis.
    res: usize,
    shift: u32,
    /// Coarse cells per axis, `1..=16`.
    m: usize,
    bits: [u8; COARSE_RES * COARSE_RES * COARSE_RES / 8],
}

impl CoarseOccupancy {
    /// The coarse level of `g` (a valid grid).
    pub fn new(g: &Occupancy<'_>) -> Self {
        let r = g.res as usize;
        let mut shift = 0;
        while (r - 1) >> shift >= COARSE_RES {
            shift += 1;
        }
        let mut c =
            Self { res: r, shift, m: ((r - 1) >> shift) + 1, bits: [0; COARSE_RES * COARSE_RES * COARSE_RES / 8] };
        g.for_each_occupied(|cell| {
            let j = c.index(cell.map(|x| x >> shift));
            c.bits[j >> 3] |= 1 << (j & 7);
        });
        c
    }

    #[inline(always)]
    fn index(&self, c: [usize; 3]) -> usize {
        c[0] + self.m * (c[1] + self.m * c[2])
    }

    /// How many consecutive samples to test together: those that cover
    /// about one coarse cell when consecutive samples are `step_q24` apart
    /// (Q24 normalised units) along the axis the ray moves fastest on;
    /// `1..=64`. Only speed depends on it, never the result.
    pub fn run_len(&self, step_q24: u64) -> usize {
        let cell_q24 = ((2u64 << 24) << self.shift) / self.res as u64;
        (cell_q24 / step_q24.max(1)).clamp(1, 64) as usize
    }

    /// True if no fine cell in the box spanned by fine cells `a` and `b`
    /// (inclusive, corners in any order) is occupied. Since a ray's cells
    /// are monotone in `t` along each axis, the cells of every sample
    /// between two samples lie in the box of those two samples' cells.
    #[inline]
    pub fn box_is_empty(&self, a: [usize; 3], b: [usize; 3]) -> bool {
        let lo: [usize; 3] = core::array::from_fn(|k| a[k].min(b[k]) >> self.shift);
        let hi: [usize; 3] = core::array::from_fn(|k| a[k].max(b[k]) >> self.shift);
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    let j = self.index([x, y, z]);
                    if self.bits[j >> 3] >> (j & 7) & 1 != 0 {
                        return false;
                    }
                }
            }
        }
        true
    }
}

/// Margin added around the occupied box before clipping rays to it, in
/// normalised units: far above the rounding of either path's positions, so
/// a sample outside the widened box is never in an occupied cell.
pub const BOX_MARGIN: f32 = 1e-3;

/// The box (normalised coordinates, lower and upper corner) around every
/// occupied cell, widened by [`BOX_MARGIN`]; `None` if no cell is occupied.
pub fn occupied_box(g: &Occupancy<'_>) -> Option<([f32; 3], [f32; 3])> {
    let r = g.res as usize;
    let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
    g.for_each_occupied(|c| {
        for a in 0..3 {
            lo[a] = lo[a].min(c[a]);
            hi[a] = hi[a].max(c[a]);
        }
    });
    if lo[0] == usize::MAX {
        return None;
    }
    let edge = |c: usize| c as f32 * 2.0 / r as f32 - 1.0;
    Some((lo.map(|c| edge(c) - BOX_MARGIN), hi.map(|c| edge(c + 1) + BOX_MARGIN)))
}

/// The part `[t_enter, t_exit]` of the ray `o + t·d` (normalised
/// coordinates) inside the box `(lo, hi)`, or `None` if it misses it.
pub fn clip_to_box(b: &([f32; 3], [f32; 3]), o: [f32; 3], d: [f32; 3]) -> Option<(f32, f32)> {
    let (mut enter, mut exit) = (f32::NEG_INFINITY, f32::INFINITY);
    for a in 0..3 {
        let (lo, hi) = (b.0[a], b.1[a]);
        if d[a] == 0.0 {
            if o[a] < lo || o[a] > hi {
                return None;
            }
            continue;
        }
        let (t0, t1) = ((lo - o[a]) / d[a], (hi - o[a]) / d[a]);
        enter = enter.max(t0.min(t1));
        exit = exit.min(t0.max(t1));
    }
    (enter <= exit).then_some((enter, exit))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Marks cells `(x, y, z)` of a `res³` grid occupied.
    fn set_cells(bits: &mut [u8], res: usize, cells: &[[usize; 3]]) {
        for c in cells {
            let i = c[0] + res * (c[1] + res * c[2]);
            bits[i / 8] |= 1 << (i % 8);
        }
    }

    #[test]
    fn the_occupied_cells_are_found_in_index_order_with_their_coordinates() {
        for res in [1u16, 3, 5, 8, 13] {
            let r = res as usize;
            let mut bits = [0u8; grid_bytes(13)];
            let bits = &mut bits[..grid_bytes(res)];
            for i in 0..r * r * r {
                if (i * 7 + i / 3) % 5 < 2 || i + 1 == r * r * r {
                    bits[i / 8] |= 1 << (i % 8);
                }
            }
            // padding bits past the last cell are ignored
            if !(r * r * r).is_multiple_of(8) {
                *bits.last_mut().unwrap() |= 0x80;
            }
            let g = Occupancy { res, bits };
            let mut want = (0..r * r * r).filter(|&i| g.cell(i)).map(|i| [i % r, (i / r) % r, i / (r * r)]);
            let mut found = 0;
            g.for_each_occupied(|c| {
                assert_eq!(Some(c), want.next(), "res {res}, cell {found}");
                found += 1;
            });
            assert_eq!(want.next(), None, "res {res}: {found} found");
            assert!(found > 0);
        }
        // a grid without cells has nothing to find, whatever its bytes say
        Occupancy { res: 0, bits: &[0xFF] }.for_each_occupied(|c| panic!("cell {c:?} in a grid of no cells"));
    }

    #[test]
    fn both_lookups_agree_away_from_cell_edges() {
        let mut bits = [0u8; 64]; // 8³ cells
        for i in (0..512).step_by(3) {
            bits[i / 8] |= 1 << (i % 8);
        }
        let g = Occupancy { res: 8, bits: &bits };
        assert!(g.is_valid());
        assert_eq!(g.occupied_cells(), 171);
        for k in 0..2000u32 {
            let f = |s: u32| ((s.wrapping_mul(2_654_435_761) >> 8) as f32 / (1u32 << 24) as f32) * 2.4 - 1.2;
            let p = [f(k * 3), f(k * 3 + 1), f(k * 3 + 2)];
            let q = p.map(|x| (x * (1 << 24) as f32) as i32);
            let edge = p.iter().any(|x| (((x + 1.0) * 4.0).fract() - 0.5).abs() > 0.499);
            if !edge {
                assert_eq!(g.at_f32(p), g.at_fixed(q, 24), "{p:?}");
            }
        }
        // out of bounds clamps to the edge cells, NaN to cell 0
        assert_eq!(g.at_f32([-5.0, -5.0, -5.0]), g.cell(0));
        assert_eq!(g.at_f32([f32::NAN; 3]), g.cell(0));
        assert_eq!(g.at_fixed([i32::MAX; 3], 24), g.cell(511));
    }

    #[test]
    fn the_occupied_box_holds_every_occupied_cell() {
        let mut bits = [0u8; 64];
        set_cells(&mut bits, 8, &[[2, 3, 4], [5, 3, 1], [2, 6, 4]]);
        let g = Occupancy { res: 8, bits: &bits };
        let (lo, hi) = occupied_box(&g).unwrap();
        let m = BOX_MARGIN;
        assert_eq!(lo, [-0.5 - m, -0.25 - m, -0.75 - m]);
        assert_eq!(hi, [0.5 + m, 0.75 + m, 0.25 + m]);
        assert_eq!(occupied_box(&Occupancy { res: 8, bits: &[0; 64] }), None);
        let b = (lo, hi);
        let (t0, t1) = clip_to_box(&b, [-3.0, 0.0, 0.0], [1.0, 0.0, 0.0]).unwrap();
        assert!((t0 - (2.5 - m)).abs() < 1e-6 && (t1 - (3.5 + m)).abs() < 1e-6);
        assert_eq!(clip_to_box(&b, [-3.0, 0.9, 0.0], [1.0, 0.0, 0.0]), None);
        assert_eq!(clip_to_box(&b, [-3.0, 0.0, 0.0], [-1.0, 0.0, 0.0]).map(|s| s.1 < 0.0), Some(true));
    }

    #[test]
    fn a_coarse_box_is_empty_exactly_when_its_coarse_cells_are() {
        // res 37: coarse cells of 4 fine cells (the last one partial)
        let mut bits = [0u8; 6332];
        set_cells(&mut bits, 37, &[[0, 0, 0], [36, 20, 5], [13, 13, 13]]);
        let g = Occupancy { res: 37, bits: &bits };
        assert!(g.is_valid());
        let c = CoarseOccupancy::new(&g);
        assert_eq!((c.m, c.shift), (10, 2));
        // a box holding an occupied cell is never empty, in either corner order
        assert!(!c.box_is_empty([36, 20, 5], [36, 20, 5]));
        assert!(!c.box_is_empty([30, 25, 8], [36, 17, 4]));
        assert!(!c.box_is_empty([12, 12, 12], [15, 15, 15]));
        // one in the same coarse cell as an occupied one is not empty either
        assert!(!c.box_is_empty([14, 14, 14], [15, 15, 15]));
        // the next coarse cell over is
        assert!(c.box_is_empty([16, 12, 12], [19, 15, 15]));
        assert!(c.box_is_empty([4, 4, 4], [11, 36, 36]));
        // a coarse cell is 4·2/37 normalised units: 3.46 samples 2⁻⁴ apart
        assert_eq!(c.run_len(1 << 20), 3);
        assert_eq!((c.run_len(0), c.run_len(u64::MAX)), (64, 1));
    }
}

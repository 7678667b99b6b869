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

    /// Number of occupied cells.
    pub fn occupied_cells(&self) -> usize {
        let r = self.res as usize;
        (0..r * r * r).filter(|&i| self.cell(i)).count()
    }

    /// Whether the cell holding normalised position `p` (f32, bounds ↦
    /// `[−1, 1]³`) is occupied. Positions outside the bounds (and NaN)
    /// read the nearest edge cell.
    #[inline(always)]
    pub fn at_f32(&self, p: [f32; 3]) -> bool {
        let r = self.res as i32;
        let half = 0.5 * self.res as f32;
        let c = p.map(|x| (((x + 1.0) * half) as i32).clamp(0, r - 1) as usize);
        self.cell(c[0] + self.res as usize * (c[1] + self.res as usize * c[2]))
    }

    /// [`Occupancy::at_f32`] for a position in Q`frac` fixed point (the
    /// fixed path's Q24): integer arithmetic only.
    #[inline(always)]
    pub fn at_fixed(&self, p: [i32; 3], frac: u32) -> bool {
        let r = self.res as i64;
        let one = 1i64 << frac;
        let c = p.map(|x| (((x as i64 + one) * r) >> (frac + 1)).clamp(0, r - 1) as usize);
        self.cell(c[0] + self.res as usize * (c[1] + self.res as usize * c[2]))
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
    for (b, &byte) in g.bits.iter().enumerate() {
        if byte == 0 {
            continue;
        }
        for k in 0..8 {
            let i = 8 * b + k;
            if byte >> k & 1 == 0 || i >= r * r * r {
                continue;
            }
            let c = [i % r, (i / r) % r, i / (r * r)];
            for a in 0..3 {
                lo[a] = lo[a].min(c[a]);
                hi[a] = hi[a].max(c[a]);
            }
        }
    }
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
        for c in [[2usize, 3, 4], [5, 3, 1], [2, 6, 4]] {
            let i = c[0] + 8 * (c[1] + 8 * c[2]);
            bits[i / 8] |= 1 << (i % 8);
        }
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
}

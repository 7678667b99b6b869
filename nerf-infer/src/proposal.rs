//! The proposal grid: where the march places the network's samples in
//! unbounded and forward-facing scenes (format version 11).
//!
//! A dense grid of density codes over the normalised (in an unbounded
//! scene, contracted) coordinates `[−1, 1]³`, in the occupancy grid's cell
//! layout (`x` fastest). Code 0 is empty space; code `k ≥ 1` is the density
//! `exp(log_min + (k − 1)·log_step)` (1/world units), constant over the
//! cell. The trainer fits it so that its weights along a ray bound the
//! network's (mip-NeRF 360's proposal sampling, with a grid in place of a
//! small network): the march composites it at the stratified samples,
//! draws the network's samples from its weights, and evaluates the
//! network only there ([`crate::render`]). A lookup is one byte read and
//! one table entry, in f32 or fixed point alike: the two paths read the
//! same cell except for positions within one Q24 step of a cell's edge.

use crate::occupancy::Occupancy;
use serde::{Deserialize, Serialize};

/// Most cells per axis of a proposal grid (128³ codes: 2 MiB).
pub const MAX_PROPOSAL_RES: u16 = 128;

/// Largest density a code may stand for (1/world units): its Q10 value
/// keeps `σ·δ` within the fixed-point compositor's range.
pub const MAX_PROPOSAL_SIGMA: f32 = 1.0e6;

/// A proposal grid, borrowing its codes from the blob.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct Proposal<'a> {
    /// Cells per axis, `1..=`[`MAX_PROPOSAL_RES`].
    pub res: u16,
    /// Natural log of the density of code 1 (1/world units).
    pub log_min: f32,
    /// Step of the log-density from one code to the next (≥ 0).
    pub log_step: f32,
    /// `res³` codes (layout in the module doc).
    #[serde(borrow)]
    pub codes: &'a [u8],
}

impl Proposal<'_> {
    /// Whether the resolution, codes and scale are consistent and every
    /// code's density is finite and at most [`MAX_PROPOSAL_SIGMA`].
    pub fn is_valid(&self) -> bool {
        let r = self.res as usize;
        let top = self.log_min + 254.0 * self.log_step;
        (1..=MAX_PROPOSAL_RES).contains(&self.res)
            && self.codes.len() == r * r * r
            && self.log_min.is_finite()
            && self.log_step.is_finite()
            && self.log_step >= 0.0
            && top.is_finite()
            && libm::expf(top) <= MAX_PROPOSAL_SIGMA
    }

    /// The density (1/world units) code `k` stands for.
    pub fn sigma_of(&self, k: u8) -> f32 {
        if k == 0 {
            0.0
        } else {
            libm::expf(self.log_min + (k - 1) as f32 * self.log_step)
        }
    }

    /// The grid's cells as an occupancy grid's (for its cell arithmetic).
    fn cells(&self) -> Occupancy<'static> {
        Occupancy { res: self.res, bits: &[] }
    }

    /// The code of the cell holding normalised position `p` (f32; outside
    /// `[−1, 1]³`: the nearest edge cell).
    #[inline(always)]
    pub fn code_f32(&self, p: [f32; 3]) -> u8 {
        let g = self.cells();
        self.codes[g.index(g.cell_f32(p))]
    }

    /// [`Proposal::code_f32`] for a position in Q`frac` fixed point.
    #[inline(always)]
    pub fn code_fixed(&self, p: [i32; 3], frac: u32) -> u8 {
        let g = self.cells();
        self.codes[g.index(g.cell_fixed(p, frac))]
    }
}

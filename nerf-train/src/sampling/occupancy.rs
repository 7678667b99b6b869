//! The occupancy grid the trainer keeps up to date (as in nerfacc and
//! instant-ngp): each cell of a `res³` grid over the scene bounds holds a
//! decayed running maximum of the density found at random points inside
//! it; a cell is occupied while that maximum exceeds a threshold. Training
//! and rendering skip samples in clear cells; the bits go into the model
//! file (format version 2, [`nerf_infer::occupancy`]).

use nerf_infer::occupancy::{grid_bytes, Occupancy};
use nerf_infer::sampling::hash32;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Decay of a cell's running maximum per update (nerfacc: 0.95).
pub const DECAY: f32 = 0.95;

/// Density grid and its occupancy bits.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGrid {
    /// Cells per axis.
    pub res: u16,
    /// Decayed running maximum of ReLU(σ) per cell, world units⁻¹.
    pub density: Vec<f32>,
    /// Occupancy bits in the model format's layout.
    pub bits: Vec<u8>,
    /// Updates so far.
    pub updates: u64,
}

impl OccupancyGrid {
    /// A grid with every cell occupied (nothing learnt yet).
    pub fn new(res: u16) -> Self {
        let r = res as usize;
        let mut bits = vec![0xFFu8; grid_bytes(res)];
        let tail = (r * r * r) % 8;
        if tail != 0 {
            *bits.last_mut().expect("res ≥ 1") = (1u8 << tail) - 1;
        }
        Self { res, density: vec![0.0; r * r * r], bits, updates: 0 }
    }

    /// The bits as the kernel reads them.
    pub fn view(&self) -> Occupancy<'_> {
        Occupancy { res: self.res, bits: &self.bits }
    }

    /// Fraction of cells occupied, in `[0, 1]`.
    pub fn occupied_fraction(&self) -> f32 {
        self.view().occupied_cells() as f32 / self.density.len() as f32
    }

    /// Cell `i`'s indices along x, y and z.
    fn cell(&self, i: usize) -> [usize; 3] {
        let r = self.res as usize;
        [i % r, (i / r) % r, i / (r * r)]
    }

    /// Normalised position (bounds ↦ `[−1, 1]³`) of a random point in cell `i`.
    fn point(&self, i: usize, key: u32) -> [f32; 3] {
        let r = self.res as usize;
        let c = self.cell(i);
        core::array::from_fn(|k| {
            let u = (hash32(key ^ hash32((3 * i + k) as u32)) >> 8) as f32 / (1u32 << 24) as f32;
            (c[k] as f32 + u) * 2.0 / r as f32 - 1.0
        })
    }

    /// How much lower a cell's threshold is than one inside the bounds: 1,
    /// or in a grid over contracted space ([`nerf_infer::unbounded`]) for a
    /// cell of the outer shell whose centre has max-norm `c > ½`, `1/m²`
    /// with `m = 1/(2(1 − c))` the distance it stands for: samples there
    /// lie `m²` times farther apart in the world, so a thinner density
    /// makes them as opaque.
    fn threshold_factor(&self, i: usize, contracted: bool) -> f32 {
        if !contracted {
            return 1.0;
        }
        let r = self.res as usize;
        let norm = self.cell(i).iter().map(|&k| ((k as f32 + 0.5) * 2.0 / r as f32 - 1.0).abs()).fold(0.0, f32::max);
        if norm <= 0.5 {
            1.0
        } else {
            let m = 0.5 / (1.0 - norm);
            1.0 / (m * m)
        }
    }

    /// One update: evaluates `density` (normalised positions → raw σ, one
    /// call per chunk of cells, in parallel) at a random point of every
    /// cell, folds it into the decayed maxima, and marks a cell occupied
    /// while its maximum exceeds `min(threshold, mean)` (the mean keeps a
    /// young, low-density field from being culled whole; a field with no
    /// density at all keeps the cells it had), lowered in the
    /// outer shell of a `contracted` grid by `1/m²`, `m` the distance a cell
    /// stands for in half-sizes of the bounds (samples lie `m²` times farther
    /// apart there).
    pub fn update(
        &mut self,
        key: u32,
        threshold: f32,
        contracted: bool,
        density: impl Fn(&[[f32; 3]]) -> Vec<f32> + Sync,
    ) {
        const CHUNK: usize = 4096;
        let key = hash32(key ^ hash32(self.updates as u32));
        let this = &*self;
        let fresh: Vec<f32> = (0..self.density.len())
            .collect::<Vec<_>>()
            .par_chunks(CHUNK)
            .flat_map_iter(|cells| {
                let pts: Vec<[f32; 3]> = cells.iter().map(|&i| this.point(i, key)).collect();
                density(&pts).into_iter().map(|s| if s.is_finite() { s.max(0.0) } else { 0.0 })
            })
            .collect();
        for (d, f) in self.density.iter_mut().zip(fresh) {
            *d = (*d * DECAY).max(f);
        }
        let mean = self.density.iter().map(|&d| d as f64).sum::<f64>() / self.density.len() as f64;
        self.updates += 1;
        if mean == 0.0 {
            // a field with no density anywhere leaves nothing to keep: its
            // cells stay as they were, or training would sample nothing again
            return;
        }
        let thr = threshold.min(mean as f32);
        self.bits.fill(0);
        for (i, &d) in self.density.iter().enumerate() {
            if d > thr * self.threshold_factor(i, contracted) {
                self.bits[i / 8] |= 1 << (i % 8);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ball_of_density_is_found_and_the_rest_cleared() {
        let mut g = OccupancyGrid::new(16);
        assert_eq!(g.occupied_fraction(), 1.0);
        let ball = |p: &[[f32; 3]]| -> Vec<f32> {
            p.iter().map(|q| if q.iter().map(|x| x * x).sum::<f32>() < 0.25 { 50.0 } else { 0.0 }).collect()
        };
        for k in 0..4 {
            g.update(k, 1.0, false, ball);
        }
        let v = g.view();
        assert!(v.at_f32([0.0, 0.0, 0.0]) && v.at_f32([0.3, -0.2, 0.1]));
        assert!(!v.at_f32([0.9, 0.9, 0.9]) && !v.at_f32([-0.8, 0.0, 0.0]));
        // a sphere of radius 0.5 fills 6.5 % of the cube; edge cells add some
        let f = g.occupied_fraction();
        assert!((0.05..0.15).contains(&f), "{f}");
        // the ball moves: its old cells clear once their maximum decays
        // below the threshold (50 · 0.95ᵏ < 1 after 77 updates)
        let moved = |p: &[[f32; 3]]| ball(&p.iter().map(|q| [q[0] - 0.5, q[1], q[2]]).collect::<Vec<_>>());
        for k in 0..100 {
            g.update(100 + k, 1.0, false, moved);
        }
        let v = g.view();
        assert!(v.at_f32([0.5, 0.0, 0.0]) && !v.at_f32([-0.4, 0.0, 0.0]));
    }

    #[test]
    fn a_field_with_no_density_anywhere_keeps_its_cells() {
        let mut g = OccupancyGrid::new(8);
        let empty = |p: &[[f32; 3]]| vec![0.0; p.len()];
        g.update(0, 1.0, false, empty);
        assert_eq!(g.occupied_fraction(), 1.0, "a young field emptied by its first steps is still sampled");
        // a field with density somewhere culls the rest as before
        g.update(1, 1.0, false, |p: &[[f32; 3]]| p.iter().map(|q| if q[0] < 0.0 { 5.0 } else { 0.0 }).collect());
        assert_eq!(g.occupied_fraction(), 0.5);
        g.update(2, 1.0, false, empty);
        assert_eq!(g.occupied_fraction(), 0.5, "decaying maxima keep the cells they mark");
    }

    #[test]
    fn a_contracted_grid_keeps_the_thin_density_of_its_outer_shell() {
        // a dense ball and, in the outermost layer of cells (max-norm beyond
        // 0.875: the far distance of a contracted grid), a thin density
        let field = |p: &[[f32; 3]]| -> Vec<f32> {
            p.iter()
                .map(|q| match (q.iter().map(|x| x * x).sum::<f32>(), q.iter().fold(0.0f32, |m, x| m.max(x.abs()))) {
                    (r2, _) if r2 < 0.06 => 50.0,
                    (_, n) if n > 0.875 => 0.05,
                    _ => 0.0,
                })
                .collect()
        };
        let (mut bounded, mut contracted) = (OccupancyGrid::new(16), OccupancyGrid::new(16));
        for k in 0..4 {
            bounded.update(k, 1.0, false, field);
            contracted.update(k, 1.0, true, field);
        }
        for g in [&bounded, &contracted] {
            assert!(g.view().at_f32([0.0, 0.1, 0.0]) && !g.view().at_f32([0.6, 0.0, 0.0]));
        }
        // the shell's samples stand for distances 8 times the bounds': 0.05 is opaque enough there
        assert!(!bounded.view().at_f32([0.95, 0.2, -0.3]));
        assert!(contracted.view().at_f32([0.95, 0.2, -0.3]) && contracted.view().at_f32([-0.1, -0.97, 0.5]));
    }
}

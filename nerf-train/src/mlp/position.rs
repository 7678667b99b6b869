//! The gradient of the loss with respect to the sample positions, after a
//! backward pass: through γ(x) and through the feature grid's trilinear
//! weights (for camera pose refinement, [`crate::per_photo::pose`]).

use super::*;

impl Mlp {
    /// After [`Mlp::backward_layers`] (or [`Mlp::backward`]) on `a` with
    /// [`Acts::keep_input_gradient`] on, and with the parameters `p` of
    /// that pass: fills `gamma` with `∂L/∂x` of each sample's position
    /// `pos` (`S` rows) through γ(x), and `grid` with `∂L/∂x` of each of the
    /// feature grid's points (`S·k` rows: `pos` itself, or with a footprint
    /// its `k` points `foot`) through the grid's values; `grid` is empty
    /// without a feature grid. Positions are the network's inputs
    /// (normalised, contracted in an unbounded scene); outside `[−1, 1]`
    /// along an axis, where the grid clamps, that axis's grid gradient is 0.
    ///
    /// # Panics
    /// If `a` is not from a backward pass with [`Acts::keep_input_gradient`] on, or `pos` (`foot` with a footprint) are
    /// not its feature-grid points.
    pub fn position_gradient(
        &self,
        p: &[f32],
        a: &Acts,
        pos: &[[f32; 3]],
        foot: &[[f32; 3]],
        gamma: &mut Vec<[f32; 3]>,
        grid: &mut Vec<[f32; 3]>,
    ) {
        let denc = a.denc_in.as_deref().expect("Acts::keep_input_gradient before the backward pass");
        let gd = self.gamma_dim();
        let (freqs, raw) = (self.enc.pos_freqs as usize, self.enc.include_input);
        gamma.clear();
        gamma.extend(pos.iter().zip(denc.chunks_exact(gd)).map(|(x, d)| gamma_back(*x, freqs, raw, d)));
        grid.clear();
        let Some(f) = &self.features else { return };
        let points = if a.k > 1 { foot } else { pos };
        assert_eq!(points.len(), a.s * a.k, "one feature-grid point per sample, or k with a footprint");
        let (w, nl, t) = (f.width as usize, f.levels(), &p[self.table..]);
        let (share, n) = (1.0 / a.k as f32, points.len());
        let offsets: Vec<usize> = (0..nl).map(|l| f.offset(l)).collect();
        assert_eq!(a.corners.len(), nl * n, "the forward pass's corners of every point and level");
        grid.extend(points.iter().enumerate().map(|(i, x)| {
            let mut g = [0.0f32; 3];
            for l in 0..nl {
                let d = &a.dgf[(i * nl + l) * w..(i * nl + l + 1) * w];
                // the forward pass's cell of this point (its entries; the weights are recomputed)
                let entry = &a.corners[l * n + i].entry;
                let gl = level_back(f.resolutions[l], offsets[l], entry, t, *x, d);
                (0..3).for_each(|c| g[c] += share * gl[c]);
            }
            g
        }));
    }
}

impl Mlp {
    /// After a backward pass as [`Mlp::position_gradient`]'s: fills `out`
    /// with `∂L/∂d` of each view direction `dirs` (unit vectors, one per
    /// row of the pass's directions) through γ(d); empty for a network whose
    /// colour does not read the direction.
    pub fn direction_gradient(&self, a: &Acts, dirs: &[[f32; 3]], out: &mut Vec<[f32; 3]>) {
        out.clear();
        if !self.topo.view_dependent || a.denc_in.is_none() {
            return;
        }
        let dd = self.enc.dir_dim();
        let (freqs, raw) = (self.enc.dir_freqs as usize, self.enc.include_input);
        out.extend(dirs.iter().zip(a.ddir_in.chunks_exact(dd)).map(|(v, d)| gamma_back(*v, freqs, raw, d)));
    }
}

/// `∂L/∂x` through γ(x) ([`nerf_infer::encoding::encode_f32`]'s layout: `x`
/// itself when `raw`, then `sin πx·2ᵏ` and `cos πx·2ᵏ` for `k < freqs`)
/// from `d`, the gradient of γ(x).
fn gamma_back(x: [f32; 3], freqs: usize, raw: bool, d: &[f32]) -> [f32; 3] {
    let mut g = [0.0f32; 3];
    let mut n = 0;
    if raw {
        g.copy_from_slice(&d[..3]);
        n = 3;
    }
    let mut scale = std::f32::consts::PI;
    for _ in 0..freqs {
        for c in 0..3 {
            let (s, co) = (x[c] * scale).sin_cos();
            g[c] += scale * (co * d[n + c] - s * d[n + 3 + c]);
        }
        n += 6;
        scale *= 2.0;
    }
    g
}

/// `∂L/∂x` of one level's trilinear blend at `x` from `d`, the gradient of
/// its `width` values: the level has `res` cells per axis, its entries
/// start at `base` in the table `t` (f32), and `entry` are the eight
/// corners of `x`'s cell ([`nerf_infer::features::FeatureGrid::corners_f32`]'s).
fn level_back(res: u16, base: usize, entry: &[u32; 8], t: &[f32], x: [f32; 3], d: &[f32]) -> [f32; 3] {
    let res = res as f32;
    // the weights' factors along each axis, and their slope (0 where clamped)
    let mut w = [[0.0f32; 2]; 3];
    let mut slope = [0.0f32; 3];
    for a in 0..3 {
        let v = if x[a].is_finite() { x[a] } else { 0.0 };
        let u = (v + 1.0) * 0.5;
        let s = u.clamp(0.0, 1.0) * res;
        let frac = s - (s as u32).min(res as u32 - 1) as f32;
        w[a] = [1.0 - frac, frac];
        slope[a] = if u > 0.0 && u < 1.0 { 0.5 * res } else { 0.0 };
    }
    let mut g = [0.0f32; 3];
    for k in 0..8 {
        let e = (base + entry[k] as usize) * d.len();
        let dot: f32 = d.iter().enumerate().map(|(j, dj)| t[e + j] * dj).sum();
        let b = [k & 1, (k >> 1) & 1, k >> 2];
        for a in 0..3 {
            let sign = if b[a] == 1 { 1.0 } else { -1.0 };
            let others: f32 = (0..3).filter(|&o| o != a).map(|o| w[o][b[o]]).product();
            g[a] += sign * others * slope[a] * dot;
        }
    }
    g
}

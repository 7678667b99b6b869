//! The learned feature grid inside the network: its lookups (at points,
//! or averaged over a pixel footprint's points) ahead of the trunk, and the
//! backward pass that scatters their gradients into the table.

use super::*;
use nerf_infer::arch::prefetch;

impl Mlp {
    /// Feature-grid values (`S × grid_dim`) and corners of `pos`.
    pub(super) fn grid_forward(&self, p: &[f32], pos: &[[f32; 3]], a: &mut Acts) {
        let Some(f) = &self.features else { return };
        let (w, nl, t) = (f.width as usize, f.levels(), &p[self.table..]);
        let offsets: Vec<usize> = (0..nl).map(|l| f.offset(l)).collect();
        resize(&mut a.gf, pos.len() * nl * w);
        let n = pos.len();
        a.corners.resize(n * nl, Corners::default());
        // level after level: one level's entries stay in cache; its corners first, then the blends with the
        // corners of the samples AHEAD on asked for (a fine level's table is megabytes: each corner a miss)
        const AHEAD: usize = 8;
        for l in 0..nl {
            let corners = &mut a.corners[l * n..(l + 1) * n];
            corners.iter_mut().zip(pos).for_each(|(c, x)| *c = f.corners_f32(l, *x));
            for (i, c) in corners.iter().enumerate() {
                if let Some(next) = corners.get(i + AHEAD) {
                    next.entry.iter().for_each(|&e| prefetch(t, (offsets[l] + e as usize) * w));
                }
                c.blend(offsets[l], w, |k| t[k], &mut a.gf[(i * nl + l) * w..(i * nl + l + 1) * w]);
            }
        }
    }

    /// Scatters `a.dgf` (gradient of the grid values) into the table's gradient.
    pub(super) fn grid_backward(&self, a: &Acts, g: &mut [f32]) {
        let Some(f) = &self.features else { return };
        let mut gt = &mut g[self.table..];
        for l in 0..f.levels() {
            let (level, rest) = gt.split_at_mut(f.entries(l) * f.width as usize);
            let n = a.s * a.k;
            // whether the sums are finite is not asked here: a training step scatters through `scatter_table`,
            // which reports it; this whole-backward path leaves the check to its caller
            self.scatter_level(l, &a.corners[l * n..(l + 1) * n], &a.dgf, level);
            gt = rest;
        }
    }

    /// Adds level `l`'s share of a chunk's grid-value gradient (`dgf`,
    /// `P × grid_dim` for its `P` points, `S·k` with `k` footprint points
    /// per sample, with the level's `P` corners from the forward pass)
    /// to `gl`, the gradient of that level's entries (`entries(l) × width`
    /// values). Consecutive samples in the same cell (a ray's samples in a
    /// coarse level) are summed first and written once. Returns whether
    /// every sum written is finite.
    pub(super) fn scatter_level(&self, l: usize, corners: &[Corners], dgf: &[f32], gl: &mut [f32]) -> bool {
        let Some(f) = &self.features else { return true };
        let nl = f.levels();
        per_width!(f.width as usize, W => scatter_level_w::<W>(nl, l, corners, dgf, gl))
    }

    /// Swaps the grid-value gradient of the last [`Mlp::backward_layers`]
    /// into `out`, for [`Mlp::scatter_table`], and `out`'s buffers into
    /// `a` for reuse (`out` holds no samples without a feature grid).
    pub fn swap_grid_grad(&self, a: &mut Acts, out: &mut GridGrad) {
        std::mem::swap(&mut a.corners, &mut out.corners);
        std::mem::swap(&mut a.dgf, &mut out.dgf);
        out.s = if self.features.is_some() { a.s * a.k } else { 0 };
    }

    /// Adds the grid-value gradients of several chunks to `gt`, the
    /// gradient of the feature grid's table (the parameters from
    /// [`Mlp::table`] on): one level per task, chunks in the order given,
    /// so the sums do not depend on the thread count and each task's
    /// writes stay within one level's entries. Returns whether every value
    /// written is finite (then so is every value of `gt`, if it was before).
    pub fn scatter_table(&self, grads: &[GridGrad], gt: &mut [f32]) -> bool {
        let Some(f) = &self.features else { return true };
        let mut levels = Vec::with_capacity(f.levels());
        let mut rest = gt;
        for l in 0..f.levels() {
            let (level, r) = rest.split_at_mut(f.entries(l) * f.width as usize);
            levels.push((l, level));
            rest = r;
        }
        let level = |(l, gl): (usize, &mut [f32])| {
            let mut finite = true;
            for g in grads {
                finite &= self.scatter_level(l, &g.corners[l * g.s..(l + 1) * g.s], &g.dgf, gl);
            }
            finite
        };
        // every level scattered, finite or not (no short cut)
        levels.into_par_iter().map(level).reduce(|| true, |a, b| a & b)
    }

    /// The first part of [`Mlp::forward`]: the positions' encoding (γ and
    /// the feature grid's values) into `a`.
    pub fn encode(&self, p: &[f32], pos: &[[f32; 3]], a: &mut Acts) {
        let gd = self.gamma_dim();
        a.s = pos.len();
        a.k = 1;
        resize(&mut a.enc, pos.len() * gd);
        for (i, x) in pos.iter().enumerate() {
            encode_f32(*x, self.enc.pos_freqs as usize, self.enc.include_input, &mut a.enc[i * gd..(i + 1) * gd]);
        }
        self.grid_forward(p, pos, a);
    }

    /// [`Mlp::encode`] with the feature grid's values of sample `i` the
    /// mean of its `K` footprint points `foot[K·i..K·i + K]` (`K` =
    /// [`FOOTPRINT_POINTS`]); γ stays at `pos`. Each point's corners are
    /// kept with their weights divided by `K` (the backward pass scatters
    /// through them); where the points of
    /// a level share one cell (the coarse levels, mostly) their weights are
    /// summed into one set of corners, blended and scattered once (the
    /// others keep the cell with zero weights, which the scatter skips). An
    /// empty `foot`, or a network without a feature grid, is [`Mlp::encode`].
    ///
    /// # Panics
    /// If `foot` is neither empty nor `K` points per sample of `pos` (with a feature grid), or `p` holds fewer than
    /// [`Mlp::n_params`] values.
    pub fn encode_footprint(&self, p: &[f32], pos: &[[f32; 3]], foot: &[[f32; 3]], a: &mut Acts) {
        let Some(f) = self.features.as_ref().filter(|_| !foot.is_empty()) else {
            return self.encode(p, pos, a);
        };
        const K: usize = FOOTPRINT_POINTS;
        assert_eq!(foot.len(), K * pos.len(), "{K} footprint points per sample");
        let (gd, s) = (self.gamma_dim(), pos.len());
        resize(&mut a.enc, s * gd);
        for (i, x) in pos.iter().enumerate() {
            encode_f32(*x, self.enc.pos_freqs as usize, self.enc.include_input, &mut a.enc[i * gd..(i + 1) * gd]);
        }
        let (w, nl, t) = (f.width as usize, f.levels(), &p[self.table..]);
        resize(&mut a.gf, s * nl * w);
        a.corners.resize(K * s * nl, Corners::default());
        for l in 0..nl {
            let corners = &mut a.corners[l * K * s..(l + 1) * K * s];
            per_width!(w, W => footprint_level::<W>(f, l, t, foot, &mut a.gf, corners));
        }
        (a.s, a.k) = (s, K);
    }
}

/// Level `l` of [`Mlp::encode_footprint`] for a grid of width `W`: writes
/// each sample's values (in `gf`, `S × levels × W`) as the mean over its
/// `K` footprint points `foot`, and the points' corners (in `corners`, `K`
/// per sample) with their weights divided by `K`. When all `K` points of a
/// sample lie in one cell, their weights are summed into the first slot and
/// blended once, and the other slots are set to that cell with zero weights.
pub(super) fn footprint_level<const W: usize>(
    f: &FeatureGrid<'_>,
    l: usize,
    t: &[f32],
    foot: &[[f32; 3]],
    gf: &mut [f32],
    corners: &mut [Corners],
) {
    const K: usize = FOOTPRINT_POINTS;
    let (base, nl) = (f.offset(l), f.levels());
    let share = 1.0 / K as f32;
    for (i, (pts, slots)) in foot.chunks_exact(K).zip(corners.chunks_exact_mut(K)).enumerate() {
        let mut c: [Corners; K] = std::array::from_fn(|m| f.corners_f32(l, pts[m]));
        let out = &mut gf[(i * nl + l) * W..][..W];
        if c.iter().all(|k| k.entry == c[0].entry) {
            let weight = std::array::from_fn(|j| share * c.iter().map(|k| k.weight[j]).sum::<f32>());
            let one = Corners { entry: c[0].entry, weight };
            one.blend(base, W, |k| t[k], out);
            slots[0] = one;
            slots[1..].fill(Corners { entry: c[0].entry, weight: [0.0; 8] });
        } else {
            let (mut sum, mut one) = ([0.0f32; W], [0.0f32; W]);
            for (k, slot) in c.iter_mut().zip(slots.iter_mut()) {
                k.weight.iter_mut().for_each(|v| *v *= share);
                k.blend(base, W, |e| t[e], &mut one);
                sum.iter_mut().zip(&one).for_each(|(s, v)| *s += v);
                *slot = *k;
            }
            out.copy_from_slice(&sum);
        }
    }
}

/// [`Mlp::scatter_level`] of a grid of width `W` and `nl` levels.
pub(super) fn scatter_level_w<const W: usize>(
    nl: usize,
    l: usize,
    corners: &[Corners],
    dgf: &[f32],
    gl: &mut [f32],
) -> bool {
    let mut acc = [[0.0f32; W]; 8];
    let mut cell: Option<[u32; 8]> = None;
    // whether every sum written is finite: a non-finite value stays so under
    // further additions, so checking each write finds any in the level
    let mut finite = true;
    let flush = |entry: &[u32; 8], acc: &mut [[f32; W]; 8], gl: &mut [f32]| {
        let mut ok = true;
        for (e, a) in entry.iter().zip(acc.iter_mut()) {
            let g = &mut gl[*e as usize * W..][..W];
            g.iter_mut().zip(a.iter()).for_each(|(g, v)| {
                *g += v;
                ok &= g.is_finite();
            });
            *a = [0.0; W];
        }
        ok
    };
    const AHEAD: usize = 8;
    for (i, c) in corners.iter().enumerate() {
        if let Some(next) = corners.get(i + AHEAD) {
            next.entry.iter().for_each(|&e| prefetch(gl, e as usize * W));
        }
        // a footprint point merged into its sample's first (zero weights)
        if c.weight == [0.0; 8] {
            continue;
        }
        if cell != Some(c.entry) {
            if let Some(entry) = &cell {
                finite &= flush(entry, &mut acc, gl);
            }
            cell = Some(c.entry);
        }
        let d = &dgf[(i * nl + l) * W..][..W];
        for (a, wk) in acc.iter_mut().zip(&c.weight) {
            a.iter_mut().zip(d).for_each(|(a, d)| *a += wk * d);
        }
    }
    if let Some(entry) = &cell {
        finite &= flush(entry, &mut acc, gl);
    }
    finite
}

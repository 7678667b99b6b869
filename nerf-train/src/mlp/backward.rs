//! The hand-written backward pass: the gradients of the parameters (and,
//! through the grid, of the table) from those of the densities and colours.

use super::*;

impl Mlp {
    /// Backward of [`Mlp::linear`] for one input part: accumulates the
    /// weight gradient of rows `row0..row0+cols` and, if `dx` is given,
    /// writes the input gradient (`rows × cols`).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn linear_back(
        &self,
        p: &[f32],
        g: &mut [f32],
        l: usize,
        x: &[f32],
        cols: usize,
        row0: usize,
        dy: &[f32],
        rows: usize,
        dx: Option<&mut [f32]>,
    ) {
        let s = self.slots[l];
        let gw = &mut g[s.w + row0 * s.dout..s.w + (row0 + cols) * s.dout];
        matmul(cols, s.dout, rows, gw, s.dout, true, View::t(x, cols), View::rows(dy, s.dout));
        if let Some(dx) = dx {
            let w = &p[s.w + row0 * s.dout..s.w + (row0 + cols) * s.dout];
            matmul(rows, cols, s.dout, dx, cols, false, View::rows(dy, s.dout), View::t(w, s.dout));
        }
    }

    pub(super) fn bias_back(&self, g: &mut [f32], l: usize, dy: &[f32], rows: usize) {
        let s = self.slots[l];
        let gb = &mut g[s.b..s.b + s.dout];
        for r in 0..rows {
            for (a, d) in gb.iter_mut().zip(&dy[r * s.dout..(r + 1) * s.dout]) {
                *a += d;
            }
        }
    }

    /// Backward pass: given `dsigma` (`S`) and `drgb` (`3S`, or empty if the
    /// forward skipped colour), accumulates parameter gradients into `g`.
    pub fn backward(&self, p: &[f32], a: &mut Acts, dsigma: &[f32], drgb: &[f32], g: &mut [f32]) {
        self.backward_layers(p, a, dsigma, drgb, &mut g[..self.table]);
        self.grid_backward(a, g);
    }

    /// [`Mlp::backward`] without the feature grid's table: accumulates the
    /// layers' gradients into `g` (the first [`Mlp::table`] parameters) and
    /// leaves the grid values' gradient in `a` ([`Mlp::swap_grid_grad`]).
    pub fn backward_layers(&self, p: &[f32], a: &mut Acts, dsigma: &[f32], drgb: &[f32], g: &mut [f32]) {
        let (s, r) = (a.s, a.r);
        let pd = self.enc.pos_dim();
        let (gd, fd) = (self.gamma_dim(), self.enc.grid_dim as usize);
        let dd = self.enc.dir_dim();
        let w = self.topo.width as usize;
        let d = self.topo.depth as usize;
        let si = self.sigma_idx();
        let mut dh = std::mem::take(&mut a.dh);
        let mut dtmp = std::mem::take(&mut a.dtmp);
        resize(&mut dh, s * w);
        resize(&mut dtmp, s * w);
        let trunk = &a.h[d - 1];
        // Colour branch: gradient into dh (overwritten), or zero.
        if drgb.is_empty() {
            dh.fill(0.0);
        } else {
            let dz: Vec<f32> = drgb.iter().zip(&a.rgb).map(|(g, y)| g * y * (1.0 - y)).collect();
            if self.topo.view_dependent {
                let vw = self.topo.view_width as usize;
                let mut dview = std::mem::take(&mut a.dview);
                resize(&mut dview, s * vw);
                self.linear_back(p, g, si + 3, &a.view, vw, 0, &dz, s, Some(&mut dview));
                self.bias_back(g, si + 3, &dz, s);
                for (dv, v) in dview.iter_mut().zip(&a.view) {
                    if *v <= 0.0 {
                        *dv = 0.0;
                    }
                }
                // per-ray sum for the direction part
                let mut dray = std::mem::take(&mut a.dray);
                resize(&mut dray, r * vw);
                dray.fill(0.0);
                let spr = s / r;
                for (i, row) in dview.chunks_exact(vw).enumerate() {
                    for (acc, x) in dray[(i / spr) * vw..(i / spr + 1) * vw].iter_mut().zip(row) {
                        *acc += x;
                    }
                }
                self.linear_back(p, g, si + 2, &a.denc, dd, w, &dray, r, None);
                if a.denc_in.is_some() {
                    // γ(d)'s rows of the view layer's weights: the directions' input gradient
                    let sl = self.slots[si + 2];
                    let wd = &p[sl.w + w * vw..sl.w + (w + dd) * vw];
                    resize(&mut a.ddir_in, r * dd);
                    matmul(r, dd, vw, &mut a.ddir_in, dd, false, View::rows(&dray, vw), View::t(wd, vw));
                }
                self.linear_back(p, g, si + 2, &a.feat, w, 0, &dview, s, Some(&mut dtmp));
                self.bias_back(g, si + 2, &dview, s);
                self.linear_back(p, g, si + 1, trunk, w, 0, &dtmp, s, Some(&mut dh));
                self.bias_back(g, si + 1, &dtmp, s);
                a.dview = dview;
                a.dray = dray;
            } else {
                self.linear_back(p, g, si + 1, trunk, w, 0, &dz, s, Some(&mut dh));
                self.bias_back(g, si + 1, &dz, s);
            }
        }
        // Density head: dh += dσ · Wσᵀ.
        self.linear_back(p, g, si, trunk, w, 0, dsigma, s, None);
        self.bias_back(g, si, dsigma, s);
        let ws = &p[self.slots[si].w..self.slots[si].w + w];
        for (row, ds) in dh.chunks_exact_mut(w).zip(dsigma) {
            for (x, wv) in row.iter_mut().zip(ws) {
                *x += ds * wv;
            }
        }
        // Trunk, last layer first; the grid values' gradient summed over
        // layer 0 and the skip layers.
        let (mut dgf, mut dpart) = (std::mem::take(&mut a.dgf), std::mem::take(&mut a.dgf_part));
        resize(&mut dgf, s * fd);
        resize(&mut dpart, s * fd);
        dgf.fill(0.0);
        let mut denc_in = a.denc_in.take();
        if let Some(v) = denc_in.as_mut() {
            resize(v, s * gd);
            v.fill(0.0);
        }
        for i in (0..d).rev() {
            for (x, h) in dh.iter_mut().zip(&a.h[i]) {
                if *h <= 0.0 {
                    *x = 0.0;
                }
            }
            self.bias_back(g, i, &dh, s);
            if i == 0 || self.topo.is_skip(i) {
                self.linear_back(p, g, i, &a.enc, gd, 0, &dh, s, None);
                if let Some(v) = denc_in.as_mut() {
                    // γ's rows of the layer's weights: the input gradient, summed over layers
                    let sl = self.slots[i];
                    let w = &p[sl.w..sl.w + gd * sl.dout];
                    matmul(s, gd, sl.dout, v, gd, true, View::rows(&dh, sl.dout), View::t(w, sl.dout));
                }
                if fd > 0 {
                    self.linear_back(p, g, i, &a.gf, fd, gd, &dh, s, Some(&mut dpart));
                    dgf.iter_mut().zip(&dpart).for_each(|(a, b)| *a += b);
                }
            }
            if i == 0 {
                break;
            }
            let row0 = if self.topo.is_skip(i) { pd } else { 0 };
            self.linear_back(p, g, i, &a.h[i - 1], w, row0, &dh, s, Some(&mut dtmp));
            std::mem::swap(&mut dh, &mut dtmp);
        }
        a.denc_in = denc_in;
        if a.k > 1 {
            // each footprint point's corners carry its share in their weights
            let mut spread = dpart;
            resize(&mut spread, s * a.k * fd);
            for (i, row) in dgf.chunks_exact(fd).enumerate() {
                for m in 0..a.k {
                    let o = (i * a.k + m) * fd;
                    spread[o..o + fd].copy_from_slice(row);
                }
            }
            a.dgf = spread;
            a.dgf_part = dgf;
            a.dh = dh;
            a.dtmp = dtmp;
            return;
        }
        a.dgf = dgf;
        a.dgf_part = dpart;
        a.dh = dh;
        a.dtmp = dtmp;
    }
}

//! The forward pass over a chunk of samples, layer by layer, and the
//! activation statistics export calibrates with.

use super::*;

impl Mlp {
    /// `out = bias + Σ parts · W[row0..]` for `rows` rows.
    pub(super) fn linear(&self, p: &[f32], l: usize, parts: &[(&[f32], usize, usize)], rows: usize, out: &mut [f32]) {
        let s = self.slots[l];
        for r in 0..rows {
            out[r * s.dout..(r + 1) * s.dout].copy_from_slice(&p[s.b..s.b + s.dout]);
        }
        for &(x, cols, row0) in parts {
            let w = &p[s.w + row0 * s.dout..s.w + (row0 + cols) * s.dout];
            matmul(rows, s.dout, cols, out, s.dout, true, View::rows(x, cols), View::rows(w, s.dout));
        }
    }

    /// Forward pass on normalised positions `pos` (`S`) and unit view
    /// directions `dirs` (`R`, one per `S/R` consecutive samples). Fills
    /// `acts.sigma` and, if `need_rgb`, `acts.rgb`: [`Mlp::encode`], then
    /// [`Mlp::forward_layers`].
    ///
    /// # Panics
    /// As [`Mlp::forward_layers`].
    pub fn forward(&self, p: &[f32], pos: &[[f32; 3]], dirs: &[[f32; 3]], need_rgb: bool, a: &mut Acts) {
        self.encode(p, pos, a);
        self.forward_layers(p, dirs, need_rgb, a);
    }

    /// The rest of [`Mlp::forward`]: the layers on the encoding
    /// [`Mlp::encode`] left in `a`, with the view directions `dirs`.
    ///
    /// # Panics
    /// If `p` holds fewer than [`Mlp::n_params`] values, or a view-dependent network's colour is asked for with
    /// `dirs` not one per `S/R` samples (an empty `dirs` included).
    pub fn forward_layers(&self, p: &[f32], dirs: &[[f32; 3]], need_rgb: bool, a: &mut Acts) {
        let (s, r) = (a.s, dirs.len());
        let (pd, dd) = (self.enc.pos_dim(), self.enc.dir_dim());
        let (gd, fd) = (self.gamma_dim(), self.enc.grid_dim as usize);
        let w = self.topo.width as usize;
        let d = self.topo.depth as usize;
        a.r = r;
        a.h.resize(d, Vec::new());
        for i in 0..d {
            let mut out = std::mem::take(&mut a.h[i]);
            resize(&mut out, s * w);
            if i == 0 {
                self.linear(p, 0, &[(&a.enc, gd, 0), (&a.gf, fd, gd)], s, &mut out);
            } else if self.topo.is_skip(i) {
                self.linear(p, i, &[(&a.enc, gd, 0), (&a.gf, fd, gd), (&a.h[i - 1], w, pd)], s, &mut out);
            } else {
                self.linear(p, i, &[(&a.h[i - 1], w, 0)], s, &mut out);
            }
            out.iter_mut().for_each(|v| *v = v.max(0.0));
            a.h[i] = out;
        }
        let trunk = &a.h[d - 1];
        resize(&mut a.sigma, s);
        self.linear(p, self.sigma_idx(), &[(trunk, w, 0)], s, &mut a.sigma);
        if !need_rgb {
            return;
        }
        resize(&mut a.rgb, s * 3);
        let si = self.sigma_idx();
        if self.topo.view_dependent {
            let vw = self.topo.view_width as usize;
            resize(&mut a.feat, s * w);
            self.linear(p, si + 1, &[(trunk, w, 0)], s, &mut a.feat);
            resize(&mut a.denc, r * dd);
            for (i, v) in dirs.iter().enumerate() {
                encode_f32(*v, self.enc.dir_freqs as usize, self.enc.include_input, &mut a.denc[i * dd..(i + 1) * dd]);
            }
            let sl = self.slots[si + 2];
            resize(&mut a.dirpart, r * vw);
            let wd = &p[sl.w + w * vw..sl.w + (w + dd) * vw];
            matmul(r, vw, dd, &mut a.dirpart, vw, false, View::rows(&a.denc, dd), View::rows(wd, vw));
            resize(&mut a.view, s * vw);
            self.linear(p, si + 2, &[(&a.feat, w, 0)], s, &mut a.view);
            let spr = s / r;
            for (i, row) in a.view.chunks_exact_mut(vw).enumerate() {
                let dp = &a.dirpart[(i / spr) * vw..(i / spr + 1) * vw];
                for (v, x) in row.iter_mut().zip(dp) {
                    *v = (*v + x).max(0.0);
                }
            }
            self.linear(p, si + 3, &[(&a.view, vw, 0)], s, &mut a.rgb);
        } else {
            self.linear(p, si + 1, &[(trunk, w, 0)], s, &mut a.rgb);
        }
        a.rgb.iter_mut().for_each(|v| *v = 1.0 / (1.0 + (-*v).exp()));
    }

    /// Raises `max[l]` to the largest |output| of layer `l` in `a` (trunk,
    /// density head, and on the view branch feature and view layers).
    pub fn record_max_abs(&self, a: &Acts, max: &mut [f32]) {
        let m = |v: &[f32]| v.iter().fold(0.0f32, |m, x| m.max(x.abs()));
        let d = self.topo.depth as usize;
        for i in 0..d {
            max[i] = max[i].max(m(&a.h[i]));
        }
        max[d] = max[d].max(m(&a.sigma));
        if self.topo.view_dependent && !a.feat.is_empty() {
            max[d + 1] = max[d + 1].max(m(&a.feat));
            max[d + 2] = max[d + 2].max(m(&a.view));
        }
    }

    /// Marks in `active[l][c]` every ReLU output `c` of layer `l` (trunk and
    /// view layer) that is positive for some sample of `a`; `active` holds
    /// one `Vec` of the layer's width per layer.
    pub fn record_active(&self, a: &Acts, active: &mut [Vec<bool>]) {
        let mark = |v: &[f32], w: usize, act: &mut Vec<bool>| {
            for row in v.chunks_exact(w) {
                for (f, x) in act.iter_mut().zip(row) {
                    *f |= *x > 0.0;
                }
            }
        };
        let d = self.topo.depth as usize;
        for i in 0..d {
            mark(&a.h[i][..a.s * self.slots[i].dout], self.slots[i].dout, &mut active[i]);
        }
        if self.topo.view_dependent && !a.view.is_empty() {
            let vw = self.slots[d + 2].dout;
            mark(&a.view[..a.s * vw], vw, &mut active[d + 2]);
        }
    }
}

//! Samples dropped from a forward pass's activations before the backward
//! pass: a sample whose density and colour gradients are zero adds
//! nothing to any parameter's gradient, yet costs the backward's products
//! and the table's scatter as much as any other.

use super::*;

/// Keeps the rows of `v` (`width` values each, one per flag of `keep`)
/// whose flag is set, in order, and drops the rest.
///
/// # Panics
/// If `v` holds fewer than `keep.len() × width` values.
pub fn retain_rows<T: Copy>(v: &mut Vec<T>, width: usize, keep: &[bool]) {
    assert!(v.len() >= keep.len() * width, "{} values for {} rows of {width}", v.len(), keep.len());
    let mut o = 0;
    for (i, _) in keep.iter().enumerate().filter(|(_, &k)| k) {
        if o != i {
            v.copy_within(i * width..(i + 1) * width, o * width);
        }
        o += 1;
    }
    v.truncate(o * width);
}

impl Acts {
    /// Samples of the last forward pass.
    pub fn samples(&self) -> usize {
        self.s
    }

    /// Keeps the samples `keep` marks (one flag per sample of the last
    /// [`Mlp::forward_layers`] of `net` with colour), in order, in every
    /// buffer [`Mlp::backward_layers`] reads: the encoding, the feature
    /// grid's values and corners, the layers' outputs, density and colour,
    /// and the view branch's, whose per-ray rows become one per sample
    /// first where a ray's samples shared one. The backward pass then
    /// takes the kept samples' gradients alone and gives the parameters
    /// the gradient it gave before, less the dropped samples' share.
    /// Returns the samples kept.
    ///
    /// # Panics
    /// If `keep` does not hold one flag per sample, or the activations
    /// keep the input gradient ([`Acts::keep_input_gradient`]), which is
    /// read per sample of the forward pass.
    pub fn retain_samples(&mut self, net: &Mlp, keep: &[bool]) -> usize {
        let (s, k) = (self.s, self.k);
        assert_eq!(keep.len(), s, "one flag per sample");
        assert!(self.denc_in.is_none(), "the input gradient is read per sample of the forward pass");
        let kept = keep.iter().filter(|&&x| x).count();
        if kept == s {
            return s;
        }
        retain_rows(&mut self.enc, net.gamma_dim(), keep);
        retain_rows(&mut self.gf, net.enc.grid_dim as usize, keep);
        let levels = net.features.as_ref().map_or(0, |f| f.levels());
        // level after level, `k` points a sample: each level's kept rows move
        // down to `kept·k` from `s·k`, never past a row not yet read
        let mut o = 0;
        for l in 0..levels {
            for (i, _) in keep.iter().enumerate().filter(|(_, &x)| x) {
                self.corners.copy_within((l * s + i) * k..(l * s + i + 1) * k, o);
                o += k;
            }
        }
        self.corners.truncate(o);
        let w = net.topo.width as usize;
        for h in self.h.iter_mut().take(net.topo.depth as usize) {
            retain_rows(h, w, keep);
        }
        retain_rows(&mut self.sigma, 1, keep);
        retain_rows(&mut self.rgb, 3, keep);
        if net.topo.view_dependent {
            let (vw, dd) = (net.topo.view_width as usize, net.enc.dir_dim());
            retain_rows(&mut self.feat, w, keep);
            retain_rows(&mut self.view, vw, keep);
            if self.r == s {
                retain_rows(&mut self.denc, dd, keep);
                retain_rows(&mut self.dirpart, vw, keep);
            } else {
                // each kept sample gets its ray's row
                let spr = s / self.r.max(1);
                let rows = |v: &[f32], n: usize| -> Vec<f32> {
                    let kept_rays = keep.iter().enumerate().filter(|(_, &x)| x).map(|(i, _)| i / spr);
                    kept_rays.flat_map(|r| &v[r * n..(r + 1) * n]).copied().collect()
                };
                self.denc = rows(&self.denc, dd);
                self.dirpart = rows(&self.dirpart, vw);
            }
            self.r = kept;
        } else if self.r == s {
            self.r = kept;
        }
        self.s = kept;
        kept
    }
}
